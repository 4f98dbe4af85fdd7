// The continuum driver's hooks (continuum::run, ../run.cpp), each called between steps:
//   log.cpp           log.txt, a checked stream whose failure every rank raises together
//   probe_source.cpp  what each probe measures, from the model (output::ProbeSource)
//   records.cpp       steps.csv, the snapshots, the small-strain watch, progress, and the records
//                     at the end (surface_profile.csv, contact states, timings)
//   checkpoint.cpp    the explicit run's checkpoint: written, read back, checked against the run
#pragma once

#include <chrono>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "demfem/continuum/run.hpp"
#include "demfem/output/csv.hpp"
#include "demfem/output/probe.hpp"
#include "demfem/scene/scene.hpp"
#include "fem.hpp"

namespace demfem::continuum::run_detail {

// ---- log.cpp ------------------------------------------------------------------------------------
// A streamed text output whose every write is checked: the first failure (a full disk, a file
// size limit, an unwritable directory) is kept as "cannot write <path>: <cause> (<step>)" and
// later writes are dropped. Nothing is thrown here: the run raises it at its next collective
// point (Outputs::raise), so that every MPI rank stops together.
class CheckedStream {
public:
  void open(const std::filesystem::path& p, bool append = false); // append: a resumed run's
  [[nodiscard]] bool is_open() const { return f_.is_open(); }
  template <class T> CheckedStream& operator<<(const T& v) {
    if (f_.is_open() && error_.empty()) {
      f_ << v;
      check("writing");
    }
    return *this;
  }
  CheckedStream& operator<<(std::ostream& (*manip)(std::ostream&));
  void flush() { *this << std::flush; }
  void close();
  [[nodiscard]] const std::string& error() const { return error_; }

private:
  void check(const char* step);
  std::filesystem::path path_;
  std::ofstream f_;
  std::string error_;
};

// ---- probe_source.cpp ---------------------------------------------------------------------------
// The continuum's answers to its probes, with the DEM's names, signs and units: structure motion
// and soil reaction, wall thrust and boundary pressure on structures. Each structure's motion and
// reaction are computed once per sample time (collective calls: every rank samples).
class ContinuumProbeSource final : public output::ProbeSource {
public:
  ContinuumProbeSource(const fem::Model& m, const scene::Scene& scene);
  void begin(double t);

  [[nodiscard]] double time() const override { return t_; }
  // the soil's force is computed on structures (not on the DEM's [[wall]]s)
  [[nodiscard]] bool has_boundary(std::string_view name) const override;
  output::StructureState structure(std::size_t k) override;
  output::WallReaction wall(std::string_view name) override;
  void pressure(std::string_view target, std::span<double> bins) override;

private:
  [[nodiscard]] long index_of(std::string_view name) const;
  const fem::Reaction& reaction(std::size_t k);
  const fem::Model& m_;
  const scene::Scene& scene_;
  double t_ = 0.0;
  std::vector<std::optional<fem::Reaction>> reactions_;
};

// ---- records.cpp --------------------------------------------------------------------------------
// steps.csv: the solver's statistics per step (root only; failures kept for Outputs::raise).
class StepRecord {
public:
  void open(const std::filesystem::path& dir); // on the root
  // A resumed run: keeps the rows up to step `keep` and appends after them.
  void open(const std::filesystem::path& dir, long long keep);
  void add(long long step, double t, const fem::StepStats& st, double wall_seconds);
  [[nodiscard]] std::string error() const { return csv_ ? csv_->error() : std::string(); }
  void flush();
  void close();

private:
  std::optional<output::CsvWriter> csv_;
};

// The .vtu snapshots at output.interval and the .pvd collection at the end.
class Snapshots {
public:
  Snapshots(fem::Model& m, const scene::Scene& scene, std::filesystem::path dir);
  void write(double t);                    // now (t: the model's time)
  void at(double t, double dt, bool last); // when due, and at the last step
  void write_if_missed(double t);          // unless one was written at t (an early stop)
  void finish();                           // the .pvd
  // What a checkpoint keeps: the next file's index, the next due time, the last time written.
  struct State {
    int index = 0;
    double next = 0.0;
    std::optional<double> last;
  };
  [[nodiscard]] State state() const { return {index_, next_, last_}; }
  void restore(const State& s) {
    index_ = s.index;
    next_ = s.next;
    last_ = s.last;
  }

private:
  fem::Model& m_;
  bool vtk_;
  double interval_, next_;
  std::string dir_;
  int index_ = 0;
  std::optional<double> last_;
};

// The small-strain validity limit (continuum.max_displacement): "" or which structure moved how
// far.
[[nodiscard]] std::string beyond_small_strain(const fem::Model& m, const scene::Scene& scene);

// The progress line every 10 steps and at the last.
void report_progress(const RunOptions& options, long long step, long long nsteps, double t,
                     double duration, std::chrono::steady_clock::time_point t_start);

// surface_profile.csv: the settlement (−u_z) at each point of the soil's top, in x order
// (collective; the root writes it). Returns "" or the write failure.
[[nodiscard]] std::string write_surface_profile(const fem::Model& m,
                                                std::span<const fem::Point> top,
                                                const std::filesystem::path& dir, bool root);

} // namespace demfem::continuum::run_detail

namespace demfem::continuum::run_detail {

// ---- checkpoint.cpp -----------------------------------------------------------------------------
// The explicit run's checkpoint at a step boundary, after the step's outputs: continuum/
// checkpoint.ckpt (MPI rank r > 0: checkpoint.<r>.ckpt, its own quadrature points), written
// atomically (scene::write_file_atomic). `identity` is the run as computed (the scene as run, the
// mesh's refinement and degree, the MPI ranks): a resume of another one is refused, naming the
// first line that differs.
struct Checkpoint {
  std::string identity;
  long long step = 0, nsteps = 0; // loop steps done, of
  double dt = 0.0, time = 0.0;    // the loop's step and the time reached [s]
  double next_checkpoint = 0.0;   // output.checkpoint_interval's next time [s]
  output::ProbeSet::State probes;
  Snapshots::State snapshots;
  long long newton = 0, linear = 0, cuts = 0, substeps = 0; // Totals
  std::string model;                                        // fem::Model::explicit_state
};
[[nodiscard]] std::filesystem::path checkpoint_path(const std::filesystem::path& dir, int rank);
// The run's identity: the scene as run (scene::to_toml) and the options that shape the mesh.
[[nodiscard]] std::string run_identity(const scene::Scene& scene, const fem::Problem& pb,
                                       int ranks);
// Throws scene::WriteError naming the file and the cause.
void write_checkpoint(const std::filesystem::path& path, const Checkpoint& c);
// Nothing when there is no file; throws std::runtime_error naming the file when it cannot be read
// or is not a continuum checkpoint of this version.
[[nodiscard]] std::optional<Checkpoint> read_checkpoint(const std::filesystem::path& path);
// "" when the identities are the same, else the first differing line of each ("continuum.dt = 0.001
// here, 0.002 in the checkpoint"), with its [section].
[[nodiscard]] std::string identity_difference(const std::string& here, const std::string& saved);

// ---- setup.cpp ----------------------------------------------------------------------------------
// What was run, for the report: dofs, cells, refinement, degree, integrator, cell sizes.
void describe(RunSummary& summary, const fem::Model& m, const fem::Problem& pb);
// log.txt's first lines: the mesh, the solver, the absorbing boundaries.
void log_header(CheckedStream& log, const scene::Scene& scene, const fem::Model& m,
                const fem::Problem& pb);
// Gravity, the K0 state and the structures' seating before t = 0. Returns "" or why it failed.
[[nodiscard]] std::string initialise(fem::Model& m, const scene::Scene& scene,
                                     const fem::Problem& pb, CheckedStream& log, bool root,
                                     RunSummary& summary,
                                     std::chrono::steady_clock::time_point t_start);
// The loop's step: continuum.dt (implicit), else the finest probe interval or a hundredth of the
// duration; explicit runs take it in central-difference substeps of at most the stable step
// (logged). Sets summary.dt and the step count.
double loop_step(fem::Model& m, const scene::Scene& scene, double finest_interval,
                 CheckedStream& log, bool root, RunSummary& summary, long long& nsteps);

// The solver's totals over the dynamic steps.
struct Totals {
  long long newton = 0, linear = 0, cuts = 0, substeps = 0;
  void add(const fem::StepStats& st) {
    newton += st.newton_iterations;
    linear += st.linear_iterations;
    cuts += st.cuts;
    substeps += st.substeps;
  }
};
// log.txt's last lines: the model's log, the Coulomb contact planes' state (collective), the
// dynamic stage's totals and timings.
void log_end(CheckedStream& log, const fem::Model& m, const fem::Problem& pb, bool root,
             const RunSummary& summary, const Totals& totals, double dt, bool explicit_dyn,
             std::chrono::steady_clock::time_point t_dyn);

} // namespace demfem::continuum::run_detail
