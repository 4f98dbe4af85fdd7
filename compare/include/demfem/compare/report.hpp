// The comparison report of a run directory: the metric table (metric_table.hpp: each metric one
// row, with how each solver's output yields it), each series split into static / increment /
// oscillation and compared with a verdict, pressure and surface profiles, coarse-grained field
// maps (coarse_grain.hpp), what differs between the two models and both models' parameters with
// their provenance (model_differences.hpp), the calibration, run times, the reproducing command
// and links to `demfem study` pages of the scene, in a self-contained HTML page plus metrics.json.
#pragma once

#include <filesystem>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "demfem/compare/coarse_grain.hpp"
#include "demfem/compare/metrics.hpp"
#include "demfem/compare/model_differences.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::compare {

struct ReportOptions {
  double divergence_threshold = 0.2; // relative to the DEM's largest |increment| / mean increment
  std::string title;
  std::vector<std::string> notes;      // shown at the top (e.g. a solver that did not run)
  const scene::Scene* scene = nullptr; // load start, periods, structures, domain (may be null)
  double kernel_width = 0.0;           // coarse-graining support radius [m] (0: 2 mean diameters)
  bool fields = true;                  // coarse-grained field maps (needs both solvers' snapshots)
  std::string command;                 // the reproducing command ("" = demfem compare SCENE …)
  std::span<const Metric> table;       // the metric table (empty: metric_table())
  // Solvers whose series end before the scene's duration or come from a failed run, one line
  // each: shown first in the report and listed in metrics.json ("incomplete") when not empty.
  std::vector<std::string> incomplete;
};

// A word of a shell command, single-quoted when it holds anything but [A-Za-z0-9_-./=:+,@%]
// (the report's reproducing command; `demfem run` and `compare` log the same).
[[nodiscard]] std::string shell_quote(const std::string& word);

// A `demfem study` page of the compared scene (study.json + study.html).
struct StudyLink {
  std::filesystem::path html;
  std::string kind;    // "stability" | "error-vs-time"
  std::string scene;   // the study's scene label
  std::string summary; // e.g. "14 rows: 10 completed, 2 refused, 2 stopped"
};

// Studies of the same scene (study.json "scene" = name or name/variant): <dir>/study*/study.json
// and <dir>/study*/*/study.json for dir = the run directory, its parent, and runs/<scene name>
// (the default `demfem study` output, relative to the working directory). The run's own
// variant first.
[[nodiscard]] std::vector<StudyLink> find_studies(const std::filesystem::path& run_dir,
                                                  const scene::Scene& scene);

struct ReportResult {
  std::filesystem::path html;
  std::filesystem::path metrics_json;
  std::vector<MetricRow> compared;          // one row per physical quantity, key ones first
  std::vector<MetricSeries> zero;           // identically zero in both (fixed by the scene)
  std::vector<Alias> aliases;               // solver columns folded into a compared quantity
  std::vector<std::string> profile_figures; // pressure and surface profiles
  std::vector<std::string> profile_notes;   // what the profiles show, in words (plain text)
  FieldComparison fields;                   // coarse-grained DEM against continuum
  std::vector<DiffRow> differences;         // what differs between the two models
  std::vector<ParamRow> parameters;         // both models' parameters with provenance
  std::vector<StudyLink> studies;           // linked study pages
  std::size_t dem_series = 0, continuum_series = 0;
};

// Linear interpolation of (t, y) at time `at`; held constant outside.
[[nodiscard]] double interpolate(const std::vector<double>& t, const std::vector<double>& y,
                                 double at);

// The largest values of a profile either way: `down` (≥ 0, its x) and `up` (≤ 0, its x) over the
// finite values; x is NaN where no value has that sign.
struct ProfileExtremes {
  double down = 0.0, x_down = std::numeric_limits<double>::quiet_NaN();
  double up = 0.0, x_up = std::numeric_limits<double>::quiet_NaN();
};
[[nodiscard]] ProfileExtremes profile_extremes(const std::vector<double>& x,
                                               const std::vector<double>& v);

// One sentence on a surface subsidence profile (down positive, metres) between t_rest and t_end:
// how far each solver's surface settled and rose at most, and where.
[[nodiscard]] std::string subsidence_summary(double t_rest, double t_end,
                                             const ProfileExtremes& dem,
                                             const ProfileExtremes& continuum);

// Reads <run>/dem/*.csv, <run>/continuum/*.csv, <run>/run_<solver>.json, <run>/dem/packing.json,
// <run>/calibration/ and figures under <run>/*/figures, and writes <run>/report.html (figures
// embedded) and <run>/metrics.json.
ReportResult write_report(const std::filesystem::path& run_dir, const ReportOptions& options);

} // namespace demfem::compare
