#include "demfem/output/probe.hpp"

#include <algorithm>
#include <limits>

#include <fmt/format.h>

#include "probe_kinds.hpp"

namespace demfem::output {
namespace {

// The probe a [[probe]] entry of a per-entry kind adds, or why this solver records none.
std::unique_ptr<Probe> make_probe(const scene::Probe& spec, ProbeSource& source,
                                  std::vector<std::uint32_t>& traced, bool restored,
                                  std::string& why) {
  using scene::ProbeKind;
  const char* name = scene::keyword(scene::kProbeKindNames, spec.kind);
  switch (spec.kind) {
  case ProbeKind::PressureProfile:
    if (source.has_boundary(spec.target))
      return std::make_unique<detail::PressureProbe>(spec.target, spec.bins, spec.interval);
    why = fmt::format("{} on '{}': this solver models no soil contact there", name, spec.target);
    return nullptr;
  case ProbeKind::SurfaceProfile:
    if (source.has_particles())
      return std::make_unique<detail::SurfaceProbe>(spec.bins, spec.interval);
    break;
  case ProbeKind::Loci:
    if (source.has_particles()) {
      if (!restored) traced = source.trace(spec.points);
      return std::make_unique<detail::LociProbe>(traced, spec.interval);
    }
    break;
  case ProbeKind::Coordination:
    if (source.has_particles()) return std::make_unique<detail::CoordinationProbe>(spec.interval);
    break;
  case ProbeKind::Energy:     // energy.csv (ProbeSet)
  case ProbeKind::WallThrust: // walls.csv (ProbeSet)
    return nullptr;
  }
  why = fmt::format("{}: a particle quantity", name);
  return nullptr;
}

// walls.csv's columns: walls with record = true, structures of kind wall or recording "thrust",
// then the wall-thrust probes' targets; each once, where the solver models the soil's force.
std::vector<std::string> thrust_targets(const scene::Scene& scene, const ProbeSource& source) {
  std::vector<std::string> out;
  auto add = [&](const std::string& name) {
    if (!source.has_boundary(name)) return;
    if (std::find(out.begin(), out.end(), name) == out.end()) out.push_back(name);
  };
  for (const auto& w : scene.walls)
    if (w.record) add(w.name);
  for (const auto& s : scene.structures)
    if (s.kind == scene::StructureKind::Wall ||
        std::find(s.record.begin(), s.record.end(), "thrust") != s.record.end())
      add(s.name);
  for (const auto& p : scene.probes)
    if (p.kind == scene::ProbeKind::WallThrust) add(p.target);
  return out;
}

} // namespace

ProbeSet::ProbeSet(const scene::Scene& scene, ProbeSource& source, ProbeSetOptions options,
                   const State* restored)
    : options_(std::move(options)) {
  if (restored) traced_ = restored->traced;
  auto add = [&](std::unique_ptr<Probe> p) { probes_.push_back({std::move(p), 0.0}); };
  // The interval of the (at most one) energy probe and of the wall-thrust probes (which write one
  // file, so the scene gives them one interval).
  double energy_dt = 0.0, walls_dt = 0.0;
  for (const auto& p : scene.probes) {
    if (p.kind == scene::ProbeKind::Energy) energy_dt = p.interval;
    if (p.kind == scene::ProbeKind::WallThrust) walls_dt = p.interval;
  }
  if (source.has_energy()) add(std::make_unique<detail::EnergyProbe>(energy_dt));
  if (!scene.structures.empty()) {
    std::vector<std::string> names;
    for (const auto& s : scene.structures) names.push_back(s.name);
    add(std::make_unique<detail::StructuresProbe>(std::move(names), options_.load_histories));
  }
  if (auto targets = thrust_targets(scene, source); !targets.empty())
    add(std::make_unique<detail::WallsProbe>(std::move(targets), walls_dt));
  for (const auto& spec : scene.probes) {
    const char* name = scene::keyword(scene::kProbeKindNames, spec.kind);
    if (spec.kind == scene::ProbeKind::Energy && !source.has_energy())
      not_recorded_.push_back(fmt::format("{}: this solver keeps no energy budget", name));
    if (spec.kind == scene::ProbeKind::WallThrust && !source.has_boundary(spec.target))
      not_recorded_.push_back(
          fmt::format("{} on '{}': this solver models no soil contact there", name, spec.target));
    std::string why;
    if (auto p = make_probe(spec, source, traced_, restored != nullptr, why))
      add(std::move(p));
    else if (!why.empty())
      not_recorded_.push_back(std::move(why));
  }
  if (restored) {
    next_base_ = restored->next_base;
    std::size_t k = 0;
    for (auto& s : probes_)
      if (s.probe->interval() > 0.0)
        s.next = k < restored->next_own.size() ? restored->next_own[k++] : next_base_;
  }
}

ProbeSet::~ProbeSet() = default;

void ProbeSet::open(const std::filesystem::path& dir) {
  if (!options_.write) return;
  for (auto& s : probes_) s.probe->open(dir, options_.csv);
}

bool ProbeSet::base_due(double t, double tolerance) const {
  return t >= next_base_ - tolerance;
}

bool ProbeSet::any_due(double t, double tolerance) const {
  if (base_due(t, tolerance)) return true;
  for (const auto& s : probes_)
    if (s.probe->interval() > 0.0 && t >= s.next - tolerance) return true;
  return false;
}

double ProbeSet::next_time() const {
  double t = next_base_;
  for (const auto& s : probes_)
    if (s.probe->interval() > 0.0) t = std::min(t, s.next);
  return t;
}

double ProbeSet::finest_interval() const {
  double dt = options_.base_interval;
  for (const auto& s : probes_)
    if (s.probe->interval() > 0.0) dt = std::min(dt, s.probe->interval());
  return dt;
}

void ProbeSet::sample_due(ProbeSource& source, double tolerance, bool all) {
  const double t = source.time();
  const bool base = base_due(t, tolerance);
  for (auto& s : probes_) {
    const double own = s.probe->interval();
    const bool due = own > 0.0 ? t >= s.next - tolerance : base;
    if (due || all) s.probe->sample(source);
    if (due && own > 0.0) s.next += own;
  }
  if (base) next_base_ += options_.base_interval;
}

void ProbeSet::sample_missing(ProbeSource& source) {
  const double t = source.time();
  for (auto& s : probes_)
    if (s.probe->last_sample() != t) s.probe->sample(source);
}

void ProbeSet::flush() {
  for (auto& s : probes_) s.probe->flush();
}

void ProbeSet::close() {
  for (auto& s : probes_) s.probe->close();
}

std::string ProbeSet::error() const {
  for (const auto& s : probes_)
    if (auto e = s.probe->error(); !e.empty()) return e;
  return {};
}

ProbeSet::State ProbeSet::state() const {
  State st;
  st.next_base = next_base_;
  for (const auto& s : probes_)
    if (s.probe->interval() > 0.0) st.next_own.push_back(s.next);
  st.traced = traced_;
  return st;
}

} // namespace demfem::output
