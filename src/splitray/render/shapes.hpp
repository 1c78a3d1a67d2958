#pragma once
// Meshes generated in code for the built-in scene and the tests: spheres as triangle meshes
// with smooth normals, quads, boxes and checkerboards. All are wound counter-clockwise seen
// from outside, so the geometric normal points outwards (refraction relies on it).
#include "splitray/core/mesh.hpp"

namespace splitray {

// Unit sphere at the origin: an icosahedron subdivided `subdivisions` times
// (20 * 4^subdivisions triangles), vertex normals = positions.
Mesh make_icosphere(int subdivisions);

// The parallelogram origin, origin + u, origin + u + v, origin + v; normal along cross(u, v).
Mesh make_quad(const Vec3& origin, const Vec3& u, const Vec3& v);

// The tiles (i, j) of an n x n grid over the parallelogram whose (i + j) % 2 == parity.
Mesh make_checker(const Vec3& origin, const Vec3& u, const Vec3& v, int n, int parity);

// Axis-aligned box with flat faces (separate vertices per face), normals outwards.
Mesh make_box(const Vec3& lo, const Vec3& hi);

}  // namespace splitray
