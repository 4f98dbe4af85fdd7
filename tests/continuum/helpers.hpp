// Shared by the continuum tests: the acceleration of a sampled motion, a fixed rigid wall.
#pragma once

#include <utility>
#include <vector>

#include "fem.hpp"

namespace demfem::test {

// Least-squares fit of q(t) = c0 + c1 t + c2 t² to samples; returns 2 c2 (the acceleration).
inline double fitted_acceleration(const std::vector<std::pair<double, double>>& s) {
  double A[3][3] = {}, b[3] = {};
  for (const auto& [t, q] : s) {
    const double p[3] = {1.0, t, t * t};
    for (int i = 0; i < 3; ++i) {
      b[i] += p[i] * q;
      for (int j = 0; j < 3; ++j) A[i][j] += p[i] * p[j];
    }
  }
  for (int c = 0; c < 3; ++c) // Gaussian elimination (A is SPD)
    for (int r = c + 1; r < 3; ++r) {
      const double f = A[r][c] / A[c][c];
      for (int j = c; j < 3; ++j) A[r][j] -= f * A[c][j];
      b[r] -= f * b[c];
    }
  double x[3];
  for (int c = 2; c >= 0; --c) {
    x[c] = b[c];
    for (int j = c + 1; j < 3; ++j) x[c] -= A[c][j] * x[j];
    x[c] /= A[c][c];
  }
  return 2.0 * x[2];
}

// A rigid wall of thickness t against the soil's right side x = W, from z = 0 to H, every DoF
// fixed, pivot and load point at its base centre.
inline demfem::continuum::fem::Region fixed_rigid_wall(double W, double t, double H, double young) {
  using demfem::continuum::fem::Region;
  Region wall;
  wall.name = "wall";
  wall.outline = {{W, 0}, {W + t, 0}, {W + t, H}, {W, H}};
  wall.material.young = young;
  wall.material.poisson = 0.2;
  wall.rigid = true;
  wall.pivot = wall.load_point = {W + 0.5 * t, 0};
  wall.mode[0] = wall.mode[1] = wall.mode[2] = Region::Mode::Fixed;
  return wall;
}

} // namespace demfem::test
