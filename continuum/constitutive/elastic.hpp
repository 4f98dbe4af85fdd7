// Linear isotropic elasticity in plane strain (Hooke), the elastic part every model here shares
// (the Mohr–Coulomb model is elastic–perfectly plastic on it), and the "elastic" model itself.
// Pure C++ without deal.II; C++17-compatible. Conventions: seam.hpp.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "seam.hpp"

namespace demfem::scene {
class ParamVisitor;
struct ModelChoice;
struct ModelEntry;
} // namespace demfem::scene

namespace demfem::continuum::constitutive {

// An optional parameter that is not set (a parameter block's NaN, scene/params.hpp).
inline constexpr double kUnset = std::numeric_limits<double>::quiet_NaN();

// Isotropic elastic constants.
struct Hooke {
  double young = 3.0e7; // E [Pa]
  double poisson = 0.3; // ν
  [[nodiscard]] double shear_modulus() const { return young / (2.0 * (1.0 + poisson)); }
  [[nodiscard]] double lame() const {
    return young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson));
  }
  [[nodiscard]] double bulk_modulus() const { return young / (3.0 * (1.0 - 2.0 * poisson)); }
};

// The constants with Young's modulus × f (a point's stiffness factor).
inline Hooke with_stiffness(const Hooke& h, double f) {
  Hooke q = h;
  q.young *= f;
  return q;
}

// Elastic strain of a point: (εxx, εzz, γxz) in the plane and εyy out of it.
struct ElasticStrain {
  Voigt in_plane{{0.0, 0.0, 0.0}};
  double out_of_plane = 0.0;
};

// Stress from an elastic strain (isotropic Hooke's law, plane strain components).
void elastic_stress(const Hooke& h, const ElasticStrain& e, Voigt& stress, double& stress_yy);
// Elastic strain from a stress (inverse Hooke); a point put at a given stress (K0 state).
[[nodiscard]] ElasticStrain elastic_strain_from_stress(const Hooke& h, const Voigt& stress,
                                                       double stress_yy);
// Plane-strain Hooke matrix dσ/dε (Voigt, engineering shear).
[[nodiscard]] VoigtMatrix elastic_tangent(const Hooke& h);

// E = E_ref (p/p_ref)^n for a point of in-plane mean stress p = −(σxx + σzz)/2 (compression
// positive, the 2D DEM's confinement σ_c), with p below `min_stress` taken as min_stress and
// the factor capped at `max_factor` (Janbu 1963; Hardin & Richart 1963: G0 ∝ p^n). exponent 0:
// a uniform modulus. Fixed per point from its stress after the initial-stress procedure.
struct StressDependentModulus {
  double exponent = 0.0;
  double reference_stress = 0.0; // p_ref [Pa]: where E_ref (the model's young) holds
  double min_stress = 0.0;       // [Pa]
  double max_factor = std::numeric_limits<double>::infinity();
  [[nodiscard]] bool active() const { return exponent != 0.0 && reference_stress > 0.0; }
  // The factor E/E_ref at in-plane mean stress p (compression positive) [Pa].
  [[nodiscard]] double factor(double p) const {
    if (!active()) return 1.0;
    const double f = std::pow(std::max(p, min_stress) / reference_stress, exponent);
    return std::min(f, max_factor);
  }
};

// A model's reference elasticity: its constants at the reference stress and how a point's modulus
// follows its stress. The integrators take the elastic tangent, the wave speeds (absorbing
// boundaries) and the stable explicit step from it.
struct Elasticity {
  Hooke hooke;
  StressDependentModulus modulus;
  [[nodiscard]] VoigtMatrix tangent() const { return elastic_tangent(hooke); }
};

// The "elastic" model: linear isotropic elasticity (Hooke), optionally with a stress-dependent
// modulus.
struct Elastic {
  static constexpr const char* keyword = "elastic";
  // The parameter block of the elasticity (soil.continuum keys; also Mohr–Coulomb's).
  struct Parameters {
    static constexpr const char* kName = "elastic";
    double young = 3.0e7; // E at p_ref [Pa]
    double poisson = 0.3;
    // E = young (p/p_ref)^modulus_exponent (StressDependentModulus); exponent 0: uniform
    double modulus_exponent = 0.0;
    double modulus_reference_stress = kUnset; // p_ref [Pa]
    double modulus_min_stress = kUnset;       // [Pa]; unset: p_ref / 100
    void fields(scene::ParamVisitor& v);
    [[nodiscard]] Elasticity elasticity() const;
    [[nodiscard]] bool stress_dependent() const {
      return modulus_exponent != 0.0 && !std::isnan(modulus_reference_stress);
    }
  };
  struct Internal {
    ElasticStrain ee; // elastic strain (= total strain since the point's stress-free state)
  };

  Elasticity el;

  explicit Elastic(const Parameters& p) : el(p.elasticity()) {}
  explicit Elastic(const Hooke& h) { el.hooke = h; }
  // The registry's entry (keyword, summary, blocks) and the model of a scene's choice.
  static scene::ModelEntry entry();
  static Elastic from(const scene::ModelChoice& choice);

  [[nodiscard]] const Elasticity& elasticity() const { return el; }
  [[nodiscard]] bool symmetric_tangent() const { return true; }
  void set_stress(PointStress& s, Internal& i) const {
    i.ee = elastic_strain_from_stress(
        s.stiffness != 1.0 ? with_stiffness(el.hooke, s.stiffness) : el.hooke, s.stress, s.syy);
  }
  // σ = D (εe + Δε) with the point's modulus; the tangent is D.
  Return update(const PointStress& c0, const Internal& i0, const Voigt& deps, PointStress& s,
                Internal& i, VoigtMatrix* tangent, bool /*predictor*/) const {
    s.stiffness = c0.stiffness;
    Hooke own;
    const Hooke& h =
        c0.stiffness != 1.0 ? (own = with_stiffness(el.hooke, c0.stiffness)) : el.hooke;
    i.ee = i0.ee;
    for (std::size_t k = 0; k < 3; ++k) i.ee.in_plane[k] += deps[k];
    elastic_stress(h, i.ee, s.stress, s.syy);
    if (tangent) *tangent = elastic_tangent(h);
    return Return::Elastic;
  }
  [[nodiscard]] double equivalent_plastic_strain(const Internal&) const { return 0.0; }
  static constexpr std::array<const char*, 0> output_names{}; // no variables of its own
  void output(const Internal&, double*) const {}
};

} // namespace demfem::continuum::constitutive
