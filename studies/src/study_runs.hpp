// Internals of `demfem study error-vs-time` shared by the closed-form sweeps (study_error.cpp) and
// the sweeps of scenes without one (study_scene.cpp): runs as separate processes, fits, fronts.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "demfem/studies/error_study.hpp"
#include "demfem/studies/processes.hpp"

namespace demfem::studies::study_detail {

using TaskResult = ProcessResult; // demfem/studies/processes.hpp

// A study under a launcher (`mpirun -np N`, srun): rank r of N runs the tasks t with t mod N = r,
// writes their results into spread_directory(out) and reads the others' back, so every rank goes
// on with the same results; rank 0 alone writes the study's outputs. Outside a launcher: rank 0
// of 1 and nothing is exchanged. No scheduler of our own: the launcher places the ranks.
struct Spread {
  int rank = 0;
  int size = 1;
  std::string token; // one launch (its job id), naming the exchange directory
};
const Spread& launcher_spread();
std::filesystem::path spread_directory(const std::filesystem::path& out_dir);

// A point and how to run and evaluate it.
struct Job {
  ErrorPoint point;
  std::vector<std::vector<std::string>> argv; // per repeat
  std::vector<std::filesystem::path> dirs;    // per repeat
  std::function<void(ErrorPoint&, const std::filesystem::path& dir)> evaluate;
  double timeout = 0.0;   // per run [s]; 0 = none
  bool timed_out = false; // a repeat was stopped at the limit
};

// Runs every job's repeats (at most o.jobs processes at once), fills timings and evaluates each
// point from its first successful repeat.
void run_jobs(std::vector<Job>& jobs, const ErrorStudyOptions& o);
// Marks each group's Pareto front (median wall time against the primary error).
void mark_fronts(ErrorStudy& st, const std::vector<std::vector<std::string>>& groups);
// Least-squares order of `metric` against `against` ("dt", "h" or "wall") over the knob's points.
void add_fit(ErrorStudy& st, const std::string& knob, const std::string& metric,
             const std::string& against, double x_max);
std::string frac_label(double f);

// Makes `s` start from the packing checkpoint `from` (another scene's: e.g. the same scene with
// another Δt, which the packing key includes): writes it into `cache_dir` under s's cache key and
// label and points s's packing cache there (study_scene.cpp).
void use_packing(const std::filesystem::path& from, scene::Scene& s,
                 const std::filesystem::path& cache_dir);

} // namespace demfem::studies::study_detail
