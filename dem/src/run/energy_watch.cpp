#include <algorithm>
#include <cmath>
#include <iterator>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "demfem/scene/write_file.hpp"
#include "hooks.hpp"

namespace demfem::dem::run_detail {
namespace {

// The particle with the most kinetic (translational + rotational) energy, for stop messages.
std::string most_energetic(Engine& e) {
  const auto& p = e.particles();
  std::size_t best = p.size();
  double eb = -1.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.flags[i] & kFlagRemoved) continue;
    const double ek = 0.5 * p.mass[i] * (p.vx[i] * p.vx[i] + p.vz[i] * p.vz[i]) +
                      0.5 * p.omega[i] * p.omega[i] / p.inv_inertia[i]; // ½mv² + ½Iω²
    if (ek > eb) {
      eb = ek;
      best = i;
    }
  }
  if (best == p.size()) return std::string("no particles");
  return fmt::format("largest-energy particle: id {} at ({:.4g}, {:.4g}) m, r = {:.4g} m, "
                     "{:.4g} J",
                     p.id[best], p.x[best], p.z[best], p.radius[best], eb);
}

} // namespace

EnergyWatch::EnergyWatch(const scene::Scene& scene, LoopState& ls)
    : ls_(ls), warn_(scene.soil.dem->energy_warning), stop_(scene.soil.dem->energy_limit) {}

std::string EnergyWatch::check(Engine& e, const EnergyBudget& b, RunSummary& summary) {
  const double t = e.time();
  double& scale = ls_.energy_scale;
  if (!ls_.e0_set) scale = std::max(scale, b.kinetic + b.rotational);
  // Blow-up by energy jump: kinetic energy far above everything that was put in.
  scale = std::max(scale, std::abs(b.gravity_work) + std::abs(b.external_work) + b.spring_normal +
                              b.spring_shear);
  // (the scale starts at the initial kinetic energy and never decreases)
  if (b.kinetic + b.rotational > 10.0 * scale + 1e-9 && t > 0.0 && !e.failed())
    return fmt::format("energy jump: kinetic energy {:.4g} J exceeds 10 × the energy put in "
                       "({:.4g} J); {}",
                       b.kinetic + b.rotational, scale, most_energetic(e));
  if (ls_.e0_set) {
    if (auto stop = closure(e, b.total() - ls_.e0, t); !stop.empty()) return stop;
  }
  leaving(e, summary);
  // Largest overlap ratio δ/r: pairs from the positions, boundary contacts from the force the
  // law recorded (Engine::largest_overlap_ratio).
  summary.max_overlap_ratio = std::max(summary.max_overlap_ratio, e.largest_overlap_ratio());
  return {};
}

// Particles that left while no wall was open (kFlagLeftUnplanned): above 1 % of the count the
// container has a gap the scene did not plan; warned once.
void EnergyWatch::leaving(const Engine& e, RunSummary& summary) {
  const auto& flags = e.particles().flags;
  const auto n = static_cast<std::size_t>(
      std::count_if(flags.begin(), flags.end(), [](auto f) { return f & kFlagLeftUnplanned; }));
  summary.particles_left_unplanned = n;
  if (leave_warned_ || 100 * n <= flags.size()) return;
  leave_warned_ = true;
  spdlog::warn("{} of {} particles ({:.3g} %) have left the scene by t = {:.6g} s while no wall "
               "was open: the particles' container has a gap the scene does not plan (a wall "
               "short of its neighbour, particles thrown over a side wall?); summary.json counts "
               "them (particles_left_unplanned)",
               n, flags.size(), 100.0 * static_cast<double>(n) / static_cast<double>(flags.size()),
               e.time());
}

// Energy-closure watch: |imbalance| over the largest energy put in so far.
std::string EnergyWatch::closure(Engine& e, double imbalance, double t) {
  const double scale = ls_.energy_scale;
  if (!(scale > 0.0)) return {};
  const double c = std::abs(imbalance) / scale;
  if (!std::isfinite(c) || (stop_ > 0.0 && c > stop_))
    return fmt::format("energy closure error {:.4g} exceeds soil.dem.energy_limit = {:g} "
                       "(imbalance {:.4g} J against {:.4g} J put in: the time step does not "
                       "resolve the contacts or the motion; lower soil.dem.dt or dt_safety); {}",
                       c, stop_, imbalance, scale, most_energetic(e));
  // Not in the first 100 steps: the staggered kinetic energy of leapfrog differs from the
  // energy at the positions by ½ m g v Δt, a fraction Δt/(2t) of the work in a free fall.
  if (warn_ > 0.0 && c > warn_ && !warned_ && e.stats().steps >= 100) {
    warned_ = true;
    spdlog::warn("energy closure error {:.4g} at step {} (t = {:.6g} s) exceeds "
                 "soil.dem.energy_warning = {:g} (imbalance {:.4g} J against {:.4g} J put in); "
                 "a smaller dt (soil.dem.dt_safety) closes it better",
                 c, e.stats().steps, t, warn_, imbalance, scale);
  }
  return {};
}

void EnergyWatch::start(const Engine& e) {
  const auto b0 = e.energy();
  ls_.e0 = b0.total();
  ls_.e0_set = true;
  // The springs of initially overlapping particles are known only now: their energy is put in
  // too (else the energy-jump check stops a bed released from overlaps).
  ls_.energy_scale =
      std::max(ls_.energy_scale, b0.kinetic + b0.rotational + b0.spring_normal + b0.spring_shear);
}

// Closure error = |ΔE_total| / E_in, ΔE_total the change of kinetic + potential + springs +
// dissipated + carried out of the scene − external work since the reference, E_in the largest
// energy put in during the run (|gravity work| + |external work| + spring energy, or the initial
// kinetic energy): the watch's scale, so the run's warning and its final number are one quantity.
double EnergyWatch::finish(const Engine& e, const std::filesystem::path& json_path) const {
  const EnergyBudget b = e.energy();
  const double t = e.time(), scale = ls_.energy_scale;
  const double imbalance = b.total() - ls_.e0;
  const double closure = scale > 0.0 ? std::abs(imbalance) / scale : 0.0;
  const std::pair<const char*, double> rows[] = {
      {"kinetic", b.kinetic},
      {"rotational", b.rotational},
      {"potential change", b.potential},
      {"springs (normal)", b.spring_normal},
      {"springs (shear)", b.spring_shear},
      {"friction (dissipated)", b.friction},
      {"damping (dissipated)", b.damping},
      {"rebound (dissipated)", b.rebound},
      {"left the scene", b.left_scene},
      {"external work", b.external_work},
      {"gravity work", b.gravity_work},
      {"imbalance", imbalance},
  };
  spdlog::info("DEM energy budget at t = {:.6g} s [J]:", t);
  for (const auto& [name, v] : rows) spdlog::info("  {:<24} {:>14.6e}", name, v);
  spdlog::info("  {:<24} {:>14.6e}", "energy put in", scale);
  spdlog::info("  {:<24} {:>14.3e}  (|imbalance| / energy put in: the largest gravity + external "
               "work + spring energy)",
               "closure error", closure);
  std::string js = "{\n";
  js += fmt::format("  \"time\": {:.17g},\n", t);
  const char* keys[] = {"kinetic",      "rotational",    "potential_change", "spring_normal",
                        "spring_shear", "friction",      "damping",          "rebound",
                        "left_scene",   "external_work", "gravity_work",     "imbalance"};
  for (std::size_t k = 0; k < std::size(keys); ++k)
    js += fmt::format("  \"{}\": {:.17g},\n", keys[k], rows[k].second);
  js += fmt::format("  \"energy_scale\": {:.17g},\n", scale);
  js += fmt::format("  \"closure_error\": {:.17g}\n}}\n", closure);
  scene::write_file_atomic(json_path, js);
  return closure;
}

} // namespace demfem::dem::run_detail
