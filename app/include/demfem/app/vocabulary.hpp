// The full scene vocabulary (scene/vocabulary.hpp), for the demfem program and the tests: the
// DEM's part (dem::vocabulary: the models of [soil.dem] and the DEM's step limit), the
// continuum's constitutive models (continuum/constitutive/registry.hpp) and, when the
// continuum is built, the continuum's explicit step limit (through its module, opened only when a
// scene states an explicit-integrator continuum.dt). Library demfem::vocabulary (app/CMakeLists).
#pragma once

#include "demfem/scene/vocabulary.hpp"

namespace demfem::app {

[[nodiscard]] const scene::Vocabulary& vocabulary();

} // namespace demfem::app
