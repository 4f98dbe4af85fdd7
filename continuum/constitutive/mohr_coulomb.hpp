// Constitutive point for plane strain: linear elasticity and perfectly plastic Mohr–Coulomb with
// non-associated flow (dilation angle ψ) and a tension cut-off. Pure C++ (no deal.II); this
// header must stay C++17-compatible because the deal.II translation unit includes it.
//
// Sign convention: tension positive (continuum mechanics). Vectors in Voigt order for the
// in-plane part: stress (σxx, σzz, σxz), strain (εxx, εzz, γxz = 2εxz). The out-of-plane
// stress σyy is carried separately (plane strain: total εyy = 0).
#pragma once

#include <array>
#include <limits>

namespace demfem::continuum::mc {

using Vec3 = std::array<double, 3>;
using Mat3 = std::array<std::array<double, 3>, 3>;

struct Parameters {
  double young = 3.0e7;
  double poisson = 0.3;
  bool plastic = false;         // false: linear elastic
  double friction = 0.5236;     // φ [rad]
  double cohesion = 0.0;        // c [Pa]
  double dilation = 0.0;        // ψ [rad]
  double tension_cutoff = -1.0; // t [Pa]: max principal stress; < 0 = none (only the MC apex)
  // Dilatancy cut-off: a point whose plastic volumetric strain (dilation positive) has reached
  // this value flows with ψ = 0 from then on (PLAXIS Material Models Manual, Mohr–Coulomb
  // "dilatancy cut-off": a soil stops dilating at its loosest, critical state). Without it a
  // constant ψ dilates a yielding mass without bound (constitutive::Material::update applies it).
  double dilation_cutoff = std::numeric_limits<double>::infinity();

  [[nodiscard]] double shear_modulus() const { return young / (2.0 * (1.0 + poisson)); }
  [[nodiscard]] double lame() const {
    return young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson));
  }
  [[nodiscard]] double bulk_modulus() const { return young / (3.0 * (1.0 - 2.0 * poisson)); }
};

// Which return the mapping took (for tests and statistics).
enum class Return {
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

// Elastic strain state of the point. εe = (εxx, εzz, γxz) in-plane + εyy out of plane.
struct ElasticStrain {
  Vec3 in_plane{{0.0, 0.0, 0.0}};
  double out_of_plane = 0.0;
};

struct Result {
  Vec3 stress{{0.0, 0.0, 0.0}}; // σxx, σzz, σxz
  double stress_yy = 0.0;       // out of plane
  ElasticStrain elastic;        // elastic strain after the return (= new state)
  Mat3 tangent{};               // consistent tangent dσ/dε (in-plane Voigt, engineering shear)
  Return region = Return::Elastic;
  double plastic_multiplier = 0.0; // Σ Δγ
};

// Stress from an elastic strain (isotropic Hooke's law, plane strain components).
void elastic_stress(const Parameters& p, const ElasticStrain& e, Vec3& stress, double& stress_yy);
// Elastic strain from a stress (inverse Hooke); used to start from geostatic stresses.
ElasticStrain elastic_strain_from_stress(const Parameters& p, const Vec3& stress, double stress_yy);
[[nodiscard]] Mat3 elastic_tangent(const Parameters& p);

// Yield function values of the principal stresses (sorted σ1 ≥ σ2 ≥ σ3, tension positive):
// Mohr–Coulomb main plane, de Souza Neto, Perić & Owen (2008) eq. (6.118).
[[nodiscard]] double mc_yield(const Parameters& p, double s1, double s3);

// Return mapping in principal stresses, de Souza Neto, Perić & Owen (2008) §8.2 (Boxes 8.4–8.5),
// generalised to non-associated flow and a tension cut-off by solving the linear multi-surface
// closest-point system of each candidate active set (all surfaces are planes in principal space).
// trial: elastic trial strain εe_n + Δε (Δεyy = 0 in plane strain).
// plastic_predictor: a trial stress on the Mohr–Coulomb main plane (|Φ| within 1e-6 of the stress
// scale, not beyond it) keeps its stress but gets the elastoplastic (continuum) tangent of the main
// plane instead of the elastic one (region stays Elastic). For the first Newton iteration of a
// step at points that were yielding at the end of the previous one, where the elastic tangent
// overshoots (de Souza Neto et al. 2008 §4.1: the tangent of the last converged state).
Result integrate(const Parameters& p, const ElasticStrain& trial, bool plastic_predictor = false);

} // namespace demfem::continuum::mc
