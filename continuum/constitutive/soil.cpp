#include "soil.hpp"

#include <stdexcept>
#include <string>

#include "k0.hpp"
#include "registry.hpp"

namespace demfem::continuum::constitutive {

namespace {
template <class Soil> auto& choice_of(Soil& soil) {
  auto* m = soil.model(model_slot().key);
  if (!m)
    throw std::logic_error("the scene's [soil.continuum] was read without the continuum's "
                           "vocabulary (no model slot)");
  return *m;
}
} // namespace

const scene::ModelChoice& soil_model(const scene::ContinuumSoil& soil) {
  return choice_of(soil);
}
scene::ModelChoice& soil_model(scene::ContinuumSoil& soil) {
  return choice_of(soil);
}
const Elastic::Parameters& elastic_block(const scene::ContinuumSoil& soil) {
  return soil_model(soil).get<Elastic::Parameters>();
}
Elastic::Parameters& elastic_block(scene::ContinuumSoil& soil) {
  return soil_model(soil).get<Elastic::Parameters>();
}
const MohrCoulomb::Parameters& strength_block(const scene::ContinuumSoil& soil) {
  return soil_model(soil).get<MohrCoulomb::Parameters>();
}
MohrCoulomb::Parameters& strength_block(scene::ContinuumSoil& soil) {
  return soil_model(soil).get<MohrCoulomb::Parameters>();
}

void choose_model(scene::ContinuumSoil& soil, std::string_view keyword) {
  const scene::ModelSlot slot = model_slot();
  scene::ModelChoice* m = soil.model(slot.key);
  if (!m) m = &soil.models.emplace_back(scene::default_choice(slot));
  if (!scene::choose(*m, slot, keyword))
    throw std::invalid_argument("unknown constitutive model '" + std::string(keyword) +
                                "' (valid: " + Material::keywords() + ")");
}

double soil_k0(const scene::ContinuumSoil& soil) {
  const scene::ModelChoice& m = soil_model(soil);
  // a hypoplastic soil: Jaky's K0 from its critical friction angle
  if (m.keyword == Hypoplastic::keyword)
    return k0_at_rest(soil.k0, m.get<Hypoplastic::Parameters>().critical_friction_angle);
  return k0_at_rest(soil.k0, strength_block(soil).friction_angle);
}

} // namespace demfem::continuum::constitutive
