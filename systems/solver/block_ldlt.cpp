#include "systems/solver/block_ldlt.hpp"

#include "components/capacity_bytes.hpp"
#include "systems/solver/dense_kernels.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>

#include <algorithm>
#include <array>

namespace pt {

namespace {

using Panel = Eigen::Map<Eigen::MatrixXd>;
using PanelBlock = Eigen::Map<Mat3, Eigen::Unaligned, Eigen::OuterStride<>>;

// The vertex graph (off-diagonal keys) in compressed rows.
struct VertexGraph {
  std::vector<int32_t> start, adjacent;
};

VertexGraph vertex_graph(int32_t n, const std::vector<std::pair<int32_t, int32_t>>& keys) {
  VertexGraph g;
  g.start.assign(n + 1, 0);
  for (const auto& [r, c] : keys)
    if (r != c) ++g.start[r + 1];
  for (int32_t i = 0; i < n; ++i) g.start[i + 1] += g.start[i];
  g.adjacent.resize(g.start[n]);
  std::vector<int32_t> next(g.start.begin(), g.start.end() - 1);
  for (const auto& [r, c] : keys)
    if (r != c) g.adjacent[next[r]++] = c;
  return g;
}

// Approximate minimum degree (Eigen's AMD) of the subgraph induced by `vertices`, appended to `order`.
// With `halo`, the neighbours outside the part (ordered later, by the dissection) take part as a clique
// and are dropped from the result: AMD then sees that the part's boundary vertices are coupled to the
// rest and keeps them for last, as a constrained minimum degree would. `local` maps a vertex to its
// index in the subgraph, valid where `mark` holds `stamp` (part) or `stamp + 1` (halo).
void append_minimum_degree(const VertexGraph& g, const std::vector<int32_t>& vertices, bool halo,
                           std::vector<int32_t>& mark, int32_t stamp, std::vector<int32_t>& local,
                           std::vector<int32_t>& order) {
  const int32_t m = static_cast<int32_t>(vertices.size());
  for (int32_t i = 0; i < m; ++i) {
    mark[vertices[i]] = stamp;
    local[vertices[i]] = i;
  }
  std::vector<std::pair<int32_t, int32_t>> entries;  // (row, column) of the subgraph's pattern
  std::vector<int32_t> outside;
  for (int32_t i = 0; i < m; ++i) {
    entries.emplace_back(i, i);
    const int32_t v = vertices[i];
    for (int32_t q = g.start[v]; q < g.start[v + 1]; ++q) {
      const int32_t w = g.adjacent[q];
      if (mark[w] != stamp && halo) {
        if (mark[w] != stamp + 1) {
          mark[w] = stamp + 1;
          local[w] = m + static_cast<int32_t>(outside.size());
          outside.push_back(w);
        }
        entries.emplace_back(i, local[w]);
        entries.emplace_back(local[w], i);
      } else if (mark[w] == stamp) {
        entries.emplace_back(i, local[w]);
      }
    }
  }
  const int32_t size = m + static_cast<int32_t>(outside.size());
  for (int32_t a = m; a < size; ++a)
    for (int32_t b = m; b < size; ++b) entries.emplace_back(a, b);
  // The pattern by columns, rows ascending, no repeats: what Eigen's AMDOrdering builds (a SparseMatrix by
  // setFromTriplets, summed with its transpose: the entries are symmetric already, as the graph is) before
  // it calls the same minimum_degree_ordering, so the order is the same; those sparse passes cost as much
  // as the ordering. Without a halo the columns come out sorted (rows are visited in increasing order).
  std::vector<int32_t> start(size + 1, 0);
  for (const auto& entry : entries) ++start[entry.second + 1];
  for (int32_t c = 0; c < size; ++c) start[c + 1] += start[c];
  std::vector<int32_t> rows(start[size]), next(start.begin(), start.end() - 1);
  for (const auto& [r, c] : entries) rows[next[c]++] = r;
  Eigen::SparseMatrix<double> pattern(size, size);
  int32_t nonzeros = 0;
  for (int32_t c = 0; c < size; ++c) {
    const auto first = rows.begin() + start[c], last = rows.begin() + start[c + 1];
    if (!std::is_sorted(first, last)) std::sort(first, last);
    const auto end = std::unique(first, last);
    std::copy(first, end, rows.begin() + nonzeros);
    start[c] = nonzeros;
    nonzeros += static_cast<int32_t>(end - first);
  }
  start[size] = nonzeros;
  pattern.resizeNonZeros(nonzeros);
  std::copy(start.begin(), start.end(), pattern.outerIndexPtr());
  std::copy(rows.begin(), rows.begin() + nonzeros, pattern.innerIndexPtr());
  std::fill(pattern.valuePtr(), pattern.valuePtr() + nonzeros, 0.0);
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> inverse_permutation;  // P⁻¹: new → old
  Eigen::internal::minimum_degree_ordering(pattern, inverse_permutation);
  for (int32_t k = 0; k < size; ++k)
    if (inverse_permutation.indices()[k] < m) order.push_back(vertices[inverse_permutation.indices()[k]]);
}

// Geometric nested dissection (George 1973): halve the vertices at the median of the longer axis of
// their bounding box, take as separator the smaller of the two boundary layers (vertices of one half
// adjacent to the other), order both halves first, recursively, and the separator last. The elimination
// tree's top then splits into subtrees of equal size (the cores' independent halves). Parts below
// `leaf_size` go to AMD with their halo: measured on the A4 sheet of 10 000 triangles (5 162 vertices),
// block updates are 11.38 M with AMD alone, 12.21 M / 10.50 M / 10.98 M / 11.48 M with 1 / 2 / 3 / 8
// levels of dissection (the sheet's separators are two vertex layers thick, as hinges reach across an
// edge, so deep dissection loses to AMD on the parts), and without the halo 2 levels gave 13.4 M.
struct Dissection {
  const VertexGraph& graph;
  const std::vector<Eigen::Vector2d>& xy;
  int32_t leaf_size;
  std::vector<int32_t> mark, local, order;
  int32_t stamp = 0;

  void dissect(std::vector<int32_t> vertices) {
    if (static_cast<int32_t>(vertices.size()) < leaf_size) {
      append_minimum_degree(graph, vertices, true, mark, stamp + 1, local, order);
      stamp += 2;
      return;
    }
    Eigen::Vector2d lo = xy[vertices[0]], hi = lo;
    for (int32_t v : vertices) {
      lo = lo.cwiseMin(xy[v]);
      hi = hi.cwiseMax(xy[v]);
    }
    const int axis = (hi.x() - lo.x() >= hi.y() - lo.y()) ? 0 : 1;
    const auto middle = vertices.begin() + vertices.size() / 2;
    std::nth_element(vertices.begin(), middle, vertices.end(), [&](int32_t a, int32_t b) {
      return xy[a][axis] < xy[b][axis] || (xy[a][axis] == xy[b][axis] && a < b);  // total order: deterministic
    });
    const int32_t first = ++stamp, second = ++stamp;
    for (auto it = vertices.begin(); it != vertices.end(); ++it) mark[*it] = it < middle ? first : second;
    std::vector<int32_t> halves[2], boundary[2];
    for (auto it = vertices.begin(); it != vertices.end(); ++it) {
      const int side = it < middle ? 0 : 1;
      const int32_t other = side == 0 ? second : first;
      bool touches = false;
      for (int32_t q = graph.start[*it]; q < graph.start[*it + 1] && !touches; ++q)
        touches = mark[graph.adjacent[q]] == other;
      (touches ? boundary[side] : halves[side]).push_back(*it);
    }
    const int cut = boundary[0].size() <= boundary[1].size() ? 0 : 1;  // the separator's side
    halves[1 - cut].insert(halves[1 - cut].end(), boundary[1 - cut].begin(), boundary[1 - cut].end());
    std::vector<int32_t> separator = std::move(boundary[cut]);
    dissect(std::move(halves[0]));
    dissect(std::move(halves[1]));
    order.insert(order.end(), separator.begin(), separator.end());
  }
};

std::vector<int32_t> minimum_degree_order(int32_t n, const VertexGraph& g) {
  std::vector<int32_t> all(n), mark(n, 0), local(n), order;
  for (int32_t i = 0; i < n; ++i) all[i] = i;
  order.reserve(n);
  append_minimum_degree(g, all, false, mark, 1, local, order);
  return order;
}

// The upper part of the permuted matrix by columns (counting sort, key order kept inside a column), the
// elimination tree and the column counts of L (Davis' ldl_symbolic). Returns the block updates.
struct UpperPattern {
  std::vector<int32_t> column_start, column_row, column_key, diagonal_key;
};

int64_t permute_and_count(int32_t n, const std::vector<std::pair<int32_t, int32_t>>& keys,
                          const std::vector<int32_t>& order, UpperPattern& upper, std::vector<int32_t>& parent,
                          std::vector<int32_t>& count) {
  std::vector<int32_t> rank(n);
  for (int32_t k = 0; k < n; ++k) rank[order[k]] = k;
  upper.column_start.assign(n + 1, 0);
  for (const auto& [r, c] : keys)
    if (rank[r] < rank[c]) ++upper.column_start[rank[c] + 1];
  for (int32_t k = 0; k < n; ++k) upper.column_start[k + 1] += upper.column_start[k];
  upper.column_row.resize(upper.column_start[n]);
  upper.column_key.resize(upper.column_start[n]);
  upper.diagonal_key.assign(n, -1);
  std::vector<int32_t> next(upper.column_start.begin(), upper.column_start.end() - 1);
  for (int32_t b = 0; b < static_cast<int32_t>(keys.size()); ++b) {
    const int32_t i = rank[keys[b].first], k = rank[keys[b].second];
    if (i == k) upper.diagonal_key[k] = b;
    if (i >= k) continue;
    upper.column_row[next[k]] = i;
    upper.column_key[next[k]++] = b;
  }
  parent.assign(n, -1);
  count.assign(n, 0);
  std::vector<int32_t> flag(n, -1);
  for (int32_t k = 0; k < n; ++k) {
    flag[k] = k;
    for (int32_t q = upper.column_start[k]; q < upper.column_start[k + 1]; ++q)
      for (int32_t i = upper.column_row[q]; flag[i] != k; i = parent[i]) {
        if (parent[i] == -1) parent[i] = k;
        ++count[i];
        flag[i] = k;
      }
  }
  int64_t updates = 0;
  for (int32_t k = 0; k < n; ++k) updates += int64_t{count[k]} * (count[k] + 1) / 2;
  return updates;
}

// Splits the elimination tree (of columns or supernodes) into disjoint subtrees of similar work, summed
// over the subtree: starting from the roots, the heaviest subtree is replaced by its children, its root
// joining the top, until there are `params.tasks` subtrees or the heaviest is a leaf. The top is the
// chain of the last separators, one node after the other (a supernode's fixed row chunks over the
// threads). The subtrees are then packed into at most `params.tasks` bins, heaviest first into the
// lightest bin. With nested dissection the first split is the two halves of the sheet.
void split_into_subtrees(const std::vector<int32_t>& parent, const std::vector<double>& work, int32_t blocks,
                         const BlockLdltParams& params, BlockLdlt& out) {
  const int32_t n = static_cast<int32_t>(parent.size());
  out.task_start.clear();
  out.task_nodes.clear();
  out.top_nodes.clear();
  if (blocks < params.min_parallel_blocks || params.tasks < 2) {
    out.task_start = {0, n};
    out.task_nodes.resize(n);
    for (int32_t k = 0; k < n; ++k) out.task_nodes[k] = k;
    return;
  }
  std::vector<double> subtree_work(work);
  std::vector<std::vector<int32_t>> children(n);
  std::vector<int32_t> subtrees;
  for (int32_t k = 0; k < n; ++k) {  // parent[k] > k: a subtree is complete before its root
    if (parent[k] < 0) {
      subtrees.push_back(k);
      continue;
    }
    subtree_work[parent[k]] += subtree_work[k];
    children[parent[k]].push_back(k);
  }
  auto heavier = [&](int32_t a, int32_t b) {
    return subtree_work[a] > subtree_work[b] || (subtree_work[a] == subtree_work[b] && a < b);
  };
  std::vector<char> is_top(n, 0);
  while (static_cast<int32_t>(subtrees.size()) < params.tasks) {
    const auto heaviest = std::min_element(subtrees.begin(), subtrees.end(), heavier);
    const int32_t node = *heaviest;
    if (children[node].empty()) break;
    is_top[node] = 1;
    subtrees.erase(heaviest);
    subtrees.insert(subtrees.end(), children[node].begin(), children[node].end());
  }
  std::sort(subtrees.begin(), subtrees.end(), heavier);
  const int32_t bins = std::min<int32_t>(params.tasks, static_cast<int32_t>(subtrees.size()));
  std::vector<double> bin_work(bins, 0);
  std::vector<int32_t> task_of(n, -1);
  for (int32_t root : subtrees) {
    const auto bin = std::min_element(bin_work.begin(), bin_work.end()) - bin_work.begin();
    bin_work[bin] += subtree_work[root];
    task_of[root] = static_cast<int32_t>(bin);
  }
  for (int32_t k = n - 1; k >= 0; --k)  // descendants take their subtree root's task
    if (task_of[k] < 0 && !is_top[k] && parent[k] >= 0) task_of[k] = task_of[parent[k]];
  out.task_start.assign(bins + 1, 0);
  for (int32_t k = 0; k < n; ++k)
    if (task_of[k] >= 0) ++out.task_start[task_of[k] + 1];
  for (int32_t t = 0; t < bins; ++t) out.task_start[t + 1] += out.task_start[t];
  out.task_nodes.resize(out.task_start[bins]);
  std::vector<int32_t> next(out.task_start.begin(), out.task_start.end() - 1);
  for (int32_t k = 0; k < n; ++k) {
    if (task_of[k] >= 0)
      out.task_nodes[next[task_of[k]]++] = k;
    else
      out.top_nodes.push_back(k);
  }
}

// Column path. Row k of L and the pivot's Cholesky factor C_k: a sparse triangular solve
// L(0:k, 0:k) X = A(0:k, k) in topological order (Davis' up-looking algorithm over blocks), with the row
// pattern and slots precomputed; then C_k C_kᵀ = A(k, k) − Σ_i X_iᵀ X_i. False on a pivot block that is not
// symmetric positive definite (the matrix is not, or lost it to rounding) or not finite.
//
// Why block Cholesky and not LDLᵀ with D⁻¹: a vertex of tiny mass tied stiffly to its neighbours (a sliver
// a cut left) has a pivot with condition ~10⁷, and the update Y_iᵀ D_i⁻¹ Y_i through an explicit inverse
// then loses cond(D_i)·ε of its O(1) size — enough to make a later Schur complement of size 10⁻⁷ negative
// (measured: Fig. 16 on mesh 3 refused 1 103 of its 1 500 substeps although the matrix's smallest
// eigenvalue was 8·10⁻⁸). X_i = C_i⁻¹ Y_i and the Gram update X_iᵀ X_i lose only about ε·‖X_i‖².
static_assert(sizeof(Mat3) == 9 * sizeof(double), "the dense kernels read 3x3 blocks as 9 packed doubles");

bool factor_column(const std::vector<Mat3>& values, int32_t k, std::vector<Mat3>& y, ColumnFactor& s) {
  const DenseKernels& kernels = dense_kernels();
  for (int32_t q = s.column_start[k]; q < s.column_start[k + 1]; ++q) y[s.column_row[q]] = values[s.column_key[q]];
  Mat3 d = values[s.diagonal_key[k]];
  for (int32_t t = s.pattern_start[k]; t < s.pattern_start[k + 1]; ++t) {
    const int32_t i = s.pattern_column[t], slot = s.pattern_slot[t];
    const Mat3 xi = s.c_inverse[i] * y[i];  // X_i = C_i⁻¹ Y_i; L(k, i) = X_iᵀ
    y[i].setZero();
    // y[row] −= L(row, i) X_i over the entries of column i above the slot (the dense kernels' build).
    const int32_t p0 = s.l_start[i];
    if (slot > p0)
      kernels.subtract_block_products(slot - p0, s.l_row.data() + p0, s.l_blocks[p0].data(), xi.data(), y[0].data());
    d.noalias() -= xi.transpose() * xi;
    s.l_blocks[slot] = xi.transpose();
  }
  // 3x3 Cholesky of the pivot and the inverse of its factor, closed form (the negated tests also refuse NaN).
  const double a00 = d(0, 0);
  if (!(a00 > 0)) return false;
  const double c00 = std::sqrt(a00), c10 = d(1, 0) / c00, c20 = d(2, 0) / c00;
  const double a11 = d(1, 1) - c10 * c10;
  if (!(a11 > 0)) return false;
  const double c11 = std::sqrt(a11), c21 = (d(2, 1) - c20 * c10) / c11;
  const double a22 = d(2, 2) - c20 * c20 - c21 * c21;
  if (!(a22 > 0) || !std::isfinite(a22) || !std::isfinite(c10) || !std::isfinite(c20) || !std::isfinite(c21))
    return false;
  const double c22 = std::sqrt(a22);
  const double i00 = 1 / c00, i11 = 1 / c11, i22 = 1 / c22;
  const double i10 = -c10 * i00 * i11, i21 = -c21 * i11 * i22, i20 = -(c20 * i00 + c21 * i10) * i22;
  Mat3& inv = s.c_inverse[k];
  inv << i00, 0, 0, i10, i11, 0, i20, i21, i22;
  return true;
}

// Column path: the row patterns of L in topological order with the slot each entry lands in
// (ldl_numeric's reach, done once here). Fills `work` with the block updates of each column.
void analyze_columns(int32_t n, UpperPattern&& upper, const std::vector<int32_t>& parent,
                     const std::vector<int32_t>& count, ColumnFactor& out, std::vector<double>& work) {
  out.column_start = std::move(upper.column_start);
  out.column_row = std::move(upper.column_row);
  out.column_key = std::move(upper.column_key);
  out.diagonal_key = std::move(upper.diagonal_key);
  out.l_start.assign(n + 1, 0);
  for (int32_t k = 0; k < n; ++k) out.l_start[k + 1] = out.l_start[k] + count[k];
  out.l_row.resize(out.l_start[n]);
  out.pattern_start.assign(n + 1, 0);
  out.pattern_column.reserve(out.l_start[n]);
  out.pattern_slot.reserve(out.l_start[n]);
  std::vector<int32_t> filled(n, 0), stack(n), path(n), flag(n, -1);
  work.assign(n, 1);
  for (int32_t k = 0; k < n; ++k) {
    int32_t top = n;
    flag[k] = k;
    for (int32_t q = out.column_start[k]; q < out.column_start[k + 1]; ++q) {
      int32_t length = 0;
      for (int32_t i = out.column_row[q]; flag[i] != k; i = parent[i]) {
        path[length++] = i;
        flag[i] = k;
      }
      while (length > 0) stack[--top] = path[--length];
    }
    for (int32_t t = top; t < n; ++t) {
      const int32_t i = stack[t];
      const int32_t slot = out.l_start[i] + filled[i]++;
      out.l_row[slot] = k;
      out.pattern_column.push_back(i);
      out.pattern_slot.push_back(slot);
      work[k] += slot - out.l_start[i] + 2;
    }
    out.pattern_start[k + 1] = static_cast<int32_t>(out.pattern_column.size());
  }
  out.l_blocks.assign(out.l_start[n], Mat3::Zero());
  out.c_inverse.assign(n, Mat3::Zero());
}

// Supernodal path. The rows of supernode `s`'s panel in chunk `c`: zeroed, A assembled, then every
// descendant's update (in increasing descendant order, whoever runs the chunk), C = L_d(rows in chunk)
// L_d(rows in s)ᵀ by a dense product, scattered by block. `position` maps a factor index to its row in s
// (set by the caller).
void update_chunk(const std::vector<Mat3>& values, int32_t s, int32_t c, const std::vector<int32_t>& position,
                  std::vector<double>& product, SupernodalFactor& f) {
  const int32_t rows = f.row_start[s + 1] - f.row_start[s], first_column = f.super_start[s];
  const int32_t r0 = f.chunk_begin[c], r1 = f.chunk_begin[c + 1];
  const int64_t ld = 3 * rows;
  double* panel = f.panel.data() + f.panel_start[s];
  Panel(panel, ld, 3 * (f.super_start[s + 1] - first_column)).middleRows(3 * r0, 3 * (r1 - r0)).setZero();
  for (int32_t e = f.assembly_start[c]; e < f.assembly_start[c + 1]; ++e)
    PanelBlock(panel + f.assembly_offset[e], 3, 3, Eigen::OuterStride<>(ld)) = values[f.assembly_key[e]];
  const bool whole = r0 == 0 && r1 == rows;
  const DenseKernels& kernels = dense_kernels();
  const int32_t* s_rows = f.super_row.data() + f.row_start[s];
  for (int32_t u = f.update_start[s]; u < f.update_start[s + 1]; ++u) {
    const int32_t d = f.update_source[u], first = f.update_first[u], last = f.update_last[u];
    const int32_t d_end = f.row_start[d + 1];
    const int32_t* d_rows = f.super_row.data();
    // The descendant's rows that land in [r0, r1): contiguous, as both row lists are ascending.
    const int32_t a0 = whole || r0 == 0 ? first
                                        : static_cast<int32_t>(std::lower_bound(d_rows + first, d_rows + d_end,
                                                                                s_rows[r0]) - d_rows);
    const int32_t a1 = whole || r1 == rows ? d_end
                                           : static_cast<int32_t>(std::lower_bound(d_rows + a0, d_rows + d_end,
                                                                                   s_rows[r1]) - d_rows);
    if (a1 <= a0) continue;
    const int32_t d_rows_count = d_end - f.row_start[d], d_columns = f.super_start[d + 1] - f.super_start[d];
    const int64_t d_ld = 3 * d_rows_count;  // the descendant's panel: 3·rows × 3·columns, column-major
    const int32_t m = a1 - a0, k = last - first, width = 3 * d_columns;
    const auto rows_of = [&](int32_t a) { return f.panel.data() + f.panel_start[d] + 3 * (a - f.row_start[d]); };
    // Grown, never shrunk: a resize down and up again zero-filled the difference on every update (4% of
    // a 10 000-triangle frame went to that memset), and the product overwrites every entry it reads.
    if (product.size() < static_cast<size_t>(9) * m * k) product.resize(static_cast<size_t>(9) * m * k);
    Panel cp(product.data(), 3 * m, 3 * k);
    // With the whole diagonal part in the chunk, only its lower triangle is computed (rows of s's own
    // columns: the upper one is never read), the rows below by a general product.
    const bool triangle = a0 == first && a1 >= last;
    if (triangle) {
      kernels.syrk_lower(3 * k, width, rows_of(first), d_ld, cp.data(), 3 * m);
      if (a1 > last)
        kernels.gemm_nt(3 * (a1 - last), 3 * k, width, rows_of(last), d_ld, rows_of(first), d_ld, cp.data() + 3 * k,
                        3 * m);
    } else {
      kernels.gemm_nt(3 * m, 3 * k, width, rows_of(a0), d_ld, rows_of(first), d_ld, cp.data(), 3 * m);
    }
    for (int32_t b = 0; b < k; ++b) {
      const int32_t column = d_rows[first + b] - first_column;
      double* target = panel + 3 * column * ld;
      int32_t a = std::max(a0, first + b);  // lower part only
      if (a == first + b && a < a1) {       // a diagonal block: its lower triangle
        PanelBlock(target + 3 * position[d_rows[a]], 3, 3, Eigen::OuterStride<>(ld)).triangularView<Eigen::Lower>() -=
            cp.block<3, 3>(3 * (a - a0), 3 * b);
        ++a;
      }
      for (; a < a1; ++a)
        PanelBlock(target + 3 * position[d_rows[a]], 3, 3, Eigen::OuterStride<>(ld)) -=
            cp.block<3, 3>(3 * (a - a0), 3 * b);
    }
  }
}

// The diagonal block of supernode `s` by a dense Cholesky, in place. False on a pivot that is not
// positive (the matrix is not SPD, or lost it to rounding) or not finite.
bool factor_diagonal(int32_t s, SupernodalFactor& f) {
  const int32_t rows = f.row_start[s + 1] - f.row_start[s], width = 3 * (f.super_start[s + 1] - f.super_start[s]);
  return dense_kernels().llt_lower(width, f.panel.data() + f.panel_start[s], 3 * rows);
}

// The rows of chunk `c` below the diagonal block: L_below = A_below L_ss⁻ᵀ.
void solve_chunk(int32_t s, int32_t c, SupernodalFactor& f) {
  const int32_t rows = f.row_start[s + 1] - f.row_start[s], columns = f.super_start[s + 1] - f.super_start[s];
  const int32_t r0 = std::max(f.chunk_begin[c], columns), r1 = f.chunk_begin[c + 1];
  if (r1 <= r0) return;
  double* panel = f.panel.data() + f.panel_start[s];
  dense_kernels().solve_right_lower_transposed(3 * (r1 - r0), 3 * columns, panel, 3 * rows, panel + 3 * r0, 3 * rows);
}

void set_positions(int32_t s, const SupernodalFactor& f, std::vector<int32_t>& position) {
  for (int32_t q = f.row_start[s]; q < f.row_start[s + 1]; ++q) position[f.super_row[q]] = q - f.row_start[s];
}

// Supernodal path: supernodes, their row lists, the descendant updates, row chunks and the assembly of A.
// Fills `work` (flops per supernode) and `super_parent` (the supernodal elimination tree).
void analyze_supernodes(int32_t n, const std::vector<std::pair<int32_t, int32_t>>& keys,
                        const std::vector<int32_t>& order, const UpperPattern& upper,
                        const std::vector<int32_t>& parent,
                        const std::vector<int32_t>& count, const BlockLdltParams& params, SupernodalFactor& out,
                        std::vector<double>& work, std::vector<int32_t>& super_parent) {
  // Supernodes: column k joins the supernode of k − 1 when k is k − 1's parent; every column j of the
  // run then takes the pattern {j+1 .. last} ∪ pattern(last), its own pattern (fundamental supernode,
  // no zeros) or a superset of it (relaxed, explicit zeros, within params.relaxed_zeros*). Panels of a few
  // columns and dense products beat many 1-column updates. Capped in width so a separator becomes several
  // panels whose mutual updates split into row chunks like any other.
  std::vector<int32_t> super_of(n);
  out.super_start.clear();
  for (int32_t k = 0; k < n; ++k) {
    bool joins = k > 0 && parent[k - 1] == k && k + 1 - out.super_start.back() <= params.supernode_width;
    if (joins) {
      const int32_t first = out.super_start.back(), width = k + 1 - first;
      int64_t zeros = 0, entries = 0;
      for (int32_t j = first; j <= k; ++j) {
        entries += k - j + 1 + count[k];
        zeros += k - j + count[k] - count[j];
      }
      const double fraction = static_cast<double>(zeros) / static_cast<double>(entries);
      joins = zeros == 0 || fraction <= (width <= 4 ? params.relaxed_zeros_narrow : params.relaxed_zeros);
    }
    if (!joins) out.super_start.push_back(k);
    super_of[k] = static_cast<int32_t>(out.super_start.size()) - 1;
  }
  const int32_t supernodes = static_cast<int32_t>(out.super_start.size());
  out.super_start.push_back(n);

  // Row pattern of each supernode's last column (the rows below the panel's diagonal block): the row
  // subtrees of the etree (ldl_numeric's reach), collected for the columns that are last in a supernode.
  std::vector<std::vector<int32_t>> below(supernodes);
  {
    std::vector<int32_t> flag(n, -1);
    for (int32_t k = 0; k < n; ++k) {
      flag[k] = k;
      for (int32_t q = upper.column_start[k]; q < upper.column_start[k + 1]; ++q)
        for (int32_t i = upper.column_row[q]; flag[i] != k; i = parent[i]) {
          flag[i] = k;
          if (i + 1 == out.super_start[super_of[i] + 1]) below[super_of[i]].push_back(k);
        }
    }
  }
  out.row_start.assign(supernodes + 1, 0);
  out.panel_start.assign(supernodes + 1, 0);
  out.super_row.clear();
  for (int32_t s = 0; s < supernodes; ++s) {
    const int32_t columns = out.super_start[s + 1] - out.super_start[s];
    for (int32_t k = out.super_start[s]; k < out.super_start[s + 1]; ++k) out.super_row.push_back(k);
    out.super_row.insert(out.super_row.end(), below[s].begin(), below[s].end());
    out.row_start[s + 1] = static_cast<int32_t>(out.super_row.size());
    out.panel_start[s + 1] = out.panel_start[s] + int64_t{9} * columns * (out.row_start[s + 1] - out.row_start[s]);
  }
  // Sized, not cleared: the factorisation zeroes every chunk's rows before assembling into them, and the
  // storage of the previous analysis is kept (analyze_block_ldlt), so a re-analysis after a cut neither
  // clears 24 MB (10 000 triangles) nor faults its pages in again.
  out.panel.resize(out.panel_start[supernodes]);

  // Updates: descendant d touches supernode s through its rows that are s's columns (a contiguous run of
  // d's ascending rows); listed per s in increasing d, the order every factorisation applies them in.
  work.assign(supernodes, 0.0);  // flops, for the chunks and the task split
  {
    std::vector<int32_t> per(supernodes + 1, 0);
    std::vector<std::array<int32_t, 4>> found;  // (s, d, first, last)
    for (int32_t d = 0; d < supernodes; ++d) {
      const int32_t d_columns = out.super_start[d + 1] - out.super_start[d];
      const int32_t d_end = out.row_start[d + 1];
      for (int32_t q = out.row_start[d] + d_columns; q < d_end;) {
        const int32_t s = super_of[out.super_row[q]];
        int32_t last = q;
        while (last < d_end && out.super_row[last] < out.super_start[s + 1]) ++last;
        found.push_back({s, d, q, last});
        ++per[s + 1];
        work[s] += 54.0 * d_columns * (d_end - q) * (last - q);
        q = last;
      }
      const double w = 3.0 * d_columns;
      work[d] += w * w * w / 3 + w * w * 3.0 * (d_end - out.row_start[d] - d_columns);
    }
    for (int32_t s = 0; s < supernodes; ++s) per[s + 1] += per[s];
    out.update_start = per;
    out.update_source.resize(found.size());
    out.update_first.resize(found.size());
    out.update_last.resize(found.size());
    for (const auto& [s, d, first, last] : found) {  // found is in increasing d: stable per s
      const int32_t u = per[s]++;
      out.update_source[u] = d;
      out.update_first[u] = first;
      out.update_last[u] = last;
    }
  }

  // Row chunks: a supernode with more than `chunk_flops` of work is split into up to `max_chunks` runs of
  // rows of equal length, by its structure alone, so the arithmetic of every entry is the same whether
  // the chunks run on one thread or several, and whatever the task split. Supernode s's chunks begin at
  // chunk_begin[chunk_first[s] ..], followed by one entry for the end of its last chunk (its row count).
  out.chunk_first.assign(supernodes + 1, 0);
  out.chunk_begin.clear();
  for (int32_t s = 0; s < supernodes; ++s) {
    const int32_t rows = out.row_start[s + 1] - out.row_start[s];
    const int32_t chunks = std::clamp(static_cast<int32_t>(work[s] / params.chunk_flops), 1,
                                      std::min(params.max_chunks, rows));
    for (int32_t c = 0; c <= chunks; ++c) out.chunk_begin.push_back(static_cast<int32_t>(int64_t{rows} * c / chunks));
    out.chunk_first[s + 1] = static_cast<int32_t>(out.chunk_begin.size());
  }

  // Assembly of A into the panels, per chunk: each lower block (i ≥ k in factor order) of the matrix.
  {
    std::vector<int32_t> rank(n), position(n);
    for (int32_t k = 0; k < n; ++k) rank[order[k]] = k;
    std::vector<std::vector<int32_t>> keys_of(supernodes);
    for (int32_t b = 0; b < static_cast<int32_t>(keys.size()); ++b)
      if (rank[keys[b].first] >= rank[keys[b].second]) keys_of[super_of[rank[keys[b].second]]].push_back(b);
    const int32_t chunk_slots = out.chunk_first[supernodes];
    std::vector<std::vector<std::pair<int64_t, int32_t>>> per_chunk(chunk_slots);
    for (int32_t s = 0; s < supernodes; ++s) {
      set_positions(s, out, position);
      const int64_t ld = 3 * int64_t{out.row_start[s + 1] - out.row_start[s]};
      for (int32_t b : keys_of[s]) {
        const int32_t i = position[rank[keys[b].first]], k = rank[keys[b].second] - out.super_start[s];
        int32_t c = out.chunk_first[s];
        while (out.chunk_begin[c + 1] <= i) ++c;
        per_chunk[c].emplace_back(3 * k * ld + 3 * i, b);
      }
    }
    out.assembly_start.assign(chunk_slots + 1, 0);
    for (int32_t c = 0; c < chunk_slots; ++c) {
      out.assembly_start[c + 1] = out.assembly_start[c] + static_cast<int32_t>(per_chunk[c].size());
      for (const auto& [offset, b] : per_chunk[c]) {
        out.assembly_offset.push_back(offset);
        out.assembly_key.push_back(b);
      }
    }
  }

  super_parent.assign(supernodes, -1);
  for (int32_t s = 0; s < supernodes; ++s) {
    const int32_t last = out.super_start[s + 1] - 1;
    if (parent[last] >= 0) super_parent[s] = super_of[parent[last]];
  }
}


}  // namespace

void analyze_block_ldlt(int32_t n, const std::vector<std::pair<int32_t, int32_t>>& keys, const BlockLdltParams& params,
                        BlockLdlt& out, const std::vector<Eigen::Vector2d>& coordinates, const RangeRunner& run) {
  std::vector<double> panel_storage = std::move(out.supernodes.panel);  // reused by analyze_supernodes
  out = BlockLdlt{};
  out.n = n;

  // Ordering: AMD, or nested dissection when coordinates are given and it needs fewer block updates
  // (AMD wins below a couple of thousand vertices). The two candidates are independent, each with its
  // count of block updates: range 0 is AMD, range 1 the dissection, computed concurrently when `run`
  // allows (a cut's analysis at 10 000 triangles is ~14 ms, in the frame after every cut).
  const VertexGraph graph = vertex_graph(n, keys);
  const bool try_dissection = static_cast<int32_t>(coordinates.size()) == n && n >= params.dissection_leaf;
  struct Candidate {
    std::vector<int32_t> order;
    UpperPattern upper;
    std::vector<int32_t> parent, count;
    int64_t updates = 0;
  };
  std::array<Candidate, 2> candidate;
  run(try_dissection ? 2 : 1, 1, [&](int32_t begin, int32_t end) {
    for (int32_t c = begin; c < end; ++c) {
      Candidate& k = candidate[c];
      if (c == 0) {
        k.order = minimum_degree_order(n, graph);
      } else {
        // (Below `dissection_leaf` the dissection would be AMD itself.)
        Dissection nd{graph, coordinates, params.dissection_leaf, std::vector<int32_t>(n, 0), std::vector<int32_t>(n), {}};
        std::vector<int32_t> all(n);
        for (int32_t i = 0; i < n; ++i) all[i] = i;
        nd.order.reserve(n);
        nd.dissect(std::move(all));
        k.order = std::move(nd.order);
      }
      k.updates = permute_and_count(n, keys, k.order, k.upper, k.parent, k.count);
    }
  });
  Candidate& chosen = try_dissection && candidate[1].updates < candidate[0].updates ? candidate[1] : candidate[0];
  out.order = std::move(chosen.order);
  out.block_updates = chosen.updates;
  UpperPattern upper = std::move(chosen.upper);
  const std::vector<int32_t> parent = std::move(chosen.parent), count = std::move(chosen.count);
  for (int32_t k = 0; k < n; ++k) out.fill_blocks += count[k];

  std::vector<double> work;  // per node (column or supernode), for the task split
  std::vector<int32_t> node_parent;
  out.supernodal = n >= params.min_supernodal_blocks;
  if (out.supernodal) {
    out.supernodes.panel = std::move(panel_storage);
    analyze_supernodes(n, keys, out.order, upper, parent, count, params, out.supernodes, work, node_parent);
  } else {
    analyze_columns(n, std::move(upper), parent, count, out.columns, work);
    node_parent = parent;
  }
  split_into_subtrees(node_parent, work, n, params, out);
  if (out.supernodal) {
    SupernodalFactor& sf = out.supernodes;
    const int32_t supernodes = static_cast<int32_t>(sf.super_start.size()) - 1;
    sf.below_offset.assign(supernodes + 1, 0);
    for (int32_t s = 0; s < supernodes; ++s)
      sf.below_offset[s + 1] = sf.below_offset[s] + 3 * ((sf.row_start[s + 1] - sf.row_start[s]) -
                                                         (sf.super_start[s + 1] - sf.super_start[s]));
    sf.top_column.assign(n, 0);
    for (int32_t s : out.top_nodes)
      for (int32_t k = sf.super_start[s]; k < sf.super_start[s + 1]; ++k) sf.top_column[k] = 1;
  }
  // Which key of a symmetric pair the factor reads: the column path the upper part in factor order, the
  // supernodal path the lower part (both read the diagonal).
  {
    std::vector<int32_t> rank(n);
    for (int32_t k = 0; k < n; ++k) rank[out.order[k]] = k;
    out.key_read.resize(keys.size());
    for (size_t b = 0; b < keys.size(); ++b) {
      const int32_t r = rank[keys[b].first], c = rank[keys[b].second];
      out.key_read[b] = r == c || (out.supernodal ? r > c : r < c);
    }
  }
  if (out.supernodal)
    out.supernodes.position.assign(out.task_start.size(), std::vector<int32_t>(n, 0));
  else
    out.columns.work.assign(out.task_start.size(), std::vector<Mat3>(n, Mat3::Zero()));
}

namespace {

bool factorize_columns(const std::vector<Mat3>& values, const RangeRunner& run, BlockLdlt& f) {
  ColumnFactor& c = f.columns;
  const int32_t tasks = static_cast<int32_t>(f.task_start.size()) - 1;
  std::vector<char> ok(tasks + 1, 1);
  auto factor_columns = [&](const std::vector<int32_t>& columns, int32_t first, int32_t last, int32_t slot) {
    std::vector<Mat3>& y = c.work[slot];
    for (int32_t q = first; q < last; ++q)
      if (!factor_column(values, columns[q], y, c)) {
        for (Mat3& m : y) m.setZero();  // leave the workspace clean for the next factorisation
        ok[slot] = 0;
        return;
      }
  };
  run(tasks, 1, [&](int32_t begin, int32_t end) {
    for (int32_t t = begin; t < end; ++t) factor_columns(f.task_nodes, f.task_start[t], f.task_start[t + 1], t);
  });
  for (int32_t t = 0; t < tasks; ++t)
    if (!ok[t]) return false;
  factor_columns(f.top_nodes, 0, static_cast<int32_t>(f.top_nodes.size()), tasks);
  return ok[tasks] != 0;
}

// The calling thread's scratch for the dense products (fully overwritten at each use). Reached through a
// function so that each worker thread constructs its own copy and registers its destructor: a block-scope
// thread_local of the caller, named from a lambda that runs on a worker, would be used there without ever
// being constructed, and leak (LeakSanitizer caught it).
std::vector<double>& product_scratch() {
  thread_local std::vector<double> product;
  return product;
}

bool factorize_supernodes(const std::vector<Mat3>& values, const RangeRunner& run, BlockLdlt& f) {
  SupernodalFactor& sf = f.supernodes;
  const int32_t tasks = static_cast<int32_t>(f.task_start.size()) - 1;
  std::vector<char> ok(tasks, 1);
  // A subtree task runs its supernodes one after the other, each chunk in order.
  run(tasks, 1, [&](int32_t begin, int32_t end) {
    for (int32_t t = begin; t < end; ++t) {
      std::vector<int32_t>& position = sf.position[t];
      for (int32_t q = f.task_start[t]; q < f.task_start[t + 1]; ++q) {
        const int32_t s = f.task_nodes[q];
        set_positions(s, sf, position);
        for (int32_t c = sf.chunk_first[s]; c + 1 < sf.chunk_first[s + 1]; ++c)
          update_chunk(values, s, c, position, product_scratch(), sf);
        if (!factor_diagonal(s, sf)) {
          ok[t] = 0;
          break;
        }
        for (int32_t c = sf.chunk_first[s]; c + 1 < sf.chunk_first[s + 1]; ++c) solve_chunk(s, c, sf);
      }
    }
  });
  for (int32_t t = 0; t < tasks; ++t)
    if (!ok[t]) return false;
  // The top: supernode after supernode, the chunks of each over the threads.
  std::vector<int32_t>& position = sf.position[tasks];
  for (int32_t s : f.top_nodes) {
    set_positions(s, sf, position);
    const int32_t first = sf.chunk_first[s], chunks = sf.chunk_first[s + 1] - first - 1;
    run(chunks, 1, [&](int32_t begin, int32_t end) {
      for (int32_t c = begin; c < end; ++c) update_chunk(values, s, first + c, position, product_scratch(), sf);
    });
    if (!factor_diagonal(s, sf)) return false;
    run(chunks, 1, [&](int32_t begin, int32_t end) {
      for (int32_t c = begin; c < end; ++c) solve_chunk(s, first + c, sf);
    });
  }
  return true;
}

}  // namespace

bool factorize_block_ldlt(const std::vector<Mat3>& values, const RangeRunner& run, BlockLdlt& f) {
  f.factorized = f.supernodal ? factorize_supernodes(values, run, f) : factorize_columns(values, run, f);
  return f.factorized;
}

void solve_block_ldlt(const BlockLdlt& f, const double* b, double* x, const RangeRunner& run) {
  using Vec3 = Eigen::Vector3d;
  thread_local Eigen::VectorXd z, below;
  z.resize(3 * f.n);
  for (int32_t k = 0; k < f.n; ++k) z.segment<3>(3 * k) = Eigen::Map<const Vec3>(b + 3 * f.order[k]);
  if (!f.supernodal) {
    const ColumnFactor& c = f.columns;
    // Entry i of the solution is held in a local while its column is applied: as a segment of z it had to
    // be reloaded after every store into z (they may alias, as far as the compiler knows). Same operations
    // in the same order.
    for (int32_t i = 0; i < f.n; ++i) {  // L y = b, diagonal blocks C_i
      const Vec3 zi = c.c_inverse[i] * z.segment<3>(3 * i);
      z.segment<3>(3 * i) = zi;
      for (int32_t p = c.l_start[i]; p < c.l_start[i + 1]; ++p)
        z.segment<3>(3 * c.l_row[p]).noalias() -= c.l_blocks[p] * zi;
    }
    for (int32_t i = f.n - 1; i >= 0; --i) {  // Lᵀ x = y
      Vec3 zi = z.segment<3>(3 * i);
      for (int32_t p = c.l_start[i]; p < c.l_start[i + 1]; ++p)
        zi.noalias() -= c.l_blocks[p].transpose() * z.segment<3>(3 * c.l_row[p]);
      z.segment<3>(3 * i) = c.c_inverse[i].transpose() * zi;
    }
  } else {
    // Per panel through the dense kernels (dense_kernels.hpp). A solve reads the panels twice and runs at
    // the memory's pace, not the arithmetic's (bench/results/2026-11-22-8-notes.txt). So the subtree tasks of the factorisation solve in parallel too, in a way that keeps
    // every entry's sequence of operations of the serial solve:
    // - forward (supernodes in increasing order): a task's supernode updates rows of its own subtree at
    //   once (only that task's supernodes touch them, in the serial order) and leaves its product for the
    //   rows of top supernodes in `below`; then one pass in supernode order solves the top supernodes and
    //   applies the task supernodes' products to top rows, in the serial order;
    // - backward (decreasing order): the top supernodes first (they read top rows only), then the tasks,
    //   each reading rows of its subtree and top rows, all final by then.
    const SupernodalFactor& sf = f.supernodes;
    const DenseKernels& kernels = dense_kernels();
    const int32_t supernodes = static_cast<int32_t>(sf.super_start.size()) - 1;
    const int32_t tasks = static_cast<int32_t>(f.task_start.size()) - 1;
    below.resize(sf.below_offset[supernodes]);
    double* const zd = z.data();
    double* const bd = below.data();
    auto apply_below = [&](int32_t s, int apply_top, const double* t) {
      const int32_t columns = sf.super_start[s + 1] - sf.super_start[s], rows = sf.row_start[s + 1] - sf.row_start[s];
      for (int32_t q = columns; q < rows; ++q) {
        const int32_t row = sf.super_row[sf.row_start[s] + q];
        if (apply_top >= 0 && sf.top_column[row] != apply_top) continue;
        for (int e = 0; e < 3; ++e) zd[3 * row + e] -= t[3 * (q - columns) + e];
      }
    };
    // Solves supernode s's columns and forms its product with the rows below; applies it to the rows with
    // top_column == apply_top (both when apply_top < 0).
    auto forward = [&](int32_t s, int apply_top) {
      const int32_t columns = sf.super_start[s + 1] - sf.super_start[s], rows = sf.row_start[s + 1] - sf.row_start[s];
      double* t = bd + sf.below_offset[s];
      kernels.panel_forward(3 * columns, 3 * (rows - columns), sf.panel.data() + sf.panel_start[s], 3 * rows,
                            zd + 3 * sf.super_start[s], t);
      apply_below(s, apply_top, t);
    };
    auto backward = [&](int32_t s) {
      const int32_t columns = sf.super_start[s + 1] - sf.super_start[s], rows = sf.row_start[s + 1] - sf.row_start[s];
      double* t = bd + sf.below_offset[s];
      for (int32_t q = columns; q < rows; ++q)
        for (int e = 0; e < 3; ++e) t[3 * (q - columns) + e] = zd[3 * sf.super_row[sf.row_start[s] + q] + e];
      kernels.panel_backward(3 * columns, 3 * (rows - columns), sf.panel.data() + sf.panel_start[s], 3 * rows, t,
                             zd + 3 * sf.super_start[s]);
    };
    if (f.top_nodes.empty()) {  // one task: the serial solve
      for (int32_t s = 0; s < supernodes; ++s) forward(s, -1);
      for (int32_t s = supernodes - 1; s >= 0; --s) backward(s);
    } else {
      run(tasks, 1, [&](int32_t begin, int32_t end) {
        for (int32_t k = begin; k < end; ++k)
          for (int32_t q = f.task_start[k]; q < f.task_start[k + 1]; ++q) forward(f.task_nodes[q], 0);
      });
      auto is_top = [&](int32_t s) { return sf.top_column[sf.super_start[s]] != 0; };
      for (int32_t s = 0; s < supernodes; ++s) {
        if (is_top(s)) forward(s, -1);
        else apply_below(s, 1, bd + sf.below_offset[s]);
      }
      for (int32_t s = supernodes - 1; s >= 0; --s)
        if (is_top(s)) backward(s);
      run(tasks, 1, [&](int32_t begin, int32_t end) {
        for (int32_t k = begin; k < end; ++k)
          for (int32_t q = f.task_start[k + 1] - 1; q >= f.task_start[k]; --q) backward(f.task_nodes[q]);
      });
    }
  }
  for (int32_t k = 0; k < f.n; ++k) Eigen::Map<Vec3>(x + 3 * f.order[k]) = z.segment<3>(3 * k);
}

size_t block_ldlt_bytes(const BlockLdlt& l) {
  const ColumnFactor& c = l.columns;
  const SupernodalFactor& sn = l.supernodes;
  size_t b = capacity_bytes(l.order) + capacity_bytes(l.key_read) + capacity_bytes(l.task_start) +
             capacity_bytes(l.task_nodes) + capacity_bytes(l.top_nodes);
  b += capacity_bytes(c.column_start) + capacity_bytes(c.column_row) + capacity_bytes(c.column_key) +
       capacity_bytes(c.diagonal_key) + capacity_bytes(c.l_start) + capacity_bytes(c.l_row) +
       capacity_bytes(c.pattern_start) + capacity_bytes(c.pattern_column) + capacity_bytes(c.pattern_slot) +
       capacity_bytes(c.l_blocks) + capacity_bytes(c.c_inverse) + capacity_bytes(c.work);
  for (const auto& w : c.work) b += capacity_bytes(w);
  b += capacity_bytes(sn.super_start) + capacity_bytes(sn.row_start) + capacity_bytes(sn.super_row) +
       capacity_bytes(sn.panel_start) + capacity_bytes(sn.panel) + capacity_bytes(sn.update_start) +
       capacity_bytes(sn.update_source) + capacity_bytes(sn.update_first) + capacity_bytes(sn.update_last) +
       capacity_bytes(sn.chunk_first) + capacity_bytes(sn.chunk_begin) + capacity_bytes(sn.assembly_start) +
       capacity_bytes(sn.assembly_key) + capacity_bytes(sn.assembly_offset) + capacity_bytes(sn.position) +
       capacity_bytes(sn.below_offset) + capacity_bytes(sn.top_column);
  for (const auto& p : sn.position) b += capacity_bytes(p);
  return b;
}

}  // namespace pt
