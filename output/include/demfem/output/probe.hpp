// Probes: one class per kind, used by both solvers. A probe names its file and columns
// (contract.hpp), samples a solver-neutral source at its own interval and writes a row through
// the run directory's CSV writer. What a probe measures is computed by the solver (ProbeSource);
// its name, schedule and writing live here.
//
// A new probe kind: its spec in scene/ (scene.hpp ProbeKind, probes.hpp), its class here
// (src/probe_kinds.hpp, one file), one line in make_probe (src/probe_set.cpp), and the source
// method that computes its quantity in each solver that offers it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "demfem/output/csv.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::output {

// energy.csv's terms, in its column order (contract.hpp kEnergyColumns) [J].
struct EnergyTerms {
  double kinetic = 0, rotational = 0, potential = 0, spring_normal = 0, spring_shear = 0,
         friction = 0, damping = 0, rebound = 0, external_work = 0, gravity_work = 0, imbalance = 0,
         left_scene = 0;
};

// One structure's row of structures.csv, with the contract's signs (contract.hpp).
struct StructureState {
  double settlement = 0, rotation = 0, moment = 0, force_x = 0, force_z = 0, applied_moment = 0,
         displacement_x = 0;
  double applied_force_x = 0, applied_force_z = 0; // the load histories (continuum)
};

// The soil's force on a wall or structure (walls.csv) [N].
struct WallReaction {
  double thrust = 0, reaction_x = 0, reaction_z = 0;
};

// What a solver offers its probes at the current sample time. Each solver overrides what it
// computes; a quantity it does not offer throws std::logic_error when asked for. The `has_`
// tests say which probes it can serve: a probe it cannot serve is not built (ProbeSet lists it
// in not_recorded()).
class ProbeSource {
public:
  virtual ~ProbeSource() = default;
  ProbeSource() = default;
  ProbeSource(const ProbeSource&) = delete;
  ProbeSource& operator=(const ProbeSource&) = delete;

  [[nodiscard]] virtual double time() const = 0;
  [[nodiscard]] virtual bool has_energy() const { return false; }
  [[nodiscard]] virtual bool has_particles() const { return false; }
  // A wall or structure whose soil force and boundary pressure this solver computes.
  [[nodiscard]] virtual bool has_boundary(std::string_view /*name*/) const { return false; }

  virtual EnergyTerms energy();
  virtual StructureState structure(std::size_t k); // scene.structures[k]
  virtual WallReaction wall(std::string_view name);
  // Normal soil pressure on a wall or structure per height bin [Pa], bin 0 at the bottom.
  virtual void pressure(std::string_view target, std::span<double> bins);
  // Top of the soil per x bin across the domain [m] (NaN where a bin holds none).
  virtual void surface(std::span<double> bins);
  // The particles traced from the points (nearest to each, at the start of the run), by id.
  virtual std::vector<std::uint32_t> trace(std::span<const scene::Vec2> points);
  virtual scene::Vec2 position(std::uint32_t id); // NaN when the particle left the scene
  virtual double coordination();
};

// One time series file written at its own interval.
class Probe {
public:
  // interval: its own [s]; 0 follows output.probe_interval.
  Probe(std::string file, double interval) : file_(std::move(file)), interval_(interval) {}
  virtual ~Probe() = default;
  Probe(const Probe&) = delete;
  Probe& operator=(const Probe&) = delete;

  [[nodiscard]] const std::string& file() const { return file_; }
  [[nodiscard]] double interval() const { return interval_; }
  // Header cells, time first.
  [[nodiscard]] virtual std::vector<std::string> columns() const = 0;

  // Creates the file (on the process that writes it; elsewhere sample() only asks the source,
  // so that every MPI rank makes the same collective calls).
  void open(const std::filesystem::path& dir, const CsvOptions& options);
  // One row at source.time().
  void sample(ProbeSource& source);
  void flush();
  void close();
  [[nodiscard]] std::string error() const { return csv_ ? csv_->error() : std::string(); }
  [[nodiscard]] std::optional<double> last_sample() const { return last_; }

protected:
  // The values after time, in columns() order.
  virtual void fill(ProbeSource& source, std::vector<double>& values) = 0;

private:
  std::string file_;
  double interval_;
  std::optional<CsvWriter> csv_;
  std::vector<double> row_;
  std::optional<double> last_;
};

struct ProbeSetOptions {
  double base_interval = 0.01; // output.probe_interval [s]
  CsvOptions csv;              // comments, flushing, resume; formats: the time column's only
  bool write = true;           // this process writes the files (MPI rank 0)
  bool load_histories = false; // structures.csv holds applied_force_x/_z (continuum)
};

// The probes of a scene that a solver offers, with their schedules. Probes without an interval
// of their own share the base schedule (output.probe_interval); a probe with one samples at it.
// Schedules start at 0 and advance by their interval from each sample that is due; a sample is
// due at time t when t ≥ next − tolerance (the solver's step margin).
class ProbeSet {
public:
  // The state a checkpoint keeps: the next time of each schedule and the traced particles.
  struct State {
    double next_base = 0.0;
    std::vector<double> next_own; // per probe with an interval of its own, in probe order
    std::vector<std::uint32_t> traced;
  };

  // Builds the probes (a loci probe picks its particles now, unless `restored` gives them).
  ProbeSet(const scene::Scene& scene, ProbeSource& source, ProbeSetOptions options,
           const State* restored = nullptr);
  ~ProbeSet();
  ProbeSet(const ProbeSet&) = delete;
  ProbeSet& operator=(const ProbeSet&) = delete;

  // Creates the files under dir (when options.write).
  void open(const std::filesystem::path& dir);

  [[nodiscard]] bool base_due(double t, double tolerance) const;
  [[nodiscard]] bool any_due(double t, double tolerance) const;
  // The earliest next sample time of any schedule (the base one included).
  [[nodiscard]] double next_time() const;
  // Samples every probe due at source.time() (all when `all`) and advances the schedules that
  // were due; the base schedule advances when it was due even if no probe follows it.
  void sample_due(ProbeSource& source, double tolerance, bool all = false);
  // Samples every probe whose last row is not at source.time() (the end of a run).
  void sample_missing(ProbeSource& source);

  void flush();
  void close();
  // The first failed write of any probe file ("" while none).
  [[nodiscard]] std::string error() const;

  [[nodiscard]] State state() const;
  [[nodiscard]] std::size_t size() const { return probes_.size(); }
  [[nodiscard]] const Probe& probe(std::size_t k) const { return *probes_[k].probe; }
  // The [[probe]]s this solver does not record, each with why ("loci: the particles' paths").
  [[nodiscard]] const std::vector<std::string>& not_recorded() const { return not_recorded_; }
  // The smallest interval of any schedule [s] (a solver's output step).
  [[nodiscard]] double finest_interval() const;

private:
  struct Scheduled {
    std::unique_ptr<Probe> probe;
    double next = 0.0; // own schedule (interval > 0)
  };
  ProbeSetOptions options_;
  double next_base_ = 0.0;
  std::vector<Scheduled> probes_;
  std::vector<std::string> not_recorded_;
  std::vector<std::uint32_t> traced_;
};

} // namespace demfem::output
