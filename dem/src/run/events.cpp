#include <algorithm>

#include "hooks.hpp"

namespace demfem::dem::run_detail {

Events::Events(const scene::Scene& scene, std::uint64_t next)
    : scene_(scene), next_(static_cast<std::size_t>(next)) {
  for (const auto& ev : scene.events) events_.push_back({ev.time, &ev, ev.wall});
  for (const auto& w : scene.walls)
    if (w.opens_at) events_.push_back({*w.opens_at, nullptr, w.name});
  std::stable_sort(events_.begin(), events_.end(),
                   [](const Ev& a, const Ev& b) { return a.time < b.time; });
}

void Events::apply_due(Engine& e) {
  while (next_ < events_.size() && events_[next_].time <= e.time() + 0.5 * e.dt()) {
    const auto& ev = events_[next_++];
    if (!ev.event || ev.event->action == scene::EventAction::OpenWall) {
      if (e.boundary_index(ev.wall) >= 0) e.open_wall(ev.wall);
    } else if (const auto* g = scene_.group(ev.event->group)) {
      e.set_friction(g->region, ev.event->mu_static, ev.event->mu_dynamic);
    }
  }
}

double Events::next_time(double dt) const {
  return next_ < events_.size() ? events_[next_].time - dt : kNever;
}

} // namespace demfem::dem::run_detail
