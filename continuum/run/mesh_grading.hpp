// Graded coarse grids for scene runs (continuum.mesh_size_near, mesh_grading): deal.II-free, so
// that tests/continuum can check it without the solver.
#pragma once

#include <algorithm>
#include <cmath>
#include <set>
#include <vector>

namespace demfem::continuum {

// Graded steps through every break (sorted): the cell size wanted at x is
// h(x) = min(h0, h_near + (g − 1)·d(x)), d the distance from [lo, hi], i.e. cells growing
// geometrically by g away from the focus (h_{k+1} = g h_k gives h = h_near + (g − 1)·distance).
// Per interval between breaks: n = ⌈∫ dx/h⌉ cells, placed at equal increments of ∫ dx/h.
inline std::vector<double> graded_steps_through(std::set<double> breaks, double h0, double h_near,
                                                double g, double lo, double hi) {
  std::vector<double> out;
  std::vector<double> b(breaks.begin(), breaks.end());
  auto h = [&](double x) {
    const double d = x < lo ? lo - x : (x > hi ? x - hi : 0.0);
    return std::min(h0, h_near + (g - 1.0) * d);
  };
  for (std::size_t i = 0; i + 1 < b.size(); ++i) {
    const double len = b[i + 1] - b[i];
    if (len <= 1e-9 * h0) continue;
    const int m = 4000; // trapezoidal samples of ∫ dx/h over the interval
    std::vector<double> cum(m + 1, 0.0);
    for (int k = 1; k <= m; ++k) {
      const double x0 = b[i] + len * (k - 1) / m, x1 = b[i] + len * k / m;
      cum[k] = cum[k - 1] + 0.5 * (1.0 / h(x0) + 1.0 / h(x1)) * (x1 - x0);
    }
    const int n = std::max(1, static_cast<int>(std::ceil(cum[m] - 1e-9)));
    double prev = b[i];
    int k = 0;
    for (int c = 1; c <= n; ++c) {
      double x = b[i + 1];
      if (c < n) {
        const double target = cum[m] * c / n;
        while (k < m && cum[k + 1] < target) ++k;
        const double f = (target - cum[k]) / std::max(1e-300, cum[k + 1] - cum[k]);
        x = b[i] + len * (k + f) / m;
      }
      out.push_back(x - prev);
      prev = x;
    }
  }
  return out;
}

} // namespace demfem::continuum
