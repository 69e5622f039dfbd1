// Sparse LDLᵀ of a symmetric positive definite matrix made of 3x3 blocks (one block per pair of vertices),
// the linear solve of the implicit integrator (systems/integrate_implicit.hpp).
//
// Why not Eigen's SimplicialLDLT: it factors scalar by scalar with an index lookup per multiply-add and
// re-permutes the whole matrix on every numeric factorisation. The sheet's matrix is a vertex graph with
// dense 3x3 blocks, so the same up-looking algorithm (Davis, "Algorithm 849: a concise sparse Cholesky
// factorization package", ACM TOMS 2005) over blocks does one lookup per 27 multiply-adds, and the ordering
// (approximate minimum degree on the vertex graph), the elimination tree and every row pattern are computed
// once per structure. L is unit block-lower-triangular, D block diagonal with 3x3 SPD blocks, stored inverted.
//
// Parallel over disjoint subtrees of the elimination tree (a column depends only on its descendants), then
// the columns above them in order. Every column is computed by the same arithmetic whichever task runs it,
// so the factor is bit-identical at any thread count.
#pragma once

#include "systems/parallel.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <utility>
#include <vector>

namespace pt {

using Mat3 = Eigen::Matrix3d;

struct BlockLdlt {
  int32_t n = 0;                       // block rows (vertices)
  std::vector<int32_t> order;          // factor index → matrix index (AMD)
  // Upper part of the permuted matrix, per factor column k: rows i < k and the key each block comes from.
  std::vector<int32_t> column_start, column_row, column_key;
  std::vector<int32_t> diagonal_key;   // per factor column k, the key of A(k, k)
  // L by columns: Lp, Li (row) and the blocks; the row patterns of L in topological order, with the slot
  // each L(k, i) is written to (entries of column i before that slot have rows < k).
  std::vector<int32_t> l_start, l_row;
  std::vector<int32_t> pattern_start, pattern_column, pattern_slot;
  std::vector<Mat3> l_blocks, d_inverse;
  // Tasks: task t factors the columns task_columns[task_start[t] .. task_start[t+1]) (whole subtrees,
  // increasing order); the columns of `top_columns` follow serially. One workspace per task.
  std::vector<int32_t> task_start, task_columns, top_columns;
  std::vector<std::vector<Mat3>> work;  // scattered column per task (+1 for the top), zero between uses
  int64_t block_updates = 0;  // Σ over columns of c(c+1)/2, c = blocks below the diagonal: 54 flops each
  bool factorized = false;
};

struct BlockLdltParams {
  int32_t min_parallel_blocks = 400;  // below this many block rows the factorisation stays one task
  int32_t tasks = 8;                  // subtrees to aim for (a few per core, for balance)
  int32_t min_dissection_blocks = 200;  // nested dissection tried from this many block rows (with coordinates)
  int32_t dissection_leaf = 1500;       // parts below this many block rows are ordered by AMD
};

// Symbolic analysis. `keys` are the (row, col) block positions of the full symmetric pattern, every
// diagonal block (i, i) included, each pair once; values later come in the same order. `coordinates`
// (n 2D positions, e.g. the rest pattern of the vertices, or empty) allow a geometric nested dissection.
void analyze_block_ldlt(int32_t n, const std::vector<std::pair<int32_t, int32_t>>& keys, const BlockLdltParams& params,
                        BlockLdlt& out, const std::vector<Eigen::Vector2d>& coordinates = {});

// Numeric factorisation of the matrix whose block at keys[b] is values[b]. Returns false (and leaves the
// factor unusable) when a pivot block is not positive definite or not finite.
bool factorize_block_ldlt(const std::vector<Mat3>& values, const RangeRunner& run, BlockLdlt& ldlt);

// x = A⁻¹ b for vectors of 3n entries (vertex-major). `x` may alias `b`.
void solve_block_ldlt(const BlockLdlt& ldlt, const double* b, double* x);

// Number of 3x3 blocks stored in L (fill-in measure).
inline int64_t block_ldlt_fill(const BlockLdlt& ldlt) { return static_cast<int64_t>(ldlt.l_row.size()); }

}  // namespace pt
