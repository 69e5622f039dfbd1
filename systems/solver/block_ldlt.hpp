// Sparse factorisation of a symmetric positive definite matrix made of 3x3 blocks (one block per pair of
// vertices), the linear solve of the implicit integrator (systems/physics/integrate_implicit.hpp).
//
// Why not Eigen's SimplicialLDLT: it factors scalar by scalar with an index lookup per multiply-add and
// re-permutes the whole matrix on every numeric factorisation. The ordering (AMD on the vertex graph, or
// a geometric nested dissection when the vertices' 2D coordinates are given and it needs fewer updates),
// the elimination tree and every pattern are computed once per structure. Two numeric factors:
// - below `min_supernodal_blocks`, block Cholesky by block columns: the up-looking algorithm (Davis,
//   "Algorithm 849: a concise sparse Cholesky factorization package", ACM TOMS 2005) over 3x3 blocks, one
//   lookup per 27 multiply-adds; fastest on small sheets, where dense kernels do not pay their call overhead;
// - above, a left-looking supernodal Cholesky L Lᵀ (as CHOLMOD): runs of columns with nested patterns
//   stored as dense panels, each descendant's update one dense product, the diagonal block by a dense
//   Cholesky and the rows below by a triangular solve (Eigen's blocked kernels).
//
// Parallel over disjoint subtrees of the elimination tree (a column depends only on its descendants),
// then the nodes above them in order, the big supernodes of that top split into fixed row chunks run
// over the threads. The split into supernodes and chunks depends on the structure only, and every entry
// is computed by the same arithmetic whichever task or thread runs it, so the factor is bit-identical at
// any thread count.
#pragma once

#include "systems/common/parallel.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <utility>
#include <vector>

namespace pt {

using Mat3 = Eigen::Matrix3d;

// Column path (small matrices): block Cholesky L Lᵀ = A computed column by column (up-looking); the
// blocks below the diagonal by columns, the diagonal blocks C_k (3x3 lower triangular) stored inverted.
struct ColumnFactor {
  // Upper part of the permuted matrix, per factor column k: rows i < k and the key each block comes from.
  std::vector<int32_t> column_start, column_row, column_key;
  std::vector<int32_t> diagonal_key;   // per factor column k, the key of A(k, k)
  // L by columns: Lp, Li (row) and the blocks; the row patterns of L in topological order, with the slot
  // each L(k, i) is written to (entries of column i before that slot have rows < k).
  std::vector<int32_t> l_start, l_row;
  std::vector<int32_t> pattern_start, pattern_column, pattern_slot;
  std::vector<Mat3> l_blocks, c_inverse;
  std::vector<std::vector<Mat3>> work;  // scattered column per task (+1 for the top), zero between uses
};

// Supernodal path (large matrices): L Lᵀ = A (scalar Cholesky) by supernodes, runs of consecutive factor
// columns with nested patterns. Supernode s has the columns [super_start[s], super_start[s+1]) and the
// block rows super_row[row_start[s] .. row_start[s+1]) (its own columns, then the rows below, ascending);
// its part of L is a dense column-major panel of 3·rows × 3·columns doubles at panel[panel_start[s]].
struct SupernodalFactor {
  std::vector<int32_t> super_start, row_start, super_row;
  std::vector<int64_t> panel_start;
  std::vector<double> panel;
  // Updates of supernode s: descendants update_source[u] whose rows [update_first[u], update_last[u])
  // (indices into super_row) are columns of s, for u in [update_start[s], update_start[s+1]).
  std::vector<int32_t> update_start, update_source, update_first, update_last;
  // Fixed row chunks of each supernode (see analyze) and, per chunk, the blocks of A assembled into it.
  std::vector<int32_t> chunk_first, chunk_begin;
  std::vector<int32_t> assembly_start, assembly_key;
  std::vector<int64_t> assembly_offset;
  std::vector<std::vector<int32_t>> position;  // row of a factor index in the current supernode, per task (+1)
  // For the solve: per supernode, the offset of its below-diagonal rows' values in a scratch vector
  // (3 doubles per row), and per factor column whether its supernode is one of `top_nodes`.
  std::vector<int64_t> below_offset;
  std::vector<uint8_t> top_column;
};

struct BlockLdlt {
  int32_t n = 0;                       // block rows (vertices)
  std::vector<int32_t> order;          // factor index → matrix index (AMD or nested dissection)
  bool supernodal = false;             // which of the two factors below is in use
  ColumnFactor columns;
  SupernodalFactor supernodes;
  // Tasks: task t factors the nodes (columns or supernodes) task_nodes[task_start[t] .. task_start[t+1])
  // (whole subtrees, increasing order); the nodes of `top_nodes` follow, a supernode's row chunks over
  // the threads.
  std::vector<int32_t> task_start, task_nodes, top_nodes;
  // Per key of the analysis: whether the factorisation reads its value. Of a symmetric pair (i, j), (j, i)
  // only one is read, so an assembler may skip the other (half the off-diagonal scatter).
  std::vector<uint8_t> key_read;
  int64_t fill_blocks = 0;    // blocks of L below the diagonal
  int64_t block_updates = 0;  // Σ over columns of c(c+1)/2, c = blocks below the diagonal: 54 flops each
  bool factorized = false;
};

struct BlockLdltParams {
  int32_t min_parallel_blocks = 400;  // below this many block rows the factorisation stays one task
  int32_t tasks = 8;                  // subtrees to aim for (a few per core, for balance)
  int32_t dissection_leaf = 1500;     // nested dissection (with coordinates) down to parts of this many block
                                      // rows, then AMD; tried from this size on
  // The supernodal factor from this many block rows, else by columns: the panels pay off only on big
  // sheets (the crossover measured on the A4 sheet: bench/results/2026-11-22-8-notes.txt).
  int32_t min_supernodal_blocks = 2000;
  // Structure of the supernodal factor, the same for every thread count (the result is bit-identical):
  int32_t supernode_width = 16;       // block columns per supernode at most
  // Relaxed supernodes: a run of columns that are each other's parents joins one panel, with explicit
  // zeros where the columns' patterns differ, while the zeros are at most this share of its entries
  // (runs of up to 4 columns, wider runs). Fewer explicit zeros than CHOLMOD's rule: with the AVX2
  // kernels a narrow product costs little, and the zeros cost flops, memory and scatter
  // (bench/results/2026-11-23-11-notes.txt).
  double relaxed_zeros_narrow = 0.3;
  double relaxed_zeros = 0.1;
  double chunk_flops = 2e6;           // a supernode is split into row chunks of about this much work ...
  int32_t max_chunks = 8;             // ... at most this many
};

// Symbolic analysis. `keys` are the (row, col) block positions of the full symmetric pattern, every
// diagonal block (i, i) included, each pair once; values later come in the same order. `coordinates`
// (n 2D positions, e.g. the rest pattern of the vertices, or empty) allow a geometric nested dissection.
// `run` may compute the two candidate orderings concurrently; the result does not depend on it.
void analyze_block_ldlt(int32_t n, const std::vector<std::pair<int32_t, int32_t>>& keys, const BlockLdltParams& params,
                        BlockLdlt& out, const std::vector<Eigen::Vector2d>& coordinates = {},
                        const RangeRunner& run = run_serial);

// Numeric factorisation of the matrix whose block at keys[b] is values[b]. Returns false (and leaves the
// factor unusable) when a pivot block is not positive definite or not finite.
bool factorize_block_ldlt(const std::vector<Mat3>& values, const RangeRunner& run, BlockLdlt& ldlt);

// x = A⁻¹ b for vectors of 3n entries (vertex-major). `x` may alias `b`. On the supernodal path the
// subtree tasks run through `run`; the result is bit-identical whatever it does.
void solve_block_ldlt(const BlockLdlt& ldlt, const double* b, double* x, const RangeRunner& run = run_serial);

// Heap bytes held by the analysis and the factor (capacity based), for memory accounting.
size_t block_ldlt_bytes(const BlockLdlt& ldlt);

// Number of 3x3 blocks stored in L (fill-in measure).
inline int64_t block_ldlt_fill(const BlockLdlt& ldlt) { return ldlt.fill_blocks; }

}  // namespace pt
