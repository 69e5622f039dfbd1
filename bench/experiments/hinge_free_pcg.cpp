// Experiment (bench/results/2026-11-22-8-notes.txt §8; not built by CMake): conjugate
// gradients on the implicit integrator's matrix of the A4 bench scene, preconditioned by the factor of the
// same matrix without the bending couplings between a hinge's two opposite vertices (the only blocks outside
// the triangle graph, and the cause of most of the factorisation's fill). It includes the integrator's
// source to read its assembled matrix. From the repository root, after `make build`:
//   g++ -O2 -std=c++20 -ffp-contract=off -DPT_HAVE_AVX2_KERNELS=1 -I. -I/usr/include/eigen3 \
//     bench/experiments/hinge_free_pcg.cpp $(ls build/libpt_*.a | grep -v integrate) build/libpt_integrate.a \
//     build/libpapertear.a $(ls build/libpt_*.a) -ltbb -lpng -lgmp -lmpfr -o /tmp/hinge_free_pcg
//   /tmp/hinge_free_pcg [triangles = 10000] [dt = 1/30] [1: compensate the dropped blocks on the diagonal, 0: not]
#include "systems/integrate_implicit.cpp"
#include "bench/bench_scenes.hpp"
#include "engine/sheet_builder.hpp"
#include <chrono>
#include <cstdio>
#include <set>
#include <map>
using namespace pt;
int main(int argc, char** argv) {
  const int tris = argc > 1 ? atoi(argv[1]) : 10000;
  const double dt = argc > 2 ? atof(argv[2]) : 1.0 / 30;
  const int mode = argc > 3 ? atoi(argv[3]) : 1;  // 1: compensate on the diagonal, 0: just drop
  Sheet sheet = build_sheet(bench::a4_scene(tris));
  ImplicitParams p; p.dt = dt;
  std::vector<int32_t> held; std::vector<Vec3> target;
  for (const Finger& f : sheet.fingers) { held.push_back(f.vertex); target.push_back(f.start); }
  ImplicitSolverPtr solver;
  for (int k = 0; k < 20; ++k) implicit_substep(p, held, target, solver, sheet);  // let it sag
  ImplicitSolver& s = *solver;
  // One more substep's matrix: rebuild what solve() assembles.
  implicit_substep(p, held, target, solver, sheet);
  const int32_t n = s.free_count;
  // Full symmetric matrix A from block_values (only the keys the factor reads hold values; mirror them).
  std::vector<std::pair<int32_t,int32_t>> keys = s.block_key;
  std::vector<Mat3> full(keys.size(), Mat3::Zero());
  std::map<std::pair<int32_t,int32_t>, int32_t> index;
  for (size_t b = 0; b < keys.size(); ++b) index[keys[b]] = b;
  for (size_t b = 0; b < keys.size(); ++b)
    if (s.ldlt.key_read[b]) {
      full[b] = s.block_values[b];
      if (keys[b].first != keys[b].second) full[index[{keys[b].second, keys[b].first}]] = s.block_values[b].transpose();
    }
  // Pairs sharing a triangle (free indices).
  std::set<std::pair<int32_t,int32_t>> tri_pairs;
  for (const Tri& t : sheet.tris.tri)
    for (int32_t a : t) for (int32_t b : t) {
      const int32_t i = s.free_index[a], j = s.free_index[b];
      if (i >= 0 && j >= 0) tri_pairs.insert({i, j});
    }
  std::vector<std::pair<int32_t,int32_t>> pkeys; std::vector<Mat3> pvals;
  std::vector<Mat3> diag_add(n, Mat3::Zero());
  int dropped = 0;
  for (size_t b = 0; b < keys.size(); ++b) {
    const auto [i, j] = keys[b];
    if (i != j && !tri_pairs.count({i, j})) {
      ++dropped;
      if (mode == 1) { const double c = full[b].norm() / std::sqrt(3.0); diag_add[i] += c * Mat3::Identity(); }
      continue;
    }
    pkeys.push_back(keys[b]); pvals.push_back(full[b]);
  }
  for (size_t b = 0; b < pkeys.size(); ++b) if (pkeys[b].first == pkeys[b].second) pvals[b] += diag_add[pkeys[b].first];
  std::vector<Eigen::Vector2d> xy(n);
  for (int32_t v = 0; v < sheet.verts.size(); ++v) if (s.free_index[v] >= 0) xy[s.free_index[v]] = sheet.verts.rest[v];
  BlockLdlt pf, af;
  auto t0 = std::chrono::steady_clock::now();
  analyze_block_ldlt(n, pkeys, BlockLdltParams{}, pf, xy);
  // values in the order the factor expects: every key (it reads only what it needs)
  bool ok = factorize_block_ldlt(pvals, run_serial, pf);
  auto t1 = std::chrono::steady_clock::now();
  analyze_block_ldlt(n, keys, BlockLdltParams{}, af, xy);
  bool ok2 = factorize_block_ldlt(full, run_serial, af);
  auto t2 = std::chrono::steady_clock::now();
  printf("n=%d keys=%zu dropped=%d  P factor ok=%d (%.1f ms incl. analysis, %lld updates)  A factor ok=%d (%.1f ms, %lld updates)\n", n, keys.size(), dropped, ok, 1e3*std::chrono::duration<double>(t1-t0).count(), (long long)pf.block_updates, ok2, 1e3*std::chrono::duration<double>(t2-t1).count(), (long long)af.block_updates);
  if (!ok) return 0;
  // A x product
  auto matvec = [&](const Eigen::VectorXd& x, Eigen::VectorXd& y) {
    y.setZero(3 * n);
    for (size_t b = 0; b < keys.size(); ++b) y.segment<3>(3 * keys[b].first) += full[b] * x.segment<3>(3 * keys[b].second);
  };
  Eigen::VectorXd rhs = s.rhs, exact(3 * n);
  solve_block_ldlt(af, rhs.data(), exact.data());
  Eigen::VectorXd x = Eigen::VectorXd::Zero(3 * n), r = rhs, z(3 * n), pvec, Ap(3 * n);
  solve_block_ldlt(pf, r.data(), z.data());
  pvec = z; double rz = r.dot(z);
  for (int it = 1; it <= 200; ++it) {
    matvec(pvec, Ap);
    const double alpha = rz / pvec.dot(Ap);
    x += alpha * pvec; r -= alpha * Ap;
    const double err = (x - exact).norm() / exact.norm(), res = r.norm() / rhs.norm();
    if (it <= 5 || it % 5 == 0 || err < 1e-10) printf("  it %d: rel. error %.3g, rel. residual %.3g\n", it, err, res);
    if (err < 1e-10) break;
    solve_block_ldlt(pf, r.data(), z.data());
    const double rz2 = r.dot(z);
    pvec = z + (rz2 / rz) * pvec; rz = rz2;
  }
}
