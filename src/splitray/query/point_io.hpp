#pragma once
// Point sets from files: PLY (ascii or binary, any vertex property layout; only x, y, z are
// read) and whitespace-separated XYZ text (one point per line; further columns, blank lines
// and # comments are ignored). Every problem is an Error naming the file and the place.
#include <string>
#include <vector>

#include "splitray/core/vec.hpp"

namespace splitray {

std::vector<Vec3> load_ply_points(const std::string& path);
std::vector<Vec3> load_xyz_points(const std::string& path);

// True for the names load_points reads as points: *.xyz, *.txt, *.pts, and PLY files whose
// header declares no faces (a PLY with faces is a mesh).
bool is_point_file(const std::string& path);
// Loads by extension: *.ply as PLY, anything else as XYZ text.
std::vector<Vec3> load_points(const std::string& path);

}  // namespace splitray
