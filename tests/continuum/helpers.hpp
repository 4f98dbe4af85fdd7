// Shared by the continuum tests: soil models, the acceleration of a sampled motion, a fixed rigid
// wall.
#pragma once

#include <algorithm>
#include <utility>
#include <vector>

#include "demfem/continuum/verification.hpp"
#include "fem.hpp"

namespace demfem::test {

// An elastic soil, and a Mohr–Coulomb one (angles [rad]), for fem::Problem::soil.
inline continuum::constitutive::Material elastic_soil(double young, double poisson) {
  namespace cst = continuum::constitutive;
  return cst::Material(cst::Elastic(cst::Hooke{young, poisson}));
}
inline continuum::constitutive::Material mohr_coulomb_soil(double young, double poisson,
                                                           double friction, double cohesion,
                                                           double dilation = 0.0) {
  namespace cst = continuum::constitutive;
  cst::Elastic::Parameters e;
  e.young = young;
  e.poisson = poisson;
  cst::MohrCoulomb::Parameters p;
  p.friction_angle = friction;
  p.cohesion = cohesion;
  p.dilation_angle = dilation;
  return cst::Material(cst::MohrCoulomb(e, p));
}

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

// The strip-footing problems' half space (x ≥ 0, the symmetry line at x = 0, surface z = 0):
// weightless undrained clay (φ = ψ = 0, cohesion c, E = 10 MPa, ν = 0.3) 5 B deep and wide, cells
// of B/16 under the footing growing by `growth` away from it (the Prandtl (2 + π)c tests).
inline demfem::continuum::fem::Problem undrained_half_space(double B, double c, double growth) {
  demfem::continuum::fem::Problem pb;
  pb.mesh.x0 = 0.0;
  pb.mesh.z0 = -5.0 * B;
  pb.mesh.dx = demfem::continuum::graded(1.0 * B, 0.0625 * B, 5.0 * B, growth);
  pb.mesh.dz = demfem::continuum::graded(1.0 * B, 0.0625 * B, 5.0 * B, growth);
  std::reverse(pb.mesh.dz.begin(), pb.mesh.dz.end());
  pb.soil = mohr_coulomb_soil(1.0e7, 0.3, 0.0, c);
  pb.gravity = 0.0;
  return pb;
}

} // namespace demfem::test
