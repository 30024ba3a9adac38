// glTF animation sampling (see gltf_animation.h). Everything the sampler uses is decoded and
// validated once at load into plain arrays; sampling is then pure arithmetic in double
// precision, converted to float only for the returned matrices.
#include "gltf_animation.h"

#include "cli.h"

#include "skelform/core/gltf_read.h"  // the runtime's validated accessor reader (internal, linked from skelform::runtime)

#include <tiny_gltf.h>  // the TinyGLTF::TinyGLTF shared library: no TINYGLTF_IMPLEMENTATION here

#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>

#include <algorithm>
#include <cmath>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <new>
#include <optional>

namespace skelform::samples {

namespace {

using Mat4 = glm::dmat4;
using Vec3 = glm::dvec3;
using Quat = glm::dquat;  // glm order: (w, x, y, z); glTF stores (x, y, z, w)

enum class Path { translation, rotation, scale, weights };
enum class Interpolation { linear, step, cubic_spline };

// One animation channel, decoded: keyframe times and values (components per element: 3 or 4;
// CUBICSPLINE stores in-tangent, value, out-tangent per keyframe, as glTF does).
struct Channel {
  int node = -1;
  Path path = Path::translation;
  Interpolation interpolation = Interpolation::linear;
  int components = 3;
  std::vector<double> times;
  std::vector<double> values;
};

struct Animation {
  AnimationInfo info;
  std::vector<Channel> channels;  // weights channels are dropped after validation
};

struct Node {
  int parent = -1;
  bool has_matrix = false;
  Mat4 matrix{1.0};
  Vec3 translation{0.0};
  Quat rotation{1.0, 0.0, 0.0, 0.0};
  Vec3 scale{1.0};
};

struct Skin {
  std::vector<int> joints;
  std::vector<Mat4> inverse_bind;  // one per joint (identity when the skin has none)
};

bool all_finite(const double* values, size_t count) {
  for (size_t i = 0; i < count; ++i)
    if (!std::isfinite(values[i])) return false;
  return true;
}

// Accessor data through the runtime's validated reader (core/include/skelform/core/gltf_read.h, which the
// asset loader and the baker use too: bounds, strides, sparse data, normalized integers,
// finiteness), its errors turned into this helper's GltfError; and the helper's own checks.
class AccessorReader {
 public:
  AccessorReader(const tinygltf::Model& model, const std::string& name) : model_(model), name_(name) {}

  [[noreturn]] void fail(const std::string& message) const { throw GltfError(name_ + ": " + message); }

  // All elements of accessor `index` as doubles (count × components): `type` with a
  // component type among `component_types` (FLOAT, or normalized integers), values finite.
  std::vector<double> read(int index, const std::string& what, int type,
                           const std::vector<int>& component_types) const {
    try {
      return gltf::read_values(model_, index, type, component_types, name_ + ": " + what);
    } catch (const gltf::GltfError& e) {
      throw GltfError(e.what());
    }
  }

  // Triangle indices (UNSIGNED_BYTE/SHORT/INT), each below `vertex_count`.
  std::vector<uint32_t> indices(int index, size_t vertex_count, const std::string& what) const {
    try {
      return gltf::read_indices(model_, index, vertex_count, name_ + ": " + what);
    } catch (const gltf::GltfError& e) {
      throw GltfError(e.what());
    }
  }

 private:
  const tinygltf::Model& model_;
  const std::string& name_;
};

// URIs are taken literally. Older tinygltf versions expanded them with wordexp() (`~`, `$VAR`,
// even `$(command)` from a file's URI); 2.7's default no longer does, and this keeps it so
// whichever tinygltf the helper is linked against.
std::string literal_path(const std::string& path, void*) { return path; }

// Images are never decoded: the helper needs geometry and animation only.
bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;
}

Quat normalized_or_fail(const Quat& q, const AccessorReader& reader, const std::string& what) {
  const double length = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (!(length > 1e-12)) reader.fail(what + " is a zero-length rotation quaternion");
  return q / length;
}

Mat4 local_matrix(const Vec3& translation, const Quat& rotation, const Vec3& scale) {
  Mat4 m = glm::mat4_cast(rotation);
  for (int c = 0; c < 3; ++c) m[c] *= scale[c];
  m[3] = glm::dvec4(translation, 1.0);
  return m;
}

// Shortest-arc spherical linear interpolation (glTF appendix C), normalised.
Quat slerp(Quat a, Quat b, double t) {
  double cosine = a.x * b.x + a.y * b.y + a.z * b.z + a.w * b.w;
  if (cosine < 0.0) {
    b = -b;
    cosine = -cosine;
  }
  double wa = 1.0 - t;
  double wb = t;
  if (cosine < 0.9999) {  // else nearly parallel: lerp is accurate and avoids 0/0
    const double angle = std::acos(std::min(cosine, 1.0));
    const double sine = std::sin(angle);
    wa = std::sin((1.0 - t) * angle) / sine;
    wb = std::sin(t * angle) / sine;
  }
  Quat q(wa * a.w + wb * b.w, wa * a.x + wb * b.x, wa * a.y + wb * b.y, wa * a.z + wb * b.z);
  const double length = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  return length > 0.0 ? q / length : a;
}

// Samples `channel` at `time` into `out` (channel.components values).
void sample_channel(const Channel& channel, double time, double* out) {
  const size_t k = channel.components;
  const std::vector<double>& times = channel.times;
  const bool cubic = channel.interpolation == Interpolation::cubic_spline;
  // Element e's value: for CUBICSPLINE the middle of (in-tangent, value, out-tangent).
  auto value = [&](size_t e) { return channel.values.data() + (cubic ? (3 * e + 1) * k : e * k); };
  if (time <= times.front() || times.size() == 1) {
    std::copy(value(0), value(0) + k, out);
    return;
  }
  if (time >= times.back()) {
    std::copy(value(times.size() - 1), value(times.size() - 1) + k, out);
    return;
  }
  // times[i] <= time < times[i + 1]
  const size_t i = static_cast<size_t>(std::upper_bound(times.begin(), times.end(), time) - times.begin()) - 1;
  const double interval = times[i + 1] - times[i];
  const double s = (time - times[i]) / interval;
  switch (channel.interpolation) {
    case Interpolation::step:
      std::copy(value(i), value(i) + k, out);
      return;
    case Interpolation::linear:
      if (channel.path == Path::rotation) {
        const double* a = value(i);
        const double* b = value(i + 1);
        const Quat q = slerp(Quat(a[3], a[0], a[1], a[2]), Quat(b[3], b[0], b[1], b[2]), s);
        out[0] = q.x, out[1] = q.y, out[2] = q.z, out[3] = q.w;
      } else {
        for (size_t c = 0; c < k; ++c) out[c] = value(i)[c] + s * (value(i + 1)[c] - value(i)[c]);
      }
      return;
    case Interpolation::cubic_spline: {
      // Hermite basis (glTF appendix C): p = h00 v_i + h10 td b_i + h01 v_i+1 + h11 td a_i+1,
      // with b the out-tangent of keyframe i and a the in-tangent of keyframe i + 1.
      const double s2 = s * s, s3 = s2 * s;
      const double h00 = 2 * s3 - 3 * s2 + 1, h10 = s3 - 2 * s2 + s, h01 = -2 * s3 + 3 * s2, h11 = s3 - s2;
      const double* v0 = value(i);
      const double* out_tangent0 = channel.values.data() + (3 * i + 2) * k;
      const double* in_tangent1 = channel.values.data() + (3 * (i + 1)) * k;
      const double* v1 = value(i + 1);
      for (size_t c = 0; c < k; ++c)
        out[c] = h00 * v0[c] + h10 * interval * out_tangent0[c] + h01 * v1[c] + h11 * interval * in_tangent1[c];
      if (channel.path == Path::rotation) {
        const double length = std::sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2] + out[3] * out[3]);
        if (length > 1e-12) {
          for (size_t c = 0; c < 4; ++c) out[c] /= length;
        } else {  // the spline passed through zero: hold the keyframe instead of dividing by it
          std::copy(v0, v0 + 4, out);
        }
      }
      return;
    }
  }
}

std::string too_large(const std::string& path) {
  return path + ": larger than " + std::to_string(kMaxFileBytes >> 20) + " MiB, the most the sample tools read";
}

}  // namespace

// In chunks up to kMaxFileBytes: a stream without an end is refused once it passes the limit.
std::vector<unsigned char> read_bounded_file(const std::string& path) {
  std::error_code error;
  if (std::filesystem::is_regular_file(path, error) && std::filesystem::file_size(path, error) > kMaxFileBytes &&
      !error)
    throw GltfError(too_large(path));
  std::ifstream file(path, std::ios::binary);
  if (!file) throw GltfError(path + ": cannot open the file");
  std::vector<unsigned char> bytes;
  char chunk[1 << 16];
  while (file) {
    file.read(chunk, sizeof chunk);
    const size_t n = static_cast<size_t>(file.gcount());
    if (bytes.size() + n > kMaxFileBytes) throw GltfError(too_large(path));
    bytes.insert(bytes.end(), chunk, chunk + n);
  }
  if (file.bad()) throw GltfError(path + ": read error");
  return bytes;
}

struct GltfAnimation::Impl {
  std::string name;
  tinygltf::Model model;
  std::vector<Node> nodes;
  std::vector<int> parents_first_order;  // every node after its parent
  std::vector<Skin> skins;
  std::vector<Animation> animations;
  std::vector<AnimationInfo> animation_infos;

  void validate_nodes(const AccessorReader& reader);
  void validate_skins(const AccessorReader& reader);
  void validate_animations(const AccessorReader& reader);
  std::vector<Mat4> world_matrices(size_t animation, double time) const;
};

void GltfAnimation::Impl::validate_nodes(const AccessorReader& reader) {
  const size_t count = model.nodes.size();
  nodes.assign(count, Node{});
  for (size_t n = 0; n < count; ++n) {
    const tinygltf::Node& source = model.nodes[n];
    const std::string what = "node " + std::to_string(n);
    Node& node = nodes[n];
    for (int child : source.children) {
      if (child < 0 || static_cast<size_t>(child) >= count)
        reader.fail(what + " has child " + std::to_string(child) + ", which does not exist");
      if (nodes[static_cast<size_t>(child)].parent >= 0 || static_cast<size_t>(child) == n)
        reader.fail("node " + std::to_string(child) + " has more than one parent (or is its own child)");
      nodes[static_cast<size_t>(child)].parent = static_cast<int>(n);
    }
    if (!source.matrix.empty()) {
      if (source.matrix.size() != 16 || !all_finite(source.matrix.data(), 16))
        reader.fail(what + " has a matrix that is not 16 finite numbers");
      node.has_matrix = true;
      node.matrix = glm::make_mat4(source.matrix.data());
    }
    if (!source.translation.empty()) {
      if (source.translation.size() != 3 || !all_finite(source.translation.data(), 3))
        reader.fail(what + " has a translation that is not 3 finite numbers");
      node.translation = glm::make_vec3(source.translation.data());
    }
    if (!source.scale.empty()) {
      if (source.scale.size() != 3 || !all_finite(source.scale.data(), 3))
        reader.fail(what + " has a scale that is not 3 finite numbers");
      node.scale = glm::make_vec3(source.scale.data());
    }
    if (!source.rotation.empty()) {
      if (source.rotation.size() != 4 || !all_finite(source.rotation.data(), 4))
        reader.fail(what + " has a rotation that is not 4 finite numbers");
      const std::vector<double>& r = source.rotation;
      node.rotation = normalized_or_fail(Quat(r[3], r[0], r[1], r[2]), reader, what + "'s rotation");
    }
  }
  // Roots first, then breadth-first: every node after its parent. A node never reached sits
  // on a cycle (no root above it).
  parents_first_order.clear();
  for (size_t n = 0; n < count; ++n)
    if (nodes[n].parent < 0) parents_first_order.push_back(static_cast<int>(n));
  for (size_t i = 0; i < parents_first_order.size(); ++i)
    for (int child : model.nodes[static_cast<size_t>(parents_first_order[i])].children)
      parents_first_order.push_back(child);
  if (parents_first_order.size() != count) reader.fail("the node hierarchy contains a cycle");
}

void GltfAnimation::Impl::validate_skins(const AccessorReader& reader) {
  for (size_t s = 0; s < model.skins.size(); ++s) {
    const tinygltf::Skin& source = model.skins[s];
    const std::string what = "skin " + std::to_string(s);
    Skin skin;
    if (source.joints.empty()) reader.fail(what + " has no joints");
    for (int joint : source.joints)
      if (joint < 0 || static_cast<size_t>(joint) >= nodes.size())
        reader.fail(what + " has joint " + std::to_string(joint) + ", which is not a node");
    if (source.skeleton >= 0 && static_cast<size_t>(source.skeleton) >= nodes.size())
      reader.fail(what + " has skeleton " + std::to_string(source.skeleton) + ", which is not a node");
    skin.joints = source.joints;
    skin.inverse_bind.assign(skin.joints.size(), Mat4(1.0));
    if (source.inverseBindMatrices >= 0) {
      const std::vector<double> matrices = reader.read(source.inverseBindMatrices, what + "'s inverseBindMatrices",
                                                       TINYGLTF_TYPE_MAT4, {TINYGLTF_COMPONENT_TYPE_FLOAT});
      if (matrices.size() / 16 < skin.joints.size())
        reader.fail(what + " has " + std::to_string(matrices.size() / 16) + " inverse bind matrices for " +
                    std::to_string(skin.joints.size()) + " joints");
      for (size_t j = 0; j < skin.joints.size(); ++j) skin.inverse_bind[j] = glm::make_mat4(matrices.data() + 16 * j);
    }
    skins.push_back(std::move(skin));
  }
}

void GltfAnimation::Impl::validate_animations(const AccessorReader& reader) {
  for (size_t a = 0; a < model.animations.size(); ++a) {
    const tinygltf::Animation& source = model.animations[a];
    const std::string what = "animation " + std::to_string(a);
    Animation animation;
    animation.info.name = source.name.empty() ? what : source.name;
    if (source.channels.empty()) reader.fail(what + " has no channels");
    // Samplers are decoded once even when several channels share one.
    std::vector<std::optional<Channel>> samplers(source.samplers.size());
    double start = std::numeric_limits<double>::infinity();
    double end = -std::numeric_limits<double>::infinity();
    for (size_t c = 0; c < source.channels.size(); ++c) {
      const tinygltf::AnimationChannel& channel = source.channels[c];
      const std::string label = what + " channel " + std::to_string(c);
      Channel decoded;
      if (channel.target_path == "translation")
        decoded.path = Path::translation;
      else if (channel.target_path == "rotation")
        decoded.path = Path::rotation;
      else if (channel.target_path == "scale")
        decoded.path = Path::scale;
      else if (channel.target_path == "weights")
        decoded.path = Path::weights;
      else
        reader.fail(label + " targets unknown path '" + channel.target_path + "'");
      if (channel.sampler < 0 || static_cast<size_t>(channel.sampler) >= source.samplers.size())
        reader.fail(label + " refers to sampler " + std::to_string(channel.sampler) + ", which does not exist");
      // A channel without a node is allowed (extensions may target other objects): ignored.
      if (channel.target_node >= 0 && static_cast<size_t>(channel.target_node) >= nodes.size())
        reader.fail(label + " targets node " + std::to_string(channel.target_node) + ", which does not exist");
      if (channel.target_node >= 0 && nodes[static_cast<size_t>(channel.target_node)].has_matrix &&
          decoded.path != Path::weights)
        reader.fail(label + " animates node " + std::to_string(channel.target_node) +
                    ", which has a matrix (glTF allows only TRS on animated nodes)");
      const tinygltf::AnimationSampler& sampler = source.samplers[static_cast<size_t>(channel.sampler)];
      const std::string sampler_label = what + " sampler " + std::to_string(channel.sampler);
      if (sampler.interpolation == "LINEAR")
        decoded.interpolation = Interpolation::linear;
      else if (sampler.interpolation == "STEP")
        decoded.interpolation = Interpolation::step;
      else if (sampler.interpolation == "CUBICSPLINE")
        decoded.interpolation = Interpolation::cubic_spline;
      else
        reader.fail(sampler_label + " has unknown interpolation '" + sampler.interpolation + "'");
      decoded.times =
          reader.read(sampler.input, sampler_label + " input", TINYGLTF_TYPE_SCALAR, {TINYGLTF_COMPONENT_TYPE_FLOAT});
      // glTF requires strictly increasing key times, but exporters write a repeated key (the
      // last one, typically): a jump at that instant, which sample_channel plays as such (it
      // interpolates only between keys of different times). Decreasing times are refused.
      for (size_t i = 1; i < decoded.times.size(); ++i)
        if (!(decoded.times[i] >= decoded.times[i - 1]))
          reader.fail(sampler_label + " input decreases at keyframe " + std::to_string(i));
      const size_t keyframes = decoded.times.size();
      const size_t per_keyframe = decoded.interpolation == Interpolation::cubic_spline ? 3 : 1;
      if (decoded.path == Path::weights) {
        // Morph weights: checked for shape, not applied (SCALAR outputs, a multiple of keys).
        const std::vector<double> weights = reader.read(
            sampler.output, sampler_label + " output", TINYGLTF_TYPE_SCALAR,
            {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
             TINYGLTF_COMPONENT_TYPE_SHORT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT});
        if (weights.size() % (keyframes * per_keyframe) != 0)
          reader.fail(sampler_label + " output count does not match its " + std::to_string(keyframes) + " keyframes");
        continue;
      }
      decoded.components = decoded.path == Path::rotation ? 4 : 3;
      if (decoded.path == Path::rotation) {
        decoded.values = reader.read(
            sampler.output, sampler_label + " output", TINYGLTF_TYPE_VEC4,
            {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
             TINYGLTF_COMPONENT_TYPE_SHORT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT});
      } else {
        decoded.values =
            reader.read(sampler.output, sampler_label + " output", TINYGLTF_TYPE_VEC3, {TINYGLTF_COMPONENT_TYPE_FLOAT});
      }
      const size_t elements = decoded.values.size() / static_cast<size_t>(decoded.components);
      if (elements != keyframes * per_keyframe)
        reader.fail(sampler_label + " output has " + std::to_string(elements) + " elements for " +
                    std::to_string(keyframes) + " keyframes (" + sampler.interpolation + " needs " +
                    std::to_string(keyframes * per_keyframe) + ")");
      if (decoded.path == Path::rotation) {
        // Keyframe rotations must be usable quaternions (tangents may be anything finite).
        for (size_t e = 0; e < keyframes; ++e) {
          double* q = decoded.values.data() + (per_keyframe == 3 ? 3 * e + 1 : e) * 4;
          const double length = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
          if (!(length > 1e-12))
            reader.fail(sampler_label + " output has a zero-length rotation at keyframe " + std::to_string(e));
          if (per_keyframe == 1)
            for (int i = 0; i < 4; ++i) q[i] /= length;
        }
      }
      start = std::min(start, decoded.times.front());
      end = std::max(end, decoded.times.back());
      decoded.node = channel.target_node;
      if (decoded.node >= 0) animation.channels.push_back(std::move(decoded));
    }
    animation.info.start = std::isfinite(start) ? start : 0.0;
    animation.info.end = std::isfinite(end) ? end : 0.0;
    animation_infos.push_back(animation.info);
    animations.push_back(std::move(animation));
  }
}

std::vector<Mat4> GltfAnimation::Impl::world_matrices(size_t animation, double time) const {
  if (!std::isfinite(time)) throw GltfError(name + ": the sampling time is not finite");
  if (animation != kStaticPose && animation >= animations.size())
    throw GltfError(name + ": animation " + std::to_string(animation) + " does not exist (the file has " +
                    std::to_string(animations.size()) + ")");
  // Local transforms: static TRS (or matrix), animated TRS components overriding.
  std::vector<Vec3> translation(nodes.size()), scale(nodes.size());
  std::vector<Quat> rotation(nodes.size());
  std::vector<char> animated(nodes.size(), 0);
  for (size_t n = 0; n < nodes.size(); ++n) {
    translation[n] = nodes[n].translation;
    rotation[n] = nodes[n].rotation;
    scale[n] = nodes[n].scale;
  }
  if (animation != kStaticPose) {
    const Animation& a = animations[animation];
    const double t = std::clamp(time, a.info.start, a.info.end);
    double value[4];
    for (const Channel& channel : a.channels) {
      sample_channel(channel, t, value);
      const size_t n = static_cast<size_t>(channel.node);
      animated[n] = 1;
      if (channel.path == Path::translation)
        translation[n] = Vec3(value[0], value[1], value[2]);
      else if (channel.path == Path::scale)
        scale[n] = Vec3(value[0], value[1], value[2]);
      else
        rotation[n] = Quat(value[3], value[0], value[1], value[2]);
    }
  }
  std::vector<Mat4> world(nodes.size());
  for (int index : parents_first_order) {
    const size_t n = static_cast<size_t>(index);
    const Mat4 local =
        nodes[n].has_matrix && !animated[n] ? nodes[n].matrix : local_matrix(translation[n], rotation[n], scale[n]);
    world[n] = nodes[n].parent >= 0 ? world[static_cast<size_t>(nodes[n].parent)] * local : local;
  }
  return world;
}

GltfAnimation::GltfAnimation(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
GltfAnimation::GltfAnimation(GltfAnimation&&) noexcept = default;
GltfAnimation& GltfAnimation::operator=(GltfAnimation&&) noexcept = default;
GltfAnimation::~GltfAnimation() = default;

GltfAnimation GltfAnimation::load_file(const std::string& path) {
  const std::vector<unsigned char> bytes = read_bounded_file(path);
  std::string base_dir = path;
  const size_t slash = base_dir.find_last_of('/');
  base_dir = slash == std::string::npos ? "." : base_dir.substr(0, slash);
  return load_memory(std::string(bytes.begin(), bytes.end()), path, base_dir);
}

GltfAnimation GltfAnimation::load_memory(const std::string& bytes, const std::string& name,
                                         const std::string& base_dir) {
  auto impl = std::make_unique<Impl>();
  impl->name = name;
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(skip_image, nullptr);
  loader.SetFsCallbacks(tinygltf::FsCallbacks{tinygltf::FileExists, literal_path, tinygltf::ReadWholeFile,
                                              tinygltf::WriteWholeFile, nullptr});
  std::string error, warning;
  const bool binary = bytes.size() >= 4 && bytes.compare(0, 4, "glTF") == 0;
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  bool loaded = false;
  // The runtime's checks before tinygltf (GLB container, JSON nesting) and its treatment of
  // the standard exceptions tinygltf throws on inconsistent data: an invalid file.
  try {
    gltf::check_before_parsing(data, bytes.size(), binary, name);
    loaded = binary ? loader.LoadBinaryFromMemory(&impl->model, &error, &warning, data,
                                                  static_cast<unsigned int>(bytes.size()), base_dir)
                    : loader.LoadASCIIFromString(&impl->model, &error, &warning, bytes.data(),
                                                 static_cast<unsigned int>(bytes.size()), base_dir);
  } catch (const gltf::GltfError& e) {
    throw GltfError(e.what());
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception&) {
    throw GltfError(name +
                    ": not a valid glTF file: the glTF parser failed on inconsistent data (for example a "
                    "buffer whose byteLength is 0)");
  }
  if (!loaded) {
    // tinygltf's messages can span lines; keep the first for a one-line error.
    std::string first = error.substr(0, error.find('\n'));
    if (first.empty()) first = "not a valid glTF file";
    throw GltfError(name + ": " + first);
  }
  const AccessorReader reader(impl->model, impl->name);
  impl->validate_nodes(reader);
  impl->validate_skins(reader);
  impl->validate_animations(reader);
  return GltfAnimation(std::move(impl));
}

const std::string& GltfAnimation::name() const { return impl_->name; }
size_t GltfAnimation::node_count() const { return impl_->nodes.size(); }
size_t GltfAnimation::skin_count() const { return impl_->skins.size(); }
const std::vector<AnimationInfo>& GltfAnimation::animations() const { return impl_->animation_infos; }

size_t GltfAnimation::joint_count(size_t skin) const {
  if (skin >= impl_->skins.size()) throw GltfError(impl_->name + ": skin " + std::to_string(skin) + " does not exist");
  return impl_->skins[skin].joints.size();
}

std::vector<float> GltfAnimation::joint_matrices(size_t skin, size_t animation, double time) const {
  const size_t joints = joint_count(skin);
  const std::vector<Mat4> world = impl_->world_matrices(animation, time);
  const Skin& s = impl_->skins[skin];
  std::vector<float> out(16 * joints);
  for (size_t j = 0; j < joints; ++j) {
    const Mat4 m = world[static_cast<size_t>(s.joints[j])] * s.inverse_bind[j];
    const double* p = glm::value_ptr(m);
    for (int i = 0; i < 16; ++i) out[16 * j + static_cast<size_t>(i)] = static_cast<float>(p[i]);
  }
  for (float v : out)
    if (!std::isfinite(v))  // finite doubles can still overflow float (absurd scales)
      throw GltfError(impl_->name + ": skin " + std::to_string(skin) + " gives non-finite joint matrices");
  return out;
}

std::vector<float> GltfAnimation::bind_pose_joint_matrices(size_t skin) const {
  std::vector<float> matrices = joint_matrices(skin, kStaticPose, 0.0);
  const size_t joints = matrices.size() / 16;
  if (joints == 0) return matrices;
  float largest = 1.0f;
  for (int i = 0; i < 16; ++i) largest = std::max(largest, std::fabs(matrices[size_t(i)]));
  bool common = true;
  for (size_t j = 1; j < joints && common; ++j)
    for (int i = 0; i < 16 && common; ++i)
      common = std::fabs(matrices[16 * j + size_t(i)] - matrices[size_t(i)]) <= 1e-4f * largest;
  if (common) return matrices;
  for (size_t n = 0; n < impl_->model.nodes.size(); ++n) {
    if (impl_->model.nodes[n].skin != static_cast<int>(skin) || impl_->model.nodes[n].mesh < 0) continue;
    const std::vector<Mat4> world = impl_->world_matrices(kStaticPose, 0.0);
    const double* p = glm::value_ptr(world[n]);
    for (size_t j = 0; j < joints; ++j)
      for (int i = 0; i < 16; ++i) matrices[16 * j + size_t(i)] = static_cast<float>(p[i]);
    for (float v : matrices)
      if (!std::isfinite(v))
        throw GltfError(impl_->name + ": node " + std::to_string(n) + " has a non-finite transform");
    return matrices;
  }
  return matrices;
}

std::vector<float> GltfAnimation::node_world_matrices(size_t animation, double time) const {
  const std::vector<Mat4> world = impl_->world_matrices(animation, time);
  std::vector<float> out(16 * world.size());
  for (size_t n = 0; n < world.size(); ++n) {
    const double* p = glm::value_ptr(world[n]);
    for (int i = 0; i < 16; ++i) out[16 * n + static_cast<size_t>(i)] = static_cast<float>(p[i]);
  }
  return out;
}

int GltfAnimation::node_mesh(size_t node) const {
  if (node >= impl_->nodes.size()) throw GltfError(impl_->name + ": node " + std::to_string(node) + " does not exist");
  const int mesh = impl_->model.nodes[node].mesh;
  return mesh >= 0 && static_cast<size_t>(mesh) < impl_->model.meshes.size() ? mesh : -1;
}

int GltfAnimation::node_skin(size_t node) const {
  if (node >= impl_->nodes.size()) throw GltfError(impl_->name + ": node " + std::to_string(node) + " does not exist");
  const int skin = impl_->model.nodes[node].skin;
  return skin >= 0 && static_cast<size_t>(skin) < impl_->skins.size() ? skin : -1;
}

size_t GltfAnimation::mesh_count() const { return impl_->model.meshes.size(); }

size_t GltfAnimation::primitive_count(size_t mesh) const {
  if (mesh >= impl_->model.meshes.size())
    throw GltfError(impl_->name + ": mesh " + std::to_string(mesh) + " does not exist");
  return impl_->model.meshes[mesh].primitives.size();
}

std::vector<float> GltfAnimation::primitive_positions(size_t mesh, size_t primitive) const {
  if (primitive >= primitive_count(mesh))
    throw GltfError(impl_->name + ": mesh " + std::to_string(mesh) + " has no primitive " + std::to_string(primitive));
  const tinygltf::Primitive& p = impl_->model.meshes[mesh].primitives[primitive];
  const auto position = p.attributes.find("POSITION");
  const std::string what = "mesh " + std::to_string(mesh) + " primitive " + std::to_string(primitive);
  if (position == p.attributes.end()) throw GltfError(impl_->name + ": " + what + " has no POSITION");
  const AccessorReader reader(impl_->model, impl_->name);
  const std::vector<double> values =
      reader.read(position->second, what + " POSITION", TINYGLTF_TYPE_VEC3, {TINYGLTF_COMPONENT_TYPE_FLOAT});
  return std::vector<float>(values.begin(), values.end());
}

std::vector<uint32_t> GltfAnimation::primitive_triangles(size_t mesh, size_t primitive) const {
  const size_t vertex_count = primitive_positions(mesh, primitive).size() / 3;
  const tinygltf::Primitive& p = impl_->model.meshes[mesh].primitives[primitive];
  const std::string what = "mesh " + std::to_string(mesh) + " primitive " + std::to_string(primitive);
  std::vector<uint32_t> indices;
  if (p.indices >= 0) {
    indices = AccessorReader(impl_->model, impl_->name).indices(p.indices, vertex_count, what + " indices");
  } else {
    indices.resize(vertex_count);
    for (size_t i = 0; i < vertex_count; ++i) indices[i] = static_cast<uint32_t>(i);
  }
  std::vector<uint32_t> triangles;
  const int mode = p.mode < 0 ? TINYGLTF_MODE_TRIANGLES : p.mode;
  if (mode == TINYGLTF_MODE_TRIANGLES) {
    if (indices.size() % 3 != 0)
      throw GltfError(impl_->name + ": " + what + " has " + std::to_string(indices.size()) +
                      " indices, not a multiple of 3");
    triangles = std::move(indices);
  } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
    for (size_t i = 2; i < indices.size(); ++i) {  // every other triangle flipped to keep the winding
      if (i % 2 == 0)
        triangles.insert(triangles.end(), {indices[i - 2], indices[i - 1], indices[i]});
      else
        triangles.insert(triangles.end(), {indices[i - 1], indices[i - 2], indices[i]});
    }
  } else if (mode == TINYGLTF_MODE_TRIANGLE_FAN) {
    for (size_t i = 2; i < indices.size(); ++i)
      triangles.insert(triangles.end(), {indices[0], indices[i - 1], indices[i]});
  } else {
    throw GltfError(impl_->name + ": " + what + " has mode " + std::to_string(mode) + ", not triangles");
  }
  return triangles;
}

int classify_gltf_error(const std::exception& e) {
  return dynamic_cast<const GltfError*>(&e) ? cli::kExitInvalidInput : -1;
}

}  // namespace skelform::samples
