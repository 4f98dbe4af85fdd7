#include "elastic.hpp"

#include "demfem/scene/params.hpp"

namespace demfem::continuum::constitutive {

void elastic_stress(const Hooke& h, const ElasticStrain& e, Voigt& stress, double& stress_yy) {
  const double lam = h.lame(), G = h.shear_modulus();
  const double tr = e.in_plane[0] + e.in_plane[1] + e.out_of_plane;
  // Hooke's law σ = λ tr(ε) 1 + 2G ε (isotropic linear elasticity)
  stress = {lam * tr + 2 * G * e.in_plane[0], lam * tr + 2 * G * e.in_plane[1], G * e.in_plane[2]};
  stress_yy = lam * tr + 2 * G * e.out_of_plane;
}

ElasticStrain elastic_strain_from_stress(const Hooke& h, const Voigt& s, double syy) {
  const double E = h.young, nu = h.poisson;
  const double tr = s[0] + s[1] + syy;
  // Inverse Hooke: ε = ((1+ν)σ − ν tr(σ) 1)/E
  ElasticStrain e;
  e.in_plane = {((1 + nu) * s[0] - nu * tr) / E, ((1 + nu) * s[1] - nu * tr) / E,
                2.0 * (1 + nu) * s[2] / E};
  e.out_of_plane = ((1 + nu) * syy - nu * tr) / E;
  return e;
}

VoigtMatrix elastic_tangent(const Hooke& h) {
  const double lam = h.lame(), G = h.shear_modulus();
  // Plane-strain Hooke matrix (Voigt, engineering shear)
  return VoigtMatrix{{{lam + 2 * G, lam, 0.0}, {lam, lam + 2 * G, 0.0}, {0.0, 0.0, G}}};
}

void Elastic::Parameters::fields(scene::ParamVisitor& v) {
  using scene::Field;
  v.number({"young", "E", "Pa",
            "Young's modulus of the soil (at modulus_reference_stress with a stress-dependent "
            "modulus)"},
           young, scene::positive());
  v.number({"poisson", "ν", "", "Poisson's ratio of the soil"}, poisson,
           scene::in_range(-1.0, 0.5, true));
  v.number({"modulus_exponent", "n", "",
            "stress-dependent modulus E = young (p/p_ref)^n at a point's in-plane mean stress p "
            "after the initial stresses (Janbu 1963); 0: uniform",
            scene::Scale::none, Field::Value::nonzero},
           modulus_exponent, scene::in_range(0.0, 1.0));
  v.number({"modulus_reference_stress", "p_ref", "Pa",
            "the mean stress at which young holds (needed when modulus_exponent > 0)",
            scene::Scale::none, Field::Value::optional},
           modulus_reference_stress, scene::positive());
  v.number({"modulus_min_stress", "p_min", "Pa",
            "mean stress below which the modulus stays at its value there (unset: p_ref / 100)",
            scene::Scale::none, Field::Value::optional},
           modulus_min_stress, scene::non_negative());
}

Elasticity Elastic::Parameters::elasticity() const {
  Elasticity e;
  e.hooke.young = young;
  e.hooke.poisson = poisson;
  if (modulus_exponent != 0.0 && !std::isnan(modulus_reference_stress)) {
    e.modulus.exponent = modulus_exponent;
    e.modulus.reference_stress = modulus_reference_stress;
    e.modulus.min_stress =
        std::isnan(modulus_min_stress) ? 0.01 * e.modulus.reference_stress : modulus_min_stress;
  }
  return e;
}

scene::ModelEntry Elastic::entry() {
  return {keyword,
          "linear isotropic elasticity (Hooke), optionally a stress-dependent modulus",
          {scene::ParamBlock(Parameters{})}};
}

Elastic Elastic::from(const scene::ModelChoice& choice) {
  return Elastic(choice.get<Parameters>());
}

} // namespace demfem::continuum::constitutive
