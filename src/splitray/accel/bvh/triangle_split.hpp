#pragma once
// Splitting a reference at a plane in one pass over the triangle's three edges (as Embree's
// spatial splits do), much cheaper than clipping the triangle to a box: the bounds of the
// triangle's vertices and edge crossings on each side, cut to the reference's box. Each side's
// bounds contain the part of the triangle inside the reference box on that side.
#include "splitray/core/triangle.hpp"

namespace splitray {

// `box` bounds the part of the triangle being split (a reference); left gets coordinates
// <= position on `axis`, right >= position. Either may come back empty.
void split_triangle_bounds(const Triangle& tri, const Aabb& box, int axis, float position,
                           Aabb& left, Aabb& right);

}  // namespace splitray
