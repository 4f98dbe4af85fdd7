// Progress reports passed from a solver's time loop to whoever displays them (the app).
#pragma once

#include <functional>
#include <string>

namespace demfem::scene {

struct Progress {
  std::string stage;     // "pack", "dem", "continuum", …
  double time = 0.0;     // simulated time reached [s]
  double end_time = 0.0; // simulated end time [s]
  long long step = 0;
  double wall_seconds = 0.0; // since the stage started
};
using ProgressFn = std::function<void(const Progress&)>;

} // namespace demfem::scene
