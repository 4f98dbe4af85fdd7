// The "mohr-coulomb" model: linear elasticity (elastic.hpp) and perfectly plastic Mohr–Coulomb
// in plane strain with non-associated flow (dilation angle ψ), a tension cut-off, a dilatancy
// cut-off and the stress-dependent modulus of its elasticity. Pure C++ without deal.II;
// C++17-compatible. Conventions: seam.hpp (tension positive, Voigt (xx, zz, xz), σyy apart).
#pragma once

#include <array>
#include <cmath>
#include <limits>

#include "elastic.hpp"
#include "seam.hpp"

namespace demfem::scene {
class ParamCheck;
} // namespace demfem::scene

namespace demfem::continuum::constitutive {

// Radians per degree (the file states angles in degrees).
inline constexpr double kRadPerDeg = 3.14159265358979323846 / 180.0;

namespace mohr_coulomb {

// The strength of the return mapping.
struct Strength {
  double friction = 0.5236;     // φ [rad]
  double cohesion = 0.0;        // c [Pa]
  double dilation = 0.0;        // ψ [rad]
  double tension_cutoff = -1.0; // t [Pa]: max principal stress; < 0 = none (only the MC apex)
};

struct Result {
  Voigt stress{{0.0, 0.0, 0.0}}; // σxx, σzz, σxz
  double stress_yy = 0.0;        // out of plane
  ElasticStrain elastic;         // elastic strain after the return (= new state)
  VoigtMatrix tangent{};         // consistent tangent dσ/dε (in-plane Voigt, engineering shear)
  Return region = Return::Elastic;
  double plastic_multiplier = 0.0; // Σ Δγ
};

// Yield function values of the principal stresses (sorted σ1 ≥ σ2 ≥ σ3, tension positive):
// Mohr–Coulomb main plane, de Souza Neto, Perić & Owen (2008) eq. (6.118).
[[nodiscard]] double yield(const Strength& s, double s1, double s3);

// Return mapping in principal stresses, de Souza Neto, Perić & Owen (2008) §8.2 (Boxes 8.4–8.5),
// generalised to non-associated flow and a tension cut-off by solving the linear multi-surface
// closest-point system of each candidate active set (all surfaces are planes in principal space).
// trial: elastic trial strain εe_n + Δε (Δεyy = 0 in plane strain).
// plastic_predictor: a trial stress on the Mohr–Coulomb main plane (|Φ| within 1e-6 of the stress
// scale, not beyond it) keeps its stress but gets the elastoplastic (continuum) tangent of the main
// plane instead of the elastic one (region stays Elastic). For the first Newton iteration of a
// step at points that were yielding at the end of the previous one, where the elastic tangent
// overshoots (de Souza Neto et al. 2008 §4.1: the tangent of the last converged state).
Result integrate(const Hooke& e, const Strength& s, const ElasticStrain& trial,
                 bool plastic_predictor = false);

} // namespace mohr_coulomb

struct MohrCoulomb {
  static constexpr const char* keyword = "mohr-coulomb";
  // Its parameter blocks (soil.continuum keys): the elasticity (Elastic::Parameters) and the
  // strength below. The file states the angles in degrees.
  struct Parameters {
    static constexpr const char* kName = "mohr-coulomb";
    double friction_angle = 30.0 * kRadPerDeg; // φ [rad]
    double cohesion = 0.0;                     // c [Pa]
    double dilation_angle = 0.0;               // ψ [rad]
    double tension_cutoff = 0.0;               // [Pa], the largest principal stress; 0 = none
    // Dilatancy cut-off: a point whose plastic volumetric strain (dilation positive) has reached
    // this value flows with ψ = 0 from then on (PLAXIS Material Models Manual, Mohr–Coulomb
    // "dilatancy cut-off": a soil stops dilating at its loosest, critical state). Without it a
    // constant ψ dilates a yielding mass without bound. Unset (NaN): none.
    double dilation_cutoff = kUnset;
    void fields(scene::ParamVisitor& v);
    void check(scene::ParamCheck& c) const; // ψ ≤ φ
  };
  struct Internal {
    ElasticStrain ee;                          // elastic strain
    std::array<double, 4> eps_p{{0, 0, 0, 0}}; // plastic strain xx, zz, γxz, yy
    bool plastic = false;                      // the last update returned to the yield surface
  };

  Elasticity el;
  mohr_coulomb::Strength strength;     // with ψ
  mohr_coulomb::Strength strength_cut; // with ψ = 0: past the dilatancy cut-off
  double dilation_cutoff = std::numeric_limits<double>::infinity();

  MohrCoulomb(const Elastic::Parameters& elastic, const Parameters& p);
  // The registry's entry (keyword, summary, blocks) and the model of a scene's choice.
  static scene::ModelEntry entry();
  static MohrCoulomb from(const scene::ModelChoice& choice);

  [[nodiscard]] const Elasticity& elasticity() const { return el; }
  // Non-associated flow (ψ ≠ φ) makes the consistent tangent non-symmetric; a dilatancy cut-off
  // turns ψ to 0 at some points: symmetric only when ψ = φ = 0 there too.
  [[nodiscard]] bool symmetric_tangent() const {
    const bool cutoff = std::isfinite(dilation_cutoff) && strength.friction > 1e-12;
    return std::abs(strength.friction - strength.dilation) < 1e-12 && !cutoff;
  }
  void set_stress(PointStress& s, Internal& i) const {
    i.ee = elastic_strain_from_stress(
        s.stiffness != 1.0 ? with_stiffness(el.hooke, s.stiffness) : el.hooke, s.stress, s.syy);
  }
  // Plastic volumetric strain of a point, dilation positive (tension-positive strains; plane
  // strain: the out-of-plane plastic strain counts).
  [[nodiscard]] static double plastic_volumetric_strain(const Internal& i) {
    return i.eps_p[0] + i.eps_p[1] + i.eps_p[3];
  }
  // The return mapping of the trial εe + Δε (mohr_coulomb::integrate) with the point's modulus.
  // `predictor`: a point that was yielding keeps the elastoplastic tangent of the plane it sits
  // on. The consistent tangent at the apex is zero (perfect plasticity); a whole element at the
  // apex would make a global stiffness singular, so 1e-4 of the elastic tangent is returned
  // there (it affects the Newton rate only, never the converged stresses).
  Return update(const PointStress& c0, const Internal& i0, const Voigt& deps, PointStress& s,
                Internal& i, VoigtMatrix* tangent, bool predictor) const {
    s.stiffness = c0.stiffness;
    ElasticStrain trial = i0.ee;
    for (std::size_t k = 0; k < 3; ++k) trial.in_plane[k] += deps[k];
    // Dilatancy cut-off: decided on the committed state, so that a step's Newton iterations see
    // one flow rule.
    const mohr_coulomb::Strength& st =
        plastic_volumetric_strain(i0) >= dilation_cutoff ? strength_cut : strength;
    const mohr_coulomb::Result r = mohr_coulomb::integrate(
        c0.stiffness != 1.0 ? with_stiffness(el.hooke, c0.stiffness) : el.hooke, st, trial,
        predictor && i0.plastic);
    i.ee = r.elastic;
    s.stress = r.stress;
    s.syy = r.stress_yy;
    i.plastic = r.region != Return::Elastic;
    // plastic strain increment = total − elastic (additive split)
    for (std::size_t k = 0; k < 3; ++k)
      i.eps_p[k] = i0.eps_p[k] + deps[k] - (r.elastic.in_plane[k] - i0.ee.in_plane[k]);
    i.eps_p[3] = i0.eps_p[3] - (r.elastic.out_of_plane - i0.ee.out_of_plane);
    if (tangent) {
      if (r.region == Return::Apex || r.region == Return::TensionApex) {
        const VoigtMatrix De = el.tangent();
        for (std::size_t a = 0; a < 3; ++a)
          for (std::size_t b = 0; b < 3; ++b) (*tangent)[a][b] = 1e-4 * De[a][b];
      } else {
        *tangent = r.tangent;
      }
    }
    return r.region;
  }
  // √(2/3 εp:εp) (tensor components: the engineering shear halved)
  // The snapshots' plastic_strain column holds its variables (equivalent_plastic_strain).
  static constexpr std::array<const char*, 0> output_names{};
  void output(const Internal&, double*) const {}
  [[nodiscard]] double equivalent_plastic_strain(const Internal& i) const {
    const auto& e = i.eps_p;
    const double e2 = e[0] * e[0] + e[1] * e[1] + e[3] * e[3] + 0.5 * e[2] * e[2];
    return std::sqrt(2.0 / 3.0 * e2);
  }
};

} // namespace demfem::continuum::constitutive
