// Closed-form verification problems shared by the tests and the error-vs-time study (issue 11).
#include "demfem/continuum/verification.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "fem.hpp"

namespace demfem::continuum {

std::vector<double> graded(double fine, double h0, double length, double growth) {
  std::vector<double> d;
  double x = 0.0;
  while (x < fine - 1e-12) {
    d.push_back(h0);
    x += h0;
  }
  double h = h0;
  while (x < length - 1e-9) {
    h = std::min(h * growth, length - x);
    if (length - x - h < 0.5 * h) h = length - x; // no sliver at the end
    d.push_back(h);
    x += h;
  }
  return d;
}

namespace {
// sizes growing geometrically from h0 (after a uniform zone of length `fine`) until `length`
} // namespace

FlamantResult flamant_strip_load(int refinement, int degree) {
  fem::ensure_mpi();
  fem::Problem pb;
  const double L = 200.0, b = 1.0, q = 1.0e5, E = 2.0e7, nu = 0.3;
  pb.mesh.x0 = 0.0;
  pb.mesh.z0 = -L;
  pb.mesh.dx = graded(2.0 * b, 0.25 * b, L, 1.35);
  pb.mesh.dz = graded(2.0 * b, 0.25 * b, L, 1.35);
  std::reverse(pb.mesh.dz.begin(), pb.mesh.dz.end()); // fine at the top
  pb.mesh.refinement = refinement;
  pb.degree = degree;
  pb.soil = constitutive::Material(constitutive::Elastic(constitutive::Hooke{E, nu}));
  pb.gravity = 0.0;
  pb.left = fem::Bc::Roller; // symmetry plane x = 0
  pb.tractions.push_back({{0.0, 0.0}, {b, 0.0}, q});
  fem::Model m(pb);
  const fem::StepStats st = m.static_step(1.0);
  FlamantResult r;
  r.converged = st.converged;
  r.dofs = m.n_dofs();
  r.h_min = 0.25 * b / std::pow(2.0, refinement);
  r.computed = -m.displacement({0.0, 0.0}).z + m.displacement({b, 0.0}).z;
  // Poulos & Davis (1974), strip load on an elastic half-plane (Flamant): relative settlement
  r.exact = 4.0 * std::log(2.0) / std::numbers::pi * (1 - nu * nu) * q * b / E;
  return r;
}

} // namespace demfem::continuum
