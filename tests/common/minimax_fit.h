// The best a node budget can do: the minimax-optimal fit of a piecewise-
// linear visibility function by a subsequence of its own nodes (first and
// last kept), by exhaustive dynamic programming. Written independently of
// the re-compression code it checks (hd/compress.h), so bounds derived from
// it can fail.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "hd/compress.h"

namespace cdsm_test {

// Max |alpha_k - line(z_k)| over the nodes strictly between i and j when
// they are bridged by the line from node i to node j (a vertical bridge,
// equal z, hides its inner nodes).
inline double bridge_error(const std::vector<cdsm::DsmNode>& n, size_t i, size_t j) {
  double zi = n[i].z, zj = n[j].z, ai = n[i].alpha, aj = n[j].alpha;
  if (!(zj > zi)) return 0.0;
  double worst = 0.0;
  for (size_t k = i + 1; k < j; ++k) {
    double w = std::min(1.0, std::max(0.0, (double(n[k].z) - zi) / (zj - zi)));
    worst = std::max(worst, std::fabs(double(n[k].alpha) - (ai + (aj - ai) * w)));
  }
  return worst;
}

// Smallest achievable max |alpha change| keeping at most `m` (>= 2) of the
// nodes, the first and the last among them. O(m n^2) plus O(n^3) bridges.
inline double minimax_fit_error(const std::vector<cdsm::DsmNode>& n, size_t m) {
  const size_t N = n.size();
  if (N <= m || N <= 2) return 0.0;
  std::vector<double> bridge(N * N, 0.0);
  for (size_t i = 0; i < N; ++i)
    for (size_t j = i + 1; j < N; ++j) bridge[i * N + j] = bridge_error(n, i, j);
  const double inf = std::numeric_limits<double>::infinity();
  // best[j]: least max error of a fit of nodes 0..j ending at j, with k nodes.
  std::vector<double> best(N, inf), next(N, inf);
  best[0] = 0.0;
  double answer = inf;
  for (size_t k = 2; k <= m; ++k) {
    std::fill(next.begin(), next.end(), inf);
    for (size_t j = 1; j < N; ++j)
      for (size_t i = 0; i < j; ++i)
        if (best[i] < inf) next[j] = std::min(next[j], std::max(best[i], bridge[i * N + j]));
    best.swap(next);
    answer = std::min(answer, best[N - 1]);
  }
  return answer;
}

// sup over z of |f(z) - g(z)| of two node lists (piecewise linear, steps as
// equal-z pairs, 0 before the first node, the last value after the last),
// evaluated at every node of both with both one-sided values.
inline double sup_change(const std::vector<cdsm::DsmNode>& f, const std::vector<cdsm::DsmNode>& g) {
  // The value just before z (left limit) or just after it (right limit).
  auto value = [](const std::vector<cdsm::DsmNode>& n, double z, bool right) -> double {
    auto lerp = [](const cdsm::DsmNode& a, const cdsm::DsmNode& b, double x) {
      return a.alpha + (double(b.alpha) - a.alpha) * (x - a.z) / (double(b.z) - a.z);
    };
    if (n.empty()) return 0.0;
    if (right) {  // j: first node with z_j > z
      size_t j =
          size_t(std::upper_bound(n.begin(), n.end(), z, [](double v, const cdsm::DsmNode& a) { return v < a.z; }) -
                 n.begin());
      if (j == 0) return 0.0;
      if (j == n.size() || double(n[j - 1].z) == z) return n[j - 1].alpha;
      return lerp(n[j - 1], n[j], z);
    }
    // j: first node with z_j >= z
    size_t j = size_t(
        std::lower_bound(n.begin(), n.end(), z, [](const cdsm::DsmNode& a, double v) { return a.z < v; }) - n.begin());
    if (j == 0) return 0.0;
    if (j == n.size()) return n.back().alpha;
    return lerp(n[j - 1], n[j], z);
  };
  double worst = 0.0;
  for (const auto* list : {&f, &g})
    for (const cdsm::DsmNode& nd : *list)
      for (bool right : {false, true})
        worst = std::max(worst, std::fabs(value(f, nd.z, right) - value(g, nd.z, right)));
  return worst;
}

}  // namespace cdsm_test
