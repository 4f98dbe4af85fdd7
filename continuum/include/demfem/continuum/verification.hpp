// Closed-form verification problems of the continuum solver that no scene expresses (a flexible
// strip load on a half-plane), shared by tests/continuum and `demfem study error-vs-time
// flamant` so that the problem and its closed form exist once.
#pragma once

#include <cstddef>
#include <vector>

namespace demfem::continuum {

struct FlamantResult {
  double computed = 0.0;  // settlement(centre) − settlement(edge) of the strip [m]
  double exact = 0.0;     // the closed form [m]
  std::size_t dofs = 0;   // degrees of freedom of the mesh
  double h_min = 0.0;     // smallest cell size (under the strip) [m]
  bool converged = false; // the static step converged
};

// Flamant strip load on an elastic half-plane (Poulos & Davis 1974, strip of half-width b = 1 m,
// q = 100 kPa, E = 20 MPa, ν = 0.3): settlement(centre) − settlement(edge) =
// (4 ln 2/π)(1 − ν²) q b / E. Half of a 200 m × 200 m block (symmetry plane x = 0), cells of
// b/4 under the strip growing by 1.35 outwards, `refinement` global refinements, elements of
// polynomial `degree`.
[[nodiscard]] FlamantResult flamant_strip_load(int refinement, int degree = 2);

// Cell sizes: uniform h0 over `fine`, then growing geometrically by `growth` up to `length`
// (the last cell absorbs a sliver). Shared by the verification problems and their tests.
[[nodiscard]] std::vector<double> graded(double fine, double h0, double length, double growth);

} // namespace demfem::continuum
