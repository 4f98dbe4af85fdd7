// The comparison report of a run directory: every time series that both solvers wrote under the
// same name ("<structure>.rotation [rad]", "<wall>.thrust [N]", …) is aligned on a common time
// base, differenced, plotted, and summarised in a self-contained HTML page plus metrics.json.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace demfem::compare {

struct SeriesMetrics {
  std::string name;          // column name with unit
  double rms_difference = 0; // RMS of (continuum − dem) over the common time span
  double max_abs_dem = 0;    // scale: max |dem|
  double relative_rms = 0;   // rms_difference / max_abs_dem
  double final_dem = 0, final_continuum = 0;
  double first_divergence_time = -1; // first t where |c − d| > threshold · max|d| (−1: never)
  double late_mean_dem = 0, late_mean_continuum = 0; // mean over the last third (DC part)
  std::string figure;                                // relative path of its figure
};

struct ReportOptions {
  double divergence_threshold = 0.1; // relative to the DEM series' largest magnitude
  std::string title;
  std::vector<std::string> notes; // shown at the top (e.g. a solver that did not run)
};

struct ReportResult {
  std::filesystem::path html;
  std::filesystem::path metrics_json;
  std::vector<SeriesMetrics> compared;      // key quantities first; all-zero pairs left out
  std::vector<std::string> profile_figures; // pressure profiles along walls
  std::size_t dem_series = 0, continuum_series = 0;
};

// Linear interpolation of (t, y) at time `at`; held constant outside.
[[nodiscard]] double interpolate(const std::vector<double>& t, const std::vector<double>& y,
                                 double at);

// Reads <run>/dem/*.csv, <run>/continuum/*.csv, <run>/*/summary.json and figures under
// <run>/*/figures, and writes <run>/report.html (figures embedded) and <run>/metrics.json.
ReportResult write_report(const std::filesystem::path& run_dir, const ReportOptions& options);

} // namespace demfem::compare
