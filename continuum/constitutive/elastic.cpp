#include "elastic.hpp"

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

Elasticity Elastic::Parameters::elasticity() const {
  Elasticity e;
  e.hooke.young = young;
  e.hooke.poisson = poisson;
  if (modulus_exponent != 0.0 && modulus_reference_stress) {
    e.modulus.exponent = modulus_exponent;
    e.modulus.reference_stress = *modulus_reference_stress;
    e.modulus.min_stress = modulus_min_stress.value_or(0.01 * e.modulus.reference_stress);
  }
  return e;
}

} // namespace demfem::continuum::constitutive
