// glTF skeletal animation sampling for the samples, skelform-pose and skelform-bench.
//
// The runtime takes joint matrices; where they come from is the application's business
// (DESIGN.md: the animation sampler "lives outside the runtime library, in a small helper that
// samples and CLI share"). This helper reads a glTF 2.0 file once (tinygltf; images are not
// decoded), validates every node, skin and animation it will use, and then evaluates:
//
//   joint matrix j = globalTransform(joints[j]) × inverseBindMatrices[j]
//
// column-major float[16] per joint, in the skin's `joints` order: exactly what
// sf_instance_set_joint_matrices takes. globalTransform is the product of the local
// transforms from the scene root down to the joint (node `matrix`, or T × R × S from its
// translation/rotation/scale, with animated channels overriding the static TRS).
//
// The skinned mesh node's own transform is deliberately NOT folded in (no multiplication by
// inverse(globalTransform(meshNode))): the glTF 2.0 specification (section 3.7.3.3, "Skinned
// Mesh Attributes") says the transform of a skinned mesh's node is ignored and only the joint
// transforms place the mesh. Engines that parent a skinned mesh under a moving node follow
// the same rule, and the runtime's rest pose (identity joint matrices) is the bind pose.
//
// Sampling follows the specification's appendix C: LINEAR (component-wise lerp; spherical
// linear interpolation along the shorter arc for rotations), STEP (the keyframe at or before
// t) and CUBICSPLINE (cubic Hermite with the stored in/out tangents scaled by the keyframe
// interval; rotations normalised afterwards). Before the first keyframe a channel holds its
// first value, after the last its last value. `weights` (morph target) channels are
// validated but not applied: skelform deforms skins only.
//
// Every failure is reported by throwing GltfError with a one-line message naming the file and
// the offending object; no input makes these functions crash or return non-finite matrices.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace skelform::samples {

// Invalid or unsupported glTF content, an unreadable file, or an out-of-range request.
class GltfError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// run_main's `classify` (cli.h) for a GltfError: invalid input (-1 for any other exception).
int classify_gltf_error(const std::exception& e);

// One animation of the file.
struct AnimationInfo {
  std::string name;  // the glTF name, or "animation N" when it has none
  double start = 0;  // first keyframe time of all its channels, seconds
  double end = 0;    // last keyframe time of all its channels, seconds
  double duration() const { return end - start; }
};

// Pass as `animation` to sample the static pose: every node at its static
// translation/rotation/scale or matrix, no animation applied. It is the bind pose in some
// files and a posed skeleton in others (bind_pose_joint_matrices).
inline constexpr size_t kStaticPose = std::numeric_limits<size_t>::max();

// The largest file the sample tools read (1 GiB, as skelform-bake): a regular file's size is
// checked before reading, anything else (a FIFO, a device such as /dev/zero) is read until
// it passes the limit, so no input makes a tool read until memory runs out.
inline constexpr size_t kMaxFileBytes = size_t{1} << 30;

// The bytes of the file at `path`, at most kMaxFileBytes (a FIFO or device is read until it
// passes the limit). Throws GltfError naming the file when it cannot be read or is larger.
std::vector<unsigned char> read_bounded_file(const std::string& path);

// A loaded, validated glTF document. Immutable after loading; any number of threads may
// sample it at once. Movable, not copyable.
class GltfAnimation {
 public:
  // Reads a .gltf (external buffers resolved beside it) or .glb file of at most
  // kMaxFileBytes; the container is recognised by its bytes, not the file name.
  static GltfAnimation load_file(const std::string& path);
  // The same on bytes in memory; `name` is used in messages and `base_dir` resolves
  // external URIs of a .gltf (data URIs need none).
  static GltfAnimation load_memory(const std::string& bytes, const std::string& name, const std::string& base_dir = "");

  GltfAnimation(GltfAnimation&&) noexcept;
  GltfAnimation& operator=(GltfAnimation&&) noexcept;
  ~GltfAnimation();

  const std::string& name() const;
  size_t node_count() const;
  size_t skin_count() const;
  size_t joint_count(size_t skin) const;
  const std::vector<AnimationInfo>& animations() const;

  // Joint matrices of `skin` with `animation` sampled at `time` seconds (clamped to the
  // animation's [start, end]), or of the static pose when animation == kStaticPose (time is
  // then ignored). 16 floats per joint, column-major, skin joint order. Throws GltfError for an
  // out-of-range skin/animation or a non-finite time.
  std::vector<float> joint_matrices(size_t skin, size_t animation, double time) const;
  // The bind pose in the scene: the pose the inverse bind matrices were taken in, where every
  // joint matrix is one transform G and skinning gives the mesh as stored, placed by G (DESIGN.md
  // "Metrics" measures against it). G is the static pose's joint matrix when every joint has
  // the same one there (the static pose is the bind pose: the Khronos samples). Otherwise the
  // static pose is a posed skeleton (Blender exports the armature's current pose, not its rest
  // pose: in the Quaternius characters, joints turn up to ~80 degrees from bind) and G is the
  // static world transform of the node that instances the skin's mesh, which glTF ignores for
  // skinning because at bind the joints put the mesh exactly there; with no such node, the
  // static pose itself.
  std::vector<float> bind_pose_joint_matrices(size_t skin) const;

  // Global transform of every node (16 floats each, column-major, node order) for the same
  // pose selection; the hierarchy composition the joint matrices are built from.
  std::vector<float> node_world_matrices(size_t animation, double time) const;

  // The mesh and skin a node instances (-1 when none). A skinned mesh's node transform does
  // not place the mesh (see above); its joints do.
  int node_mesh(size_t node) const;
  int node_skin(size_t node) const;

  // Mesh data, for writing posed meshes: validated reads of a triangle primitive.
  size_t mesh_count() const;
  size_t primitive_count(size_t mesh) const;
  // POSITION of the primitive: 3 floats per vertex.
  std::vector<float> primitive_positions(size_t mesh, size_t primitive) const;
  // Triangles of the primitive as index triples into its vertices (TRIANGLES, TRIANGLE_STRIP
  // and TRIANGLE_FAN; non-indexed primitives get 0, 1, 2, ...). Other modes throw.
  std::vector<uint32_t> primitive_triangles(size_t mesh, size_t primitive) const;

 private:
  struct Impl;
  explicit GltfAnimation(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace skelform::samples
