/* skelform-c-engine: the template for engine integrators, in plain C99.
 *
 *   skelform-c-engine BAKED.glb [FRAMES]       (bake with: skelform-bake IN.glb -o BAKED.glb)
 *
 * What a game engine does with skelform's C API (skelform.h), start to end:
 *  1. route skelform's memory through the engine's allocator (here: counting, aligned) and
 *     load a baked asset with an error-message buffer;
 *  2. enumerate its deformables and primitives, and size the engine's vertex buffers;
 *  3. create several instances (characters) of one deformable, each at its own animation
 *     phase and speed; they share the immutable asset;
 *  4. every frame, per character: compute joint matrices, evaluate (incrementally after the
 *     first frame), write positions, normals and tangents into an interleaved vertex buffer;
 *     the last character stands far away and is skinned by plain LBS instead, in blocks of
 *     vertices straight into its buffer (sf_instance_skin_range: what an engine's job system
 *     would run on its worker threads, one block per job);
 *  5. handle every result code, and walk each error path once on purpose;
 *  6. free everything and check that the allocator's counts are back to zero.
 * Exit status: 0 when every call and check succeeded, 1 on any failure, 2 on bad usage.
 *
 * The pose source. An engine has its own skeleton and animation system and hands skelform
 * the usual glTF skinning matrices, jointWorld × inverseBind. This example has none, so it
 * reads the skin's joint hierarchy and inverse bind matrices from the baked file itself with
 * a small GLB reader (glb_skin.c) and animates procedurally: every non-root joint turns
 * about its own local x axis by an angle oscillating in time, composed down the hierarchy
 * from the bind pose. Replace compute_joint_matrices() with your animation system's output.
 *
 * A model with several skinned meshes has several deformables: a character then needs one
 * instance per deformable (same calls). This example animates deformable 0. */
#include "glb_skin.h"
#include "skelform/skelform.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

enum { CHARACTER_COUNT = 3, LOD_CHARACTER = CHARACTER_COUNT - 1, SKIN_BLOCK = 256 };
static const float BEND_AMPLITUDE = 0.35f; /* radians, per joint */
static const float FRAME_SECONDS = 1.0f / 30.0f;
static const float TWO_PI = 6.2831853f;

/* ---- 1. The engine's allocator: counts live blocks and bytes, honours `align` ---- */

typedef struct allocation_counter {
  size_t live_allocations, live_bytes, peak_bytes, total_allocations;
  long fail_after; /* for the out-of-memory demonstration: allocations left before failing; -1 = never */
} allocation_counter;

/* Stored just before each block: where malloc's block starts and the size asked for. */
typedef struct block_header {
  void* base;
  size_t size;
} block_header;

static void* engine_alloc(void* user, size_t size, size_t align) {
  allocation_counter* counter = user;
  block_header header;
  unsigned char* base;
  uintptr_t aligned;
  if (counter->fail_after == 0) return NULL;
  if (counter->fail_after > 0) --counter->fail_after;
  if (align < 16) align = 16; /* >= sizeof(block_header): the header fits before the block */
  if (size > SIZE_MAX - align - sizeof header) return NULL;
  if (!(base = malloc(size + align + sizeof header))) return NULL;
  aligned = ((uintptr_t)base + sizeof header + (align - 1)) & ~(uintptr_t)(align - 1);
  header.base = base;
  header.size = size;
  memcpy((unsigned char*)aligned - sizeof header, &header, sizeof header);
  counter->live_allocations++;
  counter->total_allocations++;
  counter->live_bytes += size;
  if (counter->live_bytes > counter->peak_bytes) counter->peak_bytes = counter->live_bytes;
  return (void*)aligned;
}

static void engine_free(void* user, void* ptr) {
  allocation_counter* counter = user;
  block_header header;
  if (!ptr) return;
  memcpy(&header, (unsigned char*)ptr - sizeof header, sizeof header);
  counter->live_allocations--;
  counter->live_bytes -= header.size;
  free(header.base);
}

/* ---- 5. Every result code and what an engine does about it ---- */

/* No `default:`: a code appended to a later skelform.h becomes a -Wswitch error here. */
static const char* advice(sf_result result) {
  switch (result) {
    case SF_OK:
      return "success";
    case SF_ERROR_INVALID_ARGUMENT:
      return "a caller bug: fix the call; the object stays usable";
    case SF_ERROR_INVALID_DATA:
      return "corrupt asset: re-bake it with skelform-bake";
    case SF_ERROR_VERSION_MISMATCH:
      return "baked for a newer runtime: update skelform or re-bake";
    case SF_ERROR_OUT_OF_MEMORY:
      return "the allocator refused: free memory or raise the budget, retry";
    case SF_ERROR_IO:
      return "the file is unreadable: check the path";
    case SF_ERROR_UNSUPPORTED:
      return "valid but not handled: take the other path (e.g. no tangents)";
    case SF_ERROR_NOT_READY:
      return "out of order: evaluate before writing";
    case SF_RESULT_FORCE_U32:
      break;
  }
  return "unknown result code";
}

/* Returns 1 for SF_OK; otherwise prints the call, the code, the advice and the message. */
static int check(sf_result result, const char* call, const sf_instance* instance, const char* message) {
  if (result == SF_OK) return 1;
  if (instance) message = sf_instance_last_error(instance);
  fprintf(stderr, "error: %s: %s (%s): %s\n", call, sf_result_string(result), advice(result), message ? message : "");
  return 0;
}

/* For the deliberate error paths: the call must fail with `expected`. Returns 1 if it did. */
static int expect(sf_result result, sf_result expected, const char* call, const char* message) {
  printf("  %-44s -> %s: %s\n     engine: %s\n", call, sf_result_string(result), message, advice(result));
  if (result == expected) return 1;
  fprintf(stderr, "error: %s: expected %s\n", call, sf_result_string(expected));
  return 0;
}

/* ---- 4. Joint matrices: column-major 4x4, m[column * 4 + row] ---- */

static void mat4_mul(float* out, const float* a, const float* b) {
  float r[16];
  int c, k, i;
  for (c = 0; c < 4; ++c)
    for (i = 0; i < 4; ++i)
      for (r[c * 4 + i] = 0.0f, k = 0; k < 4; ++k) r[c * 4 + i] += a[k * 4 + i] * b[c * 4 + k];
  memcpy(out, r, sizeof r);
}

static void cross3(float* out, const float* a, const float* b) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

/* Inverse of an affine matrix [A t; 0 1]: rows of A^-1 are the cross products of A's columns
 * over det(A), and the translation is -A^-1 t. Returns 0 when A is singular. */
static int mat4_affine_inverse(float* out, const float* m) {
  const float* c0 = m;
  const float* c1 = m + 4;
  const float* c2 = m + 8;
  float rows[3][3], det;
  int r, k;
  cross3(rows[0], c1, c2);
  cross3(rows[1], c2, c0);
  cross3(rows[2], c0, c1);
  det = c0[0] * rows[0][0] + c0[1] * rows[0][1] + c0[2] * rows[0][2];
  if (!(fabsf(det) > 1e-12f)) return 0;
  for (r = 0; r < 3; ++r) {
    for (k = 0; k < 3; ++k) out[k * 4 + r] = rows[r][k] / det;
    out[12 + r] = -(out[r] * m[12] + out[4 + r] * m[13] + out[8 + r] * m[14]);
    out[r * 4 + 3] = 0.0f;
  }
  out[15] = 1.0f;
  return 1;
}

/* The bind pose in the hierarchy: each joint's local transform relative to its parent,
 * parentInverseBind × inverse(inverseBind) (a root's is its bind world transform). */
static int compute_bind_locals(const glb_skin* skin, float* bind_local) {
  uint32_t j;
  float bind_world[16];
  for (j = 0; j < skin->joint_count; ++j) {
    if (!mat4_affine_inverse(bind_world, skin->inverse_bind + 16 * j)) return 0;
    if (skin->parent[j] < 0)
      memcpy(bind_local + 16 * j, bind_world, sizeof bind_world);
    else
      mat4_mul(bind_local + 16 * j, skin->inverse_bind + 16 * skin->parent[j], bind_world);
  }
  return 1;
}

/* The pose source (replace with the engine's animation system): jointWorld = parentWorld ×
 * bindLocal × Rx(angle), parents first; then skinning = jointWorld × inverseBind. */
static void compute_joint_matrices(const glb_skin* skin, const float* bind_local, float amplitude, float seconds,
                                   float phase, float speed, float* joint_world, float* skinning) {
  uint32_t k;
  for (k = 0; k < skin->joint_count; ++k) {
    const uint32_t j = skin->order[k];
    const float angle = skin->parent[j] < 0 ? 0.0f : amplitude * sinf(TWO_PI * (speed * seconds + phase) + (float)j);
    const float c = cosf(angle), s = sinf(angle);
    const float rotation_x[16] = {1, 0, 0, 0, 0, c, s, 0, 0, -s, c, 0, 0, 0, 0, 1};
    float* world = joint_world + 16 * j;
    mat4_mul(world, bind_local + 16 * j, rotation_x);
    if (skin->parent[j] >= 0) mat4_mul(world, joint_world + 16 * skin->parent[j], world);
    mat4_mul(skinning + 16 * j, world, skin->inverse_bind + 16 * j);
  }
}

/* ---- 2./3. The engine's side of a character ---- */

/* An engine vertex: skelform writes position, normal and tangent in place (byte stride =
 * sizeof(engine_vertex)); uv is static, filled by the engine's importer, never touched. */
typedef struct engine_vertex {
  float position[3];
  float normal[3];
  float tangent[4];
  float uv[2];
} engine_vertex;

typedef struct character {
  sf_instance* instance;
  float phase, speed;      /* animation phase (cycles) and playback speed (cycles per second) */
  float* joint_world;      /* joint_count 4x4 */
  float* skinning;         /* joint_count 4x4: what sf_instance_set_joint_matrices takes */
  engine_vertex* vertices; /* vertex buffer: the deformable's primitives one after the other */
  double evaluate_seconds; /* CPU time spent in sf_instance_evaluate (LOD: sf_instance_skin_range) */
} character;

static const float UV_SENTINEL = 0.625f;

/* Writes every primitive's deforming streams into the character's interleaved buffer. */
static int write_vertices(const character* ch, const sf_primitive_info* primitives, uint32_t primitive_count) {
  uint32_t p;
  for (p = 0; p < primitive_count; ++p) {
    engine_vertex* v = ch->vertices + primitives[p].first_vertex;
    sf_vertex_output out;
    memset(&out, 0, sizeof out);
    out.positions = v->position, out.position_stride = sizeof *v;
    out.normals = v->normal, out.normal_stride = sizeof *v;
    if (primitives[p].has_tangents) out.tangents = v->tangent, out.tangent_stride = sizeof *v;
    out.vertex_capacity = primitives[p].vertex_count;
    if (!check(sf_instance_write(ch->instance, p, &out), "sf_instance_write", ch->instance, NULL)) return 0;
  }
  return 1;
}

/* The far character: LBS of every primitive in blocks of SKIN_BLOCK vertices, each block
 * straight into the interleaved buffer. The calls change nothing in the instance, so a job
 * system may run the blocks on several threads at once; this example runs them in turn. */
static int skin_by_blocks(const character* ch, const sf_primitive_info* primitives, uint32_t primitive_count) {
  uint32_t p, first;
  for (p = 0; p < primitive_count; ++p)
    for (first = 0; first < primitives[p].vertex_count; first += SKIN_BLOCK) {
      const uint32_t left = primitives[p].vertex_count - first;
      const uint32_t count = left < SKIN_BLOCK ? left : SKIN_BLOCK;
      engine_vertex* v = ch->vertices + primitives[p].first_vertex + first;
      sf_vertex_output out;
      sf_result result;
      memset(&out, 0, sizeof out);
      out.positions = v->position, out.position_stride = sizeof *v;
      out.normals = v->normal, out.normal_stride = sizeof *v;
      if (primitives[p].has_tangents) out.tangents = v->tangent, out.tangent_stride = sizeof *v;
      out.vertex_capacity = count;
      /* A code only: this call keeps no message (it may run on many threads at once). */
      result = sf_instance_skin_range(ch->instance, SF_METHOD_LBS, p, first, count, &out);
      if (result != SF_OK) {
        fprintf(stderr, "error: sf_instance_skin_range(primitive %u, %u..%u): %s\n  what to do: %s\n", (unsigned)p,
                (unsigned)first, (unsigned)(first + count), sf_result_string(result), advice(result));
        return 0;
      }
    }
  return 1;
}

/* Bounding box of the written positions; counts vertices that break an output property:
 * a non-finite value, a normal not of unit length, a uv the write touched. */
static size_t summarize(const engine_vertex* v, uint32_t count, float* box) {
  size_t bad = 0;
  uint32_t i;
  int k;
  for (k = 0; k < 3; ++k) box[k] = INFINITY, box[3 + k] = -INFINITY;
  for (i = 0; i < count; ++i) {
    const float* n = v[i].normal;
    const float length = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    int finite = isfinite(length);
    for (k = 0; k < 3; ++k) {
      finite = finite && isfinite(v[i].position[k]);
      if (v[i].position[k] < box[k]) box[k] = v[i].position[k];
      if (v[i].position[k] > box[3 + k]) box[3 + k] = v[i].position[k];
    }
    if (!finite || fabsf(length - 1.0f) > 1e-3f || v[i].uv[0] != UV_SENTINEL || v[i].uv[1] != UV_SENTINEL) ++bad;
  }
  return bad;
}

static unsigned char* read_file(const char* path, size_t* size, const sf_allocator* allocator) {
  FILE* f = fopen(path, "rb");
  unsigned char* data = NULL;
  long length;
  if (f && fseek(f, 0, SEEK_END) == 0 && (length = ftell(f)) > 0 && fseek(f, 0, SEEK_SET) == 0 &&
      (data = allocator->alloc(allocator->user, (size_t)length, 16)) != NULL) {
    *size = fread(data, 1, (size_t)length, f);
    if (*size != (size_t)length) allocator->free(allocator->user, data), data = NULL;
  }
  if (f) fclose(f);
  return data;
}

/* A load that should have failed but did not: release it, count a failure. */
static int discard(sf_asset** asset) {
  if (!*asset) return 0;
  sf_asset_destroy(*asset);
  *asset = NULL;
  return 1;
}

/* ---- 5. Each error path once, on purpose; returns the number of unexpected outcomes ---- */
static int show_error_paths(const char* path, const unsigned char* file, size_t file_size, const sf_load_options* load,
                            allocation_counter* counter, const sf_asset* asset, character* ch, uint32_t joint_count,
                            const sf_primitive_info* primitives, uint32_t primitive_count) {
  int failures = 0;
  size_t i, live_before;
  uint32_t p;
  char missing[512];
  sf_asset* bad_asset = NULL;
  sf_instance* bad_instance = NULL;
  unsigned char* copy;
  sf_vertex_output out;
  memset(&out, 0, sizeof out);
  printf("error paths, each on purpose:\n");

  snprintf(missing, sizeof missing, "%s.missing", path);
  failures += !expect(sf_asset_load_file(missing, load, &bad_asset), SF_ERROR_IO, "sf_asset_load_file(missing file)",
                      load->error_message);
  failures += discard(&bad_asset);
  failures += !expect(sf_asset_load_memory(file, file_size / 2, load, &bad_asset), SF_ERROR_INVALID_DATA,
                      "sf_asset_load_memory(truncated file)", load->error_message);
  failures += discard(&bad_asset);
  /* A copy whose extension claims a newer major version than this runtime reads. */
  if ((copy = load->allocator->alloc(load->allocator->user, file_size, 16)) != NULL) {
    static const char key[] = "\"majorVersion\":";
    memcpy(copy, file, file_size);
    for (i = 0; i + sizeof key < file_size && memcmp(copy + i, key, sizeof key - 1) != 0; ++i) continue;
    if (i + sizeof key < file_size) {
      for (i += sizeof key - 1; i < file_size && copy[i] == ' '; ++i) continue;
      if (i < file_size) copy[i] = '9';
    }
    failures += !expect(sf_asset_load_memory(copy, file_size, load, &bad_asset), SF_ERROR_VERSION_MISMATCH,
                        "sf_asset_load_memory(majorVersion 9)", load->error_message);
    load->allocator->free(load->allocator->user, copy);
    failures += discard(&bad_asset);
  }

  live_before = counter->live_allocations;
  counter->fail_after = 0; /* the engine's allocator refuses the next request */
  failures += !expect(sf_instance_create(asset, 0, &bad_instance), SF_ERROR_OUT_OF_MEMORY,
                      "sf_instance_create(allocator refuses)", "(the allocator returned NULL)");
  counter->fail_after = -1;
  failures += counter->live_allocations != live_before; /* a failed create frees what it took */
  if (bad_instance) sf_instance_destroy(bad_instance), ++failures;

  out.positions = &ch->vertices[0].position[0], out.position_stride = sizeof(engine_vertex);
  out.vertex_capacity = primitives[0].vertex_count;
  failures += !expect(sf_instance_write(ch->instance, 0, &out), SF_ERROR_NOT_READY,
                      "sf_instance_write(before evaluate)", sf_instance_last_error(ch->instance));
  failures +=
      !expect(sf_instance_set_joint_matrices(ch->instance, ch->skinning, joint_count + 1, 0), SF_ERROR_INVALID_ARGUMENT,
              "sf_instance_set_joint_matrices(count + 1)", sf_instance_last_error(ch->instance));
  ch->skinning[5] = NAN; /* the skinning matrices hold the bind pose (identities) here */
  failures +=
      !expect(sf_instance_set_joint_matrices(ch->instance, ch->skinning, joint_count, 0), SF_ERROR_INVALID_ARGUMENT,
              "sf_instance_set_joint_matrices(NaN)", sf_instance_last_error(ch->instance));
  ch->skinning[5] = 1.0f;

  /* Tangents exist only where the glTF authored them: asking for more is refused. */
  for (p = 0; p < primitive_count && primitives[p].has_tangents; ++p) continue;
  if (p == primitive_count) {
    printf("  (every primitive has tangents: no SF_ERROR_UNSUPPORTED case in this asset)\n");
  } else if (check(sf_instance_evaluate(ch->instance, NULL), "sf_instance_evaluate", ch->instance, NULL)) {
    out.positions = &ch->vertices[primitives[p].first_vertex].position[0];
    out.tangents = &ch->vertices[primitives[p].first_vertex].tangent[0], out.tangent_stride = sizeof(engine_vertex);
    out.vertex_capacity = primitives[p].vertex_count;
    failures += !expect(sf_instance_write(ch->instance, p, &out), SF_ERROR_UNSUPPORTED,
                        "sf_instance_write(tangents, none authored)", sf_instance_last_error(ch->instance));
  } else {
    ++failures;
  }
  return failures;
}

int main(int argc, char** argv) {
  allocation_counter counter = {0, 0, 0, 0, -1};
  sf_allocator allocator;
  sf_load_options load;
  char message[512] = "";
  sf_asset* asset = NULL;
  sf_deformable_info info;
  sf_primitive_info* primitives = NULL;
  unsigned char* file = NULL;
  size_t file_size = 0, bad_vertices = 0;
  glb_skin skin;
  float* bind_local = NULL;
  character characters[CHARACTER_COUNT];
  long frames = 24, frame;
  int failures = 0, finished = 0, c;
  uint32_t d, p;
  const char* path = argc > 1 ? argv[1] : NULL;

  memset(&skin, 0, sizeof skin);
  memset(characters, 0, sizeof characters);
  if (argc > 2) frames = strtol(argv[2], NULL, 10);
  if (!path || argc > 3 || frames < 1 || frames > 100000) {
    fprintf(stderr, "usage: skelform-c-engine BAKED.glb [FRAMES (1-100000, default 24)]\n");
    return 2;
  }
  if (sf_version() != SF_VERSION) {
    fprintf(stderr, "error: skelform.h is version %d but the library is %u\n", SF_VERSION, (unsigned)sf_version());
    return 1;
  }

  /* 1. Load through the engine's allocator; a failure's message lands in `message`. */
  allocator.alloc = engine_alloc, allocator.free = engine_free, allocator.user = &counter;
  memset(&load, 0, sizeof load);
  load.allocator = &allocator;
  load.error_message = message, load.error_message_capacity = sizeof message;
  if (!check(sf_asset_load_file(path, &load, &asset), "sf_asset_load_file", NULL, message)) goto done;

  /* 2. What the asset holds. */
  printf("%s: %u deformable(s)\n", path, (unsigned)sf_asset_deformable_count(asset));
  for (d = 0; d < sf_asset_deformable_count(asset); ++d) {
    if (!check(sf_asset_deformable_info(asset, d, &info), "sf_asset_deformable_info", NULL, NULL)) goto done;
    printf(
        "  deformable %u: mesh %d, skin %d, %u joints, %u vertices in %u primitive(s), control mesh %u vertices, "
        "Loop level %u\n",
        (unsigned)d, (int)info.mesh, (int)info.skin, (unsigned)info.joint_count, (unsigned)info.vertex_count,
        (unsigned)info.primitive_count, (unsigned)info.control_vertex_count, (unsigned)info.subdivision_level);
  }
  if (!check(sf_asset_deformable_info(asset, 0, &info), "sf_asset_deformable_info", NULL, NULL)) goto done;
  if (info.skin < 0 || info.primitive_count == 0) {
    fprintf(stderr, "error: deformable 0 has no skin (handles only); this example drives the skin\n");
    goto done;
  }
  if (!(primitives = allocator.alloc(allocator.user, info.primitive_count * sizeof *primitives, 16))) goto done;
  for (p = 0; p < info.primitive_count; ++p) {
    if (!check(sf_asset_primitive_info(asset, 0, p, &primitives[p]), "sf_asset_primitive_info", NULL, NULL)) goto done;
    printf("    primitive %u (glTF %d): %u vertices from %u, normals %s, tangents %s\n", (unsigned)p,
           (int)primitives[p].gltf_primitive, (unsigned)primitives[p].vertex_count,
           (unsigned)primitives[p].first_vertex, primitives[p].has_normals ? "authored" : "computed",
           primitives[p].has_tangents ? "yes" : "no");
  }

  /* The pose source's data: the skin's hierarchy and inverse bind matrices. */
  if (!(file = read_file(path, &file_size, &allocator))) {
    fprintf(stderr, "error: cannot read %s\n", path);
    goto done;
  }
  if (!glb_skin_read(file, file_size, info.skin, &allocator, &skin, message, sizeof message)) {
    fprintf(stderr, "error: %s: %s\n", path, message);
    goto done;
  }
  if (skin.joint_count != info.joint_count ||
      !(bind_local = allocator.alloc(allocator.user, 64 * (size_t)skin.joint_count, 16)) ||
      !compute_bind_locals(&skin, bind_local)) {
    fprintf(stderr, "error: skin %d: %u joints read, %u expected, or a singular inverse bind matrix\n", (int)info.skin,
            (unsigned)skin.joint_count, (unsigned)info.joint_count);
    goto done;
  }

  {
    uint32_t j, roots = 0, depth, max_depth = 0;
    for (j = 0; j < skin.joint_count; ++j) {
      int32_t k = skin.parent[j];
      for (depth = 0; k >= 0; k = skin.parent[k]) ++depth;
      roots += skin.parent[j] < 0;
      if (depth > max_depth) max_depth = depth;
    }
    printf("skin %d: %u joints, %u root(s), hierarchy depth %u\n", (int)info.skin, (unsigned)skin.joint_count,
           (unsigned)roots, (unsigned)max_depth);
  }

  /* 3. Several characters share the asset; each has its own instance and buffers. */
  for (c = 0; c < CHARACTER_COUNT; ++c) {
    character* ch = &characters[c];
    uint32_t i;
    ch->phase = 0.3f * (float)c;
    ch->speed = 0.5f + 0.25f * (float)c;
    if (!check(sf_instance_create(asset, 0, &ch->instance), "sf_instance_create", NULL, NULL)) goto done;
    ch->joint_world = allocator.alloc(allocator.user, 64 * (size_t)info.joint_count, 16);
    ch->skinning = allocator.alloc(allocator.user, 64 * (size_t)info.joint_count, 16);
    ch->vertices = allocator.alloc(allocator.user, info.vertex_count * sizeof *ch->vertices, 16);
    if (!ch->joint_world || !ch->skinning || !ch->vertices) goto done;
    memset(ch->vertices, 0, info.vertex_count * sizeof *ch->vertices);
    for (i = 0; i < info.vertex_count; ++i) ch->vertices[i].uv[0] = ch->vertices[i].uv[1] = UV_SENTINEL;
    /* At amplitude 0 the pose is the bind pose: every skinning matrix must be the identity,
     * which checks the matrix code (affine inverse, products, parents before children). */
    compute_joint_matrices(&skin, bind_local, 0.0f, 0.0f, ch->phase, ch->speed, ch->joint_world, ch->skinning);
    for (i = 0; i < 16 * info.joint_count; ++i)
      if (fabsf(ch->skinning[i] - (i % 16 % 5 == 0 ? 1.0f : 0.0f)) > 1e-3f) {
        fprintf(stderr, "error: the bind pose read from %s does not give identity skinning matrices\n", path);
        goto done;
      }
  }

  failures += show_error_paths(path, file, file_size, &load, &counter, asset, &characters[0], info.joint_count,
                               primitives, info.primitive_count);

  /* 4. The frame loop. */
  printf("frames (bounding box min .. max of each character's positions):\n");
  for (frame = 0; frame < frames; ++frame) {
    const float seconds = (float)frame * FRAME_SECONDS;
    printf("  frame %3ld t=%.3fs", frame, seconds);
    for (c = 0; c < CHARACTER_COUNT; ++c) {
      character* ch = &characters[c];
      sf_eval_options options;
      float box[6];
      clock_t start;
      memset(&options, 0, sizeof options);               /* zero = defaults: skelform method, limb arcs, fairing */
      if (frame == 0) options.flags = SF_EVAL_FROM_REST; /* no previous evaluation to continue from */
      compute_joint_matrices(&skin, bind_local, BEND_AMPLITUDE, seconds, ch->phase, ch->speed, ch->joint_world,
                             ch->skinning);
      if (!check(sf_instance_set_joint_matrices(ch->instance, ch->skinning, info.joint_count, 0),
                 "sf_instance_set_joint_matrices", ch->instance, NULL))
        goto done;
      start = clock();
      if (c == LOD_CHARACTER) {
        if (!skin_by_blocks(ch, primitives, info.primitive_count)) goto done;
        ch->evaluate_seconds += (double)(clock() - start) / CLOCKS_PER_SEC;
      } else {
        if (!check(sf_instance_evaluate(ch->instance, &options), "sf_instance_evaluate", ch->instance, NULL)) goto done;
        ch->evaluate_seconds += (double)(clock() - start) / CLOCKS_PER_SEC;
        if (!write_vertices(ch, primitives, info.primitive_count)) goto done;
      }
      bad_vertices += summarize(ch->vertices, info.vertex_count, box);
      printf("  #%d [%.3g %.3g %.3g .. %.3g %.3g %.3g]", c, box[0], box[1], box[2], box[3], box[4], box[5]);
    }
    printf("\n");
  }
  for (c = 0; c < CHARACTER_COUNT; ++c)
    printf("character %d: phase %.2f, speed %.2f, %.3f ms CPU per %s (%u vertices)\n", c, characters[c].phase,
           characters[c].speed, 1e3 * characters[c].evaluate_seconds / (double)frames,
           c == LOD_CHARACTER ? "frame of LBS by blocks (far away)" : "skelform evaluation",
           (unsigned)info.vertex_count);
  printf("output check: %lu frame-vertices non-finite, non-unit normal or uv touched: %s\n",
         (unsigned long)bad_vertices, bad_vertices == 0 ? "all positions finite" : "FAILED");
  failures += bad_vertices != 0;
  finished = 1;

done:
  failures += !finished;
  /* 6. Free everything: instances before their asset. */
  for (c = 0; c < CHARACTER_COUNT; ++c) {
    sf_instance_destroy(characters[c].instance);
    allocator.free(allocator.user, characters[c].joint_world);
    allocator.free(allocator.user, characters[c].skinning);
    allocator.free(allocator.user, characters[c].vertices);
  }
  sf_asset_destroy(asset);
  glb_skin_free(&skin, &allocator);
  allocator.free(allocator.user, bind_local);
  allocator.free(allocator.user, primitives);
  allocator.free(allocator.user, file);
  printf("allocator: %lu allocations in total, peak %lu bytes; allocations outstanding: %lu (%lu bytes)\n",
         (unsigned long)counter.total_allocations, (unsigned long)counter.peak_bytes,
         (unsigned long)counter.live_allocations, (unsigned long)counter.live_bytes);
  failures += counter.live_allocations != 0 || counter.live_bytes != 0;
  if (failures) fprintf(stderr, "skelform-c-engine: FAILED (%d)\n", failures);
  return failures ? 1 : 0;
}
