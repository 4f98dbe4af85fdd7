// `demfem study stability SCENE` (issue 11 item 2, DEM part): the scene run under stiff and
// extreme variants, each row with its outcome (completed, refused at setup with the cause, or
// stopped with step, time, particle and cause), energy closure, largest overlap ratio and wall
// time. Written to study.json, study.md and study.html. The continuum rows and the
// error-vs-time study are not built yet.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "demfem/scene/scene.hpp"

namespace demfem::compare {

struct StudyOptions {
  std::filesystem::path out_dir;  // rows go to out_dir/rows/<name>, tables to out_dir
  std::optional<double> duration; // override the scene's duration for every row [s]
  int threads = 1;
};

struct StabilityRow {
  std::string name;        // e.g. "kn-x100"
  std::string description; // what was changed
  // "completed", "refused" (at setup), "stopped" (during the run), "not applicable"
  std::string outcome;
  std::string cause;              // refusal or stop message; why not applicable
  double dt = 0.0;                // step used [s]
  double dt_limit = 0.0;          // the stable limit of the row's scene [s]
  double closure = 0.0;           // end-of-run energy closure error
  double max_overlap_ratio = 0.0; // largest δ/r at the probes
  long long steps = 0;
  double simulated_time = 0.0; // [s]
  double wall_seconds = 0.0;
};

// The DEM rows of issue 11's table. Throws scene::SceneError when the scene has no [soil.dem].
[[nodiscard]] std::vector<StabilityRow> stability_study(const scene::Scene& scene,
                                                        const StudyOptions& options);
// study.json, study.md and study.html in dir.
void write_stability_study(const std::vector<StabilityRow>& rows, const scene::Scene& scene,
                           const std::filesystem::path& dir);

} // namespace demfem::compare
