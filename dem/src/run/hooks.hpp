// The DEM driver's hooks (dem::run, run.cpp): each is called between steps, never per contact.
//   setup.cpp        the engine from the scene, the packing or a checkpoint
//   loop_state.cpp   the run's state a checkpoint keeps beside the engine's
//   events.cpp       friction changes and wall openings, in time order
//   probe_source.cpp what each probe measures, from the engine (output::ProbeSource)
//   energy_watch.cpp the energy-jump and closure checks, and the budget at the end
//   snapshots.cpp    the .vtp snapshots and their .pvd collections
//   checkpoints.cpp  periodic, interrupt and end checkpoints
//   progress.cpp     the progress line and the run's statistics at the end
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "demfem/dem/engine.hpp"
#include "demfem/dem/io.hpp"
#include "demfem/dem/run.hpp"
#include "demfem/output/probe.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::dem::run_detail {

inline constexpr double kNever = std::numeric_limits<double>::infinity();

// ---- loop_state.cpp -----------------------------------------------------------------------------
// What a checkpoint keeps besides the engine: the schedules, the snapshot counter, the energy
// watch's reference and the probes' state.
struct LoopState {
  std::uint64_t next_event = 0;
  double next_snap = 0.0, next_ckpt = 0.0;
  std::int64_t snap = 0;
  double e0 = 0.0, energy_scale = 0.0;
  bool e0_set = false;
  output::ProbeSet::State probes;
};
[[nodiscard]] std::vector<std::byte> pack_state(const Engine& e, const LoopState& s);
// Restores the engine (particles + engine state) and returns the loop state.
[[nodiscard]] LoopState unpack_state(Engine& e, Particles particles,
                                     std::span<const std::byte> extra);

// ---- setup.cpp ----------------------------------------------------------------------------------
// Fills the engine: particles from the packing (or the scene's list), walls, structures where the
// packing seated them, the packing's contact history and the step; on a resume, the checkpoint's
// state into `ls`. Returns "" or why the run cannot start (a checkpoint that does not fit).
// Throws scene::SceneError for a scene the engine cannot build.
[[nodiscard]] std::string set_up(const scene::Scene& scene, const RunOptions& options,
                                 const std::filesystem::path& out, Engine& e, LoopState& ls,
                                 bool& resuming);

// ---- events.cpp ---------------------------------------------------------------------------------
class Events {
public:
  Events(const scene::Scene& scene, std::uint64_t next);
  // Applies the events at or before t + Δt/2.
  void apply_due(Engine& e);
  // The step before the next event (its test is kept out by a step's margin); kNever when none.
  [[nodiscard]] double next_time(double dt) const;
  [[nodiscard]] std::uint64_t next() const { return next_; }

private:
  struct Ev {
    double time;
    const scene::Event* event; // null: a wall's opens_at
    std::string wall;
  };
  const scene::Scene& scene_;
  std::vector<Ev> events_;
  std::size_t next_;
};

// ---- energy_watch.cpp ---------------------------------------------------------------------------
// Watches the energy budget at every base probe time (output.probe_interval): an energy jump
// (kinetic energy above 10 × the energy put in) or a closure error above soil.dem.energy_limit
// stops the run; above soil.dem.energy_warning it warns once. Also records the largest overlap
// ratio seen, and warns once when more than 1 % of the particles left while no wall was open.
class EnergyWatch {
public:
  EnergyWatch(const scene::Scene& scene, LoopState& ls);
  // "" or why the run stops.
  [[nodiscard]] std::string check(Engine& e, const EnergyBudget& b, RunSummary& summary);
  // After the first step: the budget's reference (the springs of an initially packed bed are
  // known only once the engine has evaluated the contacts).
  void start(const Engine& e);
  [[nodiscard]] bool started() const { return ls_.e0_set; }
  // ΔE_total since the reference (0 before it).
  [[nodiscard]] double imbalance(const EnergyBudget& b) const {
    return ls_.e0_set ? b.total() - ls_.e0 : 0.0;
  }
  // The budget at the end: logged and written to `json`; returns the closure error.
  double finish(const Engine& e, const std::filesystem::path& json) const;

private:
  std::string closure(Engine& e, double imbalance, double t);
  void leaving(const Engine& e, RunSummary& summary);
  LoopState& ls_;
  double warn_, stop_;
  bool warned_ = false, leave_warned_ = false;
};

// ---- probe_source.cpp ---------------------------------------------------------------------------
// The DEM's answers to its probes (output::ProbeSource): computed from the engine at the current
// state, each quantity at most once per sample time (begin() starts a new one).
class DemProbeSource final : public output::ProbeSource {
public:
  DemProbeSource(Engine& e, const scene::Scene& scene, const EnergyWatch& watch);
  void begin();
  // The budget at this sample time (the energy probe's and the watch's).
  const EnergyBudget& budget();

  [[nodiscard]] double time() const override { return e_.time(); }
  [[nodiscard]] bool has_energy() const override { return true; }
  [[nodiscard]] bool has_particles() const override { return true; }
  [[nodiscard]] bool has_boundary(std::string_view name) const override;
  output::EnergyTerms energy() override;
  output::StructureState structure(std::size_t k) override;
  output::WallReaction wall(std::string_view name) override;
  void pressure(std::string_view target, std::span<double> bins) override;
  void surface(std::span<double> bins) override;
  std::vector<std::uint32_t> trace(std::span<const scene::Vec2> points) override;
  scene::Vec2 position(std::uint32_t id) override;
  double coordination() override;

private:
  const Engine& forces();
  Engine& e_;
  const scene::Scene& scene_;
  const EnergyWatch& watch_;
  double xmin_ = 0.0, xmax_ = 1.0; // the domain's extent (surface bins)
  std::optional<EnergyBudget> budget_;
  std::optional<Engine> primed_;
  bool primed_for_sample_ = false;
  bool contacts_for_sample_ = false;
  std::vector<ContactView> contacts_;
  std::vector<scene::Vec2> verts_;
};

// ---- snapshots.cpp ------------------------------------------------------------------------------
class Snapshots {
public:
  Snapshots(const scene::Scene& scene, std::filesystem::path out, bool resuming, double keep_until,
            LoopState& ls);
  // At its interval (output.interval; once, at the start, without one).
  void at(Engine& e);
  // Now (the end of the run).
  void write(Engine& e);
  [[nodiscard]] double next_time() const { return ls_.next_snap; }

private:
  const scene::Scene& scene_;
  std::filesystem::path out_;
  bool resuming_;
  double keep_until_;
  double interval_;
  LoopState& ls_;
  std::optional<io::PvdCollection> particles_, chains_, bounds_;
  std::vector<BoundaryView> bviews_;
  std::vector<ContactView> contacts_;
};

// ---- checkpoints.cpp ----------------------------------------------------------------------------
class Checkpoints {
public:
  Checkpoints(const scene::Scene& scene, std::filesystem::path path, bool resuming, LoopState& ls);
  // At output.checkpoint_interval (none when 0).
  void at(Engine& e, output::ProbeSet& probes, const Events& events);
  // The state at the top of the loop (before this time's events and output), every probe row
  // written so far on the disk.
  void write(Engine& e, output::ProbeSet& probes, const Events& events);
  [[nodiscard]] double next_time() const { return interval_ > 0.0 ? ls_.next_ckpt : kNever; }
  // The final particles as a particle checkpoint (readable without the engine).
  static void write_final(Engine& e, const scene::Scene& scene, const std::filesystem::path& path);

private:
  const scene::Scene& scene_;
  std::filesystem::path path_;
  double interval_;
  LoopState& ls_;
};

// ---- progress.cpp -------------------------------------------------------------------------------
class Progress {
public:
  Progress(const RunOptions& options, double end_time);
  void report(const Engine& e); // now
  void tick(const Engine& e);   // every 256 steps, at most every 0.5 s
private:
  using Clock = std::chrono::steady_clock;
  const RunOptions& options_;
  double end_time_;
  Clock::time_point start_ = Clock::now(), last_ = Clock::now();
};
// The run's step, neighbour, thread and rebound statistics (logged at the end).
void log_statistics(const Engine& e, double solver_seconds);

} // namespace demfem::dem::run_detail
