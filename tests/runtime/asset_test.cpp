// Runtime asset loading (runtime/src/asset_load.cpp, api_asset.cpp): bad arguments are
// refused first; a real bake loads from memory (.glb, .gltf with a data URI) and from files
// with the counts the baker wrote; the rest evaluation reproduces the original vertices;
// every kind of corruption of a baked file gives its own sf_result and a message, never a
// crash; a caller's allocator is used for everything the asset owns and balances.
#include "asset.h"
#include "refine.h"
#include "skelform/bake/bake.h"
#include "skelform/bake/gltf_writer.h"
#include "skelform/bake/glb.h"
#include "skelform/bake/input.h"
#include "skelform/core/dss_frame.h"
#include "skelform/skelform.h"
#include "capsule_glb.h"
#include "counting_heap.h"
#include "glb_edit.h"
#include "test_support.h"

#include <doctest/doctest.h>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace {

using Json = nlohmann::ordered_json;
using skelform::test::Glb;
using skelform::test::u32_at;

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_file(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

struct Baked {
  std::string glb;
  skelform::bake::BakeResult result;
};

// Bakes a sample once per process (baking takes seconds; the tests only read the result).
const Baked& baked_sample(const std::filesystem::path& path) {
  static std::mutex mutex;
  static std::map<std::string, Baked> cache;
  std::lock_guard<std::mutex> lock(mutex);
  auto found = cache.find(path.string());
  if (found != cache.end()) return found->second;
  Baked baked;
  baked.result = skelform::bake::bake_model(skelform::bake::load_mesh(path.string()));
  baked.glb = skelform::bake::baked_glb(read_file(path), path.parent_path().string() + "/", baked.result.deformables);
  return cache.emplace(path.string(), std::move(baked)).first->second;
}

// Outcome of one load: its result and message; the asset is destroyed at once.
struct Load {
  sf_result result = SF_OK;
  std::string message;
  sf_asset* asset = nullptr;
  Load() = default;
  Load(const Load&) = delete;
  Load& operator=(const Load&) = delete;
  ~Load() { sf_asset_destroy(asset); }
};

void load_memory(const std::string& bytes, Load& out, const sf_allocator* allocator = nullptr) {
  char message[512] = "untouched";
  sf_load_options options{};
  options.allocator = allocator;
  options.error_message = message;
  options.error_message_capacity = sizeof message;
  out.result = sf_asset_load_memory(bytes.data(), bytes.size(), &options, &out.asset);
  out.message = message;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

std::string base64(const std::string& bytes) {
  static const char table[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t n = uint32_t(uint8_t(bytes[i])) << 16 | uint32_t(uint8_t(bytes[i + 1])) << 8 | uint8_t(bytes[i + 2]);
    for (int s = 18; s >= 0; s -= 6) out += table[(n >> s) & 63];
  }
  if (i < bytes.size()) {
    uint32_t n = uint32_t(uint8_t(bytes[i])) << 16;
    if (i + 1 < bytes.size()) n |= uint32_t(uint8_t(bytes[i + 1])) << 8;
    out += table[(n >> 18) & 63];
    out += table[(n >> 12) & 63];
    out += i + 1 < bytes.size() ? table[(n >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

// Checks a corrupted copy gives `expected` with a message naming `part`.
void check_corrupt(const Glb& glb, sf_result expected, const std::string& part) {
  Load load;
  load_memory(glb.bytes(), load);
  CHECK_MESSAGE(load.result == expected, load.message);
  CHECK(load.asset == nullptr);
  CHECK_MESSAGE(contains(load.message, part), load.message);
}

}  // namespace

TEST_SUITE("asset") {
  TEST_CASE("default input is invalid: null pointers, empty input, garbage and bad options are refused") {
    sf_asset* asset = reinterpret_cast<sf_asset*>(uintptr_t{1});
    const char bytes[] = "glTF";
    CHECK(sf_asset_load_memory(bytes, 4, nullptr, nullptr) == SF_ERROR_INVALID_ARGUMENT);
    CHECK(sf_asset_load_memory(nullptr, 4, nullptr, &asset) == SF_ERROR_INVALID_ARGUMENT);
    CHECK(asset == nullptr);
    CHECK(sf_asset_load_memory(bytes, 0, nullptr, &asset) == SF_ERROR_INVALID_ARGUMENT);
    CHECK(sf_asset_load_file(nullptr, nullptr, &asset) == SF_ERROR_INVALID_ARGUMENT);
    CHECK(sf_asset_load_file("", nullptr, &asset) == SF_ERROR_INVALID_ARGUMENT);
    CHECK(sf_asset_load_file("x.glb", nullptr, nullptr) == SF_ERROR_INVALID_ARGUMENT);

    Load garbage;
    load_memory("this is not a glTF file at all", garbage);
    CHECK(garbage.result == SF_ERROR_INVALID_DATA);
    CHECK(contains(garbage.message, "not a valid glTF"));
    Load magic;
    load_memory(std::string("glTF\x02\0\0\0\xff\xff\xff\x7f", 12), magic);
    CHECK(magic.result == SF_ERROR_INVALID_DATA);
    CHECK(contains(magic.message, "truncated .glb"));
    Load json;
    load_memory("{\"asset\":{\"version\":\"2.0\"}}", json);
    CHECK(json.result == SF_ERROR_INVALID_DATA);
    CHECK(contains(json.message, "not a skelform-baked asset (run skelform-bake)"));

    char message[64];
    sf_load_options options{};
    options.error_message = message;
    options.error_message_capacity = sizeof message;
    CHECK(sf_asset_load_file("/nonexistent/dir/model.glb", &options, &asset) == SF_ERROR_IO);
    CHECK(contains(message, "/nonexistent/dir/model.glb"));
    CHECK(sf_asset_load_file(skelform::test::scratch_dir("asset").string().c_str(), &options, &asset) == SF_ERROR_IO);
    CHECK(contains(message, "directory"));

    // The message is cut to the caller's capacity and always terminated.
    options.error_message_capacity = 8;
    std::memset(message, 'x', sizeof message);
    CHECK(sf_asset_load_memory("garbage!", 8, &options, &asset) == SF_ERROR_INVALID_DATA);
    CHECK(std::strlen(message) == 7);
    CHECK(message[8] == 'x');

    // Half an allocator would free into another heap than it allocated from.
    sf_allocator half{};
    half.alloc = skelform::test::CountingHeap::alloc;
    options.allocator = &half;
    options.error_message_capacity = sizeof message;
    CHECK(sf_asset_load_memory("garbage!", 8, &options, &asset) == SF_ERROR_INVALID_ARGUMENT);
    CHECK(contains(message, "alloc and free"));

    CHECK(sf_asset_deformable_count(nullptr) == 0);
    sf_deformable_info info;
    sf_primitive_info primitive;
    CHECK(sf_asset_deformable_info(nullptr, 0, &info) == SF_ERROR_INVALID_ARGUMENT);
    CHECK(sf_asset_primitive_info(nullptr, 0, 0, &primitive) == SF_ERROR_INVALID_ARGUMENT);
    sf_asset_destroy(nullptr);
  }

  TEST_CASE("a baked RiggedSimple loads from memory and from a file with the baker's counts") {
    SKELFORM_REQUIRE_DATA(path, "RiggedSimple/RiggedSimple.glb");
    const Baked& baked = baked_sample(path);
    const std::filesystem::path file = skelform::test::scratch_dir("asset") / "RiggedSimple.skf.glb";
    write_file(file, baked.glb);

    Load memory;
    load_memory(baked.glb, memory);
    REQUIRE_MESSAGE(memory.result == SF_OK, memory.message);
    CHECK(memory.message.empty());
    sf_asset* from_file = nullptr;
    REQUIRE(sf_asset_load_file(file.string().c_str(), nullptr, &from_file) == SF_OK);

    for (const sf_asset* asset :
         {static_cast<const sf_asset*>(memory.asset), static_cast<const sf_asset*>(from_file)}) {
      REQUIRE(sf_asset_deformable_count(asset) == baked.result.deformables.size());
      for (uint32_t d = 0; d < sf_asset_deformable_count(asset); ++d) {
        const skelform::bake::BakedDeformable& expected = baked.result.deformables[d];
        sf_deformable_info info;
        REQUIRE(sf_asset_deformable_info(asset, d, &info) == SF_OK);
        CHECK(info.mesh == expected.mesh);
        CHECK(info.node == expected.node);
        CHECK(info.skin == expected.skin);
        CHECK(info.joint_count > 0);
        CHECK(info.primitive_count == expected.primitives.size());
        CHECK(info.vertex_count == expected.dense_vertex_count);
        CHECK(info.control_vertex_count == expected.control_positions.size());
        CHECK(info.subdivision_level == expected.subdivision_level);
        uint32_t first = 0;
        for (uint32_t p = 0; p < info.primitive_count; ++p) {
          sf_primitive_info primitive;
          REQUIRE(sf_asset_primitive_info(asset, d, p, &primitive) == SF_OK);
          CHECK(primitive.gltf_primitive == expected.primitives[p]);
          CHECK(primitive.first_vertex == first);
          first += primitive.vertex_count;
        }
        CHECK(first == info.vertex_count);
        sf_primitive_info primitive;
        CHECK(sf_asset_primitive_info(asset, d, info.primitive_count, &primitive) == SF_ERROR_INVALID_ARGUMENT);
      }
      sf_deformable_info info;
      CHECK(sf_asset_deformable_info(asset, sf_asset_deformable_count(asset), &info) == SF_ERROR_INVALID_ARGUMENT);
    }
    sf_asset_destroy(from_file);
  }

  TEST_CASE("a .gltf with a data URI loads from memory; with an external .bin only from its file") {
    SKELFORM_REQUIRE_DATA(path, "RiggedSimple/RiggedSimple.glb");
    Glb glb(baked_sample(path).glb);
    const std::string bin = glb.bin;
    Json document = glb.json;
    document["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64(bin);
    Load embedded;
    load_memory(document.dump(), embedded);
    CHECK_MESSAGE(embedded.result == SF_OK, embedded.message);

    const std::filesystem::path dir = skelform::test::scratch_dir("asset/external");
    document["buffers"][0]["uri"] = "RiggedSimple.skf.bin";
    write_file(dir / "RiggedSimple.skf.gltf", document.dump());
    write_file(dir / "RiggedSimple.skf.bin", bin);
    sf_asset* asset = nullptr;
    CHECK(sf_asset_load_file((dir / "RiggedSimple.skf.gltf").string().c_str(), nullptr, &asset) == SF_OK);
    sf_asset_destroy(asset);

    Load external;  // from memory nothing outside the bytes is read
    load_memory(document.dump(), external);
    CHECK(external.result == SF_ERROR_UNSUPPORTED);
    CHECK(contains(external.message, "RiggedSimple.skf.bin"));

    std::filesystem::remove(dir / "RiggedSimple.skf.bin");
    char message[256] = "";
    sf_load_options options{};
    options.error_message = message;
    options.error_message_capacity = sizeof message;
    CHECK(sf_asset_load_file((dir / "RiggedSimple.skf.gltf").string().c_str(), &options, &asset) == SF_ERROR_IO);
    CHECK(asset == nullptr);
    CHECK(contains(message, "RiggedSimple.skf.bin"));
  }

  // The runtime's refined rest surface (refine_surface), checked against the baker's arithmetic
  // written out here: the area-weighted normal sums of the control mesh turned onto the medial
  // directions (dss_frame.h), then each stored stencil row, scalar, positions and sums alike,
  // the sums normalised.
  void refine_like_the_baker(const skelform::runtime::Deformable& d, std::vector<glm::vec3>& refined,
                             std::vector<glm::vec3>& normals) {
    // Only the named refined vertices are refined (asset.h named_refined_count): every dense
    // vertex's bound triangle names only those, and the grouped rows are exactly those.
    REQUIRE(d.named_refined_count <= d.refined_vertex_count);
    for (const uint32_t corner : d.binding_corners) REQUIRE(corner < d.named_refined_count);
    std::vector<int> grouped(d.named_refined_count, 0);
    for (const uint32_t row : d.stencil_group_rows) {
      REQUIRE(row < d.named_refined_count);
      grouped[row] = 1;
    }
    CHECK(std::count(grouped.begin(), grouped.end(), 1) == std::ptrdiff_t(d.named_refined_count));
    refined.assign(d.named_refined_count, glm::vec3(0.0f));
    normals.assign(d.named_refined_count, glm::vec3(0.0f));
    skelform::runtime::refine_rest_surface(d, refined.data(), normals.data());
    // The runtime's pass (grouped stencils, SSE2, one walk for both) rearranges the baker's
    // arithmetic (dss_frame.h, the stored stencils row by row) for speed: same bits.
    std::vector<glm::vec3> baker_sums(d.control_vertex_count, glm::vec3(0.0f));
    skelform::dss::add_face_normals(d.control_positions.data(), d.control_indices.data(), d.control_indices.size() / 3,
                                    baker_sums.data());
    skelform::dss::medial_normal_sums(d.control_positions.data(), d.skeletal_positions.data(), d.control_vertex_count,
                                      baker_sums.data());
    // Row by row, scalar, from the grouped copy (the loader keeps only that one): each row's
    // entries in stencil order.
    std::vector<glm::vec3> baker_positions(d.named_refined_count), baker_normals(d.named_refined_count);
    const uint32_t lanes = skelform::runtime::kStencilLanes;
    size_t entry = 0;
    for (size_t g = 0; g < d.stencil_group_lengths.size(); ++g) {
      for (uint32_t lane = 0; lane < lanes; ++lane) {
        glm::vec3 point(0.0f), normal(0.0f);
        for (uint32_t s = 0; s < d.stencil_group_lengths[g]; ++s) {
          const size_t k = entry + size_t{s} * lanes + lane;
          point += d.stencil_group_weights[k] * d.control_positions[d.stencil_group_indices[k]];
          normal += d.stencil_group_weights[k] * baker_sums[d.stencil_group_indices[k]];
        }
        baker_positions[d.stencil_group_rows[g * lanes + lane]] = point;
        baker_normals[d.stencil_group_rows[g * lanes + lane]] = skelform::dss::normalise_or_zero(normal);
      }
      entry += size_t{d.stencil_group_lengths[g]} * lanes;
    }
    CHECK(std::memcmp(refined.data(), baker_positions.data(), refined.size() * sizeof(glm::vec3)) == 0);
    CHECK(std::memcmp(normals.data(), baker_normals.data(), normals.size() * sizeof(glm::vec3)) == 0);
    // The same with the position and normal sum of each control vertex side by side (`lanes`,
    // read as one 32-byte vector where the CPU has AVX2), as an evaluation refines.
    std::vector<glm::vec3> control(d.control_vertex_count + skelform::runtime::kVec3ReadPadding, glm::vec3(0.0f));
    std::copy(d.control_positions.begin(), d.control_positions.end(), control.begin());
    std::vector<glm::vec3> sums(control.size()), lane_refined(refined.size()), lane_normals(normals.size());
    std::vector<float> lanes_scratch(8 * size_t{d.control_vertex_count});
    skelform::runtime::refine_surface(d, control.data(), d.skeletal_positions.data(), sums.data(), lane_refined.data(),
                                      lane_normals.data(), lanes_scratch.data());
    CHECK(std::memcmp(lane_refined.data(), baker_positions.data(), refined.size() * sizeof(glm::vec3)) == 0);
    CHECK(std::memcmp(lane_normals.data(), baker_normals.data(), normals.size() * sizeof(glm::vec3)) == 0);
  }

  TEST_CASE("a level-2 bake: the runtime refines the rest control mesh and its normals to the baker's bits") {
    // The test capsule and most sample models bake at level 0, where the stencils are the
    // identity (CesiumMan bakes at level 1); a capsule decimated to ~150 triangles is refined
    // twice.
    const std::string bytes = skelform::test::capsule_glb();
    skelform::bake::BakeOptions options;
    options.target_triangles = 150;
    options.subdivision_level = 2;
    const skelform::bake::BakeResult baked =
        skelform::bake::bake_model(skelform::bake::load_mesh_from_memory(
                                       std::vector<unsigned char>(bytes.begin(), bytes.end()), ".glb", "capsule.glb"),
                                   options);
    Load load;
    load_memory(
        skelform::bake::baked_glb(bytes, skelform::test::scratch_dir("asset/level2").string(), baked.deformables),
        load);
    REQUIRE_MESSAGE(load.result == SF_OK, load.message);
    const skelform::runtime::Deformable& d = load.asset->deformables[0];
    REQUIRE(d.refined_vertex_count > 8 * d.control_vertex_count);  // level 2: about 16 times
    std::vector<glm::vec3> refined, normals;
    refine_like_the_baker(d, refined, normals);
    float worst_length = 0.0f;  // the refined normals are unit
    for (const glm::vec3& n : normals) worst_length = std::max(worst_length, std::fabs(glm::length(n) - 1.0f));
    CHECK(worst_length < 1e-6f);
    // The rest pose through those normals is the original mesh.
    glm::vec3 low(std::numeric_limits<float>::max()), high(-std::numeric_limits<float>::max());
    for (const glm::vec3& p : d.rest_positions) low = glm::min(low, p), high = glm::max(high, p);
    float worst = 0.0f;
    for (uint32_t v = 0; v < d.vertex_count; ++v) {
      const skelform::dss::SurfaceFrame frame = skelform::runtime::bound_frame(d, refined.data(), normals.data(), v);
      const glm::vec3 p = skelform::dss::displaced_point(frame, d.binding_displacement[v], d.binding_residual[v]);
      worst = std::max(worst, glm::length(p - d.rest_positions[v]));
    }
    MESSAGE("level-2 capsule: " << d.control_vertex_count << " control, " << d.refined_vertex_count
                                << " refined vertices (" << d.named_refined_count
                                << " named by the binding); rest error " << worst / glm::length(high - low)
                                << " of the diagonal");
    CHECK(worst <= 1e-5f * glm::length(high - low));
  }

  TEST_CASE("medial_normal_sums: the runtime's four-lane pass gives the scalar rule's bits, fallbacks included") {
    // Deformed-looking input (P − S and A disagree, as away from rest) mixed with every case the
    // rule leaves alone, at every position within a group of four and in the scalar tail.
    const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
    std::vector<glm::vec3> positions, skeletal, sums;
    uint32_t state = 12345u;
    const auto next = [&state] {
      state = state * 1664525u + 1013904223u;
      return float(state >> 8) / float(1u << 24) * 2.0f - 1.0f;
    };
    for (int v = 0; v < 67; ++v) {
      positions.emplace_back(next(), next(), next());
      skeletal.emplace_back(positions.back() - 0.3f * glm::vec3(next(), next(), next()));
      sums.emplace_back(next(), next(), next());
      switch (v % 9) {
        case 1:
          skeletal.back() = positions.back();
          break;  // zero medial radius
        case 2:
          sums.back() = glm::vec3(0.0f);
          break;  // no normal
        case 3:
          sums.back() = positions.back() - skeletal.back();
          break;  // the rest case
        case 4:
          sums.back() = skeletal.back() - positions.back();
          break;  // opposite: no bisector
        case 5:
          positions.back().y = nan;
          break;
        case 6:
          skeletal.back().z = inf;
          break;
        case 7:
          sums.back() = glm::vec3(1e-31f, 0.0f, 0.0f);
          break;
        default:
          break;
      }
    }
    std::vector<glm::vec3> scalar = sums, lanes = sums;
    skelform::dss::medial_normal_sums(positions.data(), skeletal.data(), positions.size(), scalar.data());
    skelform::runtime::medial_normal_sums(positions.data(), skeletal.data(), positions.size(), lanes.data());
    CHECK(std::memcmp(scalar.data(), lanes.data(), scalar.size() * sizeof(glm::vec3)) == 0);
    // The general case is exercised, not only the fallbacks: those vertices were turned.
    for (size_t v = 0; v < sums.size(); ++v)
      if (v % 9 == 0 || v % 9 == 8) CHECK(std::memcmp(&scalar[v], &sums[v], sizeof(glm::vec3)) != 0);
  }

  TEST_CASE("the rest evaluation reproduces the original vertices; Fox (no NORMAL) gets unit rest normals") {
    for (const char* sample : {"RiggedSimple/RiggedSimple.glb", "Fox/Fox.glb"}) {
      SKELFORM_REQUIRE_DATA(path, sample);
      Load load;
      load_memory(baked_sample(path).glb, load);
      REQUIRE_MESSAGE(load.result == SF_OK, load.message);
      for (const skelform::runtime::Deformable& d : load.asset->deformables) {
        std::vector<glm::vec3> refined, normals;
        refine_like_the_baker(d, refined, normals);
        glm::vec3 low(std::numeric_limits<float>::max()), high(-std::numeric_limits<float>::max());
        for (const glm::vec3& p : d.rest_positions) {
          low = glm::min(low, p);
          high = glm::max(high, p);
        }
        const float diagonal = glm::length(high - low);
        float worst = 0;
        REQUIRE(d.binding_corners.size() == 3 * size_t{d.vertex_count});
        REQUIRE(d.rest_normal_coords.size() == d.vertex_count);
        REQUIRE(d.rest_tangent_coords.size() == d.vertex_count);
        for (uint32_t v = 0; v < d.vertex_count; ++v) {
          const skelform::dss::SurfaceFrame frame =
              skelform::runtime::bound_frame(d, refined.data(), normals.data(), v);
          const glm::vec3 p = skelform::dss::displaced_point(frame, d.binding_displacement[v], d.binding_residual[v]);
          worst = std::max(worst, glm::length(p - d.rest_positions[v]));
          for (uint32_t k = 0; k < 3; ++k)
            CHECK(d.binding_corners[3 * size_t{v} + k] == d.refined_indices[3 * size_t{d.binding_triangle[v]} + k]);
          // The rest normal in rest-frame coordinates carries back to the rest normal.
          const glm::vec3 c = d.rest_normal_coords[v];
          const glm::vec3 carried = c.x * frame.tangent + c.y * frame.bitangent + c.z * frame.normal;
          CHECK(glm::length(carried - glm::normalize(d.rest_normals[v])) < 1e-5f);
          CHECK(d.handle_control_vertex[v] < d.control_vertex_count);
          CHECK(std::abs(glm::length(d.rest_normals[v]) - 1.0f) < 1e-3f);
        }
        CHECK_MESSAGE(worst / diagonal <= 1e-5f, sample << " rest error " << worst / diagonal);
        if (std::string(sample) == "Fox/Fox.glb") {
          for (const skelform::runtime::PrimitiveRecord& record : d.primitives) CHECK(!record.has_normals);
        }
        // Dense skin for the baselines: weights sum to 1 per vertex, joints in the skin.
        REQUIRE(d.influences >= 4);
        for (uint32_t v = 0; v < d.vertex_count; ++v) {
          float sum = 0;
          for (uint32_t k = 0; k < d.influences; ++k) {
            sum += d.dense_weights[v * d.influences + k];
            CHECK(d.dense_joints[v * d.influences + k] < d.joint_count);
          }
          CHECK(std::abs(sum - 1.0f) < 1e-5f);
        }
      }
    }
  }

  TEST_CASE("corrupt assets: each corruption gives its sf_result and a message, never a crash") {
    SKELFORM_REQUIRE_DATA(path, "RiggedSimple/RiggedSimple.glb");
    const Glb original(baked_sample(path).glb);
    Glb probe = original;
    const uint32_t control_vertices = probe.accessor("control", "positions")["count"].get<uint32_t>();
    const uint32_t refined_vertices = probe.accessor("subdivision", "stencilOffsets")["count"].get<uint32_t>() - 1;
    const uint32_t refined_triangles = probe.accessor("subdivision", "indices")["count"].get<uint32_t>() / 3;
    const uint32_t joint_count =
        static_cast<uint32_t>(probe.json["skins"][probe.deformable()["skin"].get<size_t>()]["joints"].size());

    SUBCASE("missing extension") {
      Glb glb = original;
      glb.json["extensions"].erase("SKELFORM_skeletal_deformation");
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "not a skelform-baked asset (run skelform-bake)");
    }
    SUBCASE("newer major version") {
      Glb glb = original;
      glb.extension()["majorVersion"] = 3;
      glb.extension()["minorVersion"] = 1;
      check_corrupt(glb, SF_ERROR_VERSION_MISMATCH, "version 3.1; this runtime reads major version 2");
    }
    SUBCASE("older major version: bound to another normal field, so refused with what to do") {
      Glb glb = original;
      glb.extension()["majorVersion"] = 1;
      check_corrupt(glb, SF_ERROR_VERSION_MISMATCH, "bake the asset again with this release's skelform-bake");
    }
    SUBCASE("a newer minor version is accepted") {
      Glb glb = original;
      glb.extension()["minorVersion"] = 7;
      glb.extension()["futureMember"] = 1;
      Load load;
      load_memory(glb.bytes(), load);
      CHECK_MESSAGE(load.result == SF_OK, load.message);
    }
    SUBCASE("missing majorVersion") {
      Glb glb = original;
      glb.extension().erase("majorVersion");
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "majorVersion");
    }
    SUBCASE("accessor count smaller than the layout requires") {
      Glb glb = original;
      glb.accessor("control", "skeletalPositions")["count"] = control_vertices - 1;
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "control.skeletalPositions: has");
    }
    SUBCASE("bufferView shorter than its accessor needs") {
      Glb glb = original;
      Json& view = glb.json["bufferViews"][glb.accessor("subdivision", "stencilWeights")["bufferView"].get<size_t>()];
      view["byteLength"] = view["byteLength"].get<size_t>() - 4;
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "runs past the end of bufferView");
    }
    SUBCASE("accessor index out of range") {
      Glb glb = original;
      glb.deformable()["binding"]["residual"] = 100000;
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "binding.residual");
    }
    SUBCASE("wrong component type") {
      Glb glb = original;
      glb.accessor("subdivision", "stencilIndices")["componentType"] = 5126;
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "expected UNSIGNED_INT SCALAR");
    }
    SUBCASE("stencil index out of range") {
      Glb glb = original;
      glb.put_u32(glb.offset_of(glb.accessor("subdivision", "stencilIndices"), 5, 4), control_vertices);
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "subdivision.stencilIndices: index");
    }
    SUBCASE("stencil offsets decrease") {
      Glb glb = original;
      glb.put_u32(glb.offset_of(glb.accessor("subdivision", "stencilOffsets"), 1, 4), 0xFFFFFFF0u);
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "offsets decrease");
    }
    SUBCASE("refined index out of range") {
      Glb glb = original;
      glb.put_u32(glb.offset_of(glb.accessor("subdivision", "indices"), 7, 4), refined_vertices);
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "subdivision.indices: index");
    }
    SUBCASE("control index out of range") {
      Glb glb = original;
      glb.put_u32(glb.offset_of(glb.accessor("control", "indices"), 2, 4), control_vertices + 5);
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "control.indices: index");
    }
    SUBCASE("binding triangle out of range") {
      Glb glb = original;
      glb.put_u32(glb.offset_of(glb.accessor("binding", "triangle"), 3, 4), refined_triangles);
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "binding.triangle: index");
    }
    SUBCASE("control joint outside the skin") {
      Glb glb = original;
      Json& weights = glb.json["accessors"][glb.deformable()["control"]["weights"][0].get<size_t>()];
      Json& joints = glb.json["accessors"][glb.deformable()["control"]["joints"][0].get<size_t>()];
      size_t slot = 0;  // the first influencing slot: only those must name a joint of the skin
      while (!(glb.f32(glb.offset_of(weights, slot, 4)) > 0)) ++slot;
      glb.put_u16(glb.offset_of(joints, slot, 2), static_cast<uint16_t>(joint_count));
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "names joint " + std::to_string(joint_count));
    }
    SUBCASE("NaN in a float array") {
      Glb glb = original;
      glb.put_f32(glb.offset_of(glb.accessor("binding", "barycentric"), 9, 4), std::nanf(""));
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "non-finite");
    }
    SUBCASE("infinite stencil weight") {
      Glb glb = original;
      glb.put_f32(glb.offset_of(glb.accessor("subdivision", "stencilWeights"), 0, 4), INFINITY);
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "subdivision.stencilWeights");
    }
    SUBCASE("negative medial radius") {
      Glb glb = original;
      glb.put_f32(glb.offset_of(glb.accessor("control", "medialRadius"), 0, 4), -1.0f);
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "negative radius");
    }
    SUBCASE("subdivision level out of range") {
      Glb glb = original;
      glb.deformable()["subdivision"]["level"] = 9;
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "level");
    }
    SUBCASE("vertexCount differs from the primitives") {
      Glb glb = original;
      glb.deformable()["vertexCount"] = glb.deformable()["vertexCount"].get<int>() + 1;
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "binding.triangle: has");
    }
    SUBCASE("a primitive that does not exist") {
      Glb glb = original;
      glb.deformable()["primitives"][0] = 42;
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "primitives[0]");
    }
    SUBCASE("a mesh that does not exist") {
      Glb glb = original;
      glb.deformable()["mesh"] = 42;
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "'mesh'");
    }
    SUBCASE("deformables missing") {
      Glb glb = original;
      glb.extension().erase("deformables");
      check_corrupt(glb, SF_ERROR_INVALID_DATA, "deformables");
    }
  }

  TEST_CASE("a truncated .glb fails cleanly at every kind of cut") {
    SKELFORM_REQUIRE_DATA(path, "RiggedSimple/RiggedSimple.glb");
    const std::string glb = baked_sample(path).glb;
    const size_t json_end = 20 + u32_at(glb, 12);
    for (size_t length :
         {size_t{1}, size_t{4}, size_t{11}, size_t{12}, size_t{19}, size_t{20}, size_t{21}, json_end - 1, json_end,
          json_end + 4, json_end + 8, glb.size() / 2, glb.size() - 4, glb.size() - 1}) {
      Load load;
      load_memory(glb.substr(0, length), load);
      CHECK_MESSAGE(load.result == SF_ERROR_INVALID_DATA, length << ": " << load.message);
      CHECK(load.asset == nullptr);
      CHECK_MESSAGE(!load.message.empty(), length);
    }
    // Cut and then patched so the container is consistent: the accessors no longer fit.
    Glb cut(glb);
    cut.bin.resize(cut.bin.size() / 2);
    check_corrupt(cut, SF_ERROR_INVALID_DATA, "");
  }

  TEST_CASE("a caller's allocator holds every byte of the asset and balances; failures are out of memory") {
    SKELFORM_REQUIRE_DATA(path, "RiggedSimple/RiggedSimple.glb");
    const std::string glb = baked_sample(path).glb;
    skelform::test::CountingHeap heap;
    const sf_allocator allocator = heap.callbacks();
    {
      Load load;
      load_memory(glb, load, &allocator);
      REQUIRE_MESSAGE(load.result == SF_OK, load.message);
      CHECK(heap.allocations > 10);  // the asset object and its arrays
      CHECK(heap.live > 0);
    }
    CHECK(heap.allocations == heap.frees);
    CHECK(heap.live == 0);

    // Fail the n-th allocation: every partial asset is released through the same callbacks.
    const long total = heap.allocations;
    for (long fail_at : {0L, 1L, 2L, total / 2, total - 1}) {
      skelform::test::CountingHeap failing;
      failing.fail_after = fail_at;
      const sf_allocator callbacks = failing.callbacks();
      Load load;
      load_memory(glb, load, &callbacks);
      CHECK_MESSAGE(load.result == SF_ERROR_OUT_OF_MEMORY, fail_at << ": " << load.message);
      CHECK(load.asset == nullptr);
      CHECK(failing.live == 0);
    }
  }

}  // TEST_SUITE
