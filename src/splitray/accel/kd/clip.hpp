#pragma once
// Perfect splits: the bounds of the part of a triangle inside a box (Sutherland-Hodgman
// clipping against the box's six planes), so a child cell gets only the extent a triangle
// really has in it.
#include "splitray/core/triangle.hpp"

namespace splitray {

// Bounds of triangle ∩ box, always inside `box`. Returns an empty box when the triangle
// does not reach into the box. Conservative against rounding: when clipping leaves nothing
// although the triangle's bounds overlap the box, returns that overlap instead of nothing.
Aabb clip_triangle_bounds(const Triangle& triangle, const Aabb& box);

}  // namespace splitray
