// Test input for skelform-c-engine that needs no third-party model: writes OUT.glb, the
// runtime tests' procedural skinned capsule (tests/capsule_glb.h): a capsule along z with
// authored normals and tangents on a root and a child joint, plus a sphere primitive without
// normals or tangents. The test bakes it with skelform-bake, so the example runs on two
// primitives, one of them without tangents, and a real bend.
//
//   skelform_c_engine_capsule OUT.glb
#include "capsule_glb.h"

#include <cstdio>
#include <fstream>
#include <string>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: skelform_c_engine_capsule OUT.glb\n");
    return 2;
  }
  const std::string glb = skelform::test::capsule_glb();
  std::ofstream out(argv[1], std::ios::binary);
  out.write(glb.data(), std::streamsize(glb.size()));
  if (!out.flush()) {
    std::fprintf(stderr, "skelform_c_engine_capsule: cannot write %s\n", argv[1]);
    return 1;
  }
  return 0;
}
