#include "registry.hpp"

#include <optional>
#include <stdexcept>

#include "demfem/scene/params.hpp"

namespace demfem::continuum::constitutive {

namespace {
template <class... Ms> void add_entries(scene::ModelSlot& slot, ModelList<Ms...>) {
  (slot.entries.push_back(Ms::entry()), ...);
}
template <class... Ms>
std::optional<Material> make(const scene::ModelChoice& choice, ModelList<Ms...>) {
  std::optional<Material> m;
  ((choice.keyword == Ms::keyword ? (void)m.emplace(Ms::from(choice)) : void()), ...);
  return m;
}
} // namespace

scene::ModelSlot model_slot() {
  scene::ModelSlot slot;
  slot.key = "model";
  slot.meaning = "the soil's constitutive model";
  slot.default_keyword = MohrCoulomb::keyword;
  slot.always_written = true;
  add_entries(slot, Registry{});
  return slot;
}

Material Material::from(const scene::ModelChoice& choice) {
  if (auto m = make(choice, Registry{})) return *m;
  throw std::invalid_argument("unknown constitutive model '" + choice.keyword +
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
  MohrCoulomb layer(Elastic::Parameters{}, MohrCoulomb::Parameters{});
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
