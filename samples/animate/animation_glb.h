// The animation file skelform-animate writes (README, "skelform-animate"; the web viewer reads
// it): a standard glTF 2.0 GLB, no extension, that plays in any glTF viewer.
//
// Per deformable d, three root nodes whose meshes hold every sampled frame as a morph target
// (target k = frame k; the animations' frames concatenated, animation a owning a contiguous
// range), all in world space:
//   "skelform:<mesh>"  the skelform result (POSITION and NORMAL deltas from the rest mesh as
//                      stored), translation [0, 0, 0]
//   "lbs:<mesh>"       linear blend skinning of the same frames, translation [offset, 0, 0]
//   "skeletal:<mesh>"  the deformed skeletal mesh S' (POSITION deltas only) with a translucent
//                      red double-sided material, translation [0, 0, 0]
// each with extras {"skelform": {"role": ..., "deformable": d}}. One glTF animation per source
// animation drives the `weights` of all those nodes: input = frame times from 0, output =
// one-hot weights, LINEAR. asset.extras.skelform = {"fps", "source", "animations":
// [{"name", "first_target", "frame_count", "duration"}], "offset": [offset, 0, 0]}.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace skelform::samples {

// Frames of one glTF primitive of a deformable. Vectors of floats hold x, y, z per vertex.
struct PrimitiveFrames {
  std::vector<uint32_t> triangles;    // the primitive's triangles, 3 indices each
  std::vector<float> rest_positions;  // the morph base: POSITION as stored in the input
  std::vector<float> rest_normals;    // the morph base normals (the runtime's rest normals)
  std::vector<std::vector<float>> skelform_positions, skelform_normals;  // per frame, absolute
  std::vector<std::vector<float>> lbs_positions, lbs_normals;            // per frame, absolute
};

// Frames of one deformable.
struct DeformableFrames {
  uint32_t deformable = 0;
  std::string mesh_name;  // glTF mesh name (or "mesh N")
  std::vector<PrimitiveFrames> primitives;
  std::vector<uint32_t> skeletal_triangles;            // control triangles (the skeletal mesh's)
  std::vector<float> skeletal_rest;                    // S at rest: the morph base
  std::vector<std::vector<float>> skeletal_positions;  // S' per frame, absolute
};

// One animation's frames: they are targets first_target .. first_target + times.size() - 1.
struct AnimationRange {
  std::string name;
  std::vector<double> times;  // seconds from 0, increasing; the sampler input
  uint32_t first_target = 0;
};

struct AnimationFile {
  std::string source;  // input file name (no directory), for asset.extras
  double fps = 30;     // the requested sampling rate
  float offset = 0;    // x translation of the lbs nodes
  std::vector<AnimationRange> animations;
  std::vector<DeformableFrames> deformables;
};

// The GLB bytes of `file`. Deterministic: the same frames give the same bytes. Throws
// std::invalid_argument when the frame counts or vertex counts are inconsistent.
std::string animation_glb(const AnimationFile& file);

}  // namespace skelform::samples
