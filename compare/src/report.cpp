// The comparison report (report.hpp): the metric table's series and profiles compared, the fields,
// the two models, recorded in metrics.json; report_page.cpp writes them as report.html.
#include "demfem/compare/report.hpp"
#include "demfem/output/contract.hpp"
#include "profiles.hpp"
#include "report_sections.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "demfem/compare/plot.hpp"
#include "demfem/scene/write_file.hpp"

namespace fs = std::filesystem;

namespace demfem::compare {

double interpolate(const std::vector<double>& t, const std::vector<double>& y, double at) {
  const std::size_t n = std::min(t.size(), y.size());
  if (n == 0) return NAN;
  if (at <= t[0]) return y[0];
  if (at >= t[n - 1]) return y[n - 1];
  const auto it = std::upper_bound(t.begin(), t.begin() + static_cast<std::ptrdiff_t>(n), at);
  const std::size_t k = static_cast<std::size_t>(it - t.begin());
  const double w = (at - t[k - 1]) / (t[k] - t[k - 1]); // linear interpolation
  return y[k - 1] + w * (y[k] - y[k - 1]);
}

namespace {

using nlohmann::json;

// The distinct non-time columns of the CSVs under `dir` that have a "time" column.
std::size_t count_series(const fs::path& dir) {
  if (!fs::is_directory(dir)) return 0;
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() != ".csv") continue;
    const CsvTable t = read_csv(e.path());
    const int tc = t.find(output::col::time.name);
    if (tc < 0) continue;
    for (std::size_t c = 0; c < t.columns.size(); ++c)
      if (static_cast<int>(c) != tc) names.insert(t.columns[c]);
  }
  return names.size();
}

json part_json(const Part& p) {
  auto f = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  return {{"dem", f(p.dem)},
          {"continuum", f(p.continuum)},
          {"difference", f(p.difference())},
          {"relative", f(p.relative())}};
}

// The end of the span both solvers cover, over every series [s].
double common_end(const std::vector<MetricSeries>& series) {
  double t_end = 0.0;
  for (const auto& m : series)
    if (!m.dem.t.empty() && !m.continuum.t.empty())
      t_end = std::max(t_end, std::min(m.dem.t.back(), m.continuum.t.back()));
  return t_end;
}

// Remarks on a displacement's verdict: far below the grain size (both solvers move at the scale
// of the contacts' deformation: the main job's foundation surface, 0.06 mm against 2.2 m disks),
// and a continuum beyond its small strains.
void add_displacement_remarks(MetricRow& row, double grain, double beyond_small_strain) {
  if (row.def.unit != "m" || !row.comparable) return;
  const double big = row.largest_response();
  if (grain > 0.0 && big < kSmallResponseShare * grain)
    row.verdict += fmt::format("; in both solvers the response is at most {:.2g} % of a mean "
                               "particle diameter ({:.3g} m): far below the grain scale",
                               100.0 * big / grain, grain);
  if (beyond_small_strain > 0.0)
    row.verdict += fmt::format(
        " — the continuum is beyond its small strains over {:.1f} % of the soil (note above): "
        "its displacements are not a soil's",
        100.0 * beyond_small_strain);
}

// The increments from rest of both solvers with their moving averages, in the row's scale; the
// figure's path relative to the run directory, "" when it could not be drawn.
std::string increment_figure(const MetricSeries& m, const MetricRow& row, const SplitOptions& so,
                             const fs::path& run_dir, const fs::path& figdir) {
  const double k = m.def.scale.factor;
  const std::string unit = m.def.scale.unit.empty() ? m.def.unit : std::string(m.def.scale.unit);
  auto scaled = [k](std::vector<double> v) {
    if (k != 1.0)
      for (double& y : v) y *= k;
    return v;
  };
  PlotSpec spec;
  spec.title =
      fmt::format("{}: increment from rest (static: DEM {:.4g}, continuum {:.4g} {})",
                  m.def.quantity, k * row.static_part.dem, k * row.static_part.continuum, unit);
  spec.xlabel = "time [s]";
  spec.ylabel = fmt::format("{} − static [{}]", m.def.quantity, unit);
  spec.height = 450;
  spec.series.push_back(
      {"DEM", m.dem.t, scaled(row.dem_split.increment), "lines", "lw 1 lc rgb '#a6cee3'"});
  spec.series.push_back({"continuum", m.continuum.t, scaled(row.continuum_split.increment), "lines",
                         "lw 1 lc rgb '#fb9a99'"});
  spec.series.push_back({fmt::format("DEM, moving mean ({:.3g} s)", so.window), m.dem.t,
                         scaled(row.dem_split.mean), "lines", "lw 3 lc rgb '#1f78b4'"});
  spec.series.push_back({"continuum, moving mean", m.continuum.t, scaled(row.continuum_split.mean),
                         "lines", "lw 3 lc rgb '#e31a1c'"});
  const fs::path png = figdir / (detail::safe_name(m.def.key) + ".png");
  std::string err;
  const bool drawn = plot(spec, png, &err);
  detail::fail_on_write_error(err);
  return drawn ? fs::relative(png, run_dir).string() : std::string();
}

// Every series of the set compared, with its figure: res.compared, metrics.json's metric_table
// and rows (and the aliases, warnings and series zero in both).
void compare_series(const MetricSet& set, const SplitOptions& so, const ReportOptions& options,
                    const fs::path& run_dir, const fs::path& figdir, ReportResult& res,
                    json& metrics) {
  metrics["metric_table"] = json::array();
  metrics["rows"] = json::array();
  const double grain =
      options.scene && options.scene->soil.dem ? mean_diameter(*options.scene->soil.dem) : 0.0;
  for (const auto& m : set.series) {
    MetricRow row = compare_metric(m, so, options.divergence_threshold);
    add_displacement_remarks(row, grain, set.continuum_beyond_small_strain);
    metrics["metric_table"].push_back({{"key", m.def.key},
                                       {"quantity", m.def.quantity},
                                       {"unit", m.def.unit},
                                       {"dem", m.def.dem_source},
                                       {"continuum", m.def.continuum_source},
                                       {"meaning", m.def.meaning}});
    const std::string figure = increment_figure(m, row, so, run_dir, figdir);
    metrics["rows"].push_back({{"key", m.def.key},
                               {"quantity", m.def.quantity},
                               {"unit", m.def.unit},
                               {"static", part_json(row.static_part)},
                               {"mean_increment", part_json(row.increment)},
                               {"oscillation_amplitude", part_json(row.amplitude)},
                               {"first_divergence_increment_s", row.first_divergence},
                               {"first_divergence_mean_increment_s", row.first_divergence_mean},
                               {"diverges", row.diverges},
                               {"comparable", row.comparable},
                               {"verdict", row.verdict},
                               {"figure", figure}});
    res.compared.push_back(std::move(row));
  }
  metrics["aliases"] = json::array();
  for (const auto& a : set.aliases)
    metrics["aliases"].push_back({{"column", a.column}, {"same_as", a.same_as}, {"why", a.why}});
  metrics["warnings"] = set.warnings;
  metrics["zero_in_both"] = json::array();
  for (const auto& z : set.zero)
    metrics["zero_in_both"].push_back({{"key", z.def.key}, {"note", z.note}});
}

// Every profile row of the table: res.profile_figures and profile_notes, metrics.json's records.
void compare_profile_rows(std::span<const Metric> table, const SplitOptions& so,
                          const ReportOptions& options, const fs::path& run_dir,
                          const fs::path& figdir, ReportResult& res, json& metrics) {
  for (auto& p : detail::compare_profiles(run_dir, figdir, table, so, options.scene)) {
    if (!p.figure.empty()) res.profile_figures.push_back(p.figure);
    if (!p.note.empty()) res.profile_notes.push_back(p.note);
    (p.owner.empty() ? metrics[p.record] : metrics[p.record][p.owner]) = std::move(p.values);
  }
}

// The coarse-grained DEM against the continuum: res.fields and metrics.json's fields.
void compare_field_maps(const SplitOptions& so, const ReportOptions& options,
                        const fs::path& run_dir, ReportResult& res, json& metrics) {
  double rho = 2650.0;
  if (options.scene && options.scene->soil.dem) rho = options.scene->soil.dem->density;
  res.fields = compare_fields(run_dir, so.load_start, rho, options.kernel_width);
  json jf = json::array();
  for (const auto& s : res.fields.summaries)
    jf.push_back({{"field", s.field},
                  {"mean_dem", s.mean_dem},
                  {"mean_continuum", s.mean_continuum},
                  {"rms_difference", s.rms_difference}});
  metrics["fields"] = {{"kernel", "Lucy (1977), 2D"},
                       {"support_radius_m", res.fields.width},
                       {"rest_s", res.fields.rest_time},
                       {"end_s", res.fields.end_time},
                       {"summaries", jf},
                       {"figures", res.fields.figures}};
}

// What differs between the two models, their parameters, run times and the study pages.
void record_models(const ReportResult& res, const ModelFacts& facts, json& metrics) {
  json jd = json::array();
  for (const auto& r : res.differences)
    jd.push_back({{"aspect", r.aspect},
                  {"dem", r.dem},
                  {"continuum", r.continuum},
                  {"consequence", r.consequence},
                  {"matched", r.matched}});
  metrics["what_differs"] = jd;
  json jp = json::array();
  for (const auto& r : res.parameters)
    jp.push_back(
        {{"model", r.model}, {"key", r.name}, {"value", r.value}, {"provenance", r.provenance}});
  metrics["parameters"] = jp;
  json jt = json::object();
  for (const SolverRun* r : {&facts.dem, &facts.continuum})
    if (r->present)
      jt[r == &facts.dem ? "dem" : "continuum"] = {{"ok", r->ok},
                                                   {"solver_seconds", r->solver_seconds},
                                                   {"total_seconds", r->total_seconds},
                                                   {"steps", r->steps},
                                                   {"dt_s", r->dt}};
  if (facts.calibration) jt["calibration_seconds_when_computed"] = facts.cal_wall_seconds;
  metrics["run_times"] = jt;
  json js = json::array();
  for (const auto& st : res.studies)
    js.push_back({{"kind", st.kind},
                  {"scene", st.scene},
                  {"html", st.html.string()},
                  {"summary", st.summary}});
  metrics["studies"] = js;
}

} // namespace

ReportResult write_report(const fs::path& run_dir, const ReportOptions& options) {
  ReportResult res;
  res.dem_series = count_series(run_dir / output::dir::dem);
  res.continuum_series = count_series(run_dir / output::dir::continuum);
  const fs::path figdir = run_dir / "compare"; // the report's own folder: rewritten whole
  fs::remove_all(figdir);
  fs::create_directories(figdir);
  const auto table = options.table.empty() ? metric_table() : options.table;

  const MetricSet set = collect_metrics(run_dir, options.scene, table);
  res.aliases = set.aliases;
  res.zero = set.zero;
  const SplitOptions so = split_options(options.scene, common_end(set.series));
  json metrics = json::object();
  metrics["run_dir"] = run_dir.string();
  if (!options.incomplete.empty()) metrics["incomplete"] = options.incomplete;
  metrics["divergence_threshold"] = options.divergence_threshold;
  metrics["split"] = {{"load_start_s", so.load_start},
                      {"moving_average_window_s", so.window},
                      {"late_window_s", {so.late_from, so.late_to}},
                      {"loading_period_s", so.period}};
  compare_series(set, so, options, run_dir, figdir, res, metrics);
  compare_profile_rows(table, so, options, run_dir, figdir, res, metrics);
  if (options.fields) compare_field_maps(so, options, run_dir, res, metrics);

  ModelFacts facts = read_model_facts(run_dir);
  facts.kernel_width = res.fields.width;
  if (options.scene) {
    res.differences = model_differences(*options.scene, facts);
    res.parameters = model_parameters(*options.scene, facts);
    res.studies = find_studies(run_dir, *options.scene);
  }
  const std::string command = !options.command.empty() ? options.command
                              : options.scene          ? detail::default_command(*options.scene)
                                                       : std::string("demfem compare SCENE");
  metrics["command"] = command;
  record_models(res, facts, metrics);
  res.metrics_json = run_dir / "metrics.json";
  scene::write_file_atomic(res.metrics_json, metrics.dump(2) + "\n"); // throws WriteError

  res.html = run_dir / "report.html";
  scene::write_file_atomic(
      res.html, detail::report_page(run_dir, options, set.warnings, so, res, facts, command));
  return res;
}

} // namespace demfem::compare
