// Output for the instance half of the C API (skelform.h "Evaluation"): the strided copy of
// the last evaluation's dense result into the caller's vertex buffers, and of its coarse
// meshes (S', M) for inspection.
#include "api_instance.h"

#include <cstring>

using namespace skelform::runtime;

namespace {

// Copies one element per vertex from `source` to the caller's strided stream. Only the
// element bytes are written; the gaps of a larger stride are never touched. A tightly packed
// stream (the default stride) is one block copy: the same bytes, without a call per vertex.
template <class Element>
void write_stream(float* destination, size_t stride, const Element* source, size_t count) {
  unsigned char* out = reinterpret_cast<unsigned char*>(destination);
  if (stride == sizeof(Element)) {
    std::memcpy(out, source, count * sizeof(Element));
    return;
  }
  for (size_t i = 0; i < count; ++i) std::memcpy(out + i * stride, &source[i], sizeof(Element));
}

// An sf_vertex_output's strides with 0 resolved to the packed element, and whether every
// requested stream's stride holds its element (12 bytes, 16 for tangents).
struct ResolvedStrides {
  size_t position, normal, tangent;
  bool valid;
};

ResolvedStrides resolve_strides(const sf_vertex_output& output) {
  ResolvedStrides s{output.position_stride ? output.position_stride : 12,
                    output.normal_stride ? output.normal_stride : 12,
                    output.tangent_stride ? output.tangent_stride : 16, true};
  s.valid = !((output.positions && s.position < 12) || (output.normals && s.normal < 12) ||
              (output.tangents && s.tangent < 16));
  return s;
}

}  // namespace

extern "C" {

sf_result sf_instance_write(const sf_instance* instance, uint32_t primitive, const sf_vertex_output* output) {
  if (!instance) return SF_ERROR_INVALID_ARGUMENT;
  return guarded(instance, "sf_instance_write", [&]() -> sf_result {
    const Deformable& d = *instance->deformable;
    if (!output) return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_write: output is NULL");
    if (primitive >= d.primitives.size())
      return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_write: primitive %u, the deformable has %zu",
                  primitive, d.primitives.size());
    if (!instance->evaluated)
      return fail(instance, SF_ERROR_NOT_READY, "sf_instance_write: nothing evaluated yet (sf_instance_evaluate)");
    const PrimitiveRecord& p = d.primitives[primitive];
    if (output->vertex_capacity < p.vertex_count)
      return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_write: capacity %zu, the primitive has %u vertices",
                  output->vertex_capacity, p.vertex_count);
    const ResolvedStrides strides = resolve_strides(*output);
    if (!strides.valid)
      return fail(instance, SF_ERROR_INVALID_ARGUMENT,
                  "sf_instance_write: a stride is smaller than its element (12 bytes, 16 for tangents)");
    if (output->tangents && !p.has_tangents)
      return fail(instance, SF_ERROR_UNSUPPORTED, "sf_instance_write: primitive %u has no authored tangents",
                  primitive);
    const size_t first = p.first_vertex, count = p.vertex_count;
    if (output->positions)
      write_stream(output->positions, strides.position, instance->dense_positions.data() + first, count);
    // After an evaluation with SF_EVAL_SKIP_NORMALS the normal streams are left as they are.
    if (instance->normals_valid) {
      if (output->normals) write_stream(output->normals, strides.normal, instance->dense_normals.data() + first, count);
      if (output->tangents)
        write_stream(output->tangents, strides.tangent, instance->dense_tangents.data() + first, count);
    }
    return SF_OK;
  });
}

sf_result sf_instance_skin_range(const sf_instance* instance, uint32_t method, uint32_t primitive,
                                 uint32_t first_vertex, uint32_t vertex_count, const sf_vertex_output* output) {
  // Codes only, no message: a message is instance state, and calls on disjoint ranges of one
  // instance run on several threads at once (skelform.h).
  if (!instance || !output) return SF_ERROR_INVALID_ARGUMENT;
  const Deformable& d = *instance->deformable;
  if (method != SF_METHOD_LBS && method != SF_METHOD_DQS)
    return method == SF_METHOD_SKELFORM ? SF_ERROR_UNSUPPORTED : SF_ERROR_INVALID_ARGUMENT;
  if (primitive >= d.primitives.size()) return SF_ERROR_INVALID_ARGUMENT;
  const PrimitiveRecord& p = d.primitives[primitive];
  if (first_vertex > p.vertex_count || vertex_count > p.vertex_count - first_vertex ||
      output->vertex_capacity < vertex_count)
    return SF_ERROR_INVALID_ARGUMENT;
  const ResolvedStrides strides = resolve_strides(*output);
  if (!strides.valid) return SF_ERROR_INVALID_ARGUMENT;
  if (output->tangents && !p.has_tangents) return SF_ERROR_UNSUPPORTED;
  if (d.joint_count == 0 || d.influences == 0 || instance->driver != Driver::skin) return SF_ERROR_UNSUPPORTED;
  // Positions are always computed (their finiteness is the result); without a stream they go
  // to one scratch element, stride 0.
  float scratch[3];
  const bool positions = output->positions != nullptr;
  const StridedOutput out{reinterpret_cast<unsigned char*>(positions ? output->positions : scratch),
                          positions ? strides.position : 0,
                          reinterpret_cast<unsigned char*>(output->normals),
                          strides.normal,
                          reinterpret_cast<unsigned char*>(output->tangents),
                          strides.tangent};
  const Blend blend = method == SF_METHOD_LBS ? Blend::linear : Blend::dual_quaternion;
  return dense_skinning_range(d, instance->joints, blend, primitive, first_vertex, vertex_count, out)
             ? SF_OK
             : SF_ERROR_INVALID_ARGUMENT;
}

sf_result sf_instance_write_coarse(const sf_instance* instance, uint32_t mesh, float* positions, size_t stride_bytes,
                                   size_t vertex_capacity) {
  if (!instance) return SF_ERROR_INVALID_ARGUMENT;
  return guarded(instance, "sf_instance_write_coarse", [&]() -> sf_result {
    const Deformable& d = *instance->deformable;
    if (mesh > SF_COARSE_SKELETAL)
      return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_write_coarse: unknown mesh %u", mesh);
    if (!positions) return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_write_coarse: positions is NULL");
    const size_t stride = stride_bytes ? stride_bytes : 12;
    if (stride < 12)
      return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_write_coarse: stride %zu is smaller than 12",
                  stride_bytes);
    if (vertex_capacity < d.control_vertex_count)
      return fail(instance, SF_ERROR_INVALID_ARGUMENT,
                  "sf_instance_write_coarse: capacity %zu, the mesh has %u vertices", vertex_capacity,
                  d.control_vertex_count);
    if (!instance->has_previous)
      return fail(instance, SF_ERROR_NOT_READY,
                  "sf_instance_write_coarse: no SF_METHOD_SKELFORM evaluation yet (sf_instance_evaluate)");
    // After an evaluation its S' and M live in previous_* (the incremental start).
    const glm::vec3* source =
        mesh == SF_COARSE_SKELETAL ? instance->previous_skeletal.data() : instance->previous_control.data();
    // Held in the evaluation's normalised space (instance.h JointTransforms).
    const float scale = instance->output_scale;
    unsigned char* out = reinterpret_cast<unsigned char*>(positions);
    for (uint32_t v = 0; v < d.control_vertex_count; ++v) {
      const glm::vec3 p = source[v] * scale;
      std::memcpy(out + v * stride, &p, sizeof p);
    }
    return SF_OK;
  });
}

}  // extern "C"
