/* skelform — skeleton-driven mesh deformation runtime, public C API.
 *
 * skelform deforms a skinned mesh through its Voronoi-based skeletal mesh (Yoshizawa,
 * Belyaev, Seidel 2003): the skeletal mesh S is posed by the glTF skin (or moved by free-form
 * handles), the coarse control mesh is reconstructed from it (M = S + d·N, paper eqs. (1)-(3)),
 * faired (paper eqs. (4), (5)), Loop-refined with baked stencils, and every original vertex is
 * placed from its displaced-subdivision binding. Assets are glTF files baked by
 * `skelform-bake` (extension SKELFORM_skeletal_deformation, docs/).
 *
 * This header is plain C99 and C++ compatible; it is the runtime's manual.
 *
 * Conventions, stated once for the whole API
 * - Units are those of the glTF asset; skelform never rescales.
 * - Matrices are column-major float[16], as glTF stores them. Joint matrices are
 *   jointWorld × inverseBindMatrix, in the order of the skin's `joints` array (the usual
 *   skinning matrices; the skinned node's own transform is not applied, as glTF specifies).
 * - Vertex data goes out in the original glTF vertex order of each primitive, so an engine
 *   streams it straight into the vertex buffers it built from the same glTF.
 * - Output memory belongs to the caller and is described by pointer + byte stride.
 * - Two index spaces, never mixed: the `deformable` and `primitive` arguments of every call
 *   count skelform's baked deformables and primitives (0 .. count-1); the info structs'
 *   fields `mesh`, `node`, `skin` and `gltf_primitive` are indices into the glTF document.
 *
 * Ownership and threads
 * - An sf_asset is immutable after loading: any number of threads and instances may use it
 *   at once. Destroy it after its last instance.
 * - An sf_instance holds one character's mutable state (pose, previous evaluation for
 *   incremental fairing). Use it from one thread at a time; different instances may be
 *   evaluated on different threads concurrently. "One thread at a time" includes the calls
 *   that take a const sf_instance* (sf_instance_write, sf_instance_write_coarse,
 *   sf_instance_last_error, ...): a failing one records its message in the instance, so two
 *   threads may not write out of the same instance at once. The exception is
 *   sf_instance_skin_range, which records nothing: a job system may skin ranges of one
 *   character on several threads at once.
 * - There is no global mutable state (beyond the CPU's features, read once and thread-safely
 *   to choose a kernel). No call throws, aborts or exits on bad input; every call returns an
 *   sf_result and keeps a readable message (sf_instance_last_error, or the caller's buffer in
 *   sf_load_options for loading), except sf_instance_skin_range, which returns its code only.
 * - Memory is allocated only when an asset or an instance is created (and when a handle set
 *   is changed or the contact pass turned on); evaluation and output never allocate.
 *
 * A frame
 *   load once:        sf_asset_load_file / sf_asset_load_memory, sf_asset_deformable_info,
 *                     sf_asset_primitive_info (where each primitive's vertices go)
 *   per character:    sf_instance_create (one per deformable a character shows)
 *   per frame:        sf_instance_set_joint_matrices (or the handle calls), then
 *                     sf_instance_evaluate, then sf_instance_write for each primitive into
 *                     the engine's vertex buffers
 *   at the end:       sf_instance_destroy for every instance, then sf_asset_destroy
 *   samples/c_engine/skelform_c_engine.c is this frame as a complete C99 program.
 *
 * Compatibility
 * - Result codes and enum values never change meaning; new ones are appended.
 * - Option and output structs only grow at their end, and a zeroed struct means the
 *   documented defaults: code that zero-initialises them keeps compiling and behaving the same
 *   against a later header (source compatibility).
 * - Binary compatibility is kept within a minor version (0.6.x): a program built against one
 *   0.6 header runs with any 0.6 library. Across minor versions, rebuild against the new
 *   header; sf_version() tells which library was linked.
 */
#ifndef SKELFORM_SKELFORM_H
#define SKELFORM_SKELFORM_H

#include <stddef.h>
#include <stdint.h>

#if defined(SF_SHARED_LIBRARY)
#  if defined(_WIN32)
#    if defined(SF_BUILDING_LIBRARY)
#      define SF_API __declspec(dllexport)
#    else
#      define SF_API __declspec(dllimport)
#    endif
#  else
#    define SF_API __attribute__((visibility("default")))
#  endif
#else
#  if defined(SF_BUILDING_LIBRARY) && !defined(_WIN32)
#    define SF_API __attribute__((visibility("default")))
#  else
#    define SF_API
#  endif
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ---------------------------------------------------------------------------------------- */
/* Versions and results                                                                      */
/* ---------------------------------------------------------------------------------------- */

/* Version of this header. sf_version() returns the version of the linked library; a
 * program may compare the two to detect a header/library mismatch. */
#define SF_VERSION_MAJOR 0
#define SF_VERSION_MINOR 6
#define SF_VERSION_PATCH 0
/* One integer, comparable: major * 10000 + minor * 100 + patch. */
#define SF_VERSION (SF_VERSION_MAJOR * 10000 + SF_VERSION_MINOR * 100 + SF_VERSION_PATCH)

/* The major version of the SKELFORM_skeletal_deformation extension this runtime reads.
 * Assets of another major version are refused with SF_ERROR_VERSION_MISMATCH: a newer one
 * needs a newer runtime; an older one (1.x, baked before skelform 0.2, whose binding used
 * another normal field) needs baking again with this release's skelform-bake. */
#define SF_EXTENSION_MAJOR_VERSION 2

/* Result of every call. Values are stable across versions; new codes are only appended. */
typedef enum sf_result {
  SF_OK = 0,
  SF_ERROR_INVALID_ARGUMENT = 1, /* a null pointer, an index, count or stride out of range */
  SF_ERROR_INVALID_DATA = 2,     /* the asset is corrupt or inconsistent */
  SF_ERROR_VERSION_MISMATCH = 3, /* the asset's extension major version is not this runtime's */
  SF_ERROR_OUT_OF_MEMORY = 4,    /* an allocation failed */
  SF_ERROR_IO = 5,               /* a file could not be read */
  SF_ERROR_UNSUPPORTED = 6,      /* valid data or a request this runtime does not handle */
  SF_ERROR_NOT_READY = 7,        /* a call out of order, e.g. output before any evaluation */
  SF_RESULT_FORCE_U32 = 0x7fffffff
} sf_result;

/* Version of the linked library, in the SF_VERSION encoding. Thread-safe. */
SF_API uint32_t sf_version(void);

/* A static, human-readable name for a result code ("SF_OK", "SF_ERROR_INVALID_DATA", ...).
 * Any other value of the type, a negative one passed from C included, gives
 * "SF_ERROR_UNKNOWN". Never returns NULL. Thread-safe. */
SF_API const char* sf_result_string(sf_result result);

/* ---------------------------------------------------------------------------------------- */
/* Memory                                                                                    */
/* ---------------------------------------------------------------------------------------- */

/* Optional allocator. `alloc` returns memory of at least `size` bytes aligned to `align` (a
 * power of two, at most 64), or NULL on failure; `free` releases it (ptr may be NULL). Both
 * may be called from any thread that creates or destroys objects using this allocator. The
 * struct is copied: it need not outlive the call that receives it. */
typedef struct sf_allocator {
  void* (*alloc)(void* user, size_t size, size_t align);
  void (*free)(void* user, void* ptr);
  void* user;
} sf_allocator;

/* ---------------------------------------------------------------------------------------- */
/* Assets                                                                                    */
/* ---------------------------------------------------------------------------------------- */

typedef struct sf_asset sf_asset; /* immutable after load, shareable across threads */

/* Loading options; a zeroed struct (or NULL) means the defaults. */
typedef struct sf_load_options {
  /* Allocator for the asset and for every instance created from it; NULL = malloc/free. */
  const sf_allocator* allocator;
  /* Optional caller buffer that receives a NUL-terminated message when loading fails
   * (truncated to the capacity). NULL / 0: no message. */
  char* error_message;
  size_t error_message_capacity;
} sf_load_options;

/* Loads a baked asset from glTF bytes in memory (.glb, or .gltf JSON whose buffers are data
 * URIs). Every array of the extension is validated (counts, index ranges, finite values,
 * version) before use. The bytes are not referenced after the call. On failure *out_asset
 * is NULL. Memory: everything the asset keeps comes from options->allocator; the glTF parse
 * itself (tinygltf's document and the loader's temporaries, freed before the call returns)
 * uses the default heap (operator new). A .gltf loaded from memory never reads files: an
 * external buffer URI gives SF_ERROR_UNSUPPORTED.
 * Limits (docs/SKELFORM_skeletal_deformation.md "Limits"), within which the evaluation's
 * arithmetic on the asset stays finite:
 * - SF_ERROR_INVALID_DATA: a length of the asset beyond ±1e12 (POSITION of a deformable's
 *   primitives, control.positions, control.skeletalPositions, control.medialRadius,
 *   binding.displacement, binding.residual); a control.normals vector longer than 1 (to
 *   1e-3); a subdivision.stencilWeights value outside [-1, 1]; a binding.barycentric (b1, b2)
 *   outside its triangle (b1, b2 >= 0, b1 + b2 <= 1, to 1e-5).
 * - SF_ERROR_UNSUPPORTED: more than 16 influence sets of four joints (control.joints entries,
 *   or JOINTS_n attributes of a primitive) in one deformable; more than 65536 skin joints. */
SF_API sf_result sf_asset_load_memory(const void* data, size_t size, const sf_load_options* options,
                                      sf_asset** out_asset);

/* Loads a baked asset from a file (.glb or .gltf; a .gltf's external buffers are resolved
 * relative to its directory), with the limits of sf_asset_load_memory. At most 2^32 - 1 bytes
 * are read (the largest GLB): a regular file to the size the file system reports; a FIFO or a
 * device as a stream, a GLB only to the length its header states (the writer need not close
 * it), other content to its end. Larger files, and streams that have not ended by then, give
 * SF_ERROR_UNSUPPORTED; a stream whose first byte starts neither a GLB nor a JSON document
 * (/dev/zero) gives SF_ERROR_INVALID_DATA at once; a file that cannot be opened or read,
 * SF_ERROR_IO. */
SF_API sf_result sf_asset_load_file(const char* path, const sf_load_options* options, sf_asset** out_asset);

/* Releases an asset. NULL is ignored. All its instances must have been destroyed. */
SF_API void sf_asset_destroy(sf_asset* asset);

/* Number of deformables (baked skinned meshes) in the asset; 0 for NULL. */
SF_API uint32_t sf_asset_deformable_count(const sf_asset* asset);

/* Description of one deformable. */
typedef struct sf_deformable_info {
  int32_t mesh;                    /* glTF mesh index */
  int32_t node;                    /* glTF node instancing it with the skin, or -1 */
  int32_t skin;                    /* glTF skin, or -1 (unskinned: handles only) */
  uint32_t joint_count;            /* joints of the skin (matrices sf_instance_set_joint_matrices takes) */
  uint32_t primitive_count;        /* baked primitives of the mesh */
  uint32_t vertex_count;           /* original vertices, all primitives */
  uint32_t control_vertex_count;   /* vertices of the control (and skeletal) mesh */
  uint32_t subdivision_level;      /* Loop level of the refined surface */
  uint32_t control_triangle_count; /* triangles of the control (and skeletal) mesh */
} sf_deformable_info;

/* Fills *out_info for deformable 0 .. sf_asset_deformable_count-1. SF_ERROR_INVALID_ARGUMENT
 * for a NULL pointer or a deformable out of range (*out_info then unchanged). Thread-safe. */
SF_API sf_result sf_asset_deformable_info(const sf_asset* asset, uint32_t deformable, sf_deformable_info* out_info);

/* Description of one baked primitive of a deformable (index 0 .. primitive_count-1, in the
 * glTF mesh's primitive order). */
typedef struct sf_primitive_info {
  int32_t gltf_primitive; /* index of the primitive in the glTF mesh (meshes[mesh].primitives) */
  uint32_t vertex_count;  /* its POSITION count: the vertices written by sf_instance_write */
  uint32_t first_vertex;  /* offset of its vertices among the deformable's vertices */
  uint32_t has_normals;   /* 1 if the primitive has NORMAL (else normals are computed) */
  uint32_t has_tangents;  /* 1 if the primitive has TANGENT (else no tangents are written) */
} sf_primitive_info;

/* Fills *out_info for primitive 0 .. primitive_count-1 of a deformable: where its vertices go
 * (sf_instance_write takes the same index). SF_ERROR_INVALID_ARGUMENT for a NULL pointer or an
 * index out of range (*out_info then unchanged). Thread-safe. */
SF_API sf_result sf_asset_primitive_info(const sf_asset* asset, uint32_t deformable, uint32_t primitive,
                                         sf_primitive_info* out_info);

/* Inspection (viewers, debugging): the triangles of the control mesh M, which the skeletal
 * mesh S shares, as 3 × control_triangle_count indices into the control vertices.
 * index_capacity must be at least that many. */
SF_API sf_result sf_asset_control_triangles(const sf_asset* asset, uint32_t deformable, uint32_t* indices,
                                            size_t index_capacity);

/* ---------------------------------------------------------------------------------------- */
/* Instances                                                                                 */
/* ---------------------------------------------------------------------------------------- */

typedef struct sf_instance sf_instance; /* one character's state, one thread at a time */

/* Creates an instance of one deformable, at its rest pose (joint matrices = identity). All
 * the memory it will ever need (but for handle sets) is allocated here, with the asset's
 * allocator. Returns SF_ERROR_INVALID_ARGUMENT for a NULL out_instance or asset or a
 * deformable out of range, SF_ERROR_OUT_OF_MEMORY when the allocator fails, and
 * SF_ERROR_INVALID_DATA for any other failure of building the instance's state (none is
 * known for an asset that loaded); there is no instance yet to hold a message, so the code
 * is the whole answer. */
SF_API sf_result sf_instance_create(const sf_asset* asset, uint32_t deformable, sf_instance** out_instance);

/* Releases an instance. NULL is ignored. */
SF_API void sf_instance_destroy(sf_instance* instance);

/* Message of the instance's last failed call ("" when none). Valid until the next call on
 * the instance. Never NULL for a non-NULL instance. */
SF_API const char* sf_instance_last_error(const sf_instance* instance);

/* Skin driver input: `count` column-major 4x4 matrices (jointWorld × inverseBind) in the
 * skin's joint order, each `stride_bytes` apart (0 = 64, tightly packed). count must equal
 * the deformable's joint_count; matrices must be finite (else SF_ERROR_INVALID_ARGUMENT, the
 * previous pose kept). A finite pose too large for the asset (output that would overflow a
 * float) is refused by sf_instance_evaluate. Copied: the caller's array is not referenced
 * after the call. Selects the skin driver. */
SF_API sf_result sf_instance_set_joint_matrices(sf_instance* instance, const float* matrices, size_t count,
                                                size_t stride_bytes);

/* Free-form handle driver, paper Figs. 1 and 11 (its reference [25]): `handles` are original
 * vertex indices (0 .. vertex_count-1 over the deformable's primitives) whose targets the
 * caller will set; `pinned` are original vertex indices that stay at rest. The skeletal mesh
 * follows a smooth bilaplacian displacement field interpolating them. Setting a handle set
 * factorizes the system once (this call allocates); sf_instance_set_handle_targets then only
 * solves. A handle and a pin on the same skeletal vertex, or no handle at all, are invalid. */
SF_API sf_result sf_instance_set_handle_set(sf_instance* instance, const uint32_t* handles, size_t handle_count,
                                            const uint32_t* pinned, size_t pinned_count);

/* Targets (x, y, z) for the handles of the current set, in its order, `stride_bytes` apart
 * (0 = 12). Finite (else SF_ERROR_INVALID_ARGUMENT, the previous targets kept); targets so far
 * away that the output would not be finite are refused by sf_instance_evaluate. Selects the
 * handle driver. */
SF_API sf_result sf_instance_set_handle_targets(sf_instance* instance, const float* targets, size_t count,
                                                size_t stride_bytes);

/* The contact pass (on by default; docs/runtime-api.md "Contact pass"). When on, every
 * SF_METHOD_SKELFORM evaluation runs it on the dense mesh as the output shows it (skelform's
 * result blended with LBS by the skelform weight; skelform's own result under the handle
 * driver): the remaining self-intersections are found on it (welded by rest position) and the
 * vertices skelform may move (under joint matrices: every copy's skelform weight at least
 * 1e-6; under handles: all) moved out of each other, each move kept only where the number of
 * intersecting triangle pairs around the vertex does not grow (pairs that intersect at rest,
 * parts modelled into each other, are left as they are and not counted). Under joint
 * matrices it runs inside the guard against LBS (sf_instance_evaluate), on the intersecting
 * pairs the guard's first search finds anyway, so it costs only its moves; under handles,
 * where there is no guard, it runs its own broad phase over every dense triangle. Its work
 * is bounded, linear in the triangles, and a surface tangled over itself beyond that bound is
 * left as skelform made it (the guards still apply). It never feeds the fairing's warm start.
 * Turning it off frees the pass's scratch; turning it on again allocates it. Normals and
 * tangents are left as the displacement computed them. `enabled` is 0 or 1. */
SF_API sf_result sf_instance_set_contacts(sf_instance* instance, uint32_t enabled);

/* ---------------------------------------------------------------------------------------- */
/* Evaluation                                                                                */
/* ---------------------------------------------------------------------------------------- */

/* The deformation method. LBS and DQS deform the original vertices directly with the glTF
 * skin: the baselines, through the same call path. */
typedef enum sf_method {
  SF_METHOD_SKELFORM = 0, /* skeletal mesh, reconstruction, fairing, refinement (default) */
  SF_METHOD_LBS = 1,      /* linear blend skinning of the original vertices */
  SF_METHOD_DQS = 2,      /* dual quaternion skinning of the original vertices */
  SF_METHOD_FORCE_U32 = 0x7fffffff
} sf_method;

/* How the skin moves the skeletal mesh (SF_METHOD_SKELFORM with the skin driver): by default
 * limb joints bend along arcs; SF_SKELETON_LBS is plain linear blending throughout. */
typedef enum sf_skeleton_skinning {
  /* Default. Linear blending, except at the skin's limb joints (a parent-child joint with a
   * limb-like bone on each side) once they bend or twist past where linear blending folds the
   * reconstruction (at most 45 degrees; fully from 75): there the skeletal mesh within about
   * four limb radii of the joint follows a circular arc of 1.5 limb radii, both bones beyond
   * it rigid and its cross sections scaled up to keep the volume, and the twist spreads over
   * that zone as a rotation. The reconstruction then cannot fold at deep bends, where linear
   * blending turns the skeleton more tightly than the limb's radius (docs/runtime-api.md
   * "Skeleton skinning"). Derived at load time from the glTF skin's joint hierarchy and
   * inverse bind matrices. A mild pose gives the same output as SF_SKELETON_LBS, bit for bit. */
  SF_SKELETON_ARCS = 0,
  SF_SKELETON_DQS = 1, /* dual quaternion blending of every skeletal vertex */
  SF_SKELETON_LBS = 2, /* linear blending of every skeletal vertex */
  SF_SKELETON_SKINNING_FORCE_U32 = 0x7fffffff
} sf_skeleton_skinning;

/* Which normals N the reconstruction M = S' + d·N uses (DESIGN.md: the paper's eq. (3) is
 * unstable on dense control meshes). */
typedef enum sf_reconstruction {
  /* Default. Skin driver: the rest normals turned by each skeletal vertex's blended joint
   * rotation. Handle driver: the normals of the predicted surface M_rest + (S' − S), one step
   * (where the skeleton does not move, the surface stays at rest exactly). */
  SF_RECONSTRUCTION_CARRIED = 0,
  /* The paper's homotopy (2)/(3): L steps, normals recomputed from the previous step. */
  SF_RECONSTRUCTION_PAPER = 1,
  SF_RECONSTRUCTION_FORCE_U32 = 0x7fffffff
} sf_reconstruction;

/* Evaluation flags (bit mask). */
#define SF_EVAL_FROM_REST 0x1u    /* ignore the previous evaluation: start from rest, converge in this evaluation */
#define SF_EVAL_SKIP_NORMALS 0x2u /* do not compute normals/tangents (sf_instance_write leaves them) */

/* Fairing flags (sf_eval_options.fairing_flags, bit mask). */
#define SF_FAIR_NO_FOLD_FLOW 0x1u         /* skip flow (4): folds and protrusions */
#define SF_FAIR_NO_INTERSECTION_FLOW 0x2u /* skip flow (5): self-intersections */
#define SF_FAIR_OFF 0x3u                  /* no fairing: the reconstruction is refined as it is */
/* Semi-implicit bilaplacian steps (paper sec. 5) instead of the paper's explicit ones: no
 * better here, and slower per iteration. */
#define SF_FAIR_SEMI_IMPLICIT 0x4u

/* Evaluation options; a zeroed struct (or NULL) means the documented defaults. Fields are
 * only appended in later versions. */
typedef struct sf_eval_options {
  uint32_t method;            /* sf_method; 0 = SF_METHOD_SKELFORM */
  uint32_t skeleton_skinning; /* sf_skeleton_skinning; 0 = SF_SKELETON_ARCS */
  uint32_t reconstruction;    /* sf_reconstruction; 0 = carried normals */
  uint32_t homotopy_steps;    /* L of eq. (2), <= 100; 0 = 3 (the paper's choice) */
  uint32_t flags;             /* SF_EVAL_* bits */
  /* Fairing (paper eqs. (4) and (5)), SF_METHOD_SKELFORM only; docs/runtime-api.md "Fairing".
   * Zero in every field = the defaults. */
  uint32_t fairing_flags;      /* SF_FAIR_* bits; 0 = both flows, explicit steps */
  uint32_t fairing_iterations; /* iterations per incremental evaluation, <= 1000; 0 = 1 */
  float fairing_step;          /* τ of flow (4), dimensionless, <= 10; 0 = 0.2 (explicit) / 0.5 (semi-implicit) */
  float intersection_step;     /* τ of flow (5), dimensionless, <= 10; 0 = 0.15 */
  uint32_t intersection_grid;  /* cells per axis of flow (5)'s grid, 1 .. 32; 0 = 20 (the paper's) */
} sf_eval_options;

/* Evaluates the instance's current input (joint matrices or handle targets) into its
 * internal buffers. With joint matrices, SF_METHOD_SKELFORM's output is linear blend skinning
 * plus a share of skelform's correction per vertex (docs/runtime-api.md "LBS where LBS is
 * exact"): none on a vertex the skin gives to one joint alone (it is LBS's result, bit for
 * bit) or where the baked skelform weight is 0, and never so much that the output has an
 * intersecting triangle pair that neither LBS nor the model at rest has, or, on a closed mesh,
 * a volume further from the bind volume than LBS's. Scaled joint matrices (Blender's armature scale of 100,
 * Mixamo's 0.01) give the unscaled result scaled ("Scale"). Incremental by default: the fairing warm-starts from the previous
 * evaluation's correction (carried in each control vertex's local frame, so it follows the
 * character through translation and rotation) and runs `fairing_iterations` iterations. A
 * pose jump (the local shape of the reconstruction changed at more than 2 % of the control
 * vertices since the last evaluation, as a teleport into another pose or a new animation
 * does; or a switch between joint matrices and handles) discards the warm start and starts a
 * convergence of at most 32 iterations (or fairing_iterations, if larger); so does the first
 * evaluation. That evaluation runs 16 of them, and each next one 8 more (in place of its
 * fairing_iterations; either runs fairing_iterations if that is more, or what is left of the
 * convergence if that is less) until the convergence is done, so that no one frame pays for
 * all of it.
 * SF_EVAL_FROM_REST discards the warm start too and runs the whole convergence in its own
 * evaluation: use it when the caller knows the pose jumped and wants that frame converged.
 * A pose held bit for bit comes to rest (the steps halve at each such evaluation). With
 * sf_instance_set_contacts on, the contact pass ends the evaluation. Deterministic: the same
 * sequence of inputs gives the same output bits.
 * Never allocates.
 * Options out of range (an unknown enum value or flag, homotopy_steps above 100,
 * fairing_iterations above 1000, a step outside [0, 10], intersection_grid above 32) give
 * SF_ERROR_INVALID_ARGUMENT. So does a pose whose output would not be finite (joint matrices
 * or handle targets too large for the asset, e.g. elements near FLT_MAX): it is refused
 * before it replaces anything, sf_instance_write and sf_instance_write_coarse still give the
 * last evaluation, and the next evaluation's fairing starts afresh, as after a pose jump. */
SF_API sf_result sf_instance_evaluate(sf_instance* instance, const sf_eval_options* options);

/* Where sf_instance_write puts one primitive's vertices. A NULL pointer skips that stream.
 * Strides are in bytes (0 = tightly packed: 12 for positions/normals, 16 for tangents). */
typedef struct sf_vertex_output {
  float* positions; /* x, y, z per vertex */
  size_t position_stride;
  float* normals; /* unit x, y, z per vertex */
  size_t normal_stride;
  float* tangents; /* x, y, z, w per vertex; w (handedness) as authored */
  size_t tangent_stride;
  size_t vertex_capacity; /* vertices the caller's buffers hold; must be >= the primitive's count */
} sf_vertex_output;

/* Writes the last evaluation of one primitive (0 .. primitive_count-1 of the deformable) into
 * the caller's buffers, in the primitive's original glTF vertex order. Tangents are written
 * only for primitives with authored tangents (else SF_ERROR_UNSUPPORTED if requested). Never
 * allocates; touches no byte outside the described elements. */
SF_API sf_result sf_instance_write(const sf_instance* instance, uint32_t primitive, const sf_vertex_output* output);

/* Skins vertices [first_vertex, first_vertex + vertex_count) of one primitive by
 * SF_METHOD_LBS or SF_METHOD_DQS from the joint matrices last set (the rest pose before any),
 * straight into the caller's buffers: element 0 of each stream is vertex first_vertex, and
 * output->vertex_capacity must be >= vertex_count. The same floats as sf_instance_evaluate
 * with that method followed by sf_instance_write, without the instance's own copy: an
 * engine's skinning job. A NULL normals stream computes no normals; tangents are written only
 * when requested (SF_ERROR_UNSUPPORTED for a primitive without authored tangents).
 * It changes nothing in the instance (not its last evaluation, nor its output, nor its
 * message): calls on one instance may run on several threads at once (a job system splitting
 * a character), provided no other call on that instance runs meanwhile and their output
 * elements do not overlap. The floats are the same on every thread and machine under the
 * default floating-point environment (round to nearest, denormals kept); a worker thread that
 * flushes denormals to zero may get other bits in their range. Any byte stride of at least the
 * element works. Hence it returns a code only, sf_instance_last_error does not describe it:
 * SF_ERROR_INVALID_ARGUMENT for a NULL pointer, an unknown method, a primitive or range out of
 * range, a capacity below vertex_count, a stride below its element, or a pose whose positions
 * would not be finite (the range's buffers then hold unspecified values); SF_ERROR_UNSUPPORTED
 * for SF_METHOD_SKELFORM (its fairing and guards span the whole mesh: split a crowd by
 * instance), an unskinned deformable or the handle driver. Never allocates. */
SF_API sf_result sf_instance_skin_range(const sf_instance* instance, uint32_t method, uint32_t primitive,
                                        uint32_t first_vertex, uint32_t vertex_count, const sf_vertex_output* output);

/* Inspection (viewers, debugging): the coarse meshes of the last SF_METHOD_SKELFORM
 * evaluation, control_vertex_count positions `stride_bytes` apart (0 = 12). */
typedef enum sf_coarse_mesh {
  SF_COARSE_CONTROL = 0,  /* M after reconstruction and fairing: what the refinement starts from */
  SF_COARSE_SKELETAL = 1, /* S': the deformed skeletal (medial) mesh */
  SF_COARSE_MESH_FORCE_U32 = 0x7fffffff
} sf_coarse_mesh;

/* SF_ERROR_NOT_READY until an SF_METHOD_SKELFORM evaluation has run. Never allocates. */
SF_API sf_result sf_instance_write_coarse(const sf_instance* instance, uint32_t mesh, float* positions,
                                          size_t stride_bytes, size_t vertex_capacity);

/* What the last SF_METHOD_SKELFORM evaluation's fairing did: the iterations it ran and the
 * largest vertex motion of its last iteration divided by the bounding-box diagonal (0 and 0
 * when fairing was off or unsupported: a zero-radius skeleton). Either pointer may be NULL. */
SF_API sf_result sf_instance_fairing_stats(const sf_instance* instance, uint32_t* iterations, float* residual);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* SKELFORM_SKELFORM_H */
