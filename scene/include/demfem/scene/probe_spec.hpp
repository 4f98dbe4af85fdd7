// What each [[probe]] kind records and which keys it takes (every key it takes has an effect;
// the others are refused). The probe classes that write them are in output/.
#pragma once

#include <array>

#include "demfem/scene/scene.hpp"

namespace demfem::scene {

struct ProbeSpec {
  ProbeKind kind;
  bool target; // takes `target`: a wall or structure name (required)
  bool bins;   // takes `bins`
  bool points; // takes `points`
  const char* records;
};

// Every kind takes `kind` and `interval`. One probe of a kind per target (per scene for the kinds
// without one); the wall-thrust probes write one file (walls.csv) and so share one interval.
inline constexpr std::array<ProbeSpec, 6> kProbeSpecs = {{
    {ProbeKind::Energy, false, false, false,
     "energy.csv, the DEM's energy budget (written without the probe too; the probe gives it its "
     "interval)"},
    {ProbeKind::WallThrust, true, false, false,
     "walls.csv: thrust and reaction of the target (with every recorded wall)"},
    {ProbeKind::PressureProfile, true, true, false,
     "pressure_<target>.csv: normal soil pressure on the target per height bin"},
    {ProbeKind::SurfaceProfile, false, true, false, "surface.csv: top of the soil per x bin (DEM)"},
    {ProbeKind::Loci, false, false, true,
     "loci.csv: positions of the particles nearest to the points (DEM)"},
    {ProbeKind::Coordination, false, false, false,
     "coordination.csv: 2 × particle contacts / particles (DEM)"},
}};

[[nodiscard]] constexpr const ProbeSpec& probe_spec(ProbeKind k) {
  return kProbeSpecs[static_cast<std::size_t>(k)];
}

} // namespace demfem::scene
