#include "lbs_guard.h"

#include "asset.h"
#include "instance.h"
#include "skin_blend.h"
#include "triangle_intersection.h"

#include <algorithm>
#include <cmath>

namespace skelform::runtime {

namespace {

glm::dvec3 widen(const glm::vec3& p) { return glm::dvec3(p); }

// The grid over the moved triangles' boxes, rebuilt every round: uniform cells no smaller than
// the largest moved box (so each moved triangle lies in at most 2 x 2 x 2 cells), coarsened
// until there are at most 4 cells per moved triangle.
class MovedGrid {
 public:
  explicit MovedGrid(GuardWorkspace& ws) : ws_(ws) {}

  // False when nothing can be gridded (no moved triangle, or a non-finite box).
  bool build() {
    const size_t count = ws_.moved_triangles.size();
    if (count == 0) return false;
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    float largest = 0.0f;
    for (uint32_t t : ws_.moved_triangles) {
      const float* b = ws_.boxes.data() + 6 * size_t(t);
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], b[k]);
        hi[k] = std::max(hi[k], b[3 + k]);
        largest = std::max(largest, b[3 + k] - b[k]);
      }
    }
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(lo[k]) || !std::isfinite(hi[k])) return false;
    const glm::vec3 extent = hi - lo;
    float cell = std::max({largest * 1.001f, extent.x * 1e-6f, extent.y * 1e-6f, extent.z * 1e-6f,
                           std::numeric_limits<float>::min()});
    const double max_cells = 4.0 * double(count) + 64.0;
    for (int attempt = 0; attempt < 64; ++attempt) {
      double cells = 1.0;
      for (int k = 0; k < 3; ++k) {
        dims_[k] = std::max(1, int(std::min(extent[k] / cell, 1e6f)) + 1);
        cells *= double(dims_[k]);
      }
      if (cells <= max_cells) break;
      cell *= float(std::cbrt(cells / max_cells)) * 1.01f;
    }
    origin_ = lo;
    inverse_cell_ = 1.0f / cell;
    const size_t cell_count = size_t(dims_[0]) * size_t(dims_[1]) * size_t(dims_[2]);
    std::fill(ws_.cell_offsets.begin(), ws_.cell_offsets.begin() + long(cell_count) + 1, 0u);
    for (size_t i = 0; i < count; ++i) {
      int32_t* r = ws_.ranges.data() + 6 * i;
      if (!cells_of(ws_.boxes.data() + 6 * size_t(ws_.moved_triangles[i]), r))
        for (int k = 0; k < 3; ++k) r[k] = 1, r[3 + k] = 0;  // no cell (cannot happen: the grid covers it)
      for (int z = r[2]; z <= r[5]; ++z)
        for (int y = r[1]; y <= r[4]; ++y)
          for (int x = r[0]; x <= r[3]; ++x) ++ws_.cell_offsets[linear(x, y, z) + 1];
    }
    for (size_t c = 0; c < cell_count; ++c) ws_.cell_offsets[c + 1] += ws_.cell_offsets[c];
    // Fill from the back of each cell's run, so the offsets end where they began.
    for (size_t i = count; i-- > 0;) {
      const int32_t* r = ws_.ranges.data() + 6 * i;
      for (int z = r[2]; z <= r[5]; ++z)
        for (int y = r[1]; y <= r[4]; ++y)
          for (int x = r[0]; x <= r[3]; ++x) ws_.cell_entries[--ws_.cell_offsets[linear(x, y, z) + 1]] = ws_.moved_triangles[i];
    }
    // The decrements above moved every cell's end back to its start: offsets[c + 1] now holds
    // where cell c begins. Shift them down one place and close the last cell.
    uint32_t entries = 0;
    for (size_t i = 0; i < count; ++i) {
      const int32_t* r = ws_.ranges.data() + 6 * i;
      entries += uint32_t((r[3] - r[0] + 1) * (r[4] - r[1] + 1) * (r[5] - r[2] + 1));
    }
    for (size_t c = 0; c < cell_count; ++c) ws_.cell_offsets[c] = ws_.cell_offsets[c + 1];
    ws_.cell_offsets[cell_count] = entries;
    return true;
  }

  // Calls visit(c) once for every moved triangle c whose cells meet `box`'s.
  template <class Visit>
  void query(const float* box, Visit&& visit) {
    int32_t r[6];
    if (!cells_of(box, r)) return;
    ++ws_.stamp;
    if (ws_.stamp == 0) {  // wrapped: forget every old stamp
      std::fill(ws_.stamps.begin(), ws_.stamps.end(), 0u);
      ws_.stamp = 1;
    }
    for (int z = r[2]; z <= r[5]; ++z)
      for (int y = r[1]; y <= r[4]; ++y)
        for (int x = r[0]; x <= r[3]; ++x) {
          const size_t c = linear(x, y, z);
          for (uint32_t e = ws_.cell_offsets[c]; e < ws_.cell_offsets[c + 1]; ++e) {
            const uint32_t t = ws_.cell_entries[e];
            if (ws_.stamps[t] == ws_.stamp) continue;
            ws_.stamps[t] = ws_.stamp;
            visit(t);
          }
        }
  }

 private:
  // The cells of `box`, clipped to the grid; false when the box misses the grid.
  bool cells_of(const float* box, int32_t* r) const {
    for (int k = 0; k < 3; ++k) {
      const float lo = (box[k] - origin_[k]) * inverse_cell_, hi = (box[3 + k] - origin_[k]) * inverse_cell_;
      if (!(hi >= 0.0f) || !(lo < float(dims_[k]))) return false;
      r[k] = std::max(0, int(std::floor(lo)));
      r[3 + k] = std::min(dims_[k] - 1, int(std::floor(hi)));
    }
    return true;
  }
  size_t linear(int x, int y, int z) const {
    return (size_t(z) * size_t(dims_[1]) + size_t(y)) * size_t(dims_[0]) + size_t(x);
  }

  GuardWorkspace& ws_;
  glm::vec3 origin_{0.0f};
  float inverse_cell_ = 1.0f;
  int dims_[3] = {1, 1, 1};
};

bool share_corner(const uint32_t* a, const uint32_t* b) {
  return a[0] == b[0] || a[0] == b[1] || a[0] == b[2] || a[1] == b[0] || a[1] == b[1] || a[1] == b[2] ||
         a[2] == b[0] || a[2] == b[1] || a[2] == b[2];
}

bool boxes_meet(const float* a, const float* b) {
  return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

}  // namespace

GuardWorkspace make_guard_workspace(const ContactMesh& mesh, const AllocatorRef& allocator) {
  GuardWorkspace ws(allocator);
  const size_t triangles = mesh.triangle_count;
  ws.factor.resize(mesh.vertex_count);
  ws.positions.resize(mesh.vertex_count);
  ws.moved.resize(mesh.vertex_count);
  ws.flagged.resize(mesh.vertex_count);
  ws.moved_triangles.reserve(triangles);
  ws.boxes.resize(6 * triangles);
  ws.cell_offsets.resize(4 * triangles + 66);
  ws.cell_entries.resize(8 * triangles);
  ws.ranges.resize(6 * triangles);
  ws.stamps.assign(triangles, 0u);
  return ws;
}

namespace {

// The intersection guard from the current factors (ws.factor): halves λ at the moved corners of
// every pair LBS does not have, until none is left.
void guard_intersections(const Deformable& d, const ContactMesh& mesh, const DenseOutput& skelform,
                         const DenseOutput& lbs, GuardWorkspace& ws) {
  const float* weight = d.skelform_weight.data();
  const uint32_t* tri = mesh.triangles.data();
  for (uint32_t round = 0;; ++round) {
    // This round's x at every welded vertex, and which of them differ from LBS.
    for (uint32_t v = 0; v < mesh.vertex_count; ++v) {
      const uint32_t r = mesh.representative[v];
      const float s = weight[r] * ws.factor[v];
      const glm::vec3 l = lbs.positions[r];
      ws.positions[v] = s == 0.0f ? l : l + s * (skelform.positions[r] - l);
      ws.moved[v] = ws.positions[v] != l;
    }
    ws.moved_triangles.clear();
    for (uint32_t t = 0; t < mesh.triangle_count; ++t) {
      const uint32_t* c = tri + 3 * size_t(t);
      const glm::vec3 &p0 = ws.positions[c[0]], &p1 = ws.positions[c[1]], &p2 = ws.positions[c[2]];
      float* b = ws.boxes.data() + 6 * size_t(t);
      for (int k = 0; k < 3; ++k) {
        b[k] = std::min({p0[k], p1[k], p2[k]});
        b[3 + k] = std::max({p0[k], p1[k], p2[k]});
      }
      if (ws.moved[c[0]] || ws.moved[c[1]] || ws.moved[c[2]]) ws.moved_triangles.push_back(t);
    }
    MovedGrid grid(ws);
    if (!grid.build()) return;
    std::fill(ws.flagged.begin(), ws.flagged.end(), uint8_t(0));
    bool added = false;
    for (uint32_t t = 0; t < mesh.triangle_count; ++t) {
      const uint32_t* ct = tri + 3 * size_t(t);
      const bool t_moved = ws.moved[ct[0]] || ws.moved[ct[1]] || ws.moved[ct[2]];
      const float* bt = ws.boxes.data() + 6 * size_t(t);
      grid.query(bt, [&](uint32_t s) {
        // Each pair once: a moved t meets the moved s < t here, and s > t when s queries.
        if (s == t || (t_moved && s > t)) return;
        const uint32_t* cs = tri + 3 * size_t(s);
        if (share_corner(ct, cs) || !boxes_meet(bt, ws.boxes.data() + 6 * size_t(s))) return;
        if (!geometry::triangles_intersect(widen(ws.positions[ct[0]]), widen(ws.positions[ct[1]]),
                                           widen(ws.positions[ct[2]]), widen(ws.positions[cs[0]]),
                                           widen(ws.positions[cs[1]]), widen(ws.positions[cs[2]])))
          return;
        const glm::vec3* l = lbs.positions;
        const uint32_t* rep = mesh.representative.data();
        if (geometry::triangles_intersect(widen(l[rep[ct[0]]]), widen(l[rep[ct[1]]]), widen(l[rep[ct[2]]]),
                                          widen(l[rep[cs[0]]]), widen(l[rep[cs[1]]]), widen(l[rep[cs[2]]])))
          return;  // LBS has this pair too
        for (int k = 0; k < 3; ++k) ws.flagged[ct[k]] = ws.flagged[cs[k]] = 1;
        added = true;
      });
    }
    if (!added) return;
    ++ws.rounds;
    bool reduced = false;
    for (uint32_t v = 0; v < mesh.vertex_count; ++v) {
      if (!ws.flagged[v] || !ws.moved[v]) continue;
      ws.factor[v] = round + 1 >= kGuardHalvings ? 0.0f : 0.5f * ws.factor[v];
      reduced = true;
    }
    if (!reduced) return;  // cannot happen: an added pair has a moved corner
  }
}

// The volume bounded by x(μ) = L + μ·c at the representatives, c the guarded correction, as
// the cubic V(μ) = v[0] + v[1]μ + v[2]μ² + v[3]μ³ (each triangle's det(a + μα, b + μβ, c + μγ)
// expanded), in double, about the centre of L's bounds (a closed mesh's volume does not depend
// on the origin; a near one keeps the products small).
void volume_polynomial(const Deformable& d, const ContactMesh& mesh, const DenseOutput& skelform,
                       const DenseOutput& lbs, const GuardWorkspace& ws, double v[4]) {
  const float* weight = d.skelform_weight.data();
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (uint32_t w = 0; w < mesh.vertex_count; ++w) {
    const glm::dvec3 p(lbs.positions[mesh.representative[w]]);
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  const glm::dvec3 centre = 0.5 * (lo + hi);
  auto base = [&](uint32_t w) { return glm::dvec3(lbs.positions[mesh.representative[w]]) - centre; };
  auto correction = [&](uint32_t w) {
    const uint32_t r = mesh.representative[w];
    const double s = double(weight[r]) * double(ws.factor[w]);
    return s * (glm::dvec3(skelform.positions[r]) - glm::dvec3(lbs.positions[r]));
  };
  for (int k = 0; k < 4; ++k) v[k] = 0.0;
  for (uint32_t t = 0; t < mesh.triangle_count; ++t) {
    const uint32_t* q = mesh.triangles.data() + 3 * size_t(t);
    const glm::dvec3 a = base(q[0]), b = base(q[1]), c = base(q[2]);
    const glm::dvec3 da = correction(q[0]), db = correction(q[1]), dc = correction(q[2]);
    auto det = [](const glm::dvec3& x, const glm::dvec3& y, const glm::dvec3& z) { return glm::dot(x, glm::cross(y, z)); };
    v[0] += det(a, b, c);
    v[1] += det(da, b, c) + det(a, db, c) + det(a, b, dc);
    v[2] += det(da, db, c) + det(da, b, dc) + det(a, db, dc);
    v[3] += det(da, db, dc);
  }
  for (int k = 0; k < 4; ++k) v[k] /= 6.0;
}

// The largest μ in [0, 1] whose volume error |V(μ) − target| does not exceed LBS's |V(0) −
// target|: 1 when the whole correction qualifies, else the last crossing found by sampling and
// bisection.
double volume_share(const double v[4], double target) {
  auto error = [&](double m) { return std::fabs(v[0] + m * (v[1] + m * (v[2] + m * v[3])) - target); };
  const double limit = error(0.0);
  if (error(1.0) <= limit) return 1.0;
  constexpr int kSamples = 32;
  double inside = 0.0;  // the largest sample within the limit
  for (int i = 1; i < kSamples; ++i) {
    const double m = double(i) / kSamples;
    if (error(m) <= limit) inside = m;
  }
  double outside = inside + 1.0 / kSamples;
  for (int i = 0; i < 30; ++i) {
    const double m = 0.5 * (inside + outside);
    (error(m) <= limit ? inside : outside) = m;
  }
  return inside;
}

}  // namespace

void guard_and_blend(const Deformable& d, const ContactMesh& mesh, float scale, const DenseOutput& skelform,
                     const DenseOutput& lbs, bool with_normals, const DenseOutput& out, GuardWorkspace& ws) {
  const float* weight = d.skelform_weight.data();
  std::fill(ws.factor.begin(), ws.factor.end(), 1.0f);
  ws.rounds = 0;
  ws.volume_share = 1.0f;
  const bool welded = mesh.weld.size() == d.vertex_count && mesh.triangle_count >= 2;
  if (welded) {
    guard_intersections(d, mesh, skelform, lbs, ws);
    // Volume: a closed mesh keeps its rest volume, scaled by the pose's reference scale cubed,
    // no worse than LBS does; μ scales the whole guarded correction where it would not.
    if (mesh.closed && std::isfinite(mesh.rest_volume) && mesh.rest_volume != 0.0) {
      const double target = mesh.rest_volume * double(scale) * double(scale) * double(scale);
      for (uint32_t attempt = 0; attempt < kVolumeAttempts; ++attempt) {
        double v[4];
        volume_polynomial(d, mesh, skelform, lbs, ws, v);
        const double share = attempt + 1 < kVolumeAttempts ? volume_share(v, target) : 0.0;
        if (share >= 1.0) break;
        for (float& f : ws.factor) f *= float(share);
        ws.volume_share *= float(share);
        // The scaled correction is checked again: its pairs must still be LBS's.
        guard_intersections(d, mesh, skelform, lbs, ws);
        if (share == 0.0) break;
      }
    }
  }

  ws.corrected = 0;
  for (uint32_t v = 0; v < mesh.vertex_count; ++v) ws.corrected += ws.factor[v] < 1.0f ? 1u : 0u;
  // The output, every dense vertex with its welded vertex's λ.
  for (const PrimitiveRecord& primitive : d.primitives) {
    const uint32_t end = primitive.first_vertex + primitive.vertex_count;
    const bool tangents = with_normals && primitive.has_tangents && out.tangents;
    for (uint32_t v = primitive.first_vertex; v < end; ++v) {
      const float s = weight[v] * (welded ? ws.factor[mesh.weld[v]] : 1.0f);
      if (s == 0.0f) {
        out.positions[v] = lbs.positions[v];
        if (with_normals) out.normals[v] = lbs.normals[v];
        if (tangents) out.tangents[v] = lbs.tangents[v];
        continue;
      }
      const glm::vec3 l = lbs.positions[v];
      out.positions[v] = l + s * (skelform.positions[v] - l);
      if (with_normals)
        out.normals[v] = normalize_or(lbs.normals[v] + s * (skelform.normals[v] - lbs.normals[v]), lbs.normals[v]);
      if (tangents) {
        const glm::vec3 t(lbs.tangents[v]);
        out.tangents[v] = glm::vec4(normalize_or(t + s * (glm::vec3(skelform.tangents[v]) - t), t), lbs.tangents[v].w);
      }
    }
  }
}

}  // namespace skelform::runtime
