// `demfem study error-vs-time` (issue 11 item 1): a solver swept over its resolution knobs, each
// run a separate `demfem` process (repeated for min/median/max wall time and its peak memory),
// its error against a closed form, fitted convergence orders, and error against wall time with
// the Pareto front. Written to study.json, study.md, study.html and log–log figures.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "demfem/scene/progress.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::studies {

struct ErrorStudyOptions {
  std::filesystem::path out_dir; // runs go to out_dir/runs/<point>/rep-<k>
  std::filesystem::path exe;     // the demfem binary every run executes
  int jobs = 1;                  // runs at once (separate processes)
  int repeats = 3;               // runs per point (timings: min/median/max)
  // DEM: Δt as fractions of the true critical step (dem/stable_step.hpp)
  std::vector<double> dt_fractions = {1.0 / 4,   1.0 / 8,   1.0 / 16,  1.0 / 32,  1.0 / 64,
                                      1.0 / 128, 1.0 / 256, 1.0 / 512, 1.0 / 1024};
  // DEM: K_n (and K_s) multipliers, automatic Δt
  std::vector<double> kn_factors = {0.1, 0.3, 1.0, 3.0, 10.0};
  // continuum (flamant): global refinements and polynomial degrees
  std::vector<int> refinements = {1, 2, 3, 4};
  std::vector<int> degrees = {1, 2};
  // continuum: settings whose estimated size exceeds this are skipped (and listed in the notes)
  double max_dofs = 4.0e5;
  // Points whose fit abscissa is at most this fraction of the coarsest's form the convergence
  // fit... (0: all points). The DEM fit uses Δt ≤ fit_max_fraction × the critical step.
  double fit_max_fraction = 1.0 / 16;

  // ---- scenes without a closed form (scene_error_study) ----
  std::string solvers = "both";   // "dem", "continuum" or "both" (those the scene lists)
  std::optional<double> duration; // simulated time of every run [s] (default: the scene's)
  // DEM: Δt as fractions of the critical step; K_n (and K_s) multipliers, automatic Δt
  std::vector<double> scene_dt_fractions = {0.5, 0.25, 0.125};
  std::vector<double> scene_kn_factors = {0.3, 1.0, 3.0};
  // K_n points on the scene's packing (true) or each on its own, deposited with its K_n (false:
  // the packing key includes K_n; costs a deposition per factor)
  bool kn_same_packing = true;
  // DEM, packed scenes: particle count multipliers at fixed geometry (count × f, every radius
  // / √f: the same solid area, so the same bed; each factor deposits its own packing)
  std::vector<double> scene_size_factors = {1.0, 4.0};
  // continuum: refinements (empty: the scene's refinement − 2 … the scene's), degrees, and
  // integrators (empty: the scene's, then the other)
  std::vector<int> scene_refinements;
  std::vector<int> scene_degrees = {1, 2};
  std::vector<std::string> integrators;
  // continuum, graded meshes (mesh_size_near > 0): mesh_size_near multipliers at the scene's
  // refinement, degree and integrator (the cells next to the structures, coarse to fine)
  std::vector<double> scene_near_factors = {2.0, 1.0, 0.5};
  // continuum: time step multipliers at the scene's degree and integrator on the sweep's
  // coarsest refinement (explicit: explicit_safety × f; implicit: the sweep's Newmark step × f)
  std::vector<double> scene_cont_dt_factors = {1.0, 0.5, 0.25};
  // A run longer than this is stopped (its setting and every finer one of the same knob are
  // then skipped and listed with the reason); 0 = no limit [s]
  double max_run_seconds = 300.0;
  // progress of the work done in the study's own process (depositing the size points' packings)
  scene::ProgressFn progress;
};

struct ErrorPoint {
  std::string solver = "dem"; // "dem" or "continuum"
  // "dt", "kn", "size", "mesh-q1", "mesh-q2", "mesh-q2-explicit", "mesh-near", "cont-dt"
  std::string knob;
  std::string name; // e.g. "dt-1/64"
  // the knob's setting (Δt fraction, K_n factor, count factor, refinement, mesh_size_near or
  // continuum Δt factor)
  double value = 0;
  // convergence abscissa: Δt [s] (DEM, continuum Δt), mean radius [m] (DEM size), smallest cell
  // h [m] (continuum meshes)
  double x = 0;
  double dt = 0; // DEM step [s]
  std::size_t dofs = 0;
  std::map<std::string, double> errors;  // metric → relative error (≥ 0)
  std::map<std::string, double> results; // the computed quantities behind them
  bool ok = false;
  std::string message; // why a run failed
  // Wall time of every repeat [s]: in the solver (its own timer: the cost the knob controls) and
  // of the whole process (fork to exit: adds the start-up, ~0.7 s for a binary with deal.II).
  std::vector<double> wall, process_wall;
  double wall_min = 0, wall_median = 0, wall_max = 0;
  double process_min = 0, process_median = 0, process_max = 0;
  double peak_rss_mib = 0; // largest resident set of the repeats (getrusage) [MiB]
  int rank = 0;            // the launcher rank that ran its first repeat (0 outside mpirun)
  bool pareto = false;     // on the error–wall-time Pareto front of its knob (primary metric)
  std::string command;     // the command line of one repeat
};

struct ErrorFit {
  std::string knob, metric;
  std::string against; // "dt", "h" or "wall"
  double order = 0;    // least-squares slope of log(error) against log(abscissa)
  int points = 0;
  double x_min = 0, x_max = 0;
};

struct ErrorStudy {
  std::string solver; // "dem" or "continuum"
  std::string scene, source;
  std::string reference;      // the closed form, in words
  std::string primary_metric; // the metric the Pareto front and the figures use
  std::map<std::string, std::string> metric_descriptions;
  std::map<std::string, double> closed_form; // named closed-form values
  double expected_order = 0;                 // theoretical order of the primary metric in the knob
  std::string expected_order_note;
  std::vector<ErrorPoint> points;
  std::vector<ErrorFit> fits;
  std::vector<std::string> notes; // knobs skipped and why
  int repeats = 0, jobs = 0;
  // scenes without a closed form: the reference run of each solver (solver → point name)
  std::map<std::string, std::string> reference_runs;
  // Figures: groups of knobs drawn together (empty: the closed-form studies' fixed groups).
  struct FigureGroup {
    std::vector<std::string> knobs;
    std::string stem, what;
    std::string against; // convergence figures: "dt" or "h"
  };
  std::vector<FigureGroup> wall_groups, convergence_groups;
};

// Least-squares slope of log y against log x over the pairs with x, y > 0 (NaN when fewer than
// two such pairs or all x equal).
[[nodiscard]] double loglog_slope(const std::vector<double>& x, const std::vector<double>& y);
// Indices of the points not dominated in (cost, error): no other point is at most as costly and
// at most as wrong with one of the two strictly smaller. Sorted by cost.
[[nodiscard]] std::vector<std::size_t> pareto_front(const std::vector<double>& cost,
                                                    const std::vector<double>& error);

// DEM sweep of a scene with a closed form (head-on collision). Throws std::runtime_error when
// the scene has none.
[[nodiscard]] ErrorStudy dem_error_study(const scene::Scene& scene, const ErrorStudyOptions& o);
// Continuum sweep of the built-in Flamant strip-load problem (continuum/verification.hpp); each
// run is `demfem study-point flamant …`.
[[nodiscard]] ErrorStudy flamant_error_study(const ErrorStudyOptions& o);

// Any scene (issue 11: no closed form needed): each solver the scene lists (o.solvers) swept over
// its knobs — DEM: Δt as a fraction of the critical step on the same packing, K_n scaling with
// the automatic Δt (each K_n deposits its own packing); continuum: refinement × degree ×
// integrator — each run measured with the comparison layer's metric table
// (collect_solver_metrics: static value, mean increment and oscillation amplitude of thrust,
// settlement, rotation and surface) against the most resolved run of the same solver. Each run is
// `demfem study-point dem|continuum --scene …`. Throws std::runtime_error when nothing can run.
[[nodiscard]] ErrorStudy scene_error_study(const scene::Scene& scene, const ErrorStudyOptions& o);

// study.json, study.md, study.html and the figures (figures/*.png, .svg) in dir.
void write_error_study(const ErrorStudy& study, const std::filesystem::path& dir);

// A study under a launcher (`mpirun -np N demfem study error-vs-time …`, srun): the runs are spread
// over the ranks (rank r starts every N-th run) and every rank gets every result. study_rank():
// this process's rank, 0 outside a launcher; rank 0 alone writes the study. Every rank calls
// finish_study_ranks(out_dir) at the end; rank 0 waits there for the others and removes the
// exchange directory.
[[nodiscard]] int study_rank();
[[nodiscard]] int study_ranks();
void finish_study_ranks(const std::filesystem::path& out_dir);

} // namespace demfem::studies
