#include "registry.hpp"

#include <stdexcept>

namespace demfem::continuum::constitutive {

Parameters Material::parameters(std::string_view keyword) {
  if (auto p = Registry::defaults(keyword)) return *p;
  throw std::invalid_argument("unknown constitutive model '" + std::string(keyword) +
                              "' (valid: " + keywords() + ")");
}

std::string Material::keywords() {
  std::string s;
  for (const char* k : Registry::keywords) s += (s.empty() ? "" : ", ") + std::string(k);
  return s;
}

void Material::cap_stiffness_at(double p_max) {
  std::visit(
      [&](auto& m) {
        StressDependentModulus& law = m.el.modulus;
        if (!law.active()) return;
        law.max_factor =
            std::pow(std::max(p_max, law.min_stress) / law.reference_stress, law.exponent);
      },
      model_);
}

Material interface_layer(const Material& soil, double friction, double cohesion) {
  MohrCoulomb layer{MohrCoulomb::Parameters{}};
  layer.el = soil.elasticity();
  layer.strength.friction = friction;
  layer.strength.cohesion = cohesion;
  layer.strength.dilation = 0.0;
  if (const auto* mc = soil.get_if<MohrCoulomb>()) {
    layer.strength.tension_cutoff = mc->strength.tension_cutoff;
    layer.dilation_cutoff = mc->dilation_cutoff;
  }
  layer.strength_cut = layer.strength;
  return Material(layer);
}

} // namespace demfem::continuum::constitutive
