// What the loader derives once per deformable after reading it (asset_derive.cpp): the
// stencils renumbered and grouped for the per-frame loops, the rest frames and handle control
// vertices, and the fairing's connectivity and rest values. Private to the loader; the
// deformable has passed every check of asset_load.cpp's reading.
#pragma once

#include "asset.h"
#include "memory.h"

namespace skelform::runtime::loader {

// The rest evaluation, once: refined rest surface, the corners of every bound triangle, the
// rest normal and tangent in the frame at every bound point, and the control vertex a handle
// on each dense vertex moves. Renumbers and groups the stencils first and keeps only the
// grouped ones.
void derive_rest_data(Deformable& deformable);

// The fairing's connectivity and rest values (fair.h), once per deformable.
void derive_fairing_data(Deformable& deformable, const AllocatorRef& allocator);

// The junction anchors (Deformable::anchor_vertices), from the welded mesh's rest pairs (after
// build_contact_mesh): for each pair of triangles that intersects as modelled, the corners of
// one that skelform may move (every copy's skelform weight ≥ kContactMinWeight) follow a
// vertex of the other: the triangle whose corners one joint carries alone hosts (a rigid part
// cannot move), else the one in the larger connected part (a leg pushed into a body follows
// the body); a vertex met by several keeps its first rigid host, else its first. Pairs of two
// rigid triangles have nothing to anchor; pairs of two blended triangles in one part, or in
// parts of one size, have no host.
void derive_junction_anchors(Deformable& deformable);

}  // namespace skelform::runtime::loader
