// One character's mutable state (sf_instance) and the stages of an evaluation, in frame order
// (DESIGN.md "Runtime pipeline"; one file per stage):
//
//   drive_skeleton.cpp  S → S'           skin driver (LBS/DQS of the skeletal vertices) or handles
//   reconstruct.cpp     S' → M           M = S' + d·N, carried normals or the paper's homotopy (2)/(3)
//   fair_stage.cpp      M → M''          flows (4), (5), warm-started from the previous evaluation
//   displace.cpp        M'' → dense      Loop stencils, DSS binding, carried normals/tangents
//   dense_skinning.cpp  baselines        SF_METHOD_LBS / SF_METHOD_DQS on the original vertices
//   api_instance.cpp    the C API: creation, poses, handle sets; api_evaluate.cpp runs the stages,
//   api_output.cpp      sf_instance_write copies into the caller's buffers
//
// Every buffer an evaluation touches is allocated in sf_instance_create (handle sets
// excepted, by the API's contract), so evaluation and output never allocate.
#pragma once

#include "asset.h"
#include "contact.h"
#include "fair.h"
#include "lbs_guard.h"
#include "memory.h"
#include "skin_blend.h"

#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cstdint>

namespace skelform::runtime {

struct HandleSystem;  // handles.h

enum class Driver : uint8_t {
  skin,     // joint matrices (identity at creation)
  handles,  // free-form handles (after sf_instance_set_handle_targets)
};

// The skin as prepared from the caller's joint matrices (skin_blend.h).
//
// Scale. glTF joint matrices may carry a scale: Blender's centimetre armatures export a node
// scale of 100, Mixamo's 0.01, and a rig may scale single joints. The medial radii, the
// fairing's rest values and the displacements are lengths of the stored (rest) mesh, so
// skelform evaluates in a normalised space: every joint matrix divided by the pose's
// reference scale σ (`scale`: the mean of the joints' scales s_j = |det L_j|^(1/3), each
// weighted by its use in the control skin), and the output multiplied by σ again. A pose
// whose joints all carry one uniform scale s (any rotation × s) is then exactly the unscaled
// pose's result, scaled by s. Joints whose scale differs from σ scale the medial radii of
// the vertices they drive by their ratio s_j / σ (`scale_ratio`, blended by the skin), so a
// uniformly scaled limb grows or shrinks in thickness as it does in length. Non-uniform
// scale and shear have no single radius scale: |det|^(1/3) is the volume-preserving mean.
struct JointTransforms {
  explicit JointTransforms(const AllocatorRef& a)
      : affine(a), dual_quaternion(a), skin_affine(a), skin_dual_quaternion(a), scale_ratio(a), matrices(a) {}
  // The caller's matrices as given: the LBS/DQS baselines and skelform's rigid parts.
  Array<JointAffine> affine;
  Array<JointDualQuaternion> dual_quaternion;
  // The same divided by `scale`: what the skeletal mesh is driven with.
  Array<JointAffine> skin_affine;
  Array<JointDualQuaternion> skin_dual_quaternion;
  Array<float> scale_ratio;   // s_j / σ per joint
  Array<glm::mat4> matrices;  // the caller's matrices, as last set
  float scale = 1.0f;         // σ
  bool uniform = true;        // every scale_ratio is exactly 1
  // The normalised forms (skin_*, scale_ratio, scale, uniform) are those of `matrices`: false
  // from sf_instance_set_joint_matrices until an SF_METHOD_SKELFORM evaluation prepares them,
  // so LBS and DQS (evaluated or by range) never pay for them.
  bool skin_prepared = true;
};

// Prepares the caller's representations (affine, dual_quaternion) from joints.matrices
// (column-major, d.joint_count of them, finite: checked by the caller); the normalised ones
// wait for prepare_skin_joints.
void prepare_joints(const Deformable& d, JointTransforms& joints);
// The normalised representations, σ and the ratios from joints.matrices (skin_prepared).
void prepare_skin_joints(const Deformable& d, JointTransforms& joints);

// The current handle set (sf_instance_set_handle_set): the caller's original vertex ids and
// targets. The system gets one displacement per caller handle; handles collapsing onto one
// control vertex (a glTF seam) are averaged there by handles.h.
struct HandleState {
  explicit HandleState(const AllocatorRef& a) : original(a), targets(a), displacements(a) {}
  HandleSystem* system = nullptr;
  Array<uint32_t> original;        // per handle: original (dense) vertex id
  Array<glm::vec3> targets;        // per handle, as last set
  Array<glm::vec3> displacements;  // per handle: target − rest position (solve input)
  bool has_targets = false;
};

// Which skinning blends the skeletal vertices (SF_SKELETON_*) and the dense baselines.
enum class Blend : uint8_t { linear, dual_quaternion };

// ---- Stages (each in its own file) ---------------------------------------------------------

// drive_skeleton.cpp. Skin driver (DESIGN.md runtime step 1): every skeletal vertex S_i moved
// by the blend of its control influences; `normal_matrices[i]` receives the matrix carrying
// its rest normal (inverse transpose of the blended linear part, up to a positive factor).
void drive_skeleton_skin(const Deformable& d, const JointTransforms& joints, Blend blend, glm::vec3* skeletal_out,
                         glm::mat3* normal_matrices);
// SF_SKELETON_ARCS (joint_arcs.h): as the linear skin driver, except that the share of an arc
// joint's pair in a vertex's skin moves it by the arc (poses from pose_joint_arcs); also
// writes each vertex's medial radius scaled by the arc's bulge to `radius_out`.
void drive_skeleton_arcs(const Deformable& d, const JointTransforms& joints, const ArcPose* poses,
                         glm::vec3* skeletal_out, glm::mat3* normal_matrices, float* radius_out);
// Handle driver: S' = S + the smooth displacement field of the current targets (handles.h).
void drive_skeleton_handles(const Deformable& d, HandleState& handles, glm::vec3* skeletal_out);
// Joints whose scale differs from the pose's reference (JointTransforms::scale_ratio): every
// control vertex's radius times its skin's blend of the ratios. radius_in may be radius_out.
void scale_medial_radii(const Deformable& d, const JointTransforms& joints, const float* radius_in, float* radius_out);

// reconstruct.cpp. Carried normals, one step: M_i = S'_i + d_i·normalize(K_i·N_i), with d_i
// from `radius` (the asset's medial radius, or the arcs' bulged one).
void reconstruct_carried(const Deformable& d, const glm::vec3* skeletal, const glm::mat3* normal_matrices,
                         const float* radius, glm::vec3* control_out);
// Per control vertex N_rest − N_area(M_rest): what the homotopy adds to its recomputed
// reconstruct.cpp. Handle driver, carried mode: normals of the predicted surface
// M_rest + (S' − S) (with the rest offsets), one step. `predicted` and `normals` are scratch.
void reconstruct_predicted(const Deformable& d, const glm::vec3* rest_offset, const glm::vec3* skeletal,
                           glm::vec3* predicted, glm::vec3* normals, glm::vec3* control_out);
// normals so that they equal the bake's at rest (reconstruct.cpp says why). Once per instance.
void rest_normal_offsets(const Deformable& d, glm::vec3* offsets);
// The paper's homotopy (2)/(3) from (start_skeletal, start_control, start_normals) to S_L =
// `skeletal`: L steps, normals recomputed from each step, d from `radius` (that of S_L) at
// every step. `start_normals` may be null (they are then computed from start_control).
// `normals_a`/`normals_b` are scratch (control count). L is at most kMaxHomotopySteps: each
// step is a pass over the control mesh, and beyond a few the steps change nothing visible.
constexpr uint32_t kMaxHomotopySteps = 100;
constexpr uint32_t kDefaultHomotopySteps = 3;  // the paper's choice
void reconstruct_homotopy(const Deformable& d, const glm::vec3* rest_offset, const glm::vec3* start_skeletal,
                          const glm::vec3* start_control, const glm::vec3* start_normals, const glm::vec3* skeletal,
                          const float* radius, uint32_t steps, glm::vec3* normals_a, glm::vec3* normals_b,
                          glm::vec3* control_out);

// fair_stage.cpp. Stage 3: flows (4) and (5) (fair.h) on instance.control (M from the
// reconstruction, with S' in instance.skeletal), in place. `from_rest` discards the warm start
// and converges afresh: in this evaluation when `requested`, else over this one and the next
// ones (kFreshStartChunks). Options already validated by the caller.
constexpr uint32_t kMaxIntersectionGrid = 32;      // workspace grid per instance (32³ cells)
constexpr uint32_t kMaxFairingIterations = 1000;   // per evaluation, incremental budget
constexpr uint32_t kDefaultFairingIterations = 1;  // per incremental evaluation
// Cap from rest or after a pose jump: 16 iterations at the full steps, 8 at 0.3 and 8 at 0.09 of
// them. Further annealed iterations (it was 64) only shrank the chatter below a tenth of what
// the next warm evaluation, at the full steps, has again; they were a third of a fresh start's
// cost (docs/tuning.md).
constexpr uint32_t kConvergenceIterations = 32;
constexpr float kConvergedResidual = 1e-5f;  // of the diagonal: converged
constexpr uint32_t kSearchStride = 16;       // warm: each vertex searches flow (5)'s grid every 16th evaluation
constexpr uint32_t kConvergenceChunk = 8;    // converging: iterations per fair_run() call
constexpr uint32_t kAnnealAfter = 16;        // converging: full steps for this many iterations,
constexpr float kAnnealRate = 0.3f;          // then steps × this per chunk
constexpr float kPoseJumpFraction = 0.02f;   // of the control vertices: a pose jump
constexpr float kPoseJumpShape = 0.25f;      // change of a vertex's local shape, in edge lengths, that is a pose jump
// Skin driver: a control vertex sits out this evaluation's flows (fair_stage.cpp) while the local
// shape of M at it and its one-ring differs from rest by under kQuietShape mean edges and its
// correction is under kQuietCorrection mean edges: the flows' shape terms, relative to rest,
// are then about zero there; what it does not see, another part pressing in, is left to the
// bent vertices, the contact pass and the guard (fair_stage.cpp, docs/tuning.md).
constexpr float kQuietShape = 0.1f;
constexpr float kQuietCorrection = 0.01f;
// A fresh start the caller did not ask for (the first evaluation, a pose jump) runs this many
// chunks (the full steps) in its evaluation, and each next evaluation one more (annealed) until
// the convergence is done: the frame of a spawn or an animation cut costs about half of what the
// whole convergence costs, the two after it about a quarter each (docs/results.md).
constexpr uint32_t kFreshStartChunks = 2;

struct FairStageOptions {
  FairingParams params;  // flows, stepping, steps, grid; params.iterations = the budget
  bool from_rest = false;
  bool requested = false;  // SF_EVAL_FROM_REST: the caller asked for the fresh start, it converges here
};

// What the fairing stage keeps from one evaluation to the next, owned by the instance: its
// workspace, this evaluation's local frames of M, and the last correction M'' − M in those
// frames (the warm start of the next evaluation), with what the pose-jump test compares.
struct FairingState {
  explicit FairingState(const AllocatorRef& allocator);
  // Sizes everything for `d` (instance creation: evaluation never allocates).
  void allocate(const Deformable& d, const AllocatorRef& allocator);

  FairingWorkspace workspace;
  Array<glm::mat3> frames;
  Array<glm::vec3> offset;              // the correction, per control vertex in its frame
  bool has_offset = false;              // offset holds a correction to warm-start from
  Driver driver = Driver::skin;         // the driver that correction was made under
  Array<glm::vec3> start;               // M before fairing
  Array<glm::vec3> shape;               // U(M) per vertex in its frame (pose-jump test)
  Array<glm::vec3> reference_umbrella;  // U(M) (FairingParams::smoothing_reference_umbrella)
  Array<float> mean_edge;               // mean one-ring edge length of M (pose-jump and quiet tests)
  Array<float> rest_change;             // |U(M) − U(M_rest)| per vertex, in its frame, in mean edges
  Array<uint8_t> fixed;                 // vertices kept out of this evaluation's flows
  float gain = 1.0f;                    // step scale: halves per evaluation while the pose is held
  uint32_t converging = 0;              // iterations of an unfinished convergence (0: none)
  uint32_t last_iterations = 0;         // of the last evaluation (sf_instance_fairing_stats)
  float last_residual = 0.0f;
};
void fair_stage(sf_instance& instance, const FairStageOptions& options);

// The iteration schedule fair_stage runs (also for tests that fair a mesh without an instance).
// Warm: one fair_run() call of params.iterations iterations, flow (5) searching its grid every
// kSearchStride-th call. Converging (`warm` false: from rest, after a pose jump): calls of
// kConvergenceChunk iterations with a full search, until the residual is below
// kConvergedResidual or max(params.iterations, kConvergenceIterations) iterations are done,
// the steps annealed by kAnnealRate per call once kAnnealAfter are done. params.fold_step and
// params.intersection_step are the resolved (non-zero) steps before the gain; every call scales
// them by the current gain, which starts at `gain`; below 1e-7 a step cannot move a float
// coordinate, and nothing runs.
// A convergence may be run in parts: `done` iterations of it ran before (in earlier
// evaluations), and this call makes at most `calls` fair_run() calls.
struct FairingSchedule {
  uint32_t iterations = 0;            // run in this call
  float residual = 0.0f;              // fair_run()'s result for the last call
  float gain = 1.0f;                  // the steps' scale after the schedule (annealed when converging)
  bool finished = true;               // warm, or the convergence is done (converged or at its cap)
  uint32_t converged_iterations = 0;  // converging: iterations of it so far, `done` included
};
FairingSchedule run_fairing_schedule(const FairingTopology& topology, const glm::vec3* skeletal, const float* radius,
                                     glm::vec3* positions, size_t vertex_count, FairingParams params, bool warm,
                                     float gain, FairingWorkspace& workspace, const FairingRest* rest,
                                     const glm::mat3* frames, uint32_t done = 0, uint32_t calls = UINT32_MAX);

// displace.cpp. Refines the control mesh (refine.h refine_surface, `control_normal_sums` and
// `refine_lanes` its control-sized scratch) and places every dense vertex from its DSS binding; with
// `with_normals`, also normals (and tangents where authored). `control`,
// `control_normal_sums`, `refined_positions` and `refined_normals` carry kVec3ReadPadding
// vectors past their vertices (memory.h: read by 16-byte loads).
struct DenseOutput {
  glm::vec3* positions;
  glm::vec3* normals;
  glm::vec4* tangents;  // may be null when no primitive has tangents
};
void displace(const Deformable& d, const glm::vec3* control, const glm::vec3* skeletal, glm::vec3* control_normal_sums,
              float* refine_lanes, glm::vec3* refined_positions, glm::vec3* refined_normals, bool with_normals,
              const DenseOutput& out);

// dense_skinning.cpp. The baselines on the original vertices (dense_joints/dense_weights),
// LBS by the fastest kernel this build and CPU run. False when a position is not finite (a
// pose too large for the asset; normals and tangents are always finite).
bool dense_skinning(const Deformable& d, const JointTransforms& joints, Blend blend, bool with_normals,
                    const DenseOutput& out);
// The caller's strided streams (sf_vertex_output with its strides resolved): element 0 is
// the range's first vertex; null normals/tangents are not written, positions never null.
struct StridedOutput {
  unsigned char* positions;
  size_t position_stride;
  unsigned char* normals;
  size_t normal_stride;
  unsigned char* tangents;  // only for a primitive with tangents
  size_t tangent_stride;
};
// Vertices [first, first + count) of `primitive` (checked by the caller), straight into `out`:
// the same floats as dense_skinning. Reads d and joints only (sf_instance_skin_range).
bool dense_skinning_range(const Deformable& d, const JointTransforms& joints, Blend blend, uint32_t primitive,
                          uint32_t first, uint32_t count, const StridedOutput& out);
// LBS's kernels one by one, for the tests that hold each to the portable loop's bits. An
// unavailable kernel (linear_kernel_available false) runs the portable loop.
enum class LinearKernel : uint8_t { portable, sse2, avx2 };
bool linear_kernel_available(LinearKernel kernel);
bool dense_skinning_linear(const Deformable& d, const JointTransforms& joints, LinearKernel kernel, bool with_normals,
                           const DenseOutput& out);
bool dense_skinning_linear_range(const Deformable& d, const JointTransforms& joints, LinearKernel kernel,
                                 uint32_t primitive, uint32_t first, uint32_t count, const StridedOutput& out);

}  // namespace skelform::runtime

// The public opaque type.
struct sf_instance {
  sf_instance(const sf_asset& owner, const skelform::runtime::Deformable& d);
  ~sf_instance();
  sf_instance(const sf_instance&) = delete;
  sf_instance& operator=(const sf_instance&) = delete;

  const sf_asset* asset;
  const skelform::runtime::Deformable* deformable;
  skelform::runtime::AllocatorRef allocator;

  // Input.
  skelform::runtime::Driver driver = skelform::runtime::Driver::skin;
  skelform::runtime::JointTransforms joints;
  skelform::runtime::HandleState handles;

  // Coarse state. `skeletal`/`control` are this evaluation's S' and M; `previous_*` the last
  // SF_METHOD_SKELFORM evaluation's (the incremental start), swapped in after each one.
  // `control` and `previous_control` (swapped) hold kVec3ReadPadding vectors past the control
  // vertices, as displace reads them (memory.h).
  skelform::runtime::Array<glm::vec3> skeletal;
  skelform::runtime::Array<glm::mat3> normal_matrices;
  skelform::runtime::Array<glm::vec3> control;
  skelform::runtime::Array<glm::vec3> previous_skeletal;
  skelform::runtime::Array<glm::vec3> previous_control;
  skelform::runtime::Array<glm::vec3> step_normals_a;
  skelform::runtime::Array<glm::vec3> step_normals_b;
  skelform::runtime::Array<glm::vec3> rest_normal_offset;  // rest_normal_offsets()
  // SF_SKELETON_ARCS: this evaluation's pose of each arc joint (joint_arcs.h) and medial radius
  // of each skeletal vertex (d scaled by the arc's bulge). `radius` is what stages 2 and 3
  // read: arc_radius.data() after an arcs evaluation, else the asset's medial_radius.
  skelform::runtime::Array<skelform::runtime::ArcPose> arc_poses;
  skelform::runtime::Array<float> arc_radius;
  skelform::runtime::Array<float> scaled_radius;  // radii of joints scaled unlike the pose (scale_medial_radii)
  const float* radius = nullptr;
  float output_scale = 1.0f;  // σ of the last SF_METHOD_SKELFORM evaluation (1 for handles)
  bool has_previous = false;

  skelform::runtime::FairingState fairing;  // fair_stage.cpp
  // The contact pass (contact.h), on unless sf_instance_set_contacts turned it off: its scratch
  // (empty while it is off; its grid only with a handle set).
  skelform::runtime::ContactWorkspace contact;
  bool contacts_enabled = false;

  // Refined surface (and the control mesh's normal sums it is refined from; these three padded
  // by kVec3ReadPadding vectors, memory.h) and the dense result sf_instance_write copies out.
  // An evaluation computes its result in skelform_* (SF_METHOD_SKELFORM) or lbs_* (the
  // baselines) and swaps it into dense_* only once every value is known finite, so a refused
  // evaluation leaves the last output as it was.
  skelform::runtime::Array<glm::vec3> control_normal_sums;
  // refine.h refine_surface's `lanes`: on AVX2 CPUs, for control meshes refined at least once.
  skelform::runtime::Array<float> refine_lanes;
  skelform::runtime::Array<glm::vec3> refined_positions;
  skelform::runtime::Array<glm::vec3> refined_normals;
  skelform::runtime::Array<glm::vec3> dense_positions;
  skelform::runtime::Array<glm::vec3> dense_normals;
  skelform::runtime::Array<glm::vec4> dense_tangents;  // empty when no primitive has tangents
  // skelform's own dense result (K; with the skin driver, blended in place by the guard with
  // LBS of the pose, L: lbs_guard.h). lbs_* are empty for an unskinned deformable.
  skelform::runtime::Array<glm::vec3> skelform_positions;
  skelform::runtime::Array<glm::vec3> skelform_normals;
  skelform::runtime::Array<glm::vec4> skelform_tangents;
  skelform::runtime::Array<glm::vec3> lbs_positions;
  skelform::runtime::Array<glm::vec3> lbs_normals;
  skelform::runtime::Array<glm::vec4> lbs_tangents;
  skelform::runtime::GuardWorkspace guard;
  bool evaluated = false;
  bool normals_valid = false;

  // Last error message; mutable because sf_instance_write (const) reports into it too.
  mutable char message[256] = {};
};
