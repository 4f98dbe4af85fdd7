// What each probe measures in the continuum, with the DEM's names, signs and units
// (output/contract.hpp).
#include <algorithm>

#include "hooks.hpp"

namespace demfem::continuum::run_detail {

ContinuumProbeSource::ContinuumProbeSource(const fem::Model& m, const scene::Scene& scene)
    : m_(m), scene_(scene), reactions_(scene.structures.size()) {}

void ContinuumProbeSource::begin(double t) {
  t_ = t;
  std::fill(reactions_.begin(), reactions_.end(), std::nullopt);
}

long ContinuumProbeSource::index_of(std::string_view name) const {
  for (std::size_t k = 0; k < scene_.structures.size(); ++k)
    if (scene_.structures[k].name == name) return static_cast<long>(k);
  return -1;
}

bool ContinuumProbeSource::has_boundary(std::string_view name) const {
  return index_of(name) >= 0;
}

// The force of the soil on structure k and its moment about the pivot (collective).
const fem::Reaction& ContinuumProbeSource::reaction(std::size_t k) {
  if (!reactions_[k]) reactions_[k] = m_.soil_reaction(k);
  return *reactions_[k];
}

output::StructureState ContinuumProbeSource::structure(std::size_t k) {
  const auto motion = m_.region_motion(k);
  const fem::Reaction& r = reaction(k);
  const auto& s = scene_.structures[k];
  const double fx = s.force_x(t_), fz = s.force_z(t_);
  output::StructureState st;
  st.settlement = -motion.uz;
  st.rotation = motion.rotation;
  st.moment = r.moment;
  st.force_x = r.fx;
  st.force_z = r.fz;
  // applied moment about the pivot: M + (load point − pivot) × F
  st.applied_moment =
      s.moment(t_) + (s.load_point.x - s.pivot.x) * fz - (s.load_point.z - s.pivot.z) * fx;
  st.displacement_x = motion.ux;
  st.applied_force_x = fx;
  st.applied_force_z = fz;
  return st;
}

// thrust = F·n, n the normal of the chord from the first to the last outline vertex pointing out
// of the soil (scene::thrust_normal, as the DEM): > 0 when the soil presses on the wall.
output::WallReaction ContinuumProbeSource::wall(std::string_view name) {
  const auto k = static_cast<std::size_t>(index_of(name));
  const fem::Reaction& r = reaction(k);
  const auto n = scene::thrust_normal(scene_.structures[k].outline, scene_.domain);
  return {r.fx * n.x + r.fz * n.z, r.fx, r.fz};
}

// Normal soil pressure on the structure per z bin between the outline's lowest and highest vertex
// (collective).
void ContinuumProbeSource::pressure(std::string_view target, std::span<double> bins) {
  const auto k = static_cast<std::size_t>(index_of(target));
  double lo = 1e300, hi = -1e300;
  for (const auto& p : scene_.structures[k].outline) {
    lo = std::min(lo, p.z);
    hi = std::max(hi, p.z);
  }
  const auto prof = m_.soil_pressure(k, lo, hi, static_cast<int>(bins.size()));
  std::copy_n(prof.begin(), std::min(prof.size(), bins.size()), bins.begin());
}

} // namespace demfem::continuum::run_detail
