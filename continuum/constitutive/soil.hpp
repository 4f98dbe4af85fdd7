// The continuum soil of a scene ([soil.continuum]) as the constitutive models read it: its model
// choice (model_slot(), read through the vocabulary) and the parameter blocks every choice holds,
// its K0. For the C++20 side (run/, the report, calibration); the deal.II translation units do
// not include it (scene.hpp is C++20).
#pragma once

#include <string_view>

#include "demfem/scene/scene.hpp"
#include "elastic.hpp"
#include "mohr_coulomb.hpp"

namespace demfem::continuum::constitutive {

// The soil's model choice; throws std::logic_error when the scene was read without the
// continuum's vocabulary (no soil.continuum.model slot).
[[nodiscard]] const scene::ModelChoice& soil_model(const scene::ContinuumSoil& soil);
[[nodiscard]] scene::ModelChoice& soil_model(scene::ContinuumSoil& soil);
// The blocks every choice holds, whichever model it chose (the slot reads all of them): the
// elasticity and the Mohr–Coulomb strength (its friction angle also gives K0).
[[nodiscard]] const Elastic::Parameters& elastic_block(const scene::ContinuumSoil& soil);
[[nodiscard]] Elastic::Parameters& elastic_block(scene::ContinuumSoil& soil);
[[nodiscard]] const MohrCoulomb::Parameters& strength_block(const scene::ContinuumSoil& soil);
[[nodiscard]] MohrCoulomb::Parameters& strength_block(scene::ContinuumSoil& soil);
// A soil built in code: the slot at its defaults with `keyword` chosen (an unknown one throws).
void choose_model(scene::ContinuumSoil& soil, std::string_view keyword);
// K0 of the initial stresses: soil.k0 when stated, else Jaky's from the friction angle (the
// critical friction angle φ_c of a hypoplastic soil, Mohr–Coulomb's friction_angle otherwise).
[[nodiscard]] double soil_k0(const scene::ContinuumSoil& soil);

} // namespace demfem::continuum::constitutive
