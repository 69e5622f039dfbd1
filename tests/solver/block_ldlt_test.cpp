// The block sparse factorisation against an independent truth: Eigen's dense LLT of the same matrix
// assembled densely. Random SPD matrices on vertex graphs (grid + random long edges, isolated vertices,
// and sheet patterns of triangles and hinges), by both factors (columns, supernodal), the same structure
// refactored with new values, indefinite and non-finite matrices that must be refused, the nested
// dissection order, and bit-identical factors whatever the tasks, chunks and threads.
#include "systems/solver/block_ldlt.hpp"
#include "systems/solver/dense_kernels.hpp"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>

#include <algorithm>
#include <cstdlib>
#include <limits>
#include <array>
#include <map>
#include <random>
#include <thread>
#include <string>
#include <tuple>

using namespace pt;

namespace {

// ctest runs this suite again with PAPERTEAR_DENSE_KERNELS=baseline and =avx2 (tests/CMakeLists.txt); the
// library reads no environment, so the suite passes the choice on before any test runs, as the command line
// does.
[[maybe_unused]] const bool kKernelsFromEnvironment = [] {
  DenseKernelChoice choice;
  if (dense_kernel_choice_from_name(std::getenv("PAPERTEAR_DENSE_KERNELS"), choice)) select_dense_kernels(choice);
  return true;
}();

using Keys = std::vector<std::pair<int32_t, int32_t>>;

// Full symmetric block pattern of a w×h grid graph with `extra` random long-range edges and one
// isolated vertex at the end (diagonal only).
Keys grid_pattern(int32_t w, int32_t h, int32_t extra, std::mt19937& rng) {
  const int32_t n = w * h + 1;
  Keys keys;
  auto edge = [&](int32_t a, int32_t b) {
    keys.emplace_back(a, b);
    keys.emplace_back(b, a);
  };
  for (int32_t i = 0; i < n; ++i) keys.emplace_back(i, i);
  for (int32_t y = 0; y < h; ++y)
    for (int32_t x = 0; x < w; ++x) {
      const int32_t v = y * w + x;
      if (x + 1 < w) edge(v, v + 1);
      if (y + 1 < h) edge(v, v + w);
      if (x + 1 < w && y + 1 < h) edge(v, v + w + 1);
    }
  std::uniform_int_distribution<int32_t> pick(0, w * h - 1);
  for (int32_t e = 0; e < extra; ++e) {
    const int32_t a = pick(rng), b = pick(rng);
    if (a != b) edge(a, b);
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  return keys;
}

// The integrator's pattern on a w×h grid of vertices cut into triangles by diagonals: a block per pair
// of vertices sharing a triangle or a hinge (the two vertices opposite an interior edge).
Keys sheet_pattern(int32_t w, int32_t h) {
  std::vector<std::array<int32_t, 3>> tris;
  for (int32_t y = 0; y + 1 < h; ++y)
    for (int32_t x = 0; x + 1 < w; ++x) {
      const int32_t v = y * w + x;
      tris.push_back({v, v + 1, v + w + 1});
      tris.push_back({v, v + w + 1, v + w});
    }
  Keys keys;
  std::map<std::pair<int32_t, int32_t>, std::vector<int32_t>> opposite;  // edge → opposite vertices
  for (const auto& t : tris)
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) keys.emplace_back(t[a], t[b]);
      const int32_t p = t[a], q = t[(a + 1) % 3];
      opposite[{std::min(p, q), std::max(p, q)}].push_back(t[(a + 2) % 3]);
    }
  for (const auto& [edge, across] : opposite)
    if (across.size() == 2) {
      keys.emplace_back(across[0], across[1]);
      keys.emplace_back(across[1], across[0]);
    }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  return keys;
}

// The pattern coordinates of sheet_pattern's vertices (the nested dissection reads them).
std::vector<Eigen::Vector2d> grid_coordinates(int32_t w, int32_t h) {
  std::vector<Eigen::Vector2d> xy(w * h);
  for (int32_t v = 0; v < w * h; ++v) xy[v] = Eigen::Vector2d(v % w, v / w);
  return xy;
}

// Random symmetric values, made SPD by diagonal dominance of `margin` (or indefinite when negative).
std::vector<Mat3> random_values(const Keys& keys, int32_t n, double margin, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Mat3> values(keys.size(), Mat3::Zero());
  std::vector<double> row_sum(n, 0.0);
  for (size_t b = 0; b < keys.size(); ++b) {
    const auto [r, c] = keys[b];
    if (r >= c) continue;
    Mat3 m;
    for (int i = 0; i < 9; ++i) m(i) = u(rng);
    values[b] = m;
    const auto other = std::lower_bound(keys.begin(), keys.end(), std::make_pair(c, r)) - keys.begin();
    values[other] = m.transpose();
    row_sum[r] += m.cwiseAbs().rowwise().sum().maxCoeff() + m.cwiseAbs().colwise().sum().maxCoeff();
    row_sum[c] += m.cwiseAbs().rowwise().sum().maxCoeff() + m.cwiseAbs().colwise().sum().maxCoeff();
  }
  for (size_t b = 0; b < keys.size(); ++b) {
    const auto [r, c] = keys[b];
    if (r != c) continue;
    Mat3 m;
    for (int i = 0; i < 9; ++i) m(i) = 0.1 * u(rng);
    values[b] = 0.5 * (m + m.transpose()) + Mat3::Identity() * (row_sum[r] + margin);
  }
  return values;
}

Eigen::MatrixXd dense(const Keys& keys, const std::vector<Mat3>& values, int32_t n) {
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (size_t b = 0; b < keys.size(); ++b) a.block<3, 3>(3 * keys[b].first, 3 * keys[b].second) = values[b];
  return a;
}

// A x block by block, for matrices too large to hold densely.
Eigen::VectorXd multiply(const Keys& keys, const std::vector<Mat3>& values, const Eigen::VectorXd& x) {
  Eigen::VectorXd y = Eigen::VectorXd::Zero(x.size());
  for (size_t b = 0; b < keys.size(); ++b)
    y.segment<3>(3 * keys[b].first) += values[b] * x.segment<3>(3 * keys[b].second);
  return y;
}

// Runs every task on its own real thread, started in reverse order: a task split whose result depended on
// the order or the interleaving would show it.
const RangeRunner reversed_threads = [](int32_t count, int32_t, const RangeTask& task) {
  std::vector<std::thread> threads;
  for (int32_t t = count - 1; t >= 0; --t) threads.emplace_back([&task, t] { task(t, t + 1); });
  for (std::thread& th : threads) th.join();
};

// ‖A x − b‖ / ‖b‖ for x = the factor's solution of a random b: the check every factorisation test ends with.
double solve_residual(const BlockLdlt& ldlt, const Keys& keys, const std::vector<Mat3>& values, int32_t n) {
  const Eigen::VectorXd b = Eigen::VectorXd::Random(3 * n);
  Eigen::VectorXd x(3 * n);
  solve_block_ldlt(ldlt, b.data(), x.data());
  return (multiply(keys, values, x) - b).norm() / b.norm();
}

// Both factors: by columns (the default below 2 000 block rows) and supernodal (forced).
std::vector<std::pair<const char*, BlockLdltParams>> both_paths() {
  return {{"columns", BlockLdltParams{}}, {"supernodal", BlockLdltParams{.min_supernodal_blocks = 0}}};
}

// A sheet pattern big enough for real supernodes, row chunks (chunk work lowered) and a task split.
BlockLdltParams small_chunks(int32_t tasks) {
  return BlockLdltParams{.min_parallel_blocks = 100, .tasks = tasks, .min_supernodal_blocks = 0, .chunk_flops = 2e4};
}

}  // namespace

TEST(BlockLdlt, SolvesLikeADenseCholesky) {
  std::mt19937 rng(7);
  const auto sizes = {std::tuple{1, 1, 0}, std::tuple{4, 3, 2}, std::tuple{12, 9, 6}, std::tuple{30, 20, 15}};
  for (const auto& [path, params] : both_paths())
  for (const auto& [w, h, extra] : sizes) {
    SCOPED_TRACE(path);
    const int32_t n = w * h + 1;
    const Keys keys = grid_pattern(w, h, extra, rng);
    BlockLdlt ldlt;
    analyze_block_ldlt(n, keys, params, ldlt);
    const std::vector<Mat3> values = random_values(keys, n, 0.5, rng);
    ASSERT_TRUE(factorize_block_ldlt(values, run_serial, ldlt));
    const Eigen::MatrixXd a = dense(keys, values, n);
    const Eigen::VectorXd b = Eigen::VectorXd::Random(3 * n);
    Eigen::VectorXd x(3 * n);
    solve_block_ldlt(ldlt, b.data(), x.data());
    const Eigen::VectorXd truth = a.llt().solve(b);
    EXPECT_LE((x - truth).norm(), 1e-11 * truth.norm()) << w << "x" << h;
    EXPECT_LE((a * x - b).norm(), 1e-11 * b.norm()) << w << "x" << h;
  }
}

TEST(BlockLdlt, RefactorsTheSameStructureWithNewValues) {
  std::mt19937 rng(11);
  const int32_t n = 8 * 8 + 1;
  const Keys keys = grid_pattern(8, 8, 4, rng);
  for (const auto& [path, params] : both_paths()) {
  SCOPED_TRACE(path);
  BlockLdlt ldlt;
  analyze_block_ldlt(n, keys, params, ldlt);
  for (int round = 0; round < 3; ++round) {
    const std::vector<Mat3> values = random_values(keys, n, 0.1 + round, rng);
    ASSERT_TRUE(factorize_block_ldlt(values, run_serial, ldlt));
    const Eigen::VectorXd b = Eigen::VectorXd::Random(3 * n);
    Eigen::VectorXd x = b;
    solve_block_ldlt(ldlt, x.data(), x.data());  // in place
    EXPECT_LE((dense(keys, values, n) * x - b).norm(), 1e-11 * b.norm()) << "round " << round;
  }
  }
}

TEST(BlockLdlt, RefusesAnIndefiniteMatrixAndRecovers) {
  std::mt19937 rng(3);
  const int32_t n = 5 * 5 + 1;
  const Keys keys = grid_pattern(5, 5, 0, rng);
  for (const auto& [path, params] : both_paths()) {
  SCOPED_TRACE(path);
  BlockLdlt ldlt;
  analyze_block_ldlt(n, keys, params, ldlt);
  std::vector<Mat3> values = random_values(keys, n, 0.5, rng);
  const auto diag = std::lower_bound(keys.begin(), keys.end(), std::make_pair(12, 12)) - keys.begin();
  const Mat3 kept = values[diag];
  values[diag](1, 1) = -100;  // one negative pivot direction
  EXPECT_FALSE(factorize_block_ldlt(values, run_serial, ldlt));
  values[diag](1, 1) = std::nan("");
  EXPECT_FALSE(factorize_block_ldlt(values, run_serial, ldlt));
  values[diag] = kept;  // the workspace is clean again after a refusal
  ASSERT_TRUE(factorize_block_ldlt(values, run_serial, ldlt));
  const Eigen::VectorXd b = Eigen::VectorXd::Random(3 * n);
  Eigen::VectorXd x(3 * n);
  solve_block_ldlt(ldlt, b.data(), x.data());
  EXPECT_LE((dense(keys, values, n) * x - b).norm(), 1e-11 * b.norm());
  }
}

TEST(BlockLdlt, MinimumDegreeOrderingKeepsGridFillNearNLogN) {
  // A 40x40 vertex grid: natural (banded) order fills ~n·w = 64 000 blocks; a fill-reducing order stays
  // well below that (nested-dissection bound ~ 31 n log2 n / 8 for grids is ~ 66 000, AMD does better).
  std::mt19937 rng(5);
  const int32_t w = 40, n = w * w + 1;
  const Keys keys = grid_pattern(w, w, 0, rng);
  BlockLdlt ldlt;
  analyze_block_ldlt(n, keys, BlockLdltParams{}, ldlt);
  EXPECT_LT(block_ldlt_fill(ldlt), 40000) << "fill " << block_ldlt_fill(ldlt);
  EXPECT_GT(block_ldlt_fill(ldlt), static_cast<int64_t>(keys.size() - n) / 2 - 1);  // at least A's own lower part
}

TEST(BlockLdlt, MinimumDegreeOrderIsEigensAmdOfThePattern) {
  // The analysis hands Eigen's minimum_degree_ordering the pattern by columns it builds itself; the
  // truth is the way AMDOrdering gets there (a SparseMatrix by setFromTriplets, summed with its transpose
  // inside). Same input, so the same order, on sheets, grids with long edges and an isolated vertex.
  std::mt19937 rng(21);
  std::vector<std::pair<int32_t, Keys>> patterns;
  for (const auto& [w, h] : {std::pair{12, 9}, std::pair{7, 15}, std::pair{30, 20}})
    patterns.emplace_back(w * h, sheet_pattern(w, h));
  patterns.emplace_back(20 * 20 + 1, grid_pattern(20, 20, 30, rng));
  for (const auto& [n, keys] : patterns) {
    std::vector<Eigen::Triplet<double>> entries;
    for (const auto& [r, c] : keys) entries.emplace_back(r, c, 1.0);
    Eigen::SparseMatrix<double> pattern(n, n);
    pattern.setFromTriplets(entries.begin(), entries.end());
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> inverse;
    Eigen::AMDOrdering<int>()(pattern, inverse);
    BlockLdlt ldlt;
    analyze_block_ldlt(n, keys, BlockLdltParams{}, ldlt);
    ASSERT_EQ(static_cast<int32_t>(ldlt.order.size()), n);
    for (int32_t k = 0; k < n; ++k) ASSERT_EQ(ldlt.order[k], inverse.indices()[k]) << "n " << n << ", position " << k;
  }
}

TEST(BlockLdlt, SubtreeTasksGiveTheBitIdenticalFactorInAnyOrder) {
  // Split into subtrees (threshold lowered so a 30x20 grid splits), run the tasks in reverse order and on
  // real threads: every column must come out bit-identical to the one-task factorisation.
  std::mt19937 rng(13);
  const int32_t n = 30 * 20 + 1;
  const Keys keys = grid_pattern(30, 20, 10, rng);
  const std::vector<Mat3> values = random_values(keys, n, 0.5, rng);
  BlockLdlt serial, split;
  analyze_block_ldlt(n, keys, BlockLdltParams{.min_parallel_blocks = 1 << 30, .tasks = 1}, serial);
  analyze_block_ldlt(n, keys, BlockLdltParams{.min_parallel_blocks = 100, .tasks = 6}, split);
  ASSERT_EQ(serial.task_start.size(), 2u);
  ASSERT_GT(split.task_start.size(), 3u) << "the tree was not split";
  EXPECT_LT(split.top_nodes.size(), split.task_nodes.size() / 4) << "the top chain is a separator, not the grid";
  ASSERT_TRUE(factorize_block_ldlt(values, run_serial, serial));
  for (int round = 0; round < 2; ++round) {
    ASSERT_TRUE(factorize_block_ldlt(values, reversed_threads, split));
    ASSERT_EQ(serial.columns.l_blocks.size(), split.columns.l_blocks.size());
    for (size_t p = 0; p < serial.columns.l_blocks.size(); ++p)
      ASSERT_EQ(serial.columns.l_blocks[p], split.columns.l_blocks[p]) << p;
    for (int32_t k = 0; k < n; ++k) ASSERT_EQ(serial.columns.c_inverse[k], split.columns.c_inverse[k]) << k;
  }
}

TEST(BlockLdlt, NestedDissectionIsAPermutationAndSolves) {
  // A 70x50 sheet pattern with its coordinates: two levels of dissection (leaf 1500) need fewer block
  // updates than AMD alone, so the dissection is the order kept; it must be a permutation and solve (by
  // the supernodal factor, the default at this size) like a dense Cholesky on a smaller grid does.
  std::mt19937 rng(17);
  const int32_t w = 70, h = 50, n = w * h;
  const Keys keys = sheet_pattern(w, h);
  const std::vector<Eigen::Vector2d> xy = grid_coordinates(w, h);
  BlockLdlt amd, nd;
  analyze_block_ldlt(n, keys, BlockLdltParams{}, amd);
  analyze_block_ldlt(n, keys, BlockLdltParams{}, nd, xy);
  EXPECT_LT(nd.block_updates, amd.block_updates) << "the dissection was not kept";
  std::vector<int32_t> sorted = nd.order;
  std::sort(sorted.begin(), sorted.end());
  for (int32_t k = 0; k < n; ++k) ASSERT_EQ(sorted[k], k);
  EXPECT_NE(nd.order, amd.order);
  EXPECT_TRUE(nd.supernodal);
  // The two candidate orderings computed on their own threads, the dissection started first: the same
  // analysis.
  BlockLdlt concurrent;
  analyze_block_ldlt(n, keys, BlockLdltParams{}, concurrent, xy, reversed_threads);
  EXPECT_EQ(concurrent.order, nd.order);
  EXPECT_EQ(concurrent.block_updates, nd.block_updates);
  EXPECT_EQ(concurrent.supernodes.super_start, nd.supernodes.super_start);
  EXPECT_EQ(concurrent.supernodes.super_row, nd.supernodes.super_row);
  const std::vector<Mat3> values = random_values(keys, n, 0.5, rng);
  ASSERT_TRUE(factorize_block_ldlt(values, run_serial, nd));
  EXPECT_LE(solve_residual(nd, keys, values, n), 1e-11);
}

TEST(BlockLdlt, SupernodalFactorSolvesLikeADenseCholesky) {
  // A 24x18 sheet pattern (432 vertices) ordered by nested dissection (forced from 200 blocks, leaf 64),
  // supernodal with row chunks and a task split, against Eigen's dense LLT of the same matrix.
  std::mt19937 rng(19);
  const int32_t w = 24, h = 18, n = w * h;
  const Keys keys = sheet_pattern(w, h);
  const std::vector<Eigen::Vector2d> xy = grid_coordinates(w, h);
  BlockLdltParams params = small_chunks(4);
  params.dissection_leaf = 64;
  BlockLdlt ldlt;
  analyze_block_ldlt(n, keys, params, ldlt, xy);
  const SupernodalFactor& sf = ldlt.supernodes;
  const int32_t supernodes = static_cast<int32_t>(sf.super_start.size()) - 1;
  int32_t widest = 0, chunked = 0;
  for (int32_t s = 0; s < supernodes; ++s) {
    widest = std::max(widest, sf.super_start[s + 1] - sf.super_start[s]);
    chunked += sf.chunk_first[s + 1] - sf.chunk_first[s] > 2;
  }
  EXPECT_GE(widest, 16) << "no real supernode";
  EXPECT_GT(chunked, 3) << "no supernode split into row chunks";
  EXPECT_GT(ldlt.task_start.size(), 3u) << "no task split";
  for (int round = 0; round < 2; ++round) {
    const std::vector<Mat3> values = random_values(keys, n, 0.1 + round, rng);
    ASSERT_TRUE(factorize_block_ldlt(values, run_serial, ldlt));
    const Eigen::MatrixXd a = dense(keys, values, n);
    const Eigen::VectorXd b = Eigen::VectorXd::Random(3 * n);
    Eigen::VectorXd x(3 * n);
    solve_block_ldlt(ldlt, b.data(), x.data());
    const Eigen::VectorXd truth = a.llt().solve(b);
    EXPECT_LE((x - truth).norm(), 1e-11 * truth.norm()) << "round " << round;
    EXPECT_LE((a * x - b).norm(), 1e-11 * b.norm()) << "round " << round;
  }
}

TEST(BlockLdlt, RelaxedSupernodesHoldAllOfLAndNoMoreZerosThanAllowed) {
  // The supernodes' panels against L's block pattern from a dense symbolic elimination (fill: i and k
  // both below j in column j are then coupled): every non-zero block of L is in its column's panel, and
  // each panel's explicit zeros are at most the share BlockLdltParams allows for its width (none at all
  // with a share of 0, fundamental supernodes). The factors of every setting solve the same system.
  std::mt19937 rng(41);
  const int32_t w = 24, h = 18, n = w * h;
  const Keys keys = sheet_pattern(w, h);
  const std::vector<Eigen::Vector2d> xy = grid_coordinates(w, h);
  const std::vector<Mat3> values = random_values(keys, n, 0.5, rng);
  const Eigen::VectorXd b = Eigen::VectorXd::Random(3 * n);
  const Eigen::VectorXd truth = dense(keys, values, n).llt().solve(b);
  struct Setting {
    double narrow, wide;
    int32_t width;
  };
  for (const Setting& setting : {Setting{0.0, 0.0, 16}, Setting{0.3, 0.1, 16}, Setting{0.8, 0.1, 32}}) {
    BlockLdltParams params = small_chunks(4);
    params.dissection_leaf = 64;
    params.relaxed_zeros_narrow = setting.narrow;
    params.relaxed_zeros = setting.wide;
    params.supernode_width = setting.width;
    BlockLdlt ldlt;
    analyze_block_ldlt(n, keys, params, ldlt, xy);
    ASSERT_TRUE(ldlt.supernodal);
    // L's pattern in factor order: below[j][i] for i > j.
    std::vector<int32_t> rank(n);
    for (int32_t k = 0; k < n; ++k) rank[ldlt.order[k]] = k;
    std::vector<std::vector<char>> below(n, std::vector<char>(n, 0));
    for (const auto& [r, c] : keys)
      if (rank[r] > rank[c]) below[rank[c]][rank[r]] = 1;
    for (int32_t j = 0; j < n; ++j)
      for (int32_t i = j + 1; i < n; ++i)
        if (below[j][i])
          for (int32_t k = i + 1; k < n; ++k)
            if (below[j][k]) below[i][k] = 1;
    const SupernodalFactor& sf = ldlt.supernodes;
    const int32_t supernodes = static_cast<int32_t>(sf.super_start.size()) - 1;
    int32_t widest = 0, relaxed = 0;
    for (int32_t s = 0; s < supernodes; ++s) {
      const int32_t first = sf.super_start[s], width = sf.super_start[s + 1] - first;
      const int32_t rows = sf.row_start[s + 1] - sf.row_start[s];
      std::vector<char> in_panel(n, 0);
      for (int32_t q = sf.row_start[s]; q < sf.row_start[s + 1]; ++q) in_panel[sf.super_row[q]] = 1;
      int64_t entries = 0, nonzeros = 0;
      for (int32_t c = 0; c < width; ++c) {
        const int32_t j = first + c;
        entries += rows - c;  // the panel's rows from j's diagonal down
        nonzeros += 1;
        for (int32_t i = j + 1; i < n; ++i) {
          if (!below[j][i]) continue;
          ++nonzeros;
          ASSERT_TRUE(in_panel[i]) << "L(" << i << ", " << j << ") is not in supernode " << s << "'s panel";
        }
      }
      const double zeros = static_cast<double>(entries - nonzeros) / static_cast<double>(entries);
      EXPECT_LE(zeros, width <= 4 ? setting.narrow : setting.wide) << "supernode " << s << ", width " << width;
      widest = std::max(widest, width);
      relaxed += entries > nonzeros;
    }
    EXPECT_LE(widest, setting.width);
    if (setting.narrow > 0) {
      EXPECT_GT(relaxed, 0) << "no relaxed supernode: the setting is not exercised";
    }
    ASSERT_TRUE(factorize_block_ldlt(values, run_serial, ldlt));
    Eigen::VectorXd x(3 * n);
    solve_block_ldlt(ldlt, b.data(), x.data());
    EXPECT_LE((x - truth).norm(), 1e-11 * truth.norm()) << "zeros " << setting.narrow << " / " << setting.wide;
  }
}

TEST(BlockLdlt, ReanalysisOfAnotherPatternKeepsTheSupernodalPanelsAndSolves) {
  // The panels' storage is kept from one analysis to the next (a cut re-analyses the sheet): a smaller
  // pattern after a bigger one, then a bigger one again, each factored (with a factor of the previous
  // pattern's values still in the storage) and solved.
  std::mt19937 rng(29);
  BlockLdltParams params = small_chunks(4);
  params.dissection_leaf = 64;
  BlockLdlt ldlt;
  for (const auto [w, h] : {std::array{24, 18}, std::array{15, 13}, std::array{26, 19}}) {
    const int32_t n = w * h;
    const Keys keys = sheet_pattern(w, h);
    analyze_block_ldlt(n, keys, params, ldlt, grid_coordinates(w, h));
    ASSERT_TRUE(ldlt.supernodal);
    const std::vector<Mat3> values = random_values(keys, n, 0.3, rng);
    ASSERT_TRUE(factorize_block_ldlt(values, run_serial, ldlt));
    EXPECT_LE(solve_residual(ldlt, keys, values, n), 1e-11) << w << "x" << h;
  }
}

TEST(BlockLdlt, SupernodalFactorRefusesPivotsAnywhereAndRecovers) {
  // A negative or NaN entry in a diagonal block low in the tree, then in the last separator (the top,
  // whose chunks run through the runner): refused each time, and the next good matrix factors again.
  std::mt19937 rng(23);
  const int32_t w = 24, h = 18, n = w * h;
  const Keys keys = sheet_pattern(w, h);
  BlockLdlt ldlt;
  analyze_block_ldlt(n, keys, small_chunks(4), ldlt);
  ASSERT_FALSE(ldlt.top_nodes.empty());
  const std::vector<Mat3> good = random_values(keys, n, 0.5, rng);
  const int32_t top_vertex = ldlt.order[n - 1], low_vertex = ldlt.order[0];
  for (int32_t v : {low_vertex, top_vertex})
    for (double bad : {-1e6, std::nan(""), std::numeric_limits<double>::infinity()}) {
      std::vector<Mat3> values = good;
      const auto diag = std::lower_bound(keys.begin(), keys.end(), std::make_pair(v, v)) - keys.begin();
      values[diag](2, 2) = bad;
      EXPECT_FALSE(factorize_block_ldlt(values, run_serial, ldlt)) << v << " " << bad;
      EXPECT_FALSE(ldlt.factorized);
    }
  {
    std::vector<Mat3> values = good;  // a non-finite off-diagonal block (both halves): refused at a later pivot
    for (const auto& key : {std::make_pair(0, 1), std::make_pair(1, 0)})
      values[std::lower_bound(keys.begin(), keys.end(), key) - keys.begin()](0, 0) = std::nan("");
    EXPECT_FALSE(factorize_block_ldlt(values, run_serial, ldlt));
  }
  ASSERT_TRUE(factorize_block_ldlt(good, run_serial, ldlt));
  EXPECT_LE(solve_residual(ldlt, keys, good, n), 1e-11);
}

TEST(BlockLdlt, SupernodalChunksAndTasksGiveTheBitIdenticalFactorInAnyOrder) {
  // One task against six tasks, with the tasks and the top supernodes' row chunks run in reverse order on
  // real threads: every entry of every panel, and of a solve, must come out bit-identical.
  std::mt19937 rng(29);
  const int32_t w = 30, h = 24, n = w * h;
  const Keys keys = sheet_pattern(w, h);
  const std::vector<Mat3> values = random_values(keys, n, 0.5, rng);
  BlockLdlt serial, split;
  analyze_block_ldlt(n, keys, small_chunks(1), serial);
  analyze_block_ldlt(n, keys, small_chunks(6), split);
  ASSERT_EQ(serial.task_start.size(), 2u);
  ASSERT_GT(split.task_start.size(), 3u) << "the tree was not split";
  int32_t chunked_top = 0;
  for (int32_t s : split.top_nodes)
    chunked_top += split.supernodes.chunk_first[s + 1] - split.supernodes.chunk_first[s] > 2;
  ASSERT_GT(chunked_top, 0) << "no top supernode in chunks";
  ASSERT_TRUE(factorize_block_ldlt(values, run_serial, serial));
  for (int round = 0; round < 2; ++round) {
    ASSERT_TRUE(factorize_block_ldlt(values, reversed_threads, split));
    ASSERT_EQ(serial.supernodes.panel.size(), split.supernodes.panel.size());
    for (size_t p = 0; p < serial.supernodes.panel.size(); ++p)
      ASSERT_EQ(serial.supernodes.panel[p], split.supernodes.panel[p]) << p;
  }
  // The solve: the split factor's tasks on reversed threads give the one-task solve's bits.
  const Eigen::VectorXd b = Eigen::VectorXd::Random(3 * n);
  Eigen::VectorXd x_serial(3 * n), x_split(3 * n);
  solve_block_ldlt(serial, b.data(), x_serial.data());
  solve_block_ldlt(split, b.data(), x_split.data(), reversed_threads);
  for (int32_t i = 0; i < 3 * n; ++i) ASSERT_EQ(x_serial[i], x_split[i]) << i;
  EXPECT_LE((dense(keys, values, n) * x_split - b).norm(), 1e-11 * b.norm());
}

// The suite's factorisations run the build PAPERTEAR_DENSE_KERNELS names (the fastest without it), so the
// ctest runs with it set cover the baseline and AVX2 builds.
TEST(BlockLdlt, FactorisationsUseTheBuildTheEnvironmentNames) {
  const char* named = std::getenv("PAPERTEAR_DENSE_KERNELS");
  const DenseKernels* expected = avx512_dense_kernels() ? avx512_dense_kernels()
                                 : avx2_dense_kernels() ? avx2_dense_kernels()
                                                        : &baseline_dense_kernels();
  if (named && std::string(named) == "baseline") expected = &baseline_dense_kernels();
  if (named && std::string(named) == "avx2" && avx2_dense_kernels()) expected = avx2_dense_kernels();
  EXPECT_EQ(&dense_kernels(), expected) << dense_kernels().name;
}
