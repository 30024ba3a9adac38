/* Minimal GLB skin reader for the C engine example (skelform_c_engine.c).
 *
 * An engine already has a skeleton: its importer read the glTF skin once. This example has
 * none, so it reads just what a procedural pose needs from the baked .glb itself: the
 * skin's joint hierarchy (parent of each joint, from the nodes' `children`) and its
 * inverseBindMatrices. It is not a glTF or JSON library: it understands the GLB container,
 * enough JSON to walk objects and arrays, and float MAT4 accessors in the BIN chunk. Node
 * transforms (TRS) and animations are not read: the example poses joints procedurally
 * about their bind positions, which the inverse bind matrices give.
 *
 * Plain C99. Memory comes from the caller's sf_allocator, the same hook skelform uses. */
#ifndef SKELFORM_SAMPLES_GLB_SKIN_H
#define SKELFORM_SAMPLES_GLB_SKIN_H

#include "skelform/skelform.h"

#include <stddef.h>
#include <stdint.h>

typedef struct glb_skin {
  uint32_t joint_count; /* joints of the skin, in its `joints` order (skelform's order) */
  int32_t* parent;      /* per joint: index of its parent joint in the skin, or -1 */
  uint32_t* order;      /* joint indices, every parent before its children */
  float* inverse_bind;  /* joint_count column-major 4x4 matrices (identity when absent) */
} glb_skin;

/* Reads skin `skin_index` of the GLB in `data`. Returns 1 on success; on failure returns 0,
 * writes a one-line reason into `error` (capacity `error_capacity`) and leaves *out empty. */
int glb_skin_read(const unsigned char* data, size_t size, int32_t skin_index, const sf_allocator* allocator,
                  glb_skin* out, char* error, size_t error_capacity);

/* Releases what glb_skin_read allocated (an empty skin is fine). */
void glb_skin_free(glb_skin* skin, const sf_allocator* allocator);

#endif /* SKELFORM_SAMPLES_GLB_SKIN_H */
