// What each probe measures in the DEM: the engine's state at a sample time, with the contract's
// names and signs (output/contract.hpp).
#include <algorithm>
#include <cmath>

#include "hooks.hpp"

namespace demfem::dem::run_detail {

DemProbeSource::DemProbeSource(Engine& e, const scene::Scene& scene, const EnergyWatch& watch)
    : e_(e), scene_(scene), watch_(watch) {
  if (!scene.domain.empty()) {
    xmin_ = xmax_ = scene.domain[0].x;
    for (const auto& q : scene.domain) {
      xmin_ = std::min(xmin_, q.x);
      xmax_ = std::max(xmax_, q.x);
    }
  }
}

void DemProbeSource::begin() {
  budget_.reset();
  primed_.reset();
  primed_for_sample_ = false;
  contacts_for_sample_ = false;
}

const EnergyBudget& DemProbeSource::budget() {
  if (!budget_) budget_ = e_.energy();
  return *budget_;
}

bool DemProbeSource::has_boundary(std::string_view name) const {
  return e_.boundary_index(std::string(name)) >= 0;
}

output::EnergyTerms DemProbeSource::energy() {
  const EnergyBudget& b = budget();
  // The budget's reference is the state after the first step: before it the engine has not
  // evaluated the contacts, so the springs of an initially packed (overlapping) bed are unknown.
  return {b.kinetic,       b.rotational,   b.potential,         b.spring_normal,
          b.spring_shear,  b.friction,     b.damping,           b.rebound,
          b.external_work, b.gravity_work, watch_.imbalance(b), b.left_scene};
}

// Soil forces on structures and walls are evaluated inside a step. Before the first step they are
// those of the initial positions: a copy of the engine takes one step to get them (the t = 0 row
// is the at-rest state the comparison's static values read).
const Engine& DemProbeSource::forces() {
  if (!primed_for_sample_) {
    primed_for_sample_ = true;
    if (e_.stats().steps == 0) {
      primed_.emplace(e_);
      primed_->step();
    }
  }
  return primed_ ? *primed_ : e_;
}

output::StructureState DemProbeSource::structure(std::size_t k) {
  // One state per row: a step's soil forces and applied loads come from the pose at its start,
  // x_n = x_{n+1} − v_{n+1} Δt (symplectic Euler, Engine::update_structures), so the row writes
  // that pose.
  const Engine& fe = forces();
  const double dtf = fe.dt();
  const auto& f = fe.structures()[k];
  output::StructureState s;
  s.settlement = -(f.uz - f.vz * dtf);
  s.rotation = f.rot - f.omega * dtf;
  s.moment = f.soil_moment;
  s.force_x = f.soil_fx;
  s.force_z = f.soil_fz;
  s.applied_moment = f.applied_moment;
  s.displacement_x = f.ux - f.vx * dtf;
  return s;
}

output::WallReaction DemProbeSource::wall(std::string_view name) {
  const int bi = e_.boundary_index(std::string(name));
  const auto& B = forces().boundaries()[static_cast<std::size_t>(bi)];
  e_.boundary_vertices(bi, verts_);
  // the normal of the wall's chord pointing out of the soil: thrust > 0 when the soil presses
  const auto n = scene::thrust_normal(verts_, scene_.domain);
  return {B.reaction_x * n.x + B.reaction_z * n.z, B.reaction_x, B.reaction_z};
}

// Normal contact force per unit area on the boundary, in `bins` height bins between its lowest
// and highest vertex.
void DemProbeSource::pressure(std::string_view target, std::span<double> row) {
  if (!contacts_for_sample_) {
    contacts_for_sample_ = true;
    e_.contacts(contacts_, false); // the boundary contacts only
  }
  const int bins = static_cast<int>(row.size());
  const int bi = e_.boundary_index(std::string(target));
  e_.boundary_vertices(bi, verts_);
  double z0 = verts_.empty() ? 0 : verts_[0].z, z1 = z0;
  for (const auto& v : verts_) {
    z0 = std::min(z0, v.z);
    z1 = std::max(z1, v.z);
  }
  const double h = (z1 - z0) / bins;
  for (const auto& c : contacts_)
    if (c.j == -1 - static_cast<std::int64_t>(bi) && h > 0.0) {
      const auto bin = std::clamp(static_cast<int>((c.cz - z0) / h), 0, bins - 1);
      row[static_cast<std::size_t>(bin)] += c.fn / (h * e_.config().thickness);
    }
}

// The top of the highest particle per x bin across the domain.
void DemProbeSource::surface(std::span<double> row) {
  const int bins = static_cast<int>(row.size());
  std::fill(row.begin(), row.end(), -1e300);
  const auto& p = e_.particles();
  const double h = (xmax_ - xmin_) / bins;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.flags[i] & kFlagRemoved) continue;
    const int bin = static_cast<int>((p.x[i] - xmin_) / h);
    if (bin < 0 || bin >= bins) continue;
    auto& v = row[static_cast<std::size_t>(bin)];
    v = std::max(v, p.z[i] + p.radius[i]);
  }
  for (auto& v : row)
    if (v < -1e299) v = std::nan("");
}

// The particle nearest to each point, tagged (kFlagTagged) for the snapshots.
std::vector<std::uint32_t> DemProbeSource::trace(std::span<const scene::Vec2> points) {
  std::vector<std::uint32_t> ids;
  const auto& p = e_.particles();
  for (const auto& q : points) {
    std::size_t best = 0;
    double bd = 1e300;
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double d = std::hypot(p.x[i] - q.x, p.z[i] - q.z);
      if (d < bd) {
        bd = d;
        best = i;
      }
    }
    if (p.size() == 0) break;
    e_.particles().flags[best] |= kFlagTagged;
    ids.push_back(p.id[best]);
  }
  return ids;
}

scene::Vec2 DemProbeSource::position(std::uint32_t id) {
  const long i = e_.index_of(id);
  if (i < 0) return {std::nan(""), std::nan("")};
  const auto& p = e_.particles();
  return {p.x[static_cast<std::size_t>(i)], p.z[static_cast<std::size_t>(i)]};
}

// 2 × particle contacts / particles in the scene.
double DemProbeSource::coordination() {
  const std::size_t pp = e_.pair_contact_count();
  std::size_t active = 0;
  for (auto f : e_.particles().flags)
    if (!(f & kFlagRemoved)) ++active;
  return active ? 2.0 * static_cast<double>(pp) / static_cast<double>(active) : 0.0;
}

} // namespace demfem::dem::run_detail
