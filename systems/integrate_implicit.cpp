#include "systems/integrate_implicit.hpp"

#include "systems/block_ldlt.hpp"

#include <algorithm>
#include <cmath>

namespace pt {

namespace {
using Mat32 = Eigen::Matrix<double, 3, 2>;

// Upper blocks of a triangle's 9x9 stiffness, in this order: (0,0) (0,1) (0,2) (1,1) (1,2) (2,2).
constexpr int kPairA[6] = {0, 0, 0, 1, 1, 2};
constexpr int kPairB[6] = {0, 1, 2, 1, 2, 2};

struct MaterialKey {
  double young, poisson, thickness, density, bending_scale;
  bool operator==(const MaterialKey&) const = default;
};
MaterialKey key_of(const Material& m) { return {m.young, m.poisson, m.thickness, m.density, m.bending_scale}; }
}  // namespace

struct ImplicitSolver {
  // What the symbolic structure was built for.
  uint64_t version = ~uint64_t{0};
  std::vector<int32_t> held;
  double dt = 0;
  MaterialKey material{};
  double alpha = 0, beta = 0;

  int32_t free_count = 0;
  std::vector<int32_t> free_index;                 // vertex → free index, −1 when held
  std::vector<std::pair<int32_t, int32_t>> block_key;  // sorted (I, J) of every non-zero 3x3 block (both halves)
  std::vector<Mat3> block_values;                  // the matrix, one 3x3 block per key
  std::vector<std::array<int32_t, 9>> tri_block;   // per triangle, corner pair (a, b) → block, −1 if not free
  std::vector<BendingStencil> stencils;
  std::vector<Mat3> base_values;                   // M(1 + hα) + (h² + hβ) Q, per block
  BlockLdlt ldlt;
  bool analysed = false;

  // Scratch reused every substep.
  std::vector<std::array<Mat3, 6>> tri_k;
  Eigen::VectorXd rhs, solution;
  std::vector<Vec3> velocity_next;
  ImplicitStats stats;

  std::vector<int32_t> row_start;                  // per free row I, its first key (keys sorted by row)
  std::vector<int32_t> pair_row, pair_column;      // scratch of the structure build

  int32_t block_of(int32_t i, int32_t j) const {
    const auto first = block_key.begin() + row_start[i], last = block_key.begin() + row_start[i + 1];
    const auto it = std::lower_bound(first, last, std::make_pair(i, j));
    return (it != last && *it == std::make_pair(i, j)) ? static_cast<int32_t>(it - block_key.begin()) : -1;
  }
};

namespace {
// Σ⁺: the positive part of a symmetric 2x2 stress, in closed form (λ± = m ± r; the projector on the λ+
// eigenvector is (Σ − λ− I)/(λ+ − λ−)).
Mat2 tensile_part(const Mat2& stress) {
  const double m = 0.5 * (stress(0, 0) + stress(1, 1));
  const double d = 0.5 * (stress(0, 0) - stress(1, 1));
  const double r = std::sqrt(d * d + stress(0, 1) * stress(0, 1));
  const double high = m + r, low = m - r;
  if (low >= 0) return stress;
  if (high <= 0) return Mat2::Zero();
  return (high / (high - low)) * (stress - low * Mat2::Identity());
}
}  // namespace

void ImplicitSolverDeleter::operator()(ImplicitSolver* s) const { delete s; }
const ImplicitStats& implicit_solver_stats(const ImplicitSolver& solver) { return solver.stats; }

namespace {

void build_structure(const Sheet& sheet, const ImplicitParams& params, std::vector<int32_t> held_sorted,
                     ImplicitSolver& s) {
  const Vertices& V = sheet.verts;
  const Triangles& T = sheet.tris;
  const int32_t nv = V.size(), nt = T.size();
  s.version = sheet.topology_version;
  s.held = std::move(held_sorted);
  s.dt = params.dt;
  s.material = key_of(sheet.material);
  s.alpha = params.mass_damping;
  s.beta = params.stiffness_damping;

  s.free_index.assign(nv, 0);
  for (int32_t v : s.held) s.free_index[v] = -1;
  s.free_count = 0;
  for (int32_t v = 0; v < nv; ++v)
    if (s.free_index[v] >= 0) s.free_index[v] = s.free_count++;

  build_bending_stencils(V.rest, sheet.topo.hinges, bending_stiffness(sheet.material), s.stencils);

  // Non-zero blocks: every pair of free vertices that share a triangle or a hinge. Bucketed by row, then
  // each (short) row sorted: the keys come out sorted by (I, J) without a global sort.
  s.pair_row.clear();
  s.pair_column.clear();
  auto add_pair = [&](int32_t a, int32_t b) {
    const int32_t i = s.free_index[a], j = s.free_index[b];
    if (i < 0 || j < 0) return;
    s.pair_row.push_back(i);
    s.pair_column.push_back(j);
  };
  for (const Tri& t : T.tri)
    for (int32_t a : t)
      for (int32_t b : t) add_pair(a, b);
  for (const BendingStencil& st : s.stencils)
    for (int32_t a : st.v)
      for (int32_t b : st.v) add_pair(a, b);
  for (int32_t v = 0; v < nv; ++v) add_pair(v, v);  // isolated free vertices still have their mass
  {
    std::vector<int32_t> start(s.free_count + 1, 0);
    for (int32_t i : s.pair_row) ++start[i + 1];
    for (int32_t i = 0; i < s.free_count; ++i) start[i + 1] += start[i];
    std::vector<int32_t> columns(s.pair_row.size()), next(start.begin(), start.end() - 1);
    for (size_t q = 0; q < s.pair_row.size(); ++q) columns[next[s.pair_row[q]]++] = s.pair_column[q];
    s.block_key.clear();
    s.row_start.assign(s.free_count + 1, 0);
    for (int32_t i = 0; i < s.free_count; ++i) {
      const auto first = columns.begin() + start[i], last = columns.begin() + start[i + 1];
      std::sort(first, last);
      for (auto it = first; it != last; ++it)
        if (it == first || *it != *(it - 1)) s.block_key.emplace_back(i, *it);
      s.row_start[i + 1] = static_cast<int32_t>(s.block_key.size());
    }
  }

  const int32_t n = 3 * s.free_count;
  s.tri_block.assign(nt, {});
  for (int32_t t = 0; t < nt; ++t)
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        const int32_t i = s.free_index[T.tri[t][a]], j = s.free_index[T.tri[t][b]];
        s.tri_block[t][3 * a + b] = (i >= 0 && j >= 0) ? s.block_of(i, j) : -1;
      }

  // Constant part: lumped mass with mass damping, and the (constant) bending Hessian Q.
  const double h = params.dt;
  const double kscale = h * h + h * s.beta;
  s.base_values.assign(s.block_key.size(), Mat3::Zero());
  for (int32_t v = 0; v < nv; ++v) {
    const int32_t i = s.free_index[v];
    if (i < 0) continue;
    s.base_values[s.block_of(i, i)] += Mat3::Identity() * V.mass[v] * (1 + h * s.alpha);
  }
  for (const BendingStencil& st : s.stencils)
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) {
        const int32_t i = s.free_index[st.v[a]], j = s.free_index[st.v[b]];
        if (i >= 0 && j >= 0) s.base_values[s.block_of(i, j)] += Mat3::Identity() * kscale * st.w[a] * st.w[b];
      }

  analyze_block_ldlt(s.free_count, s.block_key, BlockLdltParams{}, s.ldlt);
  s.block_values.resize(s.block_key.size());
  s.analysed = true;
  s.tri_k.resize(nt);
  s.rhs.resize(n);
  s.solution.resize(n);
  s.stats.analyses += 1;
}

}  // namespace

bool implicit_substep(const ImplicitParams& params, const std::vector<int32_t>& held,
                      const std::vector<Vec3>& held_target, ImplicitSolverPtr& solver, Sheet& sheet) {
  Vertices& V = sheet.verts;
  Triangles& T = sheet.tris;
  const int32_t nv = V.size(), nt = T.size();
  std::vector<int32_t> held_sorted = held;
  std::sort(held_sorted.begin(), held_sorted.end());
  held_sorted.erase(std::unique(held_sorted.begin(), held_sorted.end()), held_sorted.end());
  if (!solver) solver.reset(new ImplicitSolver);
  ImplicitSolver& s = *solver;
  if (!s.analysed || s.version != sheet.topology_version || s.held != held_sorted || s.dt != params.dt ||
      !(s.material == key_of(sheet.material)) || s.alpha != params.mass_damping || s.beta != params.stiffness_damping)
    build_structure(sheet, params, held_sorted, s);

  const double h = params.dt;
  const double kscale = h * h + h * s.beta;
  const MembraneParams mp = membrane_params(sheet.material);

  // Prescribed velocities of held vertices.
  std::vector<Vec3>& vnext = s.velocity_next;
  vnext.assign(nv, Vec3::Zero());
  for (size_t k = 0; k < held.size(); ++k) vnext[held[k]] = (held_target[k] - V.x[held[k]]) / h;

  // Per triangle (parallel, each writes its own slots): corotated forces of membrane_forces and the
  // in-plane stiffness K_ab = e A [2μ (g_a·g_b) R Rᵀ + λ (R g_a)(R g_b)ᵀ] with R frozen.
  params.run(nt, params.grain, [&](int32_t begin, int32_t end) {
    compute_membrane_forces(V.x, T.tri, T.rest_inv, T.rest_area, mp, begin, end, T.corner_force);
    for (int32_t t = begin; t < end; ++t) {
      const Mat32 F = deformation_gradient(V.x, T.tri[t], T.rest_inv[t]);
      const Mat32 R = polar_rotation(F);
      const Mat2& Dinv = T.rest_inv[t];
      Vec2 g[3];
      g[1] = Dinv.row(0).transpose();
      g[2] = Dinv.row(1).transpose();
      g[0] = -(g[1] + g[2]);
      const double ea = kscale * mp.thickness * T.rest_area[t];  // the (h² + hβ) of the system folded in
      const Mat3 in_plane = R * R.transpose();
      // Geometric (tension) stiffness for out-of-plane motion: g_aᵀ Σ g_b (I − R Rᵀ) with Σ the stress
      // in the triangle's frame, clamped to its tensile part (paper under compression buckles freely).
      // Without it a finger lifting a taut sheet would leave its neighbours behind for a substep and
      // pitch a tent of spurious stretch.
      Mat2 strain = R.transpose() * F;
      strain = 0.5 * (strain + strain.transpose()) - Mat2::Identity();
      const Mat2 stress = 2 * mp.mu * strain + mp.lambda * strain.trace() * Mat2::Identity();
      const Mat2 tension = tensile_part(stress);
      Vec3 rg[3];
      for (int a = 0; a < 3; ++a) rg[a] = R * g[a];
      // 2μ(g_a·g_b) RRᵀ + λ (R g_a)(R g_b)ᵀ + (g_aᵀ Σ⁺ g_b)(I − RRᵀ), with I − RRᵀ expanded.
      for (int k = 0; k < 6; ++k) {
        const int a = kPairA[k], b = kPairB[k];
        const double geometric = g[a].dot(tension * g[b]);
        Mat3 block = (2 * mp.mu * g[a].dot(g[b]) - geometric) * in_plane;
        block.noalias() += mp.lambda * rg[a] * rg[b].transpose();
        block.diagonal().array() += geometric;
        s.tri_k[t][k] = ea * block;
      }
    }
  });

  // Forces on vertices in a fixed order (no atomics), then bending.
  gather_corner_forces(sheet.topo, T.tri, T.corner_force, 0, nv, V.force);
  add_bending_forces(V.x, s.stencils, V.force);

  // Assemble the matrix values (serial, triangle order: deterministic) and the coupling to held vertices.
  std::vector<Mat3>& values = s.block_values;
  std::copy(s.base_values.begin(), s.base_values.end(), values.begin());
  s.rhs.setZero();
  for (int32_t v = 0; v < nv; ++v) {
    const int32_t i = s.free_index[v];
    if (i < 0) continue;
    s.rhs.segment<3>(3 * i) = V.mass[v] * V.v[v] + h * (V.force[v] + V.mass[v] * params.gravity);
  }
  for (int32_t t = 0; t < nt; ++t) {
    for (int k = 0; k < 6; ++k) {
      const int a = kPairA[k], b = kPairB[k];
      const Mat3& kab = s.tri_k[t][k];
      const int32_t va = T.tri[t][a], vb = T.tri[t][b];
      const int32_t ia = s.free_index[va], ib = s.free_index[vb];
      const int32_t blk_ab = s.tri_block[t][3 * a + b];
      if (blk_ab >= 0) values[blk_ab] += kab;
      if (a != b) {
        const int32_t blk_ba = s.tri_block[t][3 * b + a];
        if (blk_ba >= 0) values[blk_ba] += kab.transpose();
        if (ia >= 0 && ib < 0) s.rhs.segment<3>(3 * ia) -= kab * vnext[vb];
        if (ib >= 0 && ia < 0) s.rhs.segment<3>(3 * ib) -= kab.transpose() * vnext[va];
      }
    }
  }
  for (const BendingStencil& st : s.stencils)
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) {
        const int32_t ia = s.free_index[st.v[a]], ib = s.free_index[st.v[b]];
        if (ia >= 0 && ib < 0) s.rhs.segment<3>(3 * ia) -= kscale * st.w[a] * st.w[b] * vnext[st.v[b]];
      }

  s.stats.factorizations += 1;
  if (!factorize_block_ldlt(values, params.run, s.ldlt)) {
    s.stats.failures += 1;
    return false;
  }
  solve_block_ldlt(s.ldlt, s.rhs.data(), s.solution.data());
  if (!s.solution.allFinite()) {
    s.stats.failures += 1;
    return false;
  }
  for (int32_t v = 0; v < nv; ++v) {
    const int32_t i = s.free_index[v];
    if (i >= 0) vnext[v] = s.solution.segment<3>(3 * i);
  }
  for (int32_t v = 0; v < nv; ++v) {
    V.v[v] = vnext[v];
    V.x[v] += h * vnext[v];
  }
  for (size_t k = 0; k < held.size(); ++k) V.x[held[k]] = held_target[k];  // exact, no rounding drift
  return true;
}

}  // namespace pt
