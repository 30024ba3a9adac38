// Free-form handle driver: the bilaplacian displacement field of the paper's reference [25]
// (Yoshizawa, Belyaev, Seidel, PG 2002) on the skeletal mesh. See handles.h for the contract.
//
// The operator. [25] (after Kobbelt et al., the paper's [17]) discretises the Laplacian by
// the umbrella operator U(δ)_i = mean_{j ∈ N(i)} δ_j − δ_i, which depends on connectivity
// only. We keep it, and not the cotangent Laplacian, on purpose: the skeletal mesh is a
// crumpled Voronoi-based surface (DESIGN.md bake step 5) where thin parts collapse to curves,
// so it is full of near-degenerate and folded triangles. There, cotangent weights are
// negative or unbounded (cot of angles near 0 or π), the operator loses its maximum principle
// and the field can overshoot or spike; the umbrella weights are positive and bounded whatever
// the geometry, and a translation of all handles is still reproduced exactly (U(constant) = 0).
//
// The system. With A the adjacency and D the degree matrix of the mesh graph, K = D − A is
// the symmetric graph Laplacian and U = −D⁻¹K. The energy
//     E(δ) = Σ_i deg_i |U(δ)_i|² = δᵀ K D⁻¹ K δ = δᵀ Q δ
// is minimised over the free vertices with δ fixed at handles and pinned vertices. Its
// optimality condition at a free vertex i, (Qδ)_i = deg_i (U²δ)_i = 0, is exactly Kobbelt's
// bi-umbrella equation U²δ = 0 (Δ²δ = 0), and Q is symmetric positive semi-definite, so the
// free block Q_ff is symmetric and can be factorised by sparse LDLᵀ. Q_ff is positive
// definite as soon as every connected component holds a constrained vertex (Kδ = 0 forces δ
// constant per component, hence zero where a constrained zero sits); components without one
// are taken out of the system and stay at rest (handles.h), so no regularisation is needed.
//
// The solve. Q_ff δ_f = −Q_fh δ_h (pinned vertices contribute nothing: their δ is 0). Eigen's
// SimplicialLDLT gives P Q_ff Pᵀ = L D Lᵀ once per handle set; we copy P, L (its compressed
// columns: the rows of Lᵀ) and D into arrays of our own and do the permuted forward /
// diagonal / backward substitution ourselves, because the C API promises that evaluation
// never allocates, and Eigen's solve() allocates temporaries for the permuted right-hand side.
// Doing it here also keeps Eigen out of the per-frame code entirely. The three coordinates are
// solved together (interleaved), in double precision: Q has the condition number of a
// squared Laplacian, so float would lose several digits on a few thousand vertices.
//
// The basis. The bilaplacian couples 2-rings, so the factor is dense-ish (AMD ordering of the
// 2-ring pattern; docs/tuning.md), a substitution costs about a millisecond. The field is linear in the handle
// displacements, δ_f = Σ_u G_u δ_u with G_u = −Q_ff⁻¹ Q_f,u, and interactive deformation
// ([25]) uses a few handles, so when n_free·slots < 2·nnz(L) we precompute G in create (one
// substitution per distinct handle) and a frame costs n_free·slots multiply-adds instead:
// a fingertip drag on the 2K-vertex hand is then microseconds. Many handles (a region)
// keep the substitution, whose cost does not grow with their number.
#include "handles.h"

#include <Eigen/Dense>
#include <Eigen/Sparse>

#include <algorithm>
#include <new>
#include <stdexcept>
#include <string>
#include <utility>

namespace skelform::runtime {

namespace {

// What drives a skeletal vertex.
enum VertexRole : uint8_t {
  kFree = 0,    // unknown of the system; ref = its index among the unknowns
  kHandle = 1,  // given displacement; ref = its slot among the distinct handle vertices
  kStill = 2,   // δ = 0: pinned, or in a component with no handle and no pin
};

}  // namespace

struct HandleSystem {
  explicit HandleSystem(const AllocatorRef& a)
      : vertex_role(a),
        vertex_ref(a),
        handle_slot(a),
        slot_weight(a),
        coupling_offsets(a),
        coupling_slot(a),
        coupling_weight(a),
        permutation(a),
        factor_offsets(a),
        factor_rows(a),
        factor_values(a),
        factor_diagonal(a),
        basis(a),
        slot_displacement(a),
        work(a) {}

  uint32_t vertex_count = 0;  // the deformable's control_vertex_count
  uint32_t free_count = 0;    // unknowns of the reduced system
  size_t handle_count = 0;    // entries of the caller's handle list (duplicates included)
  uint32_t slot_count = 0;    // distinct handle vertices
  HandleSolvePath path = HandleSolvePath::substitution;

  Array<uint8_t> vertex_role;   // VertexRole per skeletal vertex
  Array<uint32_t> vertex_ref;   // see VertexRole
  Array<uint32_t> handle_slot;  // per handle entry: its distinct vertex's slot
  Array<double> slot_weight;    // per slot: 1 / how often the caller listed that vertex

  // −Q_fh, row-compressed by free unknown: rhs_f = Σ coupling_weight · δ_slot.
  Array<uint32_t> coupling_offsets;  // free_count + 1
  Array<uint32_t> coupling_slot;
  Array<double> coupling_weight;

  // P Q_ff Pᵀ = L D Lᵀ. permutation[i] = where unknown i goes in the factor's order (Eigen's
  // permutationP().indices()). L is unit lower triangular, stored by columns without its
  // diagonal: column j holds the rows i > j of L (equivalently, row j of Lᵀ).
  Array<uint32_t> permutation;
  Array<uint32_t> factor_offsets;  // free_count + 1
  Array<uint32_t> factor_rows;
  Array<double> factor_values;
  Array<double> factor_diagonal;  // D
  // Path `basis`: G, free_count rows of slot_count entries (row f: the fields of every handle
  // at unknown f). The factor and coupling arrays are released then.
  Array<double> basis;

  // Solve scratch, sized at creation (the instance is single-threaded, handles.h).
  mutable Array<double> slot_displacement;  // 3 per slot
  mutable Array<double> work;               // 3 per unknown (substitution path only)
};

namespace {

[[noreturn]] void invalid(const std::string& message) { throw std::invalid_argument("handle set: " + message); }

// Distinct undirected edges of the triangles (self-edges of degenerate triangles dropped),
// as a row-compressed adjacency: neighbours of v are adjacency[offsets[v] .. offsets[v+1]).
void build_adjacency(const Deformable& d, Array<uint32_t>& offsets, Array<uint32_t>& adjacency,
                     const AllocatorRef& alloc) {
  const uint32_t n = d.control_vertex_count;
  Array<std::pair<uint32_t, uint32_t>> directed{CallbackAllocator<std::pair<uint32_t, uint32_t>>(alloc)};
  directed.reserve(d.control_indices.size() * 2);
  for (size_t t = 0; t + 2 < d.control_indices.size(); t += 3) {
    for (int corner = 0; corner < 3; ++corner) {
      const uint32_t a = d.control_indices[t + corner];
      const uint32_t b = d.control_indices[t + (corner + 1) % 3];
      if (a == b) continue;
      directed.emplace_back(a, b);
      directed.emplace_back(b, a);
    }
  }
  std::sort(directed.begin(), directed.end());
  directed.erase(std::unique(directed.begin(), directed.end()), directed.end());
  offsets.assign(size_t(n) + 1, 0);
  for (const auto& e : directed) ++offsets[e.first + 1];
  for (uint32_t v = 0; v < n; ++v) offsets[v + 1] += offsets[v];
  adjacency.resize(directed.size());
  for (size_t k = 0; k < directed.size(); ++k) adjacency[k] = directed[k].second;  // sorted by source
}

// Solves L D Lᵀ x = y in place for `Width` interleaved right-hand sides (y already in the
// factor's order).
template <int Width>
void substitute(const HandleSystem& s, double* y) {
  const uint32_t m = s.free_count;
  // L z = y, column-oriented: once z_j is final, push it into the rows below.
  for (uint32_t j = 0; j < m; ++j) {
    double z[Width];
    for (int c = 0; c < Width; ++c) z[c] = y[size_t(Width) * j + c];
    for (uint32_t k = s.factor_offsets[j]; k < s.factor_offsets[j + 1]; ++k) {
      double* row = y + size_t(Width) * s.factor_rows[k];
      const double l = s.factor_values[k];
      for (int c = 0; c < Width; ++c) row[c] -= l * z[c];
    }
  }
  // D w = z.
  for (uint32_t j = 0; j < m; ++j) {
    const double inverse = 1.0 / s.factor_diagonal[j];
    for (int c = 0; c < Width; ++c) y[size_t(Width) * j + c] *= inverse;
  }
  // Lᵀ x = w: row j of Lᵀ is column j of L, a dot product with the later, final entries.
  for (uint32_t j = m; j-- > 0;) {
    double x[Width];
    for (int c = 0; c < Width; ++c) x[c] = y[size_t(Width) * j + c];
    for (uint32_t k = s.factor_offsets[j]; k < s.factor_offsets[j + 1]; ++k) {
      const double* row = y + size_t(Width) * s.factor_rows[k];
      const double l = s.factor_values[k];
      for (int c = 0; c < Width; ++c) x[c] -= l * row[c];
    }
    for (int c = 0; c < Width; ++c) y[size_t(Width) * j + c] = x[c];
  }
}

template <class T>
void release(Array<T>& a) {
  Array<T>(a.get_allocator()).swap(a);
}

using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

// The handles' and pinned vertices' roles: duplicated handles share one slot (their
// displacements are averaged). Rejects an index out of range or a vertex both a handle and
// pinned.
void assign_roles(HandleSystem* s, uint32_t n, const uint32_t* handle_control, size_t handle_count,
                  const uint32_t* pinned_control, size_t pinned_count, const AllocatorRef& alloc) {
  s->handle_slot.resize(handle_count);
  Array<uint32_t> slot_multiplicity{CallbackAllocator<uint32_t>(alloc)};
  Array<uint32_t> slot_vertex{CallbackAllocator<uint32_t>(alloc)};
  for (size_t i = 0; i < handle_count; ++i) {
    const uint32_t v = handle_control[i];
    if (v >= n)
      invalid("handle " + std::to_string(i) + " names control vertex " + std::to_string(v) + " of " +
              std::to_string(n));
    if (s->vertex_role[v] != kHandle) {
      s->vertex_role[v] = kHandle;
      s->vertex_ref[v] = uint32_t(slot_vertex.size());
      slot_vertex.push_back(v);
      slot_multiplicity.push_back(0);
    }
    s->handle_slot[i] = s->vertex_ref[v];
    ++slot_multiplicity[s->vertex_ref[v]];
  }
  s->slot_count = uint32_t(slot_vertex.size());
  s->slot_weight.resize(s->slot_count);
  for (uint32_t u = 0; u < s->slot_count; ++u) s->slot_weight[u] = 1.0 / slot_multiplicity[u];
  for (size_t i = 0; i < pinned_count; ++i) {
    const uint32_t v = pinned_control[i];
    if (v >= n)
      invalid("pinned vertex " + std::to_string(i) + " names control vertex " + std::to_string(v) + " of " +
              std::to_string(n));
    if (s->vertex_role[v] == kHandle) invalid("control vertex " + std::to_string(v) + " is both a handle and pinned");
    s->vertex_role[v] = kStill;
  }
}

// Components with no constrained vertex stay at rest (see the file comment): each component is
// flooded once and its free vertices demoted to kStill if nothing anchors it. Then the free
// vertices are numbered.
void settle_unanchored(HandleSystem* s, uint32_t n, const Array<uint32_t>& offsets, const Array<uint32_t>& adjacency,
                       const AllocatorRef& alloc) {
  Array<uint32_t> component(n, UINT32_MAX, CallbackAllocator<uint32_t>(alloc));
  Array<uint32_t> stack{CallbackAllocator<uint32_t>(alloc)};
  Array<uint32_t> members{CallbackAllocator<uint32_t>(alloc)};
  for (uint32_t seed = 0; seed < n; ++seed) {
    if (component[seed] != UINT32_MAX) continue;
    bool anchored = false;
    members.clear();
    stack.assign(1, seed);
    component[seed] = seed;
    while (!stack.empty()) {
      const uint32_t v = stack.back();
      stack.pop_back();
      members.push_back(v);
      anchored = anchored || s->vertex_role[v] != kFree;
      for (uint32_t k = offsets[v]; k < offsets[v + 1]; ++k) {
        const uint32_t w = adjacency[k];
        if (component[w] == UINT32_MAX) {
          component[w] = seed;
          stack.push_back(w);
        }
      }
    }
    if (!anchored)
      for (uint32_t v : members) s->vertex_role[v] = kStill;
  }
  uint32_t free_count = 0;
  for (uint32_t v = 0; v < n; ++v)
    if (s->vertex_role[v] == kFree) s->vertex_ref[v] = free_count++;
  s->free_count = free_count;
}

// Q = K D⁻¹ K over the whole mesh (Eigen, default heap), split into Q_ff (returned) and the
// free × handle coupling (s->coupling_*).
SparseMatrix assemble_system(HandleSystem* s, uint32_t n, const Array<uint32_t>& offsets,
                             const Array<uint32_t>& adjacency) {
  const uint32_t free_count = s->free_count;
  SparseMatrix q_ff(free_count, free_count);
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(adjacency.size() + n);
  Eigen::VectorXd inverse_degree = Eigen::VectorXd::Zero(n);
  for (uint32_t v = 0; v < n; ++v) {
    const uint32_t degree = offsets[v + 1] - offsets[v];
    if (degree == 0) continue;  // an unused vertex: alone in its component, kStill
    entries.emplace_back(int(v), int(v), double(degree));
    for (uint32_t k = offsets[v]; k < offsets[v + 1]; ++k) entries.emplace_back(int(v), int(adjacency[k]), -1.0);
    inverse_degree[v] = 1.0 / degree;
  }
  SparseMatrix laplacian(n, n);  // K, symmetric
  laplacian.setFromTriplets(entries.begin(), entries.end());
  const SparseMatrix scaled = inverse_degree.asDiagonal() * laplacian;
  const SparseMatrix q = laplacian * scaled;  // symmetric: column j = row j

  entries.clear();
  s->coupling_offsets.assign(size_t(free_count) + 1, 0);
  // Column v of q is row v by symmetry, so one pass over the columns of free vertices
  // gives both the free block and the free × handle coupling, row by row.
  for (uint32_t v = 0; v < n; ++v) {
    if (s->vertex_role[v] != kFree) continue;
    const uint32_t row = s->vertex_ref[v];
    for (SparseMatrix::InnerIterator it(q, int(v)); it; ++it) {
      const uint32_t w = uint32_t(it.row());
      if (it.value() == 0.0) continue;
      if (s->vertex_role[w] == kFree) {
        entries.emplace_back(int(row), int(s->vertex_ref[w]), it.value());
      } else if (s->vertex_role[w] == kHandle) {
        s->coupling_slot.push_back(s->vertex_ref[w]);
        s->coupling_weight.push_back(-it.value());
      }
    }
    s->coupling_offsets[row + 1] = uint32_t(s->coupling_slot.size());
  }
  q_ff.setFromTriplets(entries.begin(), entries.end());
  return q_ff;
}

// The LDLᵀ factor of Q_ff (s->permutation, s->factor_*), when there are free vertices.
void factorise(HandleSystem* s, const SparseMatrix& q_ff) {
  const uint32_t free_count = s->free_count;
  if (free_count == 0) return;
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower> ldlt(q_ff);
  if (ldlt.info() != Eigen::Success)
    throw std::runtime_error("handle set: the bilaplacian system could not be factorised");

  s->permutation.resize(free_count);
  const auto& p = ldlt.permutationP();
  for (uint32_t i = 0; i < free_count; ++i) s->permutation[i] = p.size() == 0 ? i : uint32_t(p.indices()[i]);

  const SparseMatrix& l = ldlt.matrixL().nestedExpression();
  s->factor_offsets.assign(size_t(free_count) + 1, 0);
  s->factor_rows.reserve(size_t(l.nonZeros()));
  s->factor_values.reserve(size_t(l.nonZeros()));
  for (uint32_t j = 0; j < free_count; ++j) {
    // The unit diagonal is implicit (Eigen's LDLᵀ does not store it); skip it if present.
    for (SparseMatrix::InnerIterator it(l, int(j)); it; ++it) {
      if (uint32_t(it.row()) <= j) continue;
      s->factor_rows.push_back(uint32_t(it.row()));
      s->factor_values.push_back(it.value());
    }
    s->factor_offsets[j + 1] = uint32_t(s->factor_rows.size());
  }
  const Eigen::VectorXd& diagonal = ldlt.vectorD();
  s->factor_diagonal.resize(free_count);
  for (uint32_t j = 0; j < free_count; ++j) {
    if (!(diagonal[j] > 0.0))  // positive definite by construction (file comment)
      throw std::runtime_error("handle set: the bilaplacian system is not positive definite");
    s->factor_diagonal[j] = diagonal[j];
  }
}

// The solve path (the cheaper per frame, unless forced) and its data: the precomputed basis
// (the factor is then released) or the substitution's work space.
void prepare_path(HandleSystem* s, HandleSolvePath path, const AllocatorRef& alloc) {
  const uint32_t free_count = s->free_count;
  // Per-frame multiply-adds of each path (per coordinate): see the file comment.
  const size_t substitution_cost = 2 * s->factor_rows.size() + s->coupling_slot.size() + 2 * size_t(free_count);
  const size_t basis_cost = size_t(free_count) * s->slot_count;
  if (path == HandleSolvePath::automatic)
    path = basis_cost < substitution_cost ? HandleSolvePath::basis : HandleSolvePath::substitution;
  s->path = path;
  if (path == HandleSolvePath::basis) {
    s->basis.assign(basis_cost, 0.0);
    Array<double> field(free_count, 0.0, CallbackAllocator<double>(alloc));
    for (uint32_t u = 0; u < s->slot_count; ++u) {
      std::fill(field.begin(), field.end(), 0.0);
      for (uint32_t f = 0; f < free_count; ++f)
        for (uint32_t k = s->coupling_offsets[f]; k < s->coupling_offsets[f + 1]; ++k)
          if (s->coupling_slot[k] == u) field[s->permutation[f]] += s->coupling_weight[k];
      substitute<1>(*s, field.data());
      for (uint32_t f = 0; f < free_count; ++f) s->basis[size_t(f) * s->slot_count + u] = field[s->permutation[f]];
    }
    release(s->coupling_offsets);
    release(s->coupling_slot);
    release(s->coupling_weight);
    release(s->permutation);
    release(s->factor_offsets);
    release(s->factor_rows);
    release(s->factor_values);
    release(s->factor_diagonal);
  } else {
    s->work.assign(size_t(free_count) * 3, 0.0);
  }
  s->slot_displacement.assign(size_t(s->slot_count) * 3, 0.0);
}

}  // namespace

HandleSystem* handle_system_create(const Deformable& d, const uint32_t* handle_control, size_t handle_count,
                                   const uint32_t* pinned_control, size_t pinned_count, const AllocatorRef& alloc) {
  return handle_system_create_with(d, handle_control, handle_count, pinned_control, pinned_count, alloc,
                                   HandleSolvePath::automatic);
}

HandleSystem* handle_system_create_with(const Deformable& d, const uint32_t* handle_control, size_t handle_count,
                                        const uint32_t* pinned_control, size_t pinned_count, const AllocatorRef& alloc,
                                        HandleSolvePath path) {
  const uint32_t n = d.control_vertex_count;
  if (handle_count == 0 || !handle_control) invalid("no handle");
  if (pinned_count > 0 && !pinned_control) invalid("pinned_count > 0 with no pinned array");
  if (d.skeletal_positions.size() != n) invalid("skeletal mesh has no positions for its control vertices");
  if (d.control_indices.size() % 3 != 0) invalid("skeletal triangle indices are not a multiple of 3");
  for (uint32_t index : d.control_indices)
    if (index >= n) invalid("skeletal triangle index out of range");

  HandleSystem* s = create_object<HandleSystem>(alloc, alloc);
  try {
    s->vertex_count = n;
    s->handle_count = handle_count;
    s->vertex_role.assign(n, kFree);
    s->vertex_ref.assign(n, 0);
    assign_roles(s, n, handle_control, handle_count, pinned_control, pinned_count, alloc);
    Array<uint32_t> offsets{CallbackAllocator<uint32_t>(alloc)};
    Array<uint32_t> adjacency{CallbackAllocator<uint32_t>(alloc)};
    build_adjacency(d, offsets, adjacency, alloc);
    settle_unanchored(s, n, offsets, adjacency, alloc);
    factorise(s, assemble_system(s, n, offsets, adjacency));
    prepare_path(s, path, alloc);
    return s;
  } catch (...) {
    destroy_object(alloc, s);
    throw;
  }
}

void handle_system_destroy(HandleSystem* s, const AllocatorRef& alloc) { destroy_object(alloc, s); }

size_t handle_system_handle_count(const HandleSystem& s) { return s.handle_count; }

HandleSolvePath handle_system_path(const HandleSystem& s) { return s.path; }

void handle_system_solve(const HandleSystem& s, const Deformable& d, const glm::vec3* handle_displacements,
                         glm::vec3* skeletal_out) {
  double* const slot = s.slot_displacement.data();
  double* const y = s.work.data();
  const uint32_t m = s.free_count;

  // Displacement of each distinct handle vertex (the mean over its entries).
  std::fill(s.slot_displacement.begin(), s.slot_displacement.end(), 0.0);
  for (size_t i = 0; i < s.handle_count; ++i) {
    const uint32_t u = s.handle_slot[i];
    const double w = s.slot_weight[u];
    slot[3 * u + 0] += w * handle_displacements[i].x;
    slot[3 * u + 1] += w * handle_displacements[i].y;
    slot[3 * u + 2] += w * handle_displacements[i].z;
  }

  if (s.path == HandleSolvePath::substitution) {
    // y = P b with b = −Q_fh δ_h, then x = L⁻ᵀ D⁻¹ L⁻¹ y.
    for (uint32_t f = 0; f < m; ++f) {
      double b[3] = {0.0, 0.0, 0.0};
      for (uint32_t k = s.coupling_offsets[f]; k < s.coupling_offsets[f + 1]; ++k) {
        const double w = s.coupling_weight[k];
        const double* h = slot + 3 * size_t(s.coupling_slot[k]);
        for (int c = 0; c < 3; ++c) b[c] += w * h[c];
      }
      double* target = y + 3 * size_t(s.permutation[f]);
      for (int c = 0; c < 3; ++c) target[c] = b[c];
    }
    substitute<3>(s, y);
  }

  // S' = S + δ; the unknowns come back through Pᵀ: δ_f = x[permutation[f]].
  for (uint32_t v = 0; v < s.vertex_count; ++v) {
    const glm::dvec3 rest(d.skeletal_positions[v]);
    glm::dvec3 delta(0.0);
    if (s.vertex_role[v] == kFree && s.path == HandleSolvePath::basis) {
      const double* g = s.basis.data() + size_t(s.vertex_ref[v]) * s.slot_count;
      for (uint32_t u = 0; u < s.slot_count; ++u)
        delta += g[u] * glm::dvec3(slot[3 * u], slot[3 * u + 1], slot[3 * u + 2]);
    } else if (s.vertex_role[v] == kFree) {
      const double* x = y + 3 * size_t(s.permutation[s.vertex_ref[v]]);
      delta = glm::dvec3(x[0], x[1], x[2]);
    } else if (s.vertex_role[v] == kHandle) {
      const double* h = slot + 3 * size_t(s.vertex_ref[v]);
      delta = glm::dvec3(h[0], h[1], h[2]);
    }
    skeletal_out[v] = glm::vec3(rest + delta);
  }
}

}  // namespace skelform::runtime
