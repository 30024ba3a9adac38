#include <skelform/bake/procedural.h>
#include <skelform/bake/skeleton.h>

#include <cstdio>

int main() {
  const skelform::bake::TriangleMesh sphere = skelform::bake::make_icosphere(1.0, 2);
  const skelform::bake::SkeletalMesh skeleton = skelform::bake::extract_skeleton(sphere);
  std::printf("skelform bake: %zu skeletal vertices\n", skeleton.skeletal_positions.size());
  return skeleton.skeletal_positions.size() == sphere.positions.size() ? 0 : 1;
}
