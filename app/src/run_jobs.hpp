// `demfem run --jobs N`: the chosen variants as separate `demfem run` processes, N at once, on
// studies/'s process runner. Here rather than in studies/ because it writes demfem's own command
// lines (pack, calibrate, run) and their console lines.
#pragma once

#include <vector>

#include "demfem/scene/scene.hpp"
#include "scenes.hpp"

namespace demfem::app {

// Each child runs with --threads as given (1 by default), so a machine with N cores runs N
// variants where one run uses one core. The packings and calibrations the variants share are made
// once each (also N at once, before any run is started while one is left to start), so no two
// children build the same cache entry; each run starts once its own is made. Each child's console
// goes to <run dir>/console.txt; this process prints one line per finished child and returns 0
// only when every child succeeded (else the first failing child's exit code).
int run_parallel(const std::vector<const scene::Scene*>& scenes, const RunArgs& a);

} // namespace demfem::app
