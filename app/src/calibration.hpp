// [soil.continuum] calibrate = "dem" as the subcommands resolve it: the scene with the calibrated
// values filled in, computed or read from the cache.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "demfem/scene/scene.hpp"

namespace demfem::app {

// The scene with the calibrated values filled in (computed, or read from the cache). Logs one
// line per key; `notes` gets them. `figures`: draw the calibration's figures into
// out/calibration even when it came from the cache (the comparison report embeds them);
// otherwise only when it was computed now. `compute` false (a DEM run, which reads no
// calibration): only a cached calibration is applied, for the record; none is made.
scene::Scene with_calibration(const scene::Scene& s, const std::filesystem::path& out,
                              std::vector<std::string>* notes = nullptr, bool figures = false,
                              bool compute = true);

// --report-only: the scene with the calibration its run used (<out>/calibration/calibration.json)
// applied, without computing anything; the scene as is when there is none.
scene::Scene calibration_of_run(const scene::Scene& s, const std::filesystem::path& out);

} // namespace demfem::app
