// Rest-pose check for the skelform-pose end-to-end test: the posed OBJ's vertices must equal
// the original glTF positions of the skinned meshes' primitives (file order, as the baker
// concatenates them) within TOLERANCE × bounding-box diagonal (DESIGN.md "rest error").
//
//   skelform_pose_rest_check ORIGINAL.gltf|glb POSED.obj TOLERANCE
//
// Prints one line with the measured error; exit 0 when within tolerance, 1 otherwise.
#include "gltf_animation.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: skelform_pose_rest_check ORIGINAL.glb POSED.obj TOLERANCE\n");
    return 2;
  }
  try {
    const skelform::samples::GltfAnimation gltf = skelform::samples::GltfAnimation::load_file(argv[1]);
    // Meshes instanced by a skinned node, as the baker selects them.
    tinygltf::Model model;
    tinygltf::TinyGLTF loader;
    std::string error, warning;
    const std::string path = argv[1];
    const bool binary = path.size() > 4 && path.substr(path.size() - 4) == ".glb";
    loader.SetImageLoader([](tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*,
                             int, void*) { return true; },
                          nullptr);
    if (!(binary ? loader.LoadBinaryFromFile(&model, &error, &warning, path)
                 : loader.LoadASCIIFromFile(&model, &error, &warning, path))) {
      std::fprintf(stderr, "cannot load %s: %s\n", argv[1], error.c_str());
      return 2;
    }
    std::set<int> skinned_meshes;
    for (const tinygltf::Node& node : model.nodes)
      if (node.mesh >= 0 && node.skin >= 0) skinned_meshes.insert(node.mesh);
    std::vector<float> original;
    for (int mesh : skinned_meshes)
      for (size_t p = 0; p < gltf.primitive_count(static_cast<size_t>(mesh)); ++p) {
        const std::vector<float> positions = gltf.primitive_positions(static_cast<size_t>(mesh), p);
        original.insert(original.end(), positions.begin(), positions.end());
      }

    std::ifstream obj(argv[2]);
    if (!obj) {
      std::fprintf(stderr, "cannot read %s\n", argv[2]);
      return 2;
    }
    std::vector<double> posed;
    std::string line;
    while (std::getline(obj, line)) {
      if (line.rfind("v ", 0) != 0) continue;
      std::istringstream in(line.substr(2));
      double x, y, z;
      in >> x >> y >> z;
      posed.insert(posed.end(), {x, y, z});
    }
    if (posed.size() != original.size()) {
      std::printf("vertex count differs: %zu posed, %zu original\n", posed.size() / 3, original.size() / 3);
      return 1;
    }
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300}, worst = 0;
    for (size_t i = 0; i < original.size(); i += 3) {
      double d2 = 0;
      for (size_t c = 0; c < 3; ++c) {
        lo[c] = std::min(lo[c], double(original[i + c]));
        hi[c] = std::max(hi[c], double(original[i + c]));
        d2 += (posed[i + c] - original[i + c]) * (posed[i + c] - original[i + c]);
      }
      worst = std::max(worst, std::sqrt(d2));
    }
    const double diagonal = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                      (hi[2] - lo[2]) * (hi[2] - lo[2]));
    const double relative = diagonal > 0 ? worst / diagonal : worst;
    const double tolerance = std::atof(argv[3]);
    std::printf("%zu vertices, rest error %.3g of the diagonal (tolerance %.3g)\n", posed.size() / 3, relative,
                tolerance);
    return relative <= tolerance ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
}
