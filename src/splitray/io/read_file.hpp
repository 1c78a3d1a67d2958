#pragma once
// Reading whole input files into memory, with plain errors for everything that can go
// wrong (missing, a directory, empty, too big, corrupt or truncated gzip, gzip bombs).
#include <cstddef>
#include <span>
#include <string>
#include <vector>

namespace splitray {

using Bytes = std::vector<unsigned char>;

// Largest file (or decompressed .gz content) splitray reads: 2 GiB.
inline constexpr std::size_t kMaxInputBytes = std::size_t{2} << 30;

// The bytes of a regular, non-empty file of at most max_bytes.
Bytes read_file(const std::string& path, std::size_t max_bytes = kMaxInputBytes);

// The content of gzip data (one or more members), at most max_bytes of it; `where` names
// the file in error messages.
Bytes gunzip(std::span<const unsigned char> compressed, const std::string& where,
             std::size_t max_bytes = kMaxInputBytes);

// True for names ending in .gz (any case).
bool has_gz_suffix(const std::string& path);

// read_file, then gunzip when the name ends in .gz.
Bytes read_maybe_gzipped(const std::string& path, std::size_t max_bytes = kMaxInputBytes);

// The lower-case extension without the dot ("obj"), looking through a .gz suffix.
std::string inner_extension(const std::string& path);

}  // namespace splitray
