#include "systems/physics/integrate_implicit.hpp"

#include "systems/solver/block_ldlt.hpp"
#include "systems/physics/contact.hpp"

#include "components/capacity_bytes.hpp"
#include "systems/common/scoped_timer.hpp"

#include <algorithm>
#include <cmath>

namespace pt {

namespace {
using Mat32 = Eigen::Matrix<double, 3, 2>;

// Upper blocks of a triangle's 9x9 stiffness, in this order: (0,0) (0,1) (0,2) (1,1) (1,2) (2,2).
constexpr int kPairA[6] = {0, 0, 0, 1, 1, 2};
constexpr int kPairB[6] = {0, 1, 2, 1, 2, 2};

struct MaterialKey {
  double young, poisson, thickness, density, bending_scale, membrane_scale, strain_limit;
  bool operator==(const MaterialKey&) const = default;
};
MaterialKey key_of(const Material& m) {
  return {m.young, m.poisson, m.thickness, m.density, m.bending_scale, m.membrane_scale, m.strain_limit};
}
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
  std::vector<std::array<int32_t, 9>> tri_block;   // per triangle, corner pair (a, b) → block; −1 if not free or not read by the factor
  // Per triangle, where each of its six stiffness blocks K_k (kPairA/B order) goes: the key that receives
  // K_k (≥ 0), −2 − key when that key receives K_kᵀ (the factor reads one block of a symmetric pair), −1
  // when neither (a held corner).
  std::vector<std::array<int32_t, 6>> tri_dest;
  struct HeldStiffness {
    int32_t triangle, pair, row, held_vertex;
    bool transpose;
  };
  // rhs[row] −= K_k (or K_kᵀ) v⁺[held_vertex], in (triangle, pair) order.
  std::vector<HeldStiffness> stiffness_held;
  std::vector<BendingStencil> stencils;
  struct HeldCoupling {
    int32_t row, held_vertex;
    double weight;
  };
  std::vector<HeldCoupling> bending_held;          // rhs[row] −= weight · v⁺[held_vertex], in stencil order
  std::vector<Mat3> base_values;                   // M(1 + hα) + (h² + hβ) Q, per block
  BlockLdlt ldlt;
  // Per halving depth, the state a split step started from and its forces (implicit_substep).
  struct SplitStart {
    std::vector<Vec3> x, v, force;
    std::vector<std::array<Vec3, 3>> corner_force;
    std::vector<Vec3> half_target;
  };
  std::vector<SplitStart> split_starts;
  std::vector<uint8_t> strain_jumps;               // scratch of strain_jumped: per triangle, whether it jumped
  std::vector<std::pair<int32_t, int32_t>> analysed_keys;  // the keys and positions ldlt was analysed for
  std::vector<Vec2> analysed_rest;
  bool analysed = false;

  // Scratch reused every substep.
  std::vector<std::array<Mat3, 6>> tri_k;
  std::vector<double> tri_energy;                  // membrane energy of each triangle at the start state
  std::vector<std::array<double, 2>> tri_check;    // energy check, per triangle: excess, v⁺ᵀ K_t v⁺
  // The energy check's frames at x⁺ = x + h v⁺ and the corners they were taken at: the next substep starts
  // at x⁺ (bit for bit, for triangles without a held corner) and takes F and R from here instead of a second
  // polar decomposition. A frame is used only when its corners still match the positions exactly.
  std::vector<CorotatedFrame> next_frame;
  std::vector<std::array<Vec3, 3>> next_corners;
  bool next_valid = false;
  int32_t brake = 0;                               // spin brake level (index of kBrakeKappa) ...
  int32_t braked_left = 0;                         // ... kept for this many more substeps
  Eigen::VectorXd rhs, solution;
  std::vector<Vec3> velocity_next;
  ImplicitStats stats;

  // Vertices resting on an obstacle at the substep's start, filtered in the solve (systems/physics/contact.hpp).
  struct RestingContact {
    int32_t vertex, row;
    Vec3 normal;
    double mu;
    double target = 0;    // prescribed normal velocity: 0 resting, −gap/h for a vertex arriving this substep
    bool stick = false;   // static friction: the whole velocity prescribed (n · target), not only its normal
    Vec3 friction = Vec3::Zero();  // sliding: the friction impulse, −μ λ along the motion, on the right-hand side
    double reaction = 0;  // normal impulse of the constraint over the substep, N·s (> 0: it supports)
    Vec3 impulse = Vec3::Zero();  // the constraint's whole impulse A v − b − friction
    int32_t pair = -1;    // an entry of ImplicitParams::self_pairs (its target follows the triangle), −1 an obstacle
    // The velocity of the surface it rests on: zero on an obstacle, the triangle's point for a pair (from the
    // solve before). Friction acts on the velocity relative to it, and a sticking pair moves with it.
    Vec3 carried = Vec3::Zero();
    // What the constraint prescribes: the normal velocity `target`, and when it sticks the surface's
    // tangential velocity too.
    Vec3 prescribed() const {
      return target * normal + (stick ? (carried - normal * normal.dot(carried)).eval() : Vec3::Zero().eval());
    }
  };
  std::vector<RestingContact> resting;
  std::vector<int32_t> resting_of_row;             // free row → its entry of `resting`, −1 when none
  std::vector<Vec3> resting_prescribed;            // scratch of filter_resting: each entry's prescribed()
  std::vector<uint8_t> constrained;                // per vertex: in `resting`
  std::vector<int32_t> obstacle_of_vertex;         // per vertex: its obstacle constraint in `resting`, −1 none
  std::vector<Mat3> unfiltered_values;             // the matrix and right-hand side before the filter,
  Eigen::VectorXd unfiltered_rhs;                  // for the constraints' reactions

  std::vector<int32_t> diagonal_key;               // per free row I, the key of block (I, I)
  std::vector<int32_t> pair_row, pair_column;      // scratch of the structure build (row −1: a held vertex)
  std::vector<int32_t> pair_key;                   // scratch: the key of each pair
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
size_t split_start_bytes(const std::vector<ImplicitSolver::SplitStart>& starts) {
  size_t bytes = capacity_bytes(starts);
  for (const ImplicitSolver::SplitStart& st : starts)
    bytes += capacity_bytes(st.x) + capacity_bytes(st.v) + capacity_bytes(st.force) +
             capacity_bytes(st.corner_force) + capacity_bytes(st.half_target);
  return bytes;
}
}  // namespace

size_t implicit_solver_bytes(const ImplicitSolver& s) {
  return sizeof(ImplicitSolver) + capacity_bytes(s.held) + capacity_bytes(s.free_index) + capacity_bytes(s.block_key) +
         capacity_bytes(s.diagonal_key) + capacity_bytes(s.block_values) + capacity_bytes(s.tri_block) +
         capacity_bytes(s.tri_dest) + capacity_bytes(s.stiffness_held) +
         capacity_bytes(s.stencils) + capacity_bytes(s.bending_held) + capacity_bytes(s.base_values) +
         block_ldlt_bytes(s.ldlt) + capacity_bytes(s.analysed_keys) + capacity_bytes(s.analysed_rest) +
         capacity_bytes(s.tri_k) + capacity_bytes(s.tri_energy) +
         capacity_bytes(s.tri_check) + capacity_bytes(s.next_frame) + capacity_bytes(s.next_corners) +
         static_cast<size_t>(s.rhs.size() + s.solution.size()) * sizeof(double) + capacity_bytes(s.velocity_next) +
         capacity_bytes(s.pair_row) + capacity_bytes(s.pair_column) +
         capacity_bytes(s.pair_key) + capacity_bytes(s.resting) + capacity_bytes(s.resting_of_row) + capacity_bytes(s.resting_prescribed) + capacity_bytes(s.constrained) + capacity_bytes(s.obstacle_of_vertex) +
         capacity_bytes(s.unfiltered_values) + static_cast<size_t>(s.unfiltered_rhs.size()) * sizeof(double) +
         split_start_bytes(s.split_starts) + capacity_bytes(s.strain_jumps);
}

namespace {

// The free vertices' numbering: held vertices get −1, the others 0, 1, … in vertex order.
void number_free_vertices(int32_t nv, ImplicitSolver& s) {
  s.free_index.assign(nv, 0);
  for (int32_t v : s.held) s.free_index[v] = -1;
  s.free_count = 0;
  for (int32_t v = 0; v < nv; ++v)
    if (s.free_index[v] >= 0) s.free_index[v] = s.free_count++;
}

// Non-zero blocks: every pair of free vertices that share a triangle or a hinge. Bucketed by row, each
// row's repeats dropped with a stamp per column, then the (short) unique row sorted: the keys come out
// sorted by (I, J) without a global sort. Every pair keeps the key it landed in (pair_key), so the
// triangles' and stencils' blocks are known without a search: pair q is corner pair (a, b) of triangle t
// at 9t + 3a + b, of stencil k at 9 nt + 16k + 4a + b, vertex v's diagonal at 9 nt + 16 ns + v (row −1
// when a vertex is held). A binary search per pair took a third of the structure's build
// time, its branches mispredicted.
void build_block_pattern(const Triangles& T, int32_t nv, ImplicitSolver& s) {
  const int32_t nt = T.size();
  s.pair_row.clear();
  s.pair_column.clear();
  auto add_pair = [&](int32_t a, int32_t b) {
    const int32_t i = s.free_index[a], j = s.free_index[b];
    const bool free = i >= 0 && j >= 0;
    s.pair_row.push_back(free ? i : -1);
    s.pair_column.push_back(free ? j : -1);
  };
  for (const Tri& t : T.tri)
    for (int32_t a : t)
      for (int32_t b : t) add_pair(a, b);
  for (const BendingStencil& st : s.stencils)
    for (int32_t a : st.v)
      for (int32_t b : st.v) add_pair(a, b);
  for (int32_t v = 0; v < nv; ++v) add_pair(v, v);  // isolated free vertices still have their mass
  const int32_t pairs = static_cast<int32_t>(s.pair_row.size());
  s.pair_key.assign(pairs, -1);
  {
    std::vector<int32_t> start(s.free_count + 1, 0);
    for (int32_t i : s.pair_row)
      if (i >= 0) ++start[i + 1];
    for (int32_t i = 0; i < s.free_count; ++i) start[i + 1] += start[i];
    std::vector<int32_t> bucket(start[s.free_count]), next(start.begin(), start.end() - 1);
    for (int32_t q = 0; q < pairs; ++q)
      if (s.pair_row[q] >= 0) bucket[next[s.pair_row[q]]++] = q;
    s.block_key.clear();
    s.diagonal_key.assign(s.free_count, -1);
    std::vector<int32_t> stamp(s.free_count, -1), key_of_column(s.free_count, -1), unique;
    for (int32_t i = 0; i < s.free_count; ++i) {
      unique.clear();
      for (int32_t p = start[i]; p < start[i + 1]; ++p) {
        const int32_t j = s.pair_column[bucket[p]];
        if (stamp[j] != i) {
          stamp[j] = i;
          unique.push_back(j);
        }
      }
      std::sort(unique.begin(), unique.end());
      for (int32_t j : unique) {
        key_of_column[j] = static_cast<int32_t>(s.block_key.size());
        if (j == i) s.diagonal_key[i] = static_cast<int32_t>(s.block_key.size());
        s.block_key.emplace_back(i, j);
      }
      for (int32_t p = start[i]; p < start[i + 1]; ++p) s.pair_key[bucket[p]] = key_of_column[s.pair_column[bucket[p]]];
    }
  }

  s.tri_block.resize(nt);
  for (int32_t t = 0; t < nt; ++t)
    for (int e = 0; e < 9; ++e) s.tri_block[t][e] = s.pair_key[9 * t + e];

}

void add_constant_blocks(const Vertices& V, const ImplicitParams& params, ImplicitSolver& s) {
  const int32_t nv = V.size(), nt = static_cast<int32_t>(s.tri_block.size());
  const int32_t ns = static_cast<int32_t>(s.stencils.size());
  const int32_t stencil_pairs = 9 * nt, vertex_pairs = stencil_pairs + 16 * ns;
  // Constant part: lumped mass with mass damping, and the (constant) bending Hessian Q. Each is c·I added to
  // a block; the entries of c·I (diagonal, and the zeros times the factors off it) are formed once, in the
  // order of the Eigen expression `Mat3::Identity() * f * g * k` they replace (bit-identical sums).
  auto add_scaled_identity = [](double f, double g, double k, Mat3& block) {
    const double diagonal = 1.0 * f * g * k, off = 0.0 * f * g * k;
    for (int col = 0; col < 3; ++col)
      for (int row = 0; row < 3; ++row) block(row, col) += row == col ? diagonal : off;
  };
  const double h = params.dt;
  const double kscale = h * h + h * s.beta;
  s.base_values.assign(s.block_key.size(), Mat3::Zero());
  for (int32_t v = 0; v < nv; ++v) {
    const int32_t key = s.pair_key[vertex_pairs + v];
    if (key >= 0) add_scaled_identity(V.mass[v], 1 + h * s.alpha, 1.0, s.base_values[key]);
  }
  s.bending_held.clear();
  for (int32_t k = 0; k < ns; ++k) {
    const BendingStencil& st = s.stencils[k];
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) {
        const int32_t key = s.pair_key[stencil_pairs + 16 * k + 4 * a + b];
        if (key >= 0) add_scaled_identity(kscale, st.w[a], st.w[b], s.base_values[key]);
        const int32_t i = s.free_index[st.v[a]], j = s.free_index[st.v[b]];
        if (i >= 0 && j < 0) s.bending_held.push_back({i, st.v[b], kscale * st.w[a] * st.w[b]});
      }
  }
}

void analyse_if_changed(const Vertices& V, const ImplicitParams& params, ImplicitSolver& s) {
  const int32_t nv = V.size();
  std::vector<Vec2> free_rest(s.free_count);  // the pattern positions let the solver order by nested dissection
  for (int32_t v = 0; v < nv; ++v)
    if (s.free_index[v] >= 0) free_rest[s.free_index[v]] = V.rest[v];
  // The analysis is a function of the keys and, from `dissection_leaf` block rows on, the positions: a
  // topology change that leaves them as they were keeps it (measured: 17 of the 47 rebuilds in 60 frames
  // of the 100-triangle A4 scene, cuts that renumbered vertices into the same pattern).
  const BlockLdltParams ldlt_params;
  if (s.free_count < ldlt_params.dissection_leaf) free_rest.clear();  // not read by the analysis
  if (!s.analysed || s.block_key != s.analysed_keys || free_rest != s.analysed_rest) {
    ScopedTimer timer(s.stats.analysis_ms);
    analyze_block_ldlt(s.free_count, s.block_key, ldlt_params, s.ldlt, free_rest, params.run);
    s.analysed_keys = s.block_key;
    s.analysed_rest = std::move(free_rest);
    s.stats.analyses += 1;
  }
}

void plan_assembly(const Triangles& T, ImplicitSolver& s) {
  const int32_t nt = T.size();
  // The factorisation reads one block of each symmetric pair: the triangles scatter into that one only.
  for (std::array<int32_t, 9>& tb : s.tri_block)
    for (int32_t& b : tb)
      if (b >= 0 && !s.ldlt.key_read[b]) b = -1;
  // The assembly's destinations and its couplings to held vertices, decided here once per structure
  // rather than per block and substep. Distinct corners have distinct free indices, so at most one block
  // of a pair (a, b), (b, a) is read.
  s.tri_dest.resize(nt);
  s.stiffness_held.clear();
  for (int32_t t = 0; t < nt; ++t)
    for (int k = 0; k < 6; ++k) {
      const int a = kPairA[k], b = kPairB[k];
      const int32_t ab = s.tri_block[t][3 * a + b], ba = s.tri_block[t][3 * b + a];
      s.tri_dest[t][k] = ab >= 0 ? ab : (a != b && ba >= 0 ? -2 - ba : -1);
      if (a == b) continue;
      const int32_t ia = s.free_index[T.tri[t][a]], ib = s.free_index[T.tri[t][b]];
      if (ia >= 0 && ib < 0) s.stiffness_held.push_back({t, k, ia, T.tri[t][b], false});
      if (ib >= 0 && ia < 0) s.stiffness_held.push_back({t, k, ib, T.tri[t][a], true});
    }
}

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

  number_free_vertices(nv, s);
  build_bending_stencils(V.rest, sheet.topo.hinges, bending_stiffness(sheet.material), s.stencils);
  build_block_pattern(T, nv, s);
  add_constant_blocks(V, params, s);
  analyse_if_changed(V, params, s);
  s.block_values.resize(s.block_key.size());
  plan_assembly(T, s);

  const int32_t n = 3 * s.free_count;
  s.analysed = true;
  s.tri_k.resize(nt);
  s.tri_energy.resize(nt);
  s.tri_check.resize(nt);
  s.next_frame.resize(nt);
  s.next_corners.resize(nt);
  s.next_valid = false;
  s.rhs.resize(n);
  s.solution.resize(n);
}

// Spin brake: κ of the in-plane stiffness by level (0: the exact, stress-dependent κ), and the substeps a
// level is kept after a step needed it.
constexpr int kBrakeLevels = 4;
constexpr double kBrakeKappa[kBrakeLevels] = {0, 1, 4, 16};
constexpr int32_t kBrakeSubsteps = 10;
// The most rounds that only add self-contact pairs after the update rounds (implicit_substep).
constexpr int kSelfPairRounds = 12;
// The most rounds that only release stickers past Coulomb's cap, after all others (implicit_substep).
constexpr int kFrictionRounds = 16;

// The step solved a linear model: membrane energy W(x) − h f·v⁺ + ½ h² v⁺ᵀ K v⁺ (exact for bending and
// gravity, which are quadratic and linear). Backward Euler on that model dissipates
//   D = h α ‖v⁺‖²_M + ½ ‖v⁺ − v‖²_M + (h β + ½ h²) ‖v⁺‖²_K
// (mass terms over free vertices; the held vertices' work is the same for model and truth). The true
// energy exceeds the model's by Σ_t [W_t(x + h v⁺) − model_t] — the stretch of rotations taken linearly —
// so the total energy cannot have grown (beyond the held vertices' work) when that excess ≤ D.
// Per-triangle terms in parallel (each writes its own slot), summed serially in triangle order.
bool energy_bounded(const Sheet& sheet, ImplicitSolver& s, const ImplicitParams& params, double kscale,
                    const MembraneParams& mp) {
  const double h = params.dt;
  const Vertices& V = sheet.verts;
  const Triangles& T = sheet.tris;
  const std::vector<Vec3>& vn = s.velocity_next;
  const int32_t nv = V.size(), nt = T.size();
  double mass_term = 0, model_k = 0, excess = 0, energy = 0;
  for (int32_t v = 0; v < nv; ++v) {
    if (s.free_index[v] < 0) continue;
    mass_term += V.mass[v] * (h * s.alpha * vn[v].squaredNorm() + 0.5 * (vn[v] - V.v[v]).squaredNorm());
  }
  params.run(nt, params.grain, [&](int32_t begin, int32_t end) {
    // The frames at x⁺ first, for the whole range, then the terms that read them: read right after
    // corotated_frame stored them, F and R were loaded in 16-byte pairs straddling its 8-byte stores, which
    // cannot be forwarded (the loads waited for the stores to reach the cache). Same values.
    for (int32_t t = begin; t < end; ++t) {
      const Tri& c = T.tri[t];
      std::array<Vec3, 3>& xp = s.next_corners[t];
      for (int a = 0; a < 3; ++a) xp[a] = V.x[c[a]] + h * vn[c[a]];
      corotated_frame(xp[0], xp[1], xp[2], T.rest_inv[t], s.next_frame[t]);
    }
    for (int32_t t = begin; t < end; ++t) {
      const Tri& c = T.tri[t];
      double quad = 0;  // v⁺ᵀ K_t v⁺ (K with the (h² + hβ) folded in)
      for (int k = 0; k < 6; ++k) {
        const int a = kPairA[k], b = kPairB[k];
        const double q = vn[c[a]].dot(s.tri_k[t][k] * vn[c[b]]);
        quad += a == b ? q : 2 * q;
      }
      quad /= kscale;
      double work = 0;
      for (int a = 0; a < 3; ++a) work += T.corner_force[t][a].dot(vn[c[a]]);
      const CorotatedFrame& frame = s.next_frame[t];
      const Mat32& F = frame.F;
      const Mat32& R = frame.R;
      const double tr = (R.transpose() * F).trace() - 2;
      const double pinch = pinched_fraction(T.pinched, t);  // a finger's triangle (Triangles::pinched)
      const double w = mp.thickness * T.rest_area[t] *
                       corotated_energy_density(F, R, tr, pinch > 0 ? pinched_params(mp, pinch) : mp);
      s.tri_check[t] = {w - (s.tri_energy[t] - h * work + 0.5 * h * h * quad), quad};
    }
  });
  s.next_valid = true;
  for (int32_t t = 0; t < nt; ++t) {
    excess += s.tri_check[t][0];
    model_k += s.tri_check[t][1];
    energy += s.tri_energy[t];
  }
  double bend = 0;
  for (const BendingStencil& st : s.stencils) {
    Vec3 d = Vec3::Zero();
    for (int a = 0; a < 4; ++a) d += st.w[a] * vn[st.v[a]];
    bend += d.squaredNorm();
  }
  const double dissipated = mass_term + (h * s.beta + 0.5 * h * h) * (model_k + bend);
  return excess <= dissipated + 1e-10 * energy;
}

// Per triangle (parallel, each writes its own slots): corotated forces of membrane_forces, the energy
// and the stiffness with R frozen (see the header): in plane
//   K_ab = e A [(1 + κ) μ (g_a·g_b) R Rᵀ + (1 − κ) μ (R g_b)(R g_a)ᵀ + λ (R g_a)(R g_b)ᵀ],
// κ the exact spin stiffness of the corotated energy (projected ≥ 0), or the brake's κ.
void triangle_forces_and_stiffness(const ImplicitParams& params, const MembraneParams& mp, double kscale,
                                   int brake, bool with_forces, const Vertices& V, Triangles& T, ImplicitSolver& s) {
  const int32_t nt = T.size();
  params.run(nt, params.grain, [&](int32_t begin, int32_t end) {
    CorotatedFrame own;  // one polar decomposition per triangle for its forces, energy and stiffness
    MembraneParams pinched;
    for (int32_t t = begin; t < end; ++t) {
      const double pinch = pinched_fraction(T.pinched, t);  // a finger's triangle (Triangles::pinched)
      if (pinch > 0) pinched = pinched_params(mp, pinch);
      const MembraneParams& mpt = pinch > 0 ? pinched : mp;
      const Tri& c = T.tri[t];
      const std::array<Vec3, 3>& carried = s.next_corners[t];
      const bool reuse = s.next_valid && carried[0] == V.x[c[0]] && carried[1] == V.x[c[1]] && carried[2] == V.x[c[2]];
      if (!reuse) corotated_frame(V.x[c[0]], V.x[c[1]], V.x[c[2]], T.rest_inv[t], own);
      const CorotatedFrame& frame = reuse ? s.next_frame[t] : own;
      if (with_forces) corotated_corner_forces(frame, T.rest_inv[t], T.rest_area[t], mpt, T.corner_force[t]);
      const Mat32& F = frame.F;
      const Mat32& R = frame.R;
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
      Mat2 stress = 2 * mp.mu * strain + mp.lambda * strain.trace() * Mat2::Identity();
      StrainLimitTangent limit;
      strain_limit_term(strain, mpt, stress, &limit);
      const Mat2 tension = tensile_part(stress);
      // A principal direction v stretched past the strain limit, or compressed under the relief, adds its
      // modulus k along v (negative for the relief's softening): k (g_a·v)(g_b·v) (R v)(R v)ᵀ, the term's
      // Hessian with v frozen, as R is; a compressed trace scales λ's part.
      Vec3 rv[2];
      double gv[2][3];
      for (int i = 0; i < limit.count; ++i) {
        rv[i] = R * limit.direction[i];
        for (int a = 0; a < 3; ++a) gv[i][a] = g[a].dot(limit.direction[i]);
      }
      const double i1 = strain.trace() + 2;  // σ₁ + σ₂
      const double kappa =
          brake > 0 ? kBrakeKappa[brake] : std::max(0.0, (mp.mu + mp.lambda) * (i1 - 2) / (mp.mu * i1));
      if (with_forces) {
        const double tr = strain.trace();
        s.tri_energy[t] = mp.thickness * T.rest_area[t] * corotated_energy_density(F, R, tr, mpt);
      }
      Vec3 rg[3], lambda_rg[3], twist_rg[3];
      for (int a = 0; a < 3; ++a) {
        rg[a] = R * g[a];
        lambda_rg[a] = (mp.lambda * limit.trace_scale) * rg[a];
        twist_rg[a] = ((1 - kappa) * mp.mu) * rg[a];
      }
      // In-plane part + (g_aᵀ Σ⁺ g_b)(I − RRᵀ), with I − RRᵀ expanded. Entry by entry in scalars, in the
      // order of the earlier Eigen form (s RRᵀ + (λ R g_a)(R g_b)ᵀ + ((1 − κ)μ R g_b)(R g_a)ᵀ + diagonal,
      // then the scale, bit for bit): that form mixed 2-lane and scalar stores of one 3x3 temporary and
      // stalled on store forwarding (a quarter of the frame's time went to this loop).
      for (int k = 0; k < 6; ++k) {
        const int a = kPairA[k], b = kPairB[k];
        const double geometric = g[a].dot(tension * g[b]);
        const double spin = (1 + kappa) * mp.mu * g[a].dot(g[b]) - geometric;
        Mat3& out = s.tri_k[t][k];
        for (int col = 0; col < 3; ++col)
          for (int row = 0; row < 3; ++row) {
            double e = spin * in_plane(row, col);
            e += lambda_rg[a][row] * rg[b][col];
            e += twist_rg[b][row] * rg[a][col];
            if (row == col) e += geometric;
            for (int i = 0; i < limit.count; ++i)
              e += limit.modulus[i] * gv[i][a] * gv[i][b] * rv[i][row] * rv[i][col];
            out(row, col) = ea * e;
          }
      }
    }
  });
}

// Vertices resting on an obstacle (on its grown surface, to a thousandth of the offset): their velocity
// into it is filtered out of the solve (Baraff & Witkin 1998, §5: S = I − n nᵀ), so the stiff membrane
// sees the support in the same step. Those whose support would pull (the sheet lifts off) are released and
// the step solved again; new contacts are caught after the solve (update_contacts).
void find_resting_contacts(const ImplicitParams& params, const Vertices& V, ImplicitSolver& s) {
  const int32_t nv = V.size();
  s.resting.clear();
  if (!params.obstacles.empty()) {
    ScopedTimer timer(s.stats.contact_ms);
    const double tolerance = std::max(1e-3 * params.contact_offset, 1e-12);
    for (int32_t v = 0; v < nv; ++v) {
      if (s.free_index[v] < 0) continue;
      Vec3 n;
      for (const Obstacle& o : params.obstacles)
        if (resting_contact_normal(o, params.contact_offset, tolerance, V.x[v], n)) {
          s.resting.push_back({v, s.free_index[v], n, o.friction});
          break;
        }
    }
  }
}

// values ← S A S + c n nᵀ per resting row (c its diagonal's scale, so the pivots stay of one size), rhs ←
// S rhs: the solution has no velocity into the obstacle. A and rhs are kept for the reactions.
void filter_resting(std::vector<Mat3>& values, ImplicitSolver& s) {
  ScopedTimer timer(s.stats.contact_ms);
  s.unfiltered_values = values;
  s.unfiltered_rhs = s.rhs;
  s.resting_of_row.assign(s.free_count, -1);
  for (size_t c = 0; c < s.resting.size(); ++c) s.resting_of_row[s.resting[c].row] = static_cast<int32_t>(c);
  // v = S y + z: the prescribed velocities z (along the normal; a sticking pair's along its triangle too)
  // move to the right-hand side, rhs −= A z.
  std::vector<Vec3>& prescribed = s.resting_prescribed;
  prescribed.resize(s.resting.size());
  for (size_t c = 0; c < s.resting.size(); ++c) prescribed[c] = s.resting[c].prescribed();
  for (size_t k = 0; k < s.block_key.size(); ++k) {
    if (!s.ldlt.key_read[k]) continue;
    const auto [i, j] = s.block_key[k];
    const int32_t a = s.resting_of_row[i], b = s.resting_of_row[j];
    if (b >= 0 && !prescribed[b].isZero(0)) s.rhs.segment<3>(3 * i) -= values[k] * prescribed[b];
    if (a >= 0 && i != j && !prescribed[a].isZero(0)) s.rhs.segment<3>(3 * j) -= values[k].transpose() * prescribed[a];
  }
  // S = I − n nᵀ sliding, 0 sticking; the pivots of the prescribed directions keep the block's scale.
  auto filter = [&](int32_t c) -> Mat3 {
    return s.resting[c].stick ? Mat3::Zero().eval() : (Mat3::Identity() - s.resting[c].normal * s.resting[c].normal.transpose()).eval();
  };
  for (size_t k = 0; k < s.block_key.size(); ++k) {
    if (!s.ldlt.key_read[k]) continue;
    const int32_t a = s.resting_of_row[s.block_key[k].first], b = s.resting_of_row[s.block_key[k].second];
    if (a < 0 && b < 0) continue;
    Mat3& block = values[k];
    const double scale = block.trace() / 3;
    if (a >= 0) block = filter(a) * block;
    if (b >= 0) block = block * filter(b);
    if (a >= 0 && a == b) block += scale * (Mat3::Identity() - filter(a));
  }
  for (size_t c = 0; c < s.resting.size(); ++c) {
    auto r = s.rhs.segment<3>(3 * s.resting[c].row);
    r = filter(static_cast<int32_t>(c)) * r;
    if (!s.resting[c].stick) r += s.resting[c].friction;
  }
}

// A sticker whose support's tangential impulse (from its last reactions) exceeds Coulomb's cap μ λ slides,
// its friction μ λ along that impulse, against the load it held. True when it did.
bool slide_if_overloaded(ImplicitSolver::RestingContact& c) {
  const double cap = c.mu * std::max(0.0, c.reaction);
  const Vec3 along = c.impulse - c.normal * c.reaction;
  const double load = along.norm();
  if (load <= cap) return false;
  c.stick = false;
  c.friction = (cap / load) * along;
  return true;
}

// Each constrained vertex's impulse A v⁺ − b (less its sliding friction), from the unfiltered system.
void resting_reactions(ImplicitSolver& s) {
  ScopedTimer timer(s.stats.contact_ms);
  std::vector<Vec3> residual(s.resting.size());
  for (size_t c = 0; c < s.resting.size(); ++c) residual[c] = -s.unfiltered_rhs.segment<3>(3 * s.resting[c].row);
  for (size_t k = 0; k < s.block_key.size(); ++k) {
    if (!s.ldlt.key_read[k]) continue;
    const auto [i, j] = s.block_key[k];
    const int32_t a = s.resting_of_row[i], b = s.resting_of_row[j];
    if (a >= 0) residual[a] += s.unfiltered_values[k] * s.solution.segment<3>(3 * j);
    if (b >= 0 && i != j) residual[b] += s.unfiltered_values[k].transpose() * s.solution.segment<3>(3 * i);
  }
  for (size_t c = 0; c < s.resting.size(); ++c) {
    ImplicitSolver::RestingContact& r = s.resting[c];
    r.impulse = residual[c] - (r.stick ? Vec3::Zero() : r.friction);
    r.reaction = r.normal.dot(r.impulse);
  }
}

// Assemble the matrix values (serial, triangle order: deterministic) and the coupling to held vertices,
// factorise, solve: vnext holds v⁺ of every vertex.
bool assemble_and_solve(const ImplicitParams& params, double kscale, const Vertices& V, const Triangles& T,
                        ImplicitSolver& s) {
  const int32_t nv = V.size();
  const int32_t nt = T.size();
  const double h = params.dt;
  std::vector<Vec3>& vnext = s.velocity_next;
  std::vector<Mat3>& values = s.block_values;
  {
    ScopedTimer timer(s.stats.assembly_ms);
    std::copy(s.base_values.begin(), s.base_values.end(), values.begin());
    s.rhs.setZero();
    for (int32_t v = 0; v < nv; ++v) {
      const int32_t i = s.free_index[v];
      if (i < 0) continue;
      s.rhs.segment<3>(3 * i) = V.mass[v] * V.v[v] + h * (V.force[v] + V.mass[v] * params.gravity);
    }
    // A spring k (anchor − x): its force on the right, its stiffness on the diagonal, like the membrane's.
    for (const ImplicitParams::Spring& spring : params.springs) {
      const int32_t i = spring.vertex >= 0 && spring.vertex < nv ? s.free_index[spring.vertex] : -1;
      if (i < 0) continue;
      s.rhs.segment<3>(3 * i) += h * spring.stiffness * (spring.anchor - V.x[spring.vertex]);
      values[s.diagonal_key[i]].diagonal().array() += kscale * spring.stiffness;
    }
    for (int32_t t = 0; t < nt; ++t)
      for (int k = 0; k < 6; ++k) {
        const int32_t dest = s.tri_dest[t][k];
        if (dest >= 0)
          values[dest] += s.tri_k[t][k];
        else if (dest < -1)
          values[-2 - dest] += s.tri_k[t][k].transpose();
      }
    for (const ImplicitSolver::HeldStiffness& c : s.stiffness_held) {
      const Mat3& kab = s.tri_k[c.triangle][c.pair];
      if (c.transpose)
        s.rhs.segment<3>(3 * c.row) -= kab.transpose() * vnext[c.held_vertex];
      else
        s.rhs.segment<3>(3 * c.row) -= kab * vnext[c.held_vertex];
    }
    for (const ImplicitSolver::HeldCoupling& c : s.bending_held)
      s.rhs.segment<3>(3 * c.row) -= c.weight * vnext[c.held_vertex];
    if (!s.resting.empty()) filter_resting(values, s);
  }

  {
    ScopedTimer timer(s.stats.factorization_ms);  // a refused factorisation returns from inside
    s.stats.factorizations += 1;
    if (!factorize_block_ldlt(values, params.run, s.ldlt)) {
      // The matrix is positive definite in exact arithmetic (lumped masses plus positive semidefinite
      // stiffness), so a refused pivot is rounding: a sliver's stiffness 10⁸ times its neighbours' puts the
      // condition near 1/ε. Rather than freeze the sheet for the substep, shift the diagonal by 10⁻¹⁴ of
      // its largest entry (then 10⁻¹², 10⁻¹⁰) and factorise again: extra inertia for that substep only,
      // comparable to a vertex's mass when a sliver makes the largest entry huge, negligible otherwise.
      double largest = 0;
      for (int32_t i = 0; i < s.free_count; ++i)
        largest = std::max(largest, values[s.diagonal_key[i]].diagonal().maxCoeff());
      bool factored = false;
      for (const double relative : {1e-14, 1e-12, 1e-10}) {
        for (int32_t i = 0; i < s.free_count; ++i)
          values[s.diagonal_key[i]].diagonal().array() += relative * largest;
        s.stats.factorizations += 1;
        if ((factored = factorize_block_ldlt(values, params.run, s.ldlt))) break;
      }
      if (!factored) {
        s.stats.failures += 1;
        return false;
      }
      s.stats.regularised += 1;
    }
  }
  {
    ScopedTimer timer(s.stats.solve_ms);
    solve_block_ldlt(s.ldlt, s.rhs.data(), s.solution.data(), params.run);
  }
  if (!s.solution.allFinite()) {
    s.stats.failures += 1;
    return false;
  }
  for (const ImplicitSolver::RestingContact& c : s.resting) {  // v = S y + z exactly
    auto y = s.solution.segment<3>(3 * c.row);
    if (c.stick) y.setZero();
    else y -= c.normal * c.normal.dot(y);
    y += c.prescribed();
  }
  for (int32_t v = 0; v < nv; ++v) {
    const int32_t i = s.free_index[v];
    if (i >= 0) vnext[v] = s.solution.segment<3>(3 * i);
  }
  return true;
}

// The linearised step may rotate triangles far enough that the true membrane energy at x⁺ exceeds what
// the step dissipated: then redo it with a stronger spin brake, kept for the next kBrakeSubsteps. (The
// filter keeps the check valid: a resting vertex's reaction is normal to its velocity, so it does no work.)
bool solve_with_energy_check(const ImplicitParams& params, const MembraneParams& mp, double kscale, int& brake,
                             Sheet& sheet, ImplicitSolver& s) {
  if (!assemble_and_solve(params, kscale, sheet.verts, sheet.tris, s)) return false;
  // A step with self-contact constraints is not braked: their vertices stop against a layer within the
  // step while their neighbours move on, an inelastic impact whose membrane energy the linearised model
  // misses by more than the step dissipates, and bracing every rotation against it (the spin brake) made a
  // folded sheet's fingers jump to their 15 N grip as its top layer landed (docs/physics.md, "Self-contact").
  const bool impact = std::any_of(s.resting.begin(), s.resting.end(),
                                  [](const ImplicitSolver::RestingContact& c) { return c.pair >= 0; });
  while (brake < kBrakeLevels - 1 && !impact && !energy_bounded(sheet, s, params, kscale, mp)) {
    brake += 1;
    s.stats.brakes += 1;
    s.brake = brake;
    s.braked_left = kBrakeSubsteps;
    triangle_forces_and_stiffness(params, mp, kscale, brake, false, sheet.verts, sheet.tris, s);
    if (!assemble_and_solve(params, kscale, sheet.verts, sheet.tris, s)) return false;
  }
  return true;
}

// A support that pulls is none: release those vertices; a free vertex whose step would enter an obstacle
// lands on it this substep (prescribed normal velocity −gap/h), so the membrane around it answers in the
// same solve rather than after a projection (projecting stiff paper after the solve stretched it: a sheet
// dropped over a box gained energy, 1.7 mJ at its impact, and never came to rest). Then solve again; a
// few rounds at most, what is left is caught by the pass after the solve. True when the set changed.
bool update_contacts(const ImplicitParams& params, const Vertices& V, ImplicitSolver& s) {
  const double h = params.dt;
  std::vector<Vec3>& vnext = s.velocity_next;
  ScopedTimer timer(s.stats.contact_ms);
  bool changed = false;
  if (!s.resting.empty()) {
    resting_reactions(s);
    const size_t before = s.resting.size();
    std::erase_if(s.resting, [](const ImplicitSolver::RestingContact& c) { return c.reaction < 0; });
    s.stats.releases += static_cast<int64_t>(before - s.resting.size());
    changed = s.resting.size() != before;
    // Coulomb, in the solve: a vertex sticks while the tangential impulse its support gives stays within
    // μ λ; one that slides gets the friction impulse μ λ against its motion (from the last solve). A slider
    // whose momentum along the surface, friction taken off, is within μ λ sticks.
    for (ImplicitSolver::RestingContact& c : s.resting) {
      if (c.stick) {
        changed = slide_if_overloaded(c) || changed;
        continue;
      }
      const double cap = c.mu * c.reaction;
      const Vec3 v = vnext[c.vertex] - c.carried;  // relative to the surface
      const Vec3 momentum = V.mass[c.vertex] * (1 + h * s.alpha) * (v - c.normal * c.normal.dot(v)) - c.friction;
      if (momentum.norm() <= cap) {
        c.stick = true;
        c.friction.setZero();
        changed = true;
        continue;
      }
      const Vec3 friction = (-cap / momentum.norm()) * momentum;
      if ((friction - c.friction).norm() > 0.1 * cap) changed = true;
      c.friction = friction;
    }
  }
  return changed;
}

// Coulomb's cap on a sticker. The rounds of update_contacts let a sticker slide only when its support
// exceeds μ λ in the solve before, and a sheet pushed along a table loads its stickers ring by ring, one
// ring a solve: after four rounds the stickers beyond the fourth ring held what the fingers pushed (an A6
// sheet dragged along a table by one finger held 15 N, its weight's friction being 5 mN). So the step ends
// with rounds that only release: every sticker whose support's tangential impulse exceeds μ λ (reactions
// of the last solve) slides, its friction μ λ against the load it held, and the step is solved again.
// Only releasing, they end (at most kFrictionRounds). True when one was released.
bool release_overloaded_stickers(ImplicitSolver& s) {
  if (s.resting.empty()) return false;
  resting_reactions(s);
  bool released = false;
  for (ImplicitSolver::RestingContact& c : s.resting)
    if (c.stick && slide_if_overloaded(c)) {
      released = true;
      s.stats.friction_releases += 1;
    }
  return released;
}

// ImplicitSolver::constrained from `resting`, for nv vertices.
void mark_constrained(int32_t nv, ImplicitSolver& s) {
  s.constrained.assign(nv, 0);
  for (const ImplicitSolver::RestingContact& c : s.resting) s.constrained[c.vertex] = 1;
}

// Free vertices not otherwise constrained whose step would enter an obstacle land on it (above). After the
// self-contact pairs, which come first: a layer lying on another on a table lands on that layer.
bool obstacle_arrivals(const ImplicitParams& params, const Vertices& V, ImplicitSolver& s) {
  const int32_t nv = V.size();
  const double h = params.dt;
  const std::vector<Vec3>& vnext = s.velocity_next;
  ScopedTimer timer(s.stats.contact_ms);
  bool changed = false;
  mark_constrained(nv, s);
  for (int32_t v = 0; v < nv; ++v) {
    if (s.free_index[v] < 0 || s.constrained[v]) continue;
    Vec3 n, on;
    double friction = 0;
    if (!entered_surface(params.obstacles, params.contact_offset, V.x[v], V.x[v] + h * vnext[v], n, on, friction))
      continue;
    s.resting.push_back({v, s.free_index[v], n, friction, -n.dot(V.x[v] - on) / h});
    s.stats.arrivals += 1;
    changed = true;
  }
  return changed;
}

// Self-contact in the solve. A pair may close to its goal over the substep: the vertex's distance at the
// start plus a tenth of what it lacks of the gap (Bridson et al. 2002's repulsion, which opens a pair that
// is too close gently rather than at once), or the gap for a pair arriving from farther. A free vertex not
// otherwise constrained whose step, with the velocities `v`, would bring it nearer its triangle than that
// is constrained to arrive there: its velocity along the normal is the triangle point's plus what closes the
// distance to the goal. Existing pair constraints take the triangle's new velocity (the pairs' two sides
// are solved in turn, round by round). True when the set changed.
double self_pair_goal(const ProximityPair& q, double gap) {
  return q.distance < gap ? q.distance + 0.1 * (gap - q.distance) : gap;
}

// The velocity of the pair's triangle corner i; a corner resting on an obstacle moves as its constraint
// prescribes (the solve that gave `v` may have had it sinking, before it arrived).
Vec3 pair_corner_velocity(const ProximityPair& q, int i, const std::vector<Vec3>& v, const ImplicitSolver& s) {
  Vec3 vi = v[q.triangle[i]];
  const int32_t c = s.obstacle_of_vertex.empty() ? -1 : s.obstacle_of_vertex[q.triangle[i]];
  if (c >= 0) vi += s.resting[c].normal * (s.resting[c].target - s.resting[c].normal.dot(vi));
  return vi;
}

// The triangle's velocity along the pair's normal at its nearest point.
double triangle_normal_velocity(const ProximityPair& q, const std::vector<Vec3>& v, const ImplicitSolver& s) {
  double vn = 0;
  for (int i = 0; i < 3; ++i) vn += q.weights[i] * q.normal.dot(pair_corner_velocity(q, i, v, s));
  return vn;
}

// The velocity of the triangle's point nearest the pair's vertex.
Vec3 triangle_point_velocity(const ProximityPair& q, const std::vector<Vec3>& v, const ImplicitSolver& s) {
  Vec3 point = Vec3::Zero();
  for (int i = 0; i < 3; ++i) point += q.weights[i] * pair_corner_velocity(q, i, v, s);
  return point;
}

bool update_self_contacts(const ImplicitParams& params, const Vertices& V, const std::vector<Vec3>& v, ImplicitSolver& s) {
  if (!params.self_pairs || params.self_pairs->empty()) return false;
  ScopedTimer timer(s.stats.contact_ms);
  const std::vector<ProximityPair>& pairs = *params.self_pairs;
  const double h = params.dt;
  s.obstacle_of_vertex.assign(v.size(), -1);
  for (size_t c = 0; c < s.resting.size(); ++c)
    if (s.resting[c].pair < 0) s.obstacle_of_vertex[s.resting[c].vertex] = static_cast<int32_t>(c);
  // The vertex's normal velocity that brings pair q to `goal` over the step, the triangle moving at vt.
  auto target_of = [&](const ProximityPair& q, double vt, double goal) { return vt + (goal - q.distance) / h; };
  for (ImplicitSolver::RestingContact& c : s.resting) {
    if (c.pair < 0) continue;
    const ProximityPair& q = pairs[c.pair];
    c.target = target_of(q, triangle_normal_velocity(q, v, s), self_pair_goal(q, params.self_gap));
    c.carried = triangle_point_velocity(q, v, s);
  }
  mark_constrained(static_cast<int32_t>(v.size()), s);
  bool changed = false;
  for (size_t k = 0; k < pairs.size(); ++k) {
    const ProximityPair& q = pairs[k];
    if (s.free_index[q.vertex] < 0 || s.constrained[q.vertex]) continue;
    const double goal = self_pair_goal(q, params.self_gap);
    const double vt = triangle_normal_velocity(q, v, s), vn = q.normal.dot(v[q.vertex]);
    if (q.distance + h * (vn - vt) >= goal) continue;  // the step keeps it at or beyond its goal
    const double target = target_of(q, vt, goal);
    // An obstacle wins: a pair that would push its vertex into one (a layer's vertex under another, on a
    // table) is left to the pass after the solve.
    const Vec3 to = V.x[q.vertex] + h * (v[q.vertex] + (target - vn) * q.normal);
    Vec3 n_o, on;
    double mu_o = 0;
    if (!params.obstacles.empty() && entered_surface(params.obstacles, params.contact_offset, V.x[q.vertex], to, n_o, on, mu_o))
      continue;
    ImplicitSolver::RestingContact c{q.vertex, s.free_index[q.vertex], q.normal, params.self_friction, target};
    c.pair = static_cast<int32_t>(k);
    c.carried = triangle_point_velocity(q, v, s);
    s.resting.push_back(c);
    s.constrained[q.vertex] = 1;
    changed = true;
  }
  return changed;
}

// A sliding vertex whose friction impulse (taken from the motion of an earlier solve) now points along
// its motion is pushed by it, and friction never does positive work: such vertices stick instead. True
// when one did (the step is to be solved again). Without it a landing piece's vertex, whose friction cap
// μ λ carries the normal impulse that stops much of the piece, was pushed by hundreds of times its own
// momentum and the membrane flung the piece along the floor (27–31 m/s, 0.6 → 62 mJ in one substep).
bool friction_pushes(ImplicitSolver& s) {
  bool changed = false;
  for (ImplicitSolver::RestingContact& c : s.resting) {
    if (c.stick) continue;
    const Vec3 v = s.velocity_next[c.vertex] - c.carried;
    if (c.friction.dot(v - c.normal * c.normal.dot(v)) > 0) {
      c.stick = true;
      c.friction.setZero();
      changed = true;
    }
  }
  return changed;
}

}  // namespace

namespace {

bool step_once(const ImplicitParams& params, const std::vector<int32_t>& held,
               const std::vector<Vec3>& held_target, ImplicitSolverPtr& solver, Sheet& sheet) {
  Vertices& V = sheet.verts;
  Triangles& T = sheet.tris;
  const int32_t nv = V.size();
  std::vector<int32_t> held_sorted = held;
  std::sort(held_sorted.begin(), held_sorted.end());
  held_sorted.erase(std::unique(held_sorted.begin(), held_sorted.end()), held_sorted.end());
  if (!solver) solver.reset(new ImplicitSolver);
  ImplicitSolver& s = *solver;
  if (!s.analysed || s.version != sheet.topology_version || s.held != held_sorted ||
      !(s.material == key_of(sheet.material)) || s.alpha != params.mass_damping || s.beta != params.stiffness_damping) {
    const double analysis_before = s.stats.analysis_ms;
    {
      ScopedTimer timer(s.stats.structure_ms);
      build_structure(sheet, params, held_sorted, s);
    }
    s.stats.structure_ms -= s.stats.analysis_ms - analysis_before;  // the analysis has its own total
  } else if (s.dt != params.dt) {
    // Only the step changed (a split substep's halves, and back): the pattern, its analysis and the
    // assembly plan stay; the blocks that scale with h are formed again, as a rebuild would form them.
    ScopedTimer timer(s.stats.structure_ms);
    s.dt = params.dt;
    add_constant_blocks(V, params, s);
  }

  const double h = params.dt;
  const double kscale = h * h + h * s.beta;
  const MembraneParams mp = membrane_params(sheet.material);

  // Prescribed velocities of held vertices.
  std::vector<Vec3>& vnext = s.velocity_next;
  vnext.assign(nv, Vec3::Zero());
  for (size_t k = 0; k < held.size(); ++k) vnext[held[k]] = (held_target[k] - V.x[held[k]]) / h;

  int brake = 0;
  if (s.braked_left > 0) {
    brake = s.brake;
    s.braked_left -= 1;
  }
  triangle_forces_and_stiffness(params, mp, kscale, brake, true, V, T, s);

  // Forces on vertices in a fixed order (no atomics), then bending.
  gather_corner_forces(sheet.topo, T.tri, T.corner_force, 0, nv, V.force);
  add_bending_forces(V.x, s.stencils, V.force);

  find_resting_contacts(params, V, s);
  const bool self_pairs = params.self_pairs && !params.self_pairs->empty();
  if (self_pairs) update_self_contacts(params, V, V.v, s);  // the first solve's guess: the velocities at the start

  if (!solve_with_energy_check(params, mp, kscale, brake, sheet, s)) return false;
  for (int round = 0; round < 4 && (!params.obstacles.empty() || self_pairs); ++round) {
    bool changed = update_contacts(params, V, s);
    if (self_pairs) changed = update_self_contacts(params, V, vnext, s) || changed;
    if (!params.obstacles.empty()) changed = obstacle_arrivals(params, V, s) || changed;
    if (!changed) break;
    if (!solve_with_energy_check(params, mp, kscale, brake, sheet, s)) return false;
  }
  // A fast layer's last solve may bring pairs near that the rounds above did not hold: they are added,
  // round after round, until none is. Only adding, these rounds end (at most kSelfPairRounds); rounds that
  // also release and re-arrive ran on without end on a sheet resting on a table, with two to three times its solves. With
  // them u-twist-pull with self-contact makes its one tear, not two, and stretches 3.1% instead of 7.2%.
  for (int round = 0; self_pairs && round < kSelfPairRounds && update_self_contacts(params, V, vnext, s); ++round)
    if (!solve_with_energy_check(params, mp, kscale, brake, sheet, s)) return false;
  // The rounds end with friction taken from the motion of the solve before the last: where that friction
  // now pushes, the vertex sticks and the step is solved once more.
  // Only with obstacles: a sheet whose only contacts are its own pairs, given these checks too, blew up
  // (torn-in-two with self-contact, 1 mesh of 4: a vertex 10⁶ m away by frame 41), so there a sticking
  // pair is held to its cap by the update rounds alone (docs/physics.md, "Self-contact", Known gaps).
  if (!params.obstacles.empty() && friction_pushes(s))
    if (!solve_with_energy_check(params, mp, kscale, brake, sheet, s)) return false;
  bool reactions_current = false;  // the last release check read the last solve's reactions
  for (int round = 0; !params.obstacles.empty() && round < kFrictionRounds; ++round) {
    if (!release_overloaded_stickers(s)) {
      reactions_current = true;
      break;
    }
    if (!solve_with_energy_check(params, mp, kscale, brake, sheet, s)) return false;
  }
  if (!s.resting.empty() && !reactions_current) resting_reactions(s);
  s.stats.resting_contacts += static_cast<int64_t>(s.resting.size());
  // Obstacles after the solve (systems/physics/contact.hpp): free vertices only, a finger wins over a table.
  // Without obstacles the step is bit for bit what it was.
  if (params.obstacles.empty()) {
    for (int32_t v = 0; v < nv; ++v) {
      V.v[v] = vnext[v];
      V.x[v] += h * vnext[v];
    }
  } else {
    ScopedTimer timer(s.stats.contact_ms);
    const ContactParams contact{params.contact_offset, h};
    for (int32_t v = 0; v < nv; ++v) {
      const Vec3 start = V.x[v];
      V.v[v] = vnext[v];
      V.x[v] += h * vnext[v];
      if (s.free_index[v] >= 0 && resolve_vertex_contact(params.obstacles, contact, start, V.x[v], V.v[v]))
        s.stats.contacts += 1;
    }
    // A vertex that landed this substep stops there (inelastic): its velocity into the surface is spent.
    for (const ImplicitSolver::RestingContact& c : s.resting)
      if (c.target != 0 && c.pair < 0) V.v[c.vertex] -= c.normal * std::min(0.0, c.normal.dot(V.v[c.vertex]));
  }
  for (size_t k = 0; k < held.size(); ++k) V.x[held[k]] = held_target[k];  // exact, no rounding drift
  return true;
}

// Whether some triangle ended the step stretched past the strain limit by more than `jump` beyond both the
// limit and its strain at the step's start (`x_start`).
bool strain_jumped(const ImplicitParams& params, const std::vector<Vec3>& x_start, const Sheet& sheet,
                   std::vector<uint8_t>& jumped) {
  const Triangles& T = sheet.tris;
  const double limit = sheet.material.strain_limit, jump = params.split_strain_jump;
  jumped.assign(T.size(), 0);  // per triangle, written by its range; reduced serially
  params.run(T.size(), params.grain, [&](int32_t b, int32_t e) {
    for (int32_t t = b; t < e; ++t) {
      const double after = max_principal_strain(sheet.verts.x, T.tri, T.rest_inv, t, t + 1);
      if (after <= limit + jump) continue;
      const double before = max_principal_strain(x_start, T.tri, T.rest_inv, t, t + 1);
      jumped[t] = after > std::max(limit, before) + jump;
    }
  });
  return std::find(jumped.begin(), jumped.end(), 1) != jumped.end();
}

bool split_substep(const ImplicitParams& params, const std::vector<int32_t>& held,
                   const std::vector<Vec3>& held_target, int32_t splits_left, ImplicitSolverPtr& solver,
                   Sheet& sheet) {
  if (splits_left <= 0 || !(params.split_strain_jump > 0)) return step_once(params, held, held_target, solver, sheet);
  Vertices& V = sheet.verts;
  if (!solver) solver.reset(new ImplicitSolver);
  std::vector<ImplicitSolver::SplitStart>& starts = solver->split_starts;
  if (starts.size() < static_cast<size_t>(splits_left)) starts.resize(splits_left);
  ImplicitSolver::SplitStart& start = starts[splits_left - 1];
  start.x = V.x;
  start.v = V.v;
  if (!step_once(params, held, held_target, solver, sheet)) return false;
  if (!strain_jumped(params, start.x, sheet, solver->strain_jumps)) return true;
  // Redo as two halves; the substep's forces stay those of the state it started from (the fingers'
  // reactions during it), which the whole step just computed.
  solver->stats.splits += 1;
  start.force = V.force;
  start.corner_force = sheet.tris.corner_force;
  V.x = start.x;
  V.v = start.v;
  ImplicitParams half = params;
  half.dt = 0.5 * params.dt;
  start.half_target.resize(held.size());
  for (size_t k = 0; k < held.size(); ++k) start.half_target[k] = 0.5 * (start.x[held[k]] + held_target[k]);
  // The halves use the slots below this one (`starts` does not grow in them: `start` stays valid).
  const bool stepped = split_substep(half, held, start.half_target, splits_left - 1, solver, sheet) &&
                       split_substep(half, held, held_target, splits_left - 1, solver, sheet);
  if (!stepped) {
    V.x = start.x;
    V.v = start.v;
  }
  V.force = start.force;
  sheet.tris.corner_force = start.corner_force;
  return stepped;
}

}  // namespace

bool implicit_substep(const ImplicitParams& params, const std::vector<int32_t>& held,
                      const std::vector<Vec3>& held_target, ImplicitSolverPtr& solver, Sheet& sheet) {
  return split_substep(params, held, held_target, params.max_splits, solver, sheet);
}

}  // namespace pt
