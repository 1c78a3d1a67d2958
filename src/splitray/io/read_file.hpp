#pragma once
// Reading whole input files into memory, with plain errors for everything that can go
// wrong (missing, a directory, empty, too big, corrupt or truncated gzip, gzip bombs).
#include <algorithm>
#include <cstddef>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "splitray/core/memory_budget.hpp"

namespace splitray {

using Bytes = std::vector<unsigned char>;

// Largest file (or decompressed .gz content) splitray reads: 2 GiB, and at most an eighth of
// the memory budget (memory_budget.hpp), which leaves room for what a loader builds from the
// bytes (assimp's faces, the mesh, the triangles: up to about 8 times a binary PLY's size).
inline constexpr std::size_t kMaxInputBytes = std::size_t{2} << 30;
inline std::size_t input_limit() { return std::min(kMaxInputBytes, memory_budget() / 8); }

// The bytes of a regular, non-empty file of at most max_bytes. Anything else (a FIFO, a
// device, a folder) is an Error naming the file, without blocking; the file is noted as an
// input (core/output_file.hpp), so that no output can replace it.
Bytes read_file(const std::string& path, std::size_t max_bytes = input_limit());
// The first max_bytes (or fewer) of a file read_file would accept, for a look at a header.
Bytes read_file_head(const std::string& path, std::size_t max_bytes);
// read_file for a file splitray wrote before and may write again (animate --resume looks at
// the frames of an earlier run): the same checks, but it is not noted as an input.
Bytes read_previous_output(const std::string& path, std::size_t max_bytes = input_limit());

// The content of gzip data (one or more members), at most max_bytes of it; `where` names
// the file in error messages.
Bytes gunzip(std::span<const unsigned char> compressed, const std::string& where,
             std::size_t max_bytes = input_limit());

// True for names ending in .gz (any case).
bool has_gz_suffix(const std::string& path);

// read_file, then gunzip when the name ends in .gz.
Bytes read_maybe_gzipped(const std::string& path, std::size_t max_bytes = input_limit());

// The lower-case extension without the dot ("obj"), looking through a .gz suffix.
std::string inner_extension(const std::string& path);

// True when `file` lies inside `folder` once both are resolved (`..`, links; relative paths
// from the working directory): the one rule for every file a model or scene refers to
// (assimp's references, textures, AFF includes).
bool inside_folder(const std::filesystem::path& folder, const std::string& file);

}  // namespace splitray
