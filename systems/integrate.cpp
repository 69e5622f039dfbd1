// Projective dynamics (Bouaziz, Martin, Liu, Kavan, Pauly 2014, "Projective dynamics: fusing constraint
// projections for fast simulation") for backward Euler. See integrate.hpp.
//
// Backward Euler minimises g(x) = 1/(2h²) ‖x − y‖²_M + E(x), y = x_n + h v_n + h² g_ext. The energy here is
// the membrane energy of membrane_forces.hpp plus the quadratic bending energy of bending_forces.hpp.
//
// Global matrix (one n x n matrix shared by x, y and z; unknowns are the non-held vertices):
//     A = M/h² + Σ_t w_t G_tᵀ G_t + Σ_h w_h w_hᵀ,   w_t = (2μ + aλ) e A_t   (a = IntegrateParams::area_term),
// where G_t maps the three corners to F_t = Ds Dm⁻¹ (F = Σ_j x_j g_jᵀ with g_1, g_2 the rows of Dm⁻¹ and
// g_0 = −g_1 − g_2), so the (i, j) block of G_tᵀ G_t is (g_i · g_j) I₃.
//
// Local step: ARAP's projection would be T_t = R_t (polar factor of F_t), with w_t = 2μ e A_t. The corotated
// energy also has the area term λ/2 tr(RᵀF − I)², which ARAP ignores. Following Liu, Bouaziz, Kavan 2017
// ("Quasi-Newton methods for real-time simulation of hyperelastic materials"), PD's global step is the
// quasi-Newton step x ← x − A⁻¹ ∇g(x); with the corotated stress P_t this is the ordinary PD step with the
// target T_t = F_t − P_t / w_t = aλ/(2μ+aλ) F_t + (2μ − aλ (tr S − 2))/(2μ+aλ) R_t. Its fixed point is the
// exact backward Euler step of the energy the force system reports (finger reactions and clustering read
// those forces), not of ARAP alone. Why w_t = (2μ + λ) e A and not 2μ e A: the true in-plane stiffness is 2μ
// for shear and 2(μ + λ) for dilation; with w = 2μ the dilation ratio is 1.86 (error × −0.86 per iteration,
// which with 2 iterations made the energy of a stretched sheet grow 6x between substeps), with w = 2μ + λ
// the ratios are 0.7 and 1.3 (error × 0.3 per iteration) and the stretched-sheet energy decays monotonically.
//
// Held vertices are eliminated: the columns of A that couple free to held vertices (A_fh) move their
// targets to the right-hand side. The factorisation (SimplicialLLT, AMD ordering) is rebuilt only when the
// topology version, the held set, dt or the material change.
#include "systems/integrate.hpp"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <algorithm>
#include <cmath>

namespace pt {

using Mat32 = Eigen::Matrix<double, 3, 2>;
using SpMat = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

struct ProjectiveSolver {
  // Key: what the factorisation depends on.
  uint64_t topology_version = ~uint64_t{0};
  double dt = 0;
  MembraneParams membrane;
  double bending_k = 0;
  int32_t vertex_count = -1, triangle_count = -1;
  std::vector<int32_t> held;  // sorted, unique user-held vertices

  // Elimination maps. "Fixed" vertices = held ∪ vertices in no triangle (no mass: they stay put).
  std::vector<int32_t> free_index;   // vertex → row of the free system, −1 if fixed
  std::vector<int32_t> fixed_index;  // vertex → column of A_fh, −1 if free
  std::vector<int32_t> free_vertices;
  std::vector<int32_t> fixed_vertices;

  // Per triangle: weight w_t, area-term ratio λ/(2μ), and shape gradients g_0, g_1, g_2.
  std::vector<double> tri_weight;
  std::vector<std::array<Vec2, 3>> tri_grad;
  double area_term = -1;  // IntegrateParams::area_term the matrix was built with
  double coef_F = 0;      // local-step target T = coef_F · F + (coef_R − coef_F (tr S − 2)) · R
  double coef_R = 1;
  std::vector<BendingStencil> stencils;

  SpMat A_fh;  // free rows x fixed columns
  Eigen::SimplicialLLT<SpMat, Eigen::Lower, Eigen::AMDOrdering<int>> llt;

  // Scratch reused every substep (no allocation after the first).
  std::vector<Mat32> target;  // local-step targets T_t
  std::vector<Vec3> xs;       // current iterate, all vertices
  std::vector<Vec3> y;        // inertial prediction
  std::vector<Vec3> fixed_pos;
  Eigen::Matrix<double, Eigen::Dynamic, 3> rhs, sol;
  std::vector<int32_t> held_scratch;

  ProjectiveStats stats;
};

void ProjectiveSolverDeleter::operator()(ProjectiveSolver* s) const { delete s; }

const ProjectiveStats& projective_solver_stats(const ProjectiveSolver& solver) { return solver.stats; }

namespace {

// Held vertices as the engine defines them: the vertices fingers hold (Finger::vertex ≥ 0).
void held_of_sheet(const Sheet& sheet, std::vector<int32_t>& held) {
  held.clear();
  for (const Finger& f : sheet.fingers)
    if (f.vertex >= 0 && f.vertex < sheet.verts.size()) held.push_back(f.vertex);
  std::sort(held.begin(), held.end());
  held.erase(std::unique(held.begin(), held.end()), held.end());
}

bool key_matches(const ProjectiveSolver& s, const Sheet& sheet, const IntegrateParams& params,
                 const std::vector<int32_t>& held) {
  const MembraneParams mp = membrane_params(sheet.material);
  return s.topology_version == sheet.topology_version && s.dt == params.dt &&
         s.vertex_count == sheet.verts.size() && s.triangle_count == sheet.tris.size() && s.held == held &&
         s.membrane.mu == mp.mu && s.membrane.lambda == mp.lambda && s.membrane.thickness == mp.thickness &&
         s.bending_k == bending_stiffness(sheet.material) && s.area_term == params.area_term;
}

// Builds maps, weights, matrices and the factorisation for the given (sorted, unique) held set.
void build_solver(const Sheet& sheet, const IntegrateParams& params, const std::vector<int32_t>& held,
                  ProjectiveSolver& s) {
  const Vertices& V = sheet.verts;
  const Triangles& T = sheet.tris;
  const int32_t nv = V.size(), nt = T.size();
  const double h = params.dt;
  s.topology_version = sheet.topology_version;
  s.dt = h;
  s.membrane = membrane_params(sheet.material);
  s.bending_k = bending_stiffness(sheet.material);
  s.vertex_count = nv;
  s.triangle_count = nt;
  s.held = held;
  s.area_term = params.area_term;
  // w_t = (2μ + aλ) e A_t, T = F − P/w_t = aλ/(2μ+aλ) · F + (2μ − aλ (tr S − 2))/(2μ+aλ) · R.
  const double two_mu = 2 * s.membrane.mu, a_lambda = params.area_term * s.membrane.lambda;
  const double wsum = two_mu + a_lambda;
  s.coef_F = wsum > 0 ? a_lambda / wsum : 0.0;
  s.coef_R = wsum > 0 ? two_mu / wsum : 1.0;

  // Vertices in no triangle have no mass and no stiffness: fix them instead of making A singular.
  std::vector<char> fixed(nv, 0);
  for (int32_t v : held) fixed[v] = 1;
  std::vector<char> used(nv, 0);
  for (const Tri& t : T.tri)
    for (int32_t c : t) used[c] = 1;
  for (int32_t v = 0; v < nv; ++v)
    if (!used[v]) fixed[v] = 1;
  s.free_index.assign(nv, -1);
  s.fixed_index.assign(nv, -1);
  s.free_vertices.clear();
  s.fixed_vertices.clear();
  for (int32_t v = 0; v < nv; ++v) {
    if (fixed[v]) {
      s.fixed_index[v] = static_cast<int32_t>(s.fixed_vertices.size());
      s.fixed_vertices.push_back(v);
    } else {
      s.free_index[v] = static_cast<int32_t>(s.free_vertices.size());
      s.free_vertices.push_back(v);
    }
  }
  const int32_t nf = static_cast<int32_t>(s.free_vertices.size());
  const int32_t nx = static_cast<int32_t>(s.fixed_vertices.size());

  s.tri_weight.resize(nt);
  s.tri_grad.resize(nt);
  for (int32_t t = 0; t < nt; ++t) {
    s.tri_weight[t] = wsum * s.membrane.thickness * T.rest_area[t];
    const Mat2& B = T.rest_inv[t];
    const Vec2 g1 = B.row(0).transpose(), g2 = B.row(1).transpose();
    s.tri_grad[t] = {-(g1 + g2), g1, g2};
  }
  build_bending_stencils(V.rest, sheet.topo.hinges, s.bending_k, s.stencils);

  // Assemble A's free-free part (lower triangle is enough for LLT, but the full matrix costs little and
  // keeps the code simple) and the free-fixed coupling.
  std::vector<Eigen::Triplet<double>> aff, afx;
  aff.reserve(static_cast<size_t>(nf) + 9 * static_cast<size_t>(nt) + 16 * s.stencils.size());
  auto add = [&](int32_t i, int32_t j, double val) {
    const int32_t fi = s.free_index[i];
    if (fi < 0) return;  // rows of fixed vertices are not unknowns
    const int32_t fj = s.free_index[j];
    if (fj >= 0)
      aff.emplace_back(fi, fj, val);
    else
      afx.emplace_back(fi, s.fixed_index[j], val);
  };
  const double inv_h2 = 1.0 / (h * h);
  for (int32_t v = 0; v < nv; ++v)
    if (s.free_index[v] >= 0) add(v, v, V.mass[v] * inv_h2);
  for (int32_t t = 0; t < nt; ++t) {
    const auto& g = s.tri_grad[t];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) add(T.tri[t][i], T.tri[t][j], s.tri_weight[t] * g[i].dot(g[j]));
  }
  for (const BendingStencil& b : s.stencils)
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) add(b.v[i], b.v[j], b.w[i] * b.w[j]);
  SpMat A(nf, nf);
  A.setFromTriplets(aff.begin(), aff.end());  // sums duplicates
  s.A_fh.resize(nf, nx);
  s.A_fh.setFromTriplets(afx.begin(), afx.end());
  s.A_fh.makeCompressed();
  s.llt.compute(A);
  s.stats.factorizations += 1;
  s.stats.factorization_ok = s.llt.info() == Eigen::Success;

  s.target.resize(nt);
  s.xs.resize(nv);
  s.y.resize(nv);
  s.fixed_pos.resize(nx);
  s.rhs.resize(nf, 3);
  s.sol.resize(nf, 3);
}

}  // namespace

void prepare_projective_solver(const Sheet& sheet, const IntegrateParams& params, ProjectiveSolverPtr& solver) {
  if (!solver) solver.reset(new ProjectiveSolver);
  ProjectiveSolver& s = *solver;
  held_of_sheet(sheet, s.held_scratch);
  if (key_matches(s, sheet, params, s.held_scratch)) return;
  const std::vector<int32_t> held = s.held_scratch;
  build_solver(sheet, params, held, s);
}

bool integrate_substep(const IntegrateParams& params, const std::vector<int32_t>& held,
                       const std::vector<Vec3>& held_target, ProjectiveSolver& s, Sheet& sheet) {
  Vertices& V = sheet.verts;
  const Triangles& T = sheet.tris;
  const int32_t nv = V.size(), nt = T.size();
  s.stats.substeps += 1;

  // The held set of this call decides; rebuild if the caller's set differs from the prepared one.
  s.held_scratch.clear();
  for (int32_t v : held)
    if (v >= 0 && v < nv) s.held_scratch.push_back(v);
  std::sort(s.held_scratch.begin(), s.held_scratch.end());
  s.held_scratch.erase(std::unique(s.held_scratch.begin(), s.held_scratch.end()), s.held_scratch.end());
  if (!key_matches(s, sheet, params, s.held_scratch)) {
    const std::vector<int32_t> h = s.held_scratch;
    build_solver(sheet, params, h, s);
  }
  if (!s.stats.factorization_ok) {
    s.stats.ok = false;
    s.stats.failures += 1;
    return false;
  }

  const double h = params.dt, inv_h2 = 1.0 / (h * h);
  const int32_t nf = static_cast<int32_t>(s.free_vertices.size());

  // Fixed positions: held targets (last entry wins for duplicates), else the vertex stays where it is.
  for (size_t k = 0; k < s.fixed_vertices.size(); ++k) s.fixed_pos[k] = V.x[s.fixed_vertices[k]];
  for (size_t i = 0; i < held.size() && i < held_target.size(); ++i) {
    const int32_t v = held[i];
    if (v >= 0 && v < nv) s.fixed_pos[s.fixed_index[v]] = held_target[i];
  }

  // Inertial prediction; the iterate starts there (Bouaziz et al. 2014, Algorithm 1).
  const Vec3 hg = h * h * params.gravity;
  for (int32_t v = 0; v < nv; ++v) {
    const int32_t k = s.fixed_index[v];
    s.y[v] = k >= 0 ? s.fixed_pos[k] : Vec3(V.x[v] + h * V.v[v] + hg);
    s.xs[v] = s.y[v];
  }

  const double cF = s.coef_F, cR = s.coef_R;
  const int32_t iterations = std::max(1, params.iterations);
  bool ok = true;
  for (int32_t it = 0; it < iterations && ok; ++it) {
    // Local step: per-triangle targets, each range writes only its own slots.
    params.run(nt, params.grain, [&](int32_t b, int32_t e) {
      for (int32_t t = b; t < e; ++t) {
        const Mat32 F = deformation_gradient(s.xs, T.tri[t], T.rest_inv[t]);
        const Mat32 R = polar_rotation(F);
        const double trS = R.col(0).dot(F.col(0)) + R.col(1).dot(F.col(1));
        s.target[t] = cF * F + (cR - cF * (trS - 2.0)) * R;
      }
    });
    // Global right-hand side, gathered per free vertex over its triangle fan in ascending order.
    params.run(nf, params.grain, [&](int32_t b, int32_t e) {
      for (int32_t f = b; f < e; ++f) {
        const int32_t v = s.free_vertices[f];
        Vec3 r = (V.mass[v] * inv_h2) * s.y[v];
        for (const int32_t t : sheet.topo.fan(v)) {
          const Tri& c = T.tri[t];
          const int32_t i = c[0] == v ? 0 : (c[1] == v ? 1 : 2);
          r += s.tri_weight[t] * (s.target[t] * s.tri_grad[t][i]);
        }
        s.rhs.row(f) = r.transpose();
      }
    });
    // Coupling to fixed vertices (column by column: a fixed order, few columns).
    for (int32_t k = 0; k < s.A_fh.outerSize(); ++k) {
      const Vec3& p = s.fixed_pos[k];
      for (SpMat::InnerIterator itk(s.A_fh, k); itk; ++itk) s.rhs.row(itk.row()) -= itk.value() * p.transpose();
    }
    s.sol = s.llt.solve(s.rhs);
    if (s.llt.info() != Eigen::Success || !s.sol.allFinite()) {
      ok = false;
      break;
    }
    for (int32_t f = 0; f < nf; ++f) s.xs[s.free_vertices[f]] = s.sol.row(f).transpose();
  }

  if (!ok) {  // keep the previous state (docs/result-format.md: never a NaN in an output)
    s.stats.ok = false;
    s.stats.failures += 1;
    return false;
  }
  s.stats.ok = true;
  const double decay = std::exp(-params.damping * h);  // mass-proportional damping, exact for dv/dt = −c v
  for (int32_t v = 0; v < nv; ++v) {
    const int32_t k = s.fixed_index[v];
    if (k >= 0) {
      V.v[v] = s.held.empty() || !std::binary_search(s.held.begin(), s.held.end(), v)
                   ? Vec3::Zero()
                   : Vec3((s.xs[v] - V.x[v]) / h);
    } else {
      V.v[v] = ((s.xs[v] - V.x[v]) / h) * decay;
    }
    V.x[v] = s.xs[v];
  }
  return true;
}

}  // namespace pt
