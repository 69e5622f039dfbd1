#include "systems/block_ldlt.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>

#include <algorithm>

namespace pt {

namespace {

// Splits the elimination tree into disjoint subtrees of similar work (updates per column, summed over the
// subtree): starting from the roots, the heaviest subtree is replaced by its children, its root joining
// the serial top, until there are `params.tasks` subtrees or the heaviest is a leaf. With a fill-reducing
// order the top is the chain of the last separators, which is serial work whatever the split. The
// subtrees are then packed into at most `params.tasks` bins, heaviest first into the lightest bin.
void split_into_subtrees(const std::vector<int32_t>& parent, const std::vector<int64_t>& column_work,
                         const BlockLdltParams& params, BlockLdlt& out) {
  const int32_t n = static_cast<int32_t>(parent.size());
  out.task_start.clear();
  out.task_columns.clear();
  out.top_columns.clear();
  if (n < params.min_parallel_blocks || params.tasks < 2) {
    out.task_start = {0, n};
    out.task_columns.resize(n);
    for (int32_t k = 0; k < n; ++k) out.task_columns[k] = k;
    return;
  }
  std::vector<int64_t> subtree_work(column_work);
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
  std::vector<int64_t> bin_work(bins, 0);
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
  out.task_columns.resize(out.task_start[bins]);
  std::vector<int32_t> next(out.task_start.begin(), out.task_start.end() - 1);
  for (int32_t k = 0; k < n; ++k) {
    if (task_of[k] >= 0)
      out.task_columns[next[task_of[k]]++] = k;
    else
      out.top_columns.push_back(k);
  }
}

// Row k of L and the pivot D_k: a sparse triangular solve L(0:k, 0:k) Y = A(0:k, k) in topological order
// (Davis' ldl_numeric over blocks), with the row pattern and slots precomputed. False on a pivot block that
// is not symmetric positive definite (the matrix is not, or lost it to rounding) or not finite.
bool factor_column(const std::vector<Mat3>& values, int32_t k, std::vector<Mat3>& y, BlockLdlt& s) {
  for (int32_t q = s.column_start[k]; q < s.column_start[k + 1]; ++q) y[s.column_row[q]] = values[s.column_key[q]];
  Mat3 d = values[s.diagonal_key[k]];
  for (int32_t t = s.pattern_start[k]; t < s.pattern_start[k + 1]; ++t) {
    const int32_t i = s.pattern_column[t], slot = s.pattern_slot[t];
    const Mat3 yi = y[i];
    y[i].setZero();
    for (int32_t p = s.l_start[i]; p < slot; ++p) y[s.l_row[p]].noalias() -= s.l_blocks[p] * yi;
    const Mat3 lki = yi.transpose() * s.d_inverse[i];  // L(k, i) = Y_iᵀ D_i⁻¹ (D_i symmetric)
    d.noalias() -= lki * yi;
    s.l_blocks[slot] = lki;
  }
  d = 0.5 * (d + d.transpose());
  const Eigen::LLT<Mat3> pivot(d);
  if (pivot.info() != Eigen::Success || !d.allFinite()) return false;
  s.d_inverse[k] = d.inverse();  // closed-form 3x3 (cofactors); d is known SPD here
  return true;
}

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
  std::vector<Eigen::Triplet<double>> entries;
  std::vector<int32_t> outside;
  for (int32_t i = 0; i < m; ++i) {
    entries.emplace_back(i, i, 1.0);
    const int32_t v = vertices[i];
    for (int32_t q = g.start[v]; q < g.start[v + 1]; ++q) {
      const int32_t w = g.adjacent[q];
      if (mark[w] != stamp && halo) {
        if (mark[w] != stamp + 1) {
          mark[w] = stamp + 1;
          local[w] = m + static_cast<int32_t>(outside.size());
          outside.push_back(w);
        }
        entries.emplace_back(i, local[w], 1.0);
        entries.emplace_back(local[w], i, 1.0);
      } else if (mark[w] == stamp) {
        entries.emplace_back(i, local[w], 1.0);
      }
    }
  }
  const int32_t size = m + static_cast<int32_t>(outside.size());
  for (int32_t a = m; a < size; ++a)
    for (int32_t b = m; b < size; ++b) entries.emplace_back(a, b, 1.0);
  Eigen::SparseMatrix<double> pattern(size, size);
  pattern.setFromTriplets(entries.begin(), entries.end());
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> inverse_permutation;  // P⁻¹: new → old
  Eigen::AMDOrdering<int>()(pattern, inverse_permutation);
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
int64_t permute_and_count(int32_t n, const std::vector<std::pair<int32_t, int32_t>>& keys,
                          const std::vector<int32_t>& order, BlockLdlt& out, std::vector<int32_t>& parent,
                          std::vector<int32_t>& count) {
  std::vector<int32_t> rank(n);
  for (int32_t k = 0; k < n; ++k) rank[order[k]] = k;
  out.diagonal_key.assign(n, -1);
  out.column_start.assign(n + 1, 0);
  for (const auto& [r, c] : keys)
    if (rank[r] < rank[c]) ++out.column_start[rank[c] + 1];
  for (int32_t k = 0; k < n; ++k) out.column_start[k + 1] += out.column_start[k];
  out.column_row.resize(out.column_start[n]);
  out.column_key.resize(out.column_start[n]);
  {
    std::vector<int32_t> next(out.column_start.begin(), out.column_start.end() - 1);
    for (int32_t b = 0; b < static_cast<int32_t>(keys.size()); ++b) {
      const int32_t i = rank[keys[b].first], k = rank[keys[b].second];
      if (i == k) out.diagonal_key[k] = b;
      if (i >= k) continue;
      out.column_row[next[k]] = i;
      out.column_key[next[k]++] = b;
    }
  }
  parent.assign(n, -1);
  count.assign(n, 0);
  std::vector<int32_t> flag(n, -1);
  for (int32_t k = 0; k < n; ++k) {
    flag[k] = k;
    for (int32_t q = out.column_start[k]; q < out.column_start[k + 1]; ++q)
      for (int32_t i = out.column_row[q]; flag[i] != k; i = parent[i]) {
        if (parent[i] == -1) parent[i] = k;
        ++count[i];
        flag[i] = k;
      }
  }
  int64_t updates = 0;
  for (int32_t k = 0; k < n; ++k) updates += int64_t{count[k]} * (count[k] + 1) / 2;
  return updates;
}

}  // namespace

void analyze_block_ldlt(int32_t n, const std::vector<std::pair<int32_t, int32_t>>& keys, const BlockLdltParams& params,
                        BlockLdlt& out, const std::vector<Eigen::Vector2d>& coordinates) {
  out = BlockLdlt{};
  out.n = n;

  // Ordering: AMD, or nested dissection when coordinates are given and it needs fewer block updates
  // (AMD wins below a couple of thousand vertices).
  const VertexGraph graph = vertex_graph(n, keys);
  std::vector<int32_t> parent, count;
  out.order = minimum_degree_order(n, graph);
  out.block_updates = permute_and_count(n, keys, out.order, out, parent, count);
  if (static_cast<int32_t>(coordinates.size()) == n && n >= params.min_dissection_blocks) {
    Dissection nd{graph, coordinates, params.dissection_leaf, std::vector<int32_t>(n, 0), std::vector<int32_t>(n), {}};
    std::vector<int32_t> all(n);
    for (int32_t i = 0; i < n; ++i) all[i] = i;
    nd.order.reserve(n);
    nd.dissect(std::move(all));
    BlockLdlt trial;
    std::vector<int32_t> trial_parent, trial_count;
    const int64_t updates = permute_and_count(n, keys, nd.order, trial, trial_parent, trial_count);
    if (updates < out.block_updates) {
      out.order = std::move(nd.order);
      out.block_updates = updates;
      out.column_start = std::move(trial.column_start);
      out.column_row = std::move(trial.column_row);
      out.column_key = std::move(trial.column_key);
      out.diagonal_key = std::move(trial.diagonal_key);
      parent = std::move(trial_parent);
      count = std::move(trial_count);
    }
  }

  // The row patterns of L in topological order with the slot each entry lands in (ldl_numeric's reach,
  // done once here).
  out.l_start.assign(n + 1, 0);
  for (int32_t k = 0; k < n; ++k) out.l_start[k + 1] = out.l_start[k] + count[k];
  out.l_row.resize(out.l_start[n]);
  out.pattern_start.assign(n + 1, 0);
  out.pattern_column.reserve(out.l_start[n]);
  out.pattern_slot.reserve(out.l_start[n]);
  std::vector<int32_t> filled(n, 0), stack(n), path(n), flag(n, -1);
  std::vector<int64_t> column_work(n, 1);  // block updates of each column, for the task split
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
      column_work[k] += slot - out.l_start[i] + 2;
    }
    out.pattern_start[k + 1] = static_cast<int32_t>(out.pattern_column.size());
  }
  out.l_blocks.assign(out.l_start[n], Mat3::Zero());
  out.d_inverse.assign(n, Mat3::Zero());
  split_into_subtrees(parent, column_work, params, out);
  out.work.assign(out.task_start.size(), std::vector<Mat3>(n, Mat3::Zero()));
}

bool factorize_block_ldlt(const std::vector<Mat3>& values, const RangeRunner& run, BlockLdlt& s) {
  s.factorized = false;
  const int32_t tasks = static_cast<int32_t>(s.task_start.size()) - 1;
  std::vector<char> ok(tasks + 1, 1);
  auto factor_columns = [&](const std::vector<int32_t>& columns, int32_t first, int32_t last, int32_t slot) {
    std::vector<Mat3>& y = s.work[slot];
    for (int32_t c = first; c < last; ++c)
      if (!factor_column(values, columns[c], y, s)) {
        for (Mat3& m : y) m.setZero();  // leave the workspace clean for the next factorisation
        ok[slot] = 0;
        return;
      }
  };
  run(tasks, 1, [&](int32_t begin, int32_t end) {
    for (int32_t t = begin; t < end; ++t) factor_columns(s.task_columns, s.task_start[t], s.task_start[t + 1], t);
  });
  for (int32_t t = 0; t < tasks; ++t)
    if (!ok[t]) return false;
  factor_columns(s.top_columns, 0, static_cast<int32_t>(s.top_columns.size()), tasks);
  s.factorized = ok[tasks] != 0;
  return s.factorized;
}

void solve_block_ldlt(const BlockLdlt& s, const double* b, double* x) {
  using Vec3 = Eigen::Vector3d;
  thread_local std::vector<Vec3> z;
  z.resize(s.n);
  for (int32_t k = 0; k < s.n; ++k) z[k] = Eigen::Map<const Vec3>(b + 3 * s.order[k]);
  for (int32_t i = 0; i < s.n; ++i)  // L z = b
    for (int32_t p = s.l_start[i]; p < s.l_start[i + 1]; ++p) z[s.l_row[p]].noalias() -= s.l_blocks[p] * z[i];
  for (int32_t i = 0; i < s.n; ++i) z[i] = s.d_inverse[i] * z[i];
  for (int32_t i = s.n - 1; i >= 0; --i)  // Lᵀ x = D⁻¹ z
    for (int32_t p = s.l_start[i]; p < s.l_start[i + 1]; ++p)
      z[i].noalias() -= s.l_blocks[p].transpose() * z[s.l_row[p]];
  for (int32_t k = 0; k < s.n; ++k) Eigen::Map<Vec3>(x + 3 * s.order[k]) = z[k];
}

}  // namespace pt
