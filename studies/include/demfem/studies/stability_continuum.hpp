// The continuum rows of the stability study: the cases of continuum/stability.hpp run through the
// continuum module the program has opened (studies/ does not link deal.II).
#pragma once

#include <functional>
#include <vector>

#include "demfem/continuum/module.hpp"
#include "demfem/scene/scene.hpp"
#include "demfem/studies/study.hpp"

namespace demfem::studies {

// ν → 0.5 (0.49, 0.499) with and without B-bar on the built-in rocking footing, a 10⁶ × stiffer
// structure, then on the scene's own mesh and seating (its continuum as `calibrated` gives it:
// calibrate = "dem" resolved) ν → 0.5 again and an explicit step 1.5 × the stable one, and loads
// at 0.9 and 1.1 × the strip's bearing capacity (2 + π)c. Each row is logged as it ends.
[[nodiscard]] std::vector<StabilityRow>
continuum_stability_rows(const continuum::ModuleApi& cm, const scene::Scene& scene,
                         const std::function<scene::Scene(const scene::Scene&)>& calibrated);

} // namespace demfem::studies
