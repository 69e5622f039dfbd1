// Experiment (bench/results/2026-11-23-9-notes.txt; not built by CMake): can a substep of the 10 000-triangle A4 bench scene solve
// its system by conjugate gradients preconditioned with the factor of an earlier substep's matrix, instead
// of factoring its own? The scene's fingers move as in the benchmark (they pull apart and twist over 2 s),
// so the sheet swings and its corotated stiffness turns from substep to substep. For each lag L it factors
// the matrix of substep k, then runs PCG on substep k + L's matrix and right-hand side, against that
// substep's direct solution. It includes the integrator's source to read its assembled matrix.
// From the repository root, after `make build`:
//   g++ -O2 -std=c++20 -ffp-contract=off -DPT_HAVE_AVX2_KERNELS=1 -I. -I/usr/include/eigen3 \
//     bench/experiments/stale_factor_pcg.cpp $(ls build/libpt_*.a | grep -v integrate) build/libpt_integrate.a \
//     build/libpapertear.a $(ls build/libpt_*.a) -ltbb -lpng -lgmp -lmpfr -o /tmp/stale_factor_pcg
//   /tmp/stale_factor_pcg [triangles = 10000] [substeps per frame = 1] [first substep = 20]
#include "systems/integrate_implicit.cpp"
#include "bench/bench_scenes.hpp"
#include "engine/sheet_builder.hpp"
#include <chrono>
#include <cstdio>
#include <map>
using namespace pt;

namespace {

struct Snapshot {
  std::vector<std::pair<int32_t, int32_t>> keys;
  std::vector<Mat3> full;  // every key's block (the factor reads one of each symmetric pair; mirrored here)
  Eigen::VectorXd rhs;
};

Snapshot snapshot(const ImplicitSolver& s) {
  Snapshot out;
  out.keys = s.block_key;
  out.full.assign(s.block_key.size(), Mat3::Zero());
  std::map<std::pair<int32_t, int32_t>, int32_t> index;
  for (size_t b = 0; b < s.block_key.size(); ++b) index[s.block_key[b]] = static_cast<int32_t>(b);
  for (size_t b = 0; b < s.block_key.size(); ++b)
    if (s.ldlt.key_read[b]) {
      out.full[b] = s.block_values[b];
      const auto [i, j] = s.block_key[b];
      if (i != j) out.full[index[{j, i}]] = s.block_values[b].transpose();
    }
  out.rhs = s.rhs;
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  const int tris = argc > 1 ? atoi(argv[1]) : 10000;
  const int substeps = argc > 2 ? atoi(argv[2]) : 1;
  const int first = argc > 3 ? atoi(argv[3]) : 20;
  Sheet sheet = build_sheet(bench::a4_scene(tris));
  ImplicitParams p;
  p.dt = 1.0 / 30 / substeps;
  std::vector<int32_t> held;
  for (const Finger& f : sheet.fingers) held.push_back(f.vertex);
  auto targets = [&](double t) {
    std::vector<Vec3> target;
    for (const Finger& f : sheet.fingers) {
      const FingerKey& a = f.keys.front();
      const FingerKey& b = f.keys.back();
      const double s = b.t > a.t ? std::clamp((t - a.t) / (b.t - a.t), 0.0, 1.0) : 1.0;
      target.push_back(a.position + s * (b.position - a.position));
    }
    return target;
  };
  ImplicitSolverPtr solver;
  int step = 0;
  auto advance = [&] {
    ++step;
    implicit_substep(p, held, targets(step * p.dt), solver, sheet);
  };
  while (step < first) advance();
  const Snapshot base = snapshot(*solver);
  const int32_t n = solver->free_count;
  std::vector<Eigen::Vector2d> xy(n);
  for (int32_t v = 0; v < sheet.verts.size(); ++v)
    if (solver->free_index[v] >= 0) xy[solver->free_index[v]] = sheet.verts.rest[v];
  BlockLdlt pf;
  analyze_block_ldlt(n, base.keys, BlockLdltParams{}, pf, xy);
  if (!factorize_block_ldlt(base.full, run_serial, pf)) return 1;
  printf("n = %d free vertices, dt = %.4g s, preconditioner: the matrix of substep %d\n", n, p.dt, first);
  for (int lag : {1, 2, 4, 8}) {
    while (step < first + lag) advance();
    const Snapshot now = snapshot(*solver);
    if (now.keys != base.keys) {
      printf("lag %d: the structure changed\n", lag);
      break;
    }
    auto matvec = [&](const Eigen::VectorXd& x, Eigen::VectorXd& y) {
      y.setZero(3 * n);
      for (size_t b = 0; b < now.keys.size(); ++b)
        y.segment<3>(3 * now.keys[b].first) += now.full[b] * x.segment<3>(3 * now.keys[b].second);
    };
    BlockLdlt af;
    analyze_block_ldlt(n, now.keys, BlockLdltParams{}, af, xy);
    factorize_block_ldlt(now.full, run_serial, af);
    Eigen::VectorXd exact(3 * n);
    solve_block_ldlt(af, now.rhs.data(), exact.data());
    // The error a direct solve itself leaves: the reference for "converged".
    Eigen::VectorXd check(3 * n);
    matvec(exact, check);
    printf("lag %d: direct solve's relative residual %.3g\n", lag, (check - now.rhs).norm() / now.rhs.norm());
    Eigen::VectorXd x = Eigen::VectorXd::Zero(3 * n), r = now.rhs, z(3 * n), d, Ad(3 * n);
    solve_block_ldlt(pf, r.data(), z.data());
    d = z;
    double rz = r.dot(z);
    for (int it = 1; it <= 60; ++it) {
      matvec(d, Ad);
      const double alpha = rz / d.dot(Ad);
      x += alpha * d;
      r -= alpha * Ad;
      const double err = (x - exact).norm() / exact.norm(), res = r.norm() / now.rhs.norm();
      if (it <= 6 || it % 5 == 0 || err < 1e-12) printf("  it %d: relative error %.3g, relative residual %.3g\n", it, err, res);
      if (err < 1e-12) break;
      solve_block_ldlt(pf, r.data(), z.data());
      const double rz2 = r.dot(z);
      d = z + (rz2 / rz) * d;
      rz = rz2;
    }
  }
}
