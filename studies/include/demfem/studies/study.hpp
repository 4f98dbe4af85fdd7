// `demfem study stability SCENE` (issue 11 item 2, DEM part): the scene run under stiff and
// extreme variants, each row with its outcome (completed, refused at setup with the cause, or
// stopped with step, time, particle and cause), energy closure, largest overlap ratio and wall
// time. Written to study.json, study.md and study.html. Scenes with a continuum add its rows
// (continuum/stability.hpp: ν → 0.5 with and without B-bar, a 10⁶× stiffer structure, an explicit
// step above the stable one, loads near and beyond (2 + π)c), each with Newton iterations and
// residual history.
#pragma once

#include <atomic>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "demfem/scene/scene.hpp"

namespace demfem::studies {

struct StabilityRow;

struct StudyOptions {
  std::filesystem::path out_dir;  // rows go to out_dir/rows/<name>, tables to out_dir
  std::optional<double> duration; // override the scene's duration for every row [s]
  int threads = 1;
  // Packed scenes: a row whose packing differs from the scene's (K_n, μ, radii are in the packing
  // key) and is not in the cache is deposited only with `repack`; otherwise it is listed as
  // skipped, with the cost it would take (a paper scene's deposition takes minutes to hours at
  // K_n × 1000).
  bool repack = false;
  // The continuum rows of a scene with [soil.continuum] (studies/ does not link the continuum:
  // the application supplies them, continuum/stability.hpp); unset: none.
  std::function<std::vector<StabilityRow>(const scene::Scene&)> continuum_rows;
  // A stop request (a stop signal): the DEM row running stops at its next step and no further
  // row runs. nullptr: none.
  std::atomic<bool>* interrupt = nullptr;
};

struct StabilityRow {
  std::string solver = "dem"; // "dem" or "continuum"
  std::string name;           // e.g. "kn-x100"
  std::string description;    // what was changed
  // "completed", "refused" (at setup), "stopped" (during the run), "not applicable", "skipped"
  // (a packing that would have to be deposited first: StudyOptions::repack)
  std::string outcome;
  std::string cause;              // refusal or stop message; why not applicable
  double dt = 0.0;                // step used [s]
  double dt_limit = 0.0;          // the stable limit of the row's scene [s]
  double closure = 0.0;           // end-of-run energy closure error
  double max_overlap_ratio = 0.0; // largest δ/r at the probes
  long long steps = 0;
  double simulated_time = 0.0; // [s]
  double wall_seconds = 0.0;
  // continuum rows: Newton iterations in all, the final residual of each load step, and what
  // was measured against which closed form or bound (in words, with the numbers)
  int iterations = 0;
  std::vector<double> residuals;
  std::string measure;
};

// The rows of issue 11's table: DEM rows when the scene has [soil.dem], then the continuum rows
// (options.continuum_rows). Throws scene::SceneError when the scene has neither model.
[[nodiscard]] std::vector<StabilityRow> stability_study(const scene::Scene& scene,
                                                        const StudyOptions& options);
// study.json, study.md and study.html in dir.
void write_stability_study(const std::vector<StabilityRow>& rows, const scene::Scene& scene,
                           const std::filesystem::path& dir);

} // namespace demfem::studies
