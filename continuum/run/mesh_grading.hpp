// Graded coarse grids for scene runs (continuum.mesh_size_near, mesh_grading): the scene's
// graded_steps_through (scene/resources.hpp), which the scene check's mesh estimate counts too.
#pragma once

#include "demfem/scene/resources.hpp"

namespace demfem::continuum {

using scene::graded_steps_through;

} // namespace demfem::continuum
