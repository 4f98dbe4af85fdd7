// The constitutive seam: what a soil model is to the continuum's two integrators (implicit
// Newton, explicit central differences). At a quadrature point a model integrates a strain
// increment from the point's committed state and returns the new stress together with its
// tangent dσ/dε when asked (deal.II step-42: the law gives the stress and its tangent together).
// The integrators read a point's stress, its stiffness factor and the model's reference
// elasticity (elastic tangent, wave speeds, stable step), and nothing else of a model.
//
// A model is a type with
//   static constexpr const char* keyword;   its name (soil.continuum.model)
//   struct Internal;                        its own per-point variables (trivially copyable)
//   static scene::ModelEntry entry();       its keyword, summary and parameter blocks (each a
//                                           struct that lists its keys: scene/params.hpp)
//   static Model from(const scene::ModelChoice&);   the model of a scene's choice
//   const Elasticity& elasticity() const;   its reference elasticity (elastic.hpp)
//   bool symmetric_tangent() const;         whether every tangent it returns is symmetric
//   void set_stress(PointStress&, Internal&) const;   a point put at the stress in PointStress
//   Return update(const PointStress& c0, const Internal& i0, const Voigt& deps, PointStress& s,
//                 Internal& i, VoigtMatrix* tangent, bool predictor) const;
//   double equivalent_plastic_strain(const Internal&) const;   √(2/3 εp:εp), for output
//   static constexpr std::array<const char*, N> output_names;  its own point variables in the
//   void output(const Internal&, double* values) const;        snapshots (N may be 0)
// and is listed in registry.hpp. `update` may sub-step the increment and may give a numerical
// tangent (numerical_tangent below).
//
// Pure C++ without deal.II; C++17-compatible (the deal.II translation units include it).
// Sign convention: tension positive (continuum mechanics). Voigt order (xx, zz, xz) in the plane:
// stress (σxx, σzz, σxz), strain (εxx, εzz, γxz = 2εxz). Plane strain: the total εyy is 0 and
// the out-of-plane stress σyy is carried separately.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <type_traits>
#include <variant>

namespace demfem::continuum::constitutive {

using Voigt = std::array<double, 3>;
using VoigtMatrix = std::array<Voigt, 3>; // [i][j] = dσ_i/dε_j (engineering shear)

// Where a stress update ended (statistics, Newton traces): elastic, or the yield surfaces a
// return mapping landed on. A model without surfaces reports Elastic.
enum class Return : unsigned char {
  Elastic,
  MainPlane,
  EdgeLeft,
  EdgeRight,
  Apex,
  Tension,
  TensionMain,
  TensionEdge,
  TensionApex
};
inline constexpr std::array<const char*, 9> kReturnNames = {
    {"el", "main", "edgeL", "edgeR", "apex", "t", "t+main", "t+edge", "t+apex"}};

// What every model keeps at a point and the integrators read.
struct PointStress {
  Voigt stress{{0.0, 0.0, 0.0}}; // σxx, σzz, σxz
  double syy = 0.0;              // σyy (out of plane)
  // Multiplier of the model's reference modulus at this point (a stress-dependent modulus,
  // elastic.hpp StressDependentModulus); 1: the reference. Stiffness-proportional damping and the
  // explicit stable step follow it.
  double stiffness = 1.0;
};

// The registered models (registry.hpp): their variant and their points' internal variables (one
// alternative per model, in the same order), and their keywords.
template <class... Models> struct ModelList {
  using Model = std::variant<Models...>;
  using Internal = std::variant<typename Models::Internal...>;
  static constexpr std::size_t size = sizeof...(Models);
  static constexpr std::array<const char*, size> keywords{{Models::keyword...}};

  template <class M> static constexpr bool contains = (std::is_same_v<M, Models> || ...);
  // The position of model M in the list.
  template <class M> static constexpr std::size_t index() {
    static_assert(contains<M>, "not a registered model");
    constexpr bool same[] = {std::is_same_v<M, Models>...};
    std::size_t k = 0;
    while (!same[k]) ++k;
    return k;
  }
};

// dσ/dε by central differences of a stress update: column j from stress_at(Δε ± h e_j), with
// h = step × max(|Δε|_∞, floor) (for a model whose consistent tangent is not written out, e.g. an
// explicitly sub-stepped rate-type law). stress_at: Voigt → Voigt, the stress after the increment
// from the same committed state.
template <class StressAt>
VoigtMatrix numerical_tangent(const StressAt& stress_at, const Voigt& deps, double step = 1e-6,
                              double floor = 1e-6) {
  double size = floor;
  for (double d : deps) size = std::max(size, std::abs(d));
  const double h = step * size;
  VoigtMatrix t{};
  for (std::size_t j = 0; j < 3; ++j) {
    Voigt a = deps, b = deps;
    a[j] += h;
    b[j] -= h;
    const Voigt sa = stress_at(a), sb = stress_at(b);
    for (std::size_t i = 0; i < 3; ++i) t[i][j] = (sa[i] - sb[i]) / (2.0 * h);
  }
  return t;
}

} // namespace demfem::continuum::constitutive
