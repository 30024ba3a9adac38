// The refined mesh's vertex normals (refine.h), every frame. Compiled with -fno-math-errno
// where the compiler understands it (runtime/CMakeLists.txt), like displace.cpp.
#include "refine.h"

namespace skelform::runtime {

void refined_normals(const Deformable& deformable, const glm::vec3* refined, glm::vec3* normals) {
  dss::refined_vertex_normals(refined, deformable.refined_vertex_count, deformable.refined_indices.data(),
                              deformable.refined_indices.size() / 3, normals);
}

}  // namespace skelform::runtime
