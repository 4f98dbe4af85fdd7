// The DEM's part of the scene vocabulary (scene/vocabulary.hpp): the slots of [soil.dem] (the
// contact law and its sub-models, dem/contact/registry.hpp) and the stable time-step limit
// (stable_step.hpp). app::vocabulary() adds the continuum's part.
#pragma once

#include "demfem/scene/vocabulary.hpp"

namespace demfem::dem {

[[nodiscard]] scene::Vocabulary vocabulary();

} // namespace demfem::dem
