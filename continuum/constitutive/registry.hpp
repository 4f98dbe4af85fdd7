// Constitutive seam: one point-wise interface used by both integrators (implicit Newton and
// explicit central differences). A material integrates a strain increment at a quadrature point
// from its committed state and gives the tangent only when asked. The models are alternatives of
// a std::variant (no virtual call per point); a new model (e.g. a densifying sand) is one more
// alternative plus its `update`, and nothing else changes.
//
// Pure C++ without deal.II; C++17-compatible (the deal.II translation units include it).
// Sign convention and Voigt order as in mohr_coulomb.hpp: tension positive, (xx, zz, γxz).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <variant>

#include "mohr_coulomb.hpp"

namespace demfem::continuum::constitutive {

// Committed or trial state of a point.
struct State {
  mc::ElasticStrain ee;           // elastic strain
  mc::Vec3 stress{{0, 0, 0}};     // σxx, σzz, σxz
  double syy = 0.0;               // out-of-plane stress
  double eps_p[4] = {0, 0, 0, 0}; // plastic strain xx, zz, γxz, yy
  bool plastic = false;           // the last update returned to the yield surface
  // Multiplier of the material's Young's modulus at this point (a stress-dependent modulus,
  // E = E_ref (p/p_ref)^n, fixed from the point's initial stress: StressDependentModulus); 1: E.
  double stiffness = 1.0;
};

// E = E_ref (p/p_ref)^n for a point of in-plane mean stress p = −(σxx + σzz)/2 (compression
// positive, the 2D DEM's confinement σ_c), with p below `min_stress` taken as min_stress and
// the factor capped at `max_factor` (Janbu 1963; Hardin & Richart 1963: G0 ∝ p^n). exponent 0:
// a uniform modulus.
struct StressDependentModulus {
  double exponent = 0.0;
  double reference_stress = 0.0; // p_ref [Pa]: where E_ref (the material's young) holds
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

// The parameters with Young's modulus × f.
inline mc::Parameters with_stiffness(const mc::Parameters& p, double f) {
  mc::Parameters q = p;
  q.young *= f;
  return q;
}

// Linear isotropic elasticity (Hooke).
struct Elastic {
  mc::Parameters p;
};
// Perfectly plastic Mohr–Coulomb with non-associated flow and tension cut-off (mc::integrate),
// and the dilatancy cut-off of p.dilation_cutoff: `p_cut` is p with ψ = 0, used at points whose
// plastic volumetric strain has reached the cut-off.
struct MohrCoulomb {
  mc::Parameters p;
  mc::Parameters p_cut;
};

// Plastic volumetric strain of a point, dilation positive (tension-positive strains; plane
// strain: the out-of-plane plastic strain counts).
inline double plastic_volumetric_strain(const State& s) {
  return s.eps_p[0] + s.eps_p[1] + s.eps_p[3];
}

class Material {
public:
  Material() = default;
  // The model the parameters describe: Mohr–Coulomb when p.plastic, else elastic.
  static Material from(const mc::Parameters& p) {
    Material m;
    if (p.plastic) {
      mc::Parameters cut = p;
      cut.dilation = 0.0;
      m.model_ = MohrCoulomb{p, cut};
    } else
      m.model_ = Elastic{p};
    return m;
  }
  // By name ("elastic", "mohr-coulomb"); throws std::invalid_argument on an unknown name.
  static Material by_name(const std::string& name, mc::Parameters p);

  [[nodiscard]] const mc::Parameters& parameters() const {
    return std::visit([](const auto& m) -> const mc::Parameters& { return m.p; }, model_);
  }
  [[nodiscard]] bool elastic() const { return std::holds_alternative<Elastic>(model_); }

  // Integrate the strain increment `deps` (Δεxx, Δεzz, Δγxz; Δεyy = 0, plane strain) from the
  // committed state `c0` into `s`. When `tangent` is given it receives dσ/dε (the consistent
  // tangent; with `predictor`, a point that was yielding keeps the elastoplastic tangent of the
  // plane it sits on, see mc::integrate). Returns the return-map region.
  mc::Return update(const State& c0, const mc::Vec3& deps, State& s, mc::Mat3* tangent,
                    bool predictor = false) const {
    s.stiffness = c0.stiffness;
    const bool scaled = c0.stiffness != 1.0;
    if (const auto* e = std::get_if<Elastic>(&model_)) {
      mc::Parameters own;
      const mc::Parameters& p = scaled ? (own = with_stiffness(e->p, c0.stiffness)) : e->p;
      s.ee = c0.ee;
      for (int k = 0; k < 3; ++k) s.ee.in_plane[k] += deps[k];
      mc::elastic_stress(p, s.ee, s.stress, s.syy);
      for (int k = 0; k < 4; ++k) s.eps_p[k] = c0.eps_p[k];
      s.plastic = false;
      if (tangent) *tangent = mc::elastic_tangent(p);
      return mc::Return::Elastic;
    }
    const auto& m = std::get<MohrCoulomb>(model_);
    mc::ElasticStrain trial = c0.ee;
    for (int k = 0; k < 3; ++k) trial.in_plane[k] += deps[k];
    // Dilatancy cut-off (mohr_coulomb.hpp): decided on the committed state, so that a step's
    // Newton iterations see one flow rule.
    const bool cut = plastic_volumetric_strain(c0) >= m.p.dilation_cutoff;
    const mc::Parameters& pm = cut ? m.p_cut : m.p;
    const mc::Result r = mc::integrate(scaled ? with_stiffness(pm, c0.stiffness) : pm, trial,
                                       predictor && c0.plastic);
    s.ee = r.elastic;
    s.stress = r.stress;
    s.syy = r.stress_yy;
    s.plastic = r.region != mc::Return::Elastic;
    // plastic strain increment = total − elastic (additive split)
    for (int k = 0; k < 3; ++k)
      s.eps_p[k] = c0.eps_p[k] + deps[k] - (r.elastic.in_plane[k] - c0.ee.in_plane[k]);
    s.eps_p[3] = c0.eps_p[3] - (r.elastic.out_of_plane - c0.ee.out_of_plane);
    if (tangent) *tangent = r.tangent;
    return r.region;
  }

private:
  std::variant<Elastic, MohrCoulomb> model_;
};

} // namespace demfem::continuum::constitutive
