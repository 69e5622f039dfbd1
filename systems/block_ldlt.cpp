#include "systems/block_ldlt.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>

namespace pt {

void analyze_block_ldlt(int32_t n, const std::vector<std::pair<int32_t, int32_t>>& keys, BlockLdlt& out) {
  out = BlockLdlt{};
  out.n = n;

  // Approximate minimum degree on the vertex graph (Eigen's AMD returns P⁻¹: factor index → matrix index).
  Eigen::SparseMatrix<double> pattern(n, n);
  {
    std::vector<Eigen::Triplet<double>> entries;
    entries.reserve(keys.size());
    for (const auto& [r, c] : keys) entries.emplace_back(r, c, 1.0);
    pattern.setFromTriplets(entries.begin(), entries.end());
  }
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> inverse_permutation;
  Eigen::AMDOrdering<int>()(pattern, inverse_permutation);
  out.order.assign(inverse_permutation.indices().data(), inverse_permutation.indices().data() + n);
  std::vector<int32_t> rank(n);
  for (int32_t k = 0; k < n; ++k) rank[out.order[k]] = k;

  // Upper part of the permuted matrix by columns (counting sort, key order kept inside a column).
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

  // Elimination tree and column counts of L (Davis' ldl_symbolic), then the row patterns of L in
  // topological order with the slot each entry lands in (ldl_numeric's reach, done once here).
  std::vector<int32_t> parent(n, -1), flag(n, -1), count(n, 0);
  for (int32_t k = 0; k < n; ++k) {
    flag[k] = k;
    for (int32_t q = out.column_start[k]; q < out.column_start[k + 1]; ++q)
      for (int32_t i = out.column_row[q]; flag[i] != k; i = parent[i]) {
        if (parent[i] == -1) parent[i] = k;
        ++count[i];
        flag[i] = k;
      }
  }
  out.l_start.assign(n + 1, 0);
  for (int32_t k = 0; k < n; ++k) out.l_start[k + 1] = out.l_start[k] + count[k];
  out.l_row.resize(out.l_start[n]);
  out.pattern_start.assign(n + 1, 0);
  out.pattern_column.reserve(out.l_start[n]);
  out.pattern_slot.reserve(out.l_start[n]);
  std::vector<int32_t> filled(n, 0), stack(n), path(n);
  std::fill(flag.begin(), flag.end(), -1);
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
    }
    out.pattern_start[k + 1] = static_cast<int32_t>(out.pattern_column.size());
  }
  out.l_blocks.assign(out.l_start[n], Mat3::Zero());
  out.d_inverse.assign(n, Mat3::Zero());
  out.work.assign(n, Mat3::Zero());
}

bool factorize_block_ldlt(const std::vector<Mat3>& values, BlockLdlt& s) {
  s.factorized = false;
  std::vector<Mat3>& y = s.work;
  for (int32_t k = 0; k < s.n; ++k) {
    // Row k of L by a sparse triangular solve L(0:k, 0:k) Y = A(0:k, k), in topological order.
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
    // Pivot block: symmetric positive definite, else the matrix is not (or lost it to rounding).
    d = 0.5 * (d + d.transpose());
    const Eigen::LLT<Mat3> pivot(d);
    if (pivot.info() != Eigen::Success || !d.allFinite()) {
      for (Mat3& m : y) m.setZero();
      return false;
    }
    s.d_inverse[k] = d.inverse();  // closed-form 3x3 (cofactors); d is known SPD here
  }
  s.factorized = true;
  return true;
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
