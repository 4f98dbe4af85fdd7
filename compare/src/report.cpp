#include "demfem/compare/report.hpp"
#include "demfem/compare/html.hpp"
#include "demfem/output/contract.hpp"
#include "report_sections.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>

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

struct Named {
  std::vector<double> t, y;
  std::string file;
};

// Every non-time column of every CSV under `dir` that has a "time" column.
std::map<std::string, Named> collect(const fs::path& dir) {
  std::map<std::string, Named> out;
  if (!fs::is_directory(dir)) return out;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".csv") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    const CsvTable t = read_csv(f);
    const int tc = t.find(output::col::time.name);
    if (tc < 0) continue;
    const auto time = t.column(t.columns[static_cast<std::size_t>(tc)]);
    for (std::size_t c = 0; c < t.columns.size(); ++c) {
      if (static_cast<int>(c) == tc) continue;
      Named n;
      n.t = time;
      n.y = t.column(t.columns[c]);
      n.file = f.filename().string();
      out.emplace(t.columns[c], std::move(n));
    }
  }
  return out;
}

std::string base64(const std::string& in) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const unsigned v = (static_cast<unsigned char>(in[i]) << 16) |
                       (static_cast<unsigned char>(in[i + 1]) << 8) |
                       static_cast<unsigned char>(in[i + 2]);
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += k[(v >> 6) & 63];
    out += k[v & 63];
  }
  if (i < in.size()) {
    unsigned v = static_cast<unsigned char>(in[i]) << 16;
    if (i + 1 < in.size()) v |= static_cast<unsigned char>(in[i + 1]) << 8;
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += i + 1 < in.size() ? k[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string img(const fs::path& png, const std::string& caption) {
  return detail::embed_png(png, caption);
}

std::string safe_name(const std::string& s) {
  std::string o;
  for (char c : s)
    o += (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-') ? c : '_';
  while (!o.empty() && o.back() == '_') o.pop_back();
  return o;
}

// "<wall>.bin<k> [Pa]" columns form a pressure profile, compared as a profile, not as 14 series.
bool is_profile_bin(const std::string& name, std::string* wall = nullptr, int* bin = nullptr) {
  return output::is_bin_heading(name, wall, bin);
}

double mean_over(const std::vector<double>& t, const std::vector<double>& y, double a, double b) {
  double sum = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < std::min(t.size(), y.size()); ++i)
    if (t[i] >= a && t[i] <= b && std::isfinite(y[i])) {
      sum += y[i];
      ++n;
    }
  return n ? sum / n : NAN;
}

} // namespace

std::string detail::embed_png(const fs::path& png, const std::string& caption) {
  if (!fs::exists(png)) return {};
  return fmt::format("<figure><img alt=\"{0}\" src=\"data:image/png;base64,{1}\"/><figcaption>{0}"
                     "</figcaption></figure>\n",
                     html_escape(caption), base64(read_all(png)));
}

namespace {

std::string num(double v) {
  return std::isfinite(v) ? fmt::format("{:.3g}", v) : std::string("—");
}
std::string pct(double v) {
  return std::isfinite(v) ? fmt::format("{:+.0f} %", 100 * v) : std::string("—");
}
std::string when(double t) {
  return t >= 0 ? fmt::format("{:.3g}", t) : std::string("never");
}

nlohmann::json part_json(const Part& p) {
  auto f = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  return {{"dem", f(p.dem)},
          {"continuum", f(p.continuum)},
          {"difference", f(p.difference())},
          {"relative", f(p.relative())}};
}

} // namespace

ProfileExtremes profile_extremes(const std::vector<double>& x, const std::vector<double>& v) {
  ProfileExtremes e;
  for (std::size_t k = 0; k < std::min(x.size(), v.size()); ++k) {
    if (!std::isfinite(v[k])) continue;
    if (v[k] > e.down) {
      e.down = v[k];
      e.x_down = x[k];
    }
    if (v[k] < e.up) {
      e.up = v[k];
      e.x_up = x[k];
    }
  }
  return e;
}

namespace {

// The DEM's surface settlement per bin followed as material, as the continuum's top nodes are:
// the particles that formed it at rest, from the particle snapshots nearest t_rest and t_end
// (each within 5 % of the span). Empty when those snapshots are missing or unreadable; the caller
// then takes the top of the bed per bin (surface.csv), which jumps by a grain whenever another
// particle becomes the highest.
std::vector<double> followed_dem_settlement(const fs::path& run_dir, double t_rest, double t_end,
                                            double x0, double x1, std::size_t bins) {
  const auto dps = read_pvd_entries(run_dir / output::dir::dem / output::file::particles_pvd);
  auto near = [&](double at) -> std::optional<std::size_t> {
    const std::size_t k = nearest_entry(dps, at);
    if (k < dps.size() && std::abs(dps[k].time - at) <= 0.05 * (t_end - t_rest)) return k;
    return std::nullopt;
  };
  const auto a = near(t_rest), b = near(t_end);
  if (!a || !b || *a == *b) return {};
  std::vector<double> zd;
  try {
    zd = dem_surface_settlement(read_particles_vtp(dps[*a].file), read_particles_vtp(dps[*b].file),
                                x0, x1, static_cast<int>(bins));
  } catch (const std::exception&) {
    return {};
  }
  if (zd.size() != bins ||
      std::none_of(zd.begin(), zd.end(), [](double v) { return std::isfinite(v); }))
    return {};
  return zd;
}

} // namespace

std::string subsidence_summary(double t_rest, double t_end, const ProfileExtremes& dem,
                               const ProfileExtremes& continuum) {
  const auto side = [](const ProfileExtremes& e) {
    const auto part = [](const char* verb, double v, double x) {
      return std::isfinite(x)
                 ? fmt::format("{} by at most {:.3g} mm (x = {:.4g} m)", verb, std::abs(v) * 1e3, x)
                 : fmt::format("nowhere {}", verb);
    };
    return part("settles", e.down, e.x_down) + " and " + part("rises", e.up, e.x_up);
  };
  return fmt::format("Surface from t = {:.3g} s to t = {:.3g} s: the DEM surface {}; the "
                     "continuum surface {}.",
                     t_rest, t_end, side(dem), side(continuum));
}

ReportResult write_report(const fs::path& run_dir, const ReportOptions& options) {
  ReportResult res;
  res.dem_series = collect(run_dir / output::dir::dem).size();
  res.continuum_series = collect(run_dir / output::dir::continuum).size();
  const fs::path figdir = run_dir / "compare"; // the report's own folder: rewritten whole
  fs::remove_all(figdir);
  fs::create_directories(figdir);
  const double thr = options.divergence_threshold;

  // ---- the metric table and the rows --------------------------------------------------------
  MetricSet set = collect_metrics(run_dir, options.scene);
  res.aliases = set.aliases;
  res.zero = set.zero;
  double t_end = 0.0;
  for (const auto& m : set.series)
    if (!m.dem.t.empty() && !m.continuum.t.empty())
      t_end = std::max(t_end, std::min(m.dem.t.back(), m.continuum.t.back()));
  const SplitOptions so = split_options(options.scene, t_end);
  nlohmann::json metrics = nlohmann::json::object();
  metrics["run_dir"] = run_dir.string();
  metrics["divergence_threshold"] = thr;
  metrics["split"] = {{"load_start_s", so.load_start},
                      {"moving_average_window_s", so.window},
                      {"late_window_s", {so.late_from, so.late_to}},
                      {"loading_period_s", so.period}};
  metrics["metric_table"] = nlohmann::json::array();
  metrics["rows"] = nlohmann::json::array();
  const double grain =
      options.scene && options.scene->soil.dem ? mean_diameter(*options.scene->soil.dem) : 0.0;
  for (const auto& m : set.series) {
    MetricRow row = compare_metric(m, so, thr);
    // A displacement far below the grains' size: both solvers move at the scale of the contacts'
    // deformation (the main job's foundation surface: 0.06 mm against 2.2 m disks).
    if (grain > 0.0 && m.def.unit == "m" && row.comparable) {
      const double big = row.largest_response();
      if (big < kSmallResponseShare * grain)
        row.verdict += fmt::format("; in both solvers the response is at most {:.2g} % of a mean "
                                   "particle diameter ({:.3g} m): far below the grain scale",
                                   100.0 * big / grain, grain);
    }
    // A displacement's verdict where the continuum is beyond its small strains says so.
    if (set.continuum_beyond_small_strain > 0.0 && m.def.unit == "m" && row.comparable)
      row.verdict += fmt::format(
          " — the continuum is beyond its small strains over {:.1f} % of the soil (note above): "
          "its displacements are not a soil's",
          100.0 * set.continuum_beyond_small_strain);
    metrics["metric_table"].push_back({{"key", m.def.key},
                                       {"quantity", m.def.quantity},
                                       {"unit", m.def.unit},
                                       {"dem", m.def.dem_source},
                                       {"continuum", m.def.continuum_source},
                                       {"meaning", m.def.meaning}});
    // Figure: the increments from rest of both solvers with their moving averages.
    PlotSpec spec;
    spec.title =
        fmt::format("{}: increment from rest (static: DEM {:.4g}, continuum {:.4g} {})",
                    m.def.quantity, row.static_part.dem, row.static_part.continuum, m.def.unit);
    spec.xlabel = "time [s]";
    spec.ylabel = fmt::format("{} − static [{}]", m.def.quantity, m.def.unit);
    spec.height = 450;
    spec.series.push_back(
        {"DEM", m.dem.t, row.dem_split.increment, "lines", "lw 1 lc rgb '#a6cee3'"});
    spec.series.push_back({"continuum", m.continuum.t, row.continuum_split.increment, "lines",
                           "lw 1 lc rgb '#fb9a99'"});
    spec.series.push_back({fmt::format("DEM, moving mean ({:.3g} s)", so.window), m.dem.t,
                           row.dem_split.mean, "lines", "lw 3 lc rgb '#1f78b4'"});
    spec.series.push_back({"continuum, moving mean", m.continuum.t, row.continuum_split.mean,
                           "lines", "lw 3 lc rgb '#e31a1c'"});
    const fs::path png = figdir / (safe_name(m.def.key) + ".png");
    std::string err;
    std::string figure;
    if (plot(spec, png, &err)) figure = fs::relative(png, run_dir).string();
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
  metrics["aliases"] = nlohmann::json::array();
  for (const auto& a : set.aliases)
    metrics["aliases"].push_back({{"column", a.column}, {"same_as", a.same_as}, {"why", a.why}});
  metrics["warnings"] = set.warnings;
  metrics["zero_in_both"] = nlohmann::json::array();
  for (const auto& z : set.zero)
    metrics["zero_in_both"].push_back({{"key", z.def.key}, {"note", z.note}});

  // ---- pressure profiles: at rest and late mean, bin 0 at the bottom ---------------------------
  {
    std::map<std::string, std::map<int, std::array<double, 4>>> prof; // wall → bin → values
    for (const char* solver : {"dem", "continuum"}) {
      const auto all = collect(run_dir / solver);
      for (const auto& [name, d] : all) {
        std::string wall;
        int bin = 0;
        if (!is_profile_bin(name, &wall, &bin) || d.file.rfind("pressure_", 0) != 0) continue;
        const double rest_a = so.load_start > 0.2 ? 0.5 * so.load_start : 0.0;
        const double rest_b =
            so.load_start > 0.2 ? so.load_start * (1 - 1e-9) - 1e-12 : d.t.front();
        const int o = std::string(solver) == "dem" ? 0 : 2;
        auto& v = prof[wall][bin];
        if (prof[wall].size() == 1 && o == 0) v.fill(NAN);
        v[static_cast<std::size_t>(o)] = mean_over(d.t, d.y, rest_a, rest_b);
        v[static_cast<std::size_t>(o + 1)] = mean_over(d.t, d.y, so.late_from, so.late_to);
      }
    }
    for (const auto& [wall, bins] : prof) {
      const int n = bins.rbegin()->first + 1;
      double hw = 1.0;
      if (options.scene)
        for (const auto& s : options.scene->structures)
          if (s.name == wall) {
            double lo = 1e300, hi = -1e300;
            for (const auto& q : s.outline) {
              lo = std::min(lo, q.z);
              hi = std::max(hi, q.z);
            }
            hw = hi > lo ? hi - lo : 1.0;
          }
      const char* names[4] = {"DEM at rest", "DEM, late mean", "continuum at rest",
                              "continuum, late mean"};
      const char* styles[4] = {"dt 2 lw 2 pt 6 lc rgb '#1f78b4'", "lw 2 pt 7 lc rgb '#1f78b4'",
                               "dt 2 lw 2 pt 4 lc rgb '#e31a1c'", "lw 2 pt 5 lc rgb '#e31a1c'"};
      std::vector<Series> ss(4);
      nlohmann::json jp = nlohmann::json::array();
      for (int c = 0; c < 4; ++c)
        ss[static_cast<std::size_t>(c)] = {names[c], {}, {}, "linespoints", styles[c]};
      for (const auto& [k, v] : bins) {
        const double h = (k + 0.5) / n * hw; // bin centre above the wall's base
        for (std::size_t c = 0; c < 4; ++c) {
          ss[c].x.push_back(v[c] * 1e-3);
          ss[c].y.push_back(h);
        }
        jp.push_back({{"height_m", h},
                      {"dem_rest_Pa", v[0]},
                      {"dem_late_Pa", v[1]},
                      {"continuum_rest_Pa", v[2]},
                      {"continuum_late_Pa", v[3]}});
      }
      PlotSpec spec;
      spec.title =
          fmt::format("{}: normal pressure along the wall, at rest and late mean ({:.3g}–{:.3g} s)",
                      wall, so.late_from, so.late_to);
      spec.xlabel = "pressure [kPa] (compression positive)";
      spec.ylabel = "height above the wall base [m]";
      spec.series = ss;
      spec.height = 500;
      const fs::path png = figdir / (safe_name(wall) + "_pressure_profile.png");
      std::string err;
      if (plot(spec, png, &err)) res.profile_figures.push_back(fs::relative(png, run_dir).string());
      metrics["pressure_profiles"][wall] = jp;
    }
  }

  // ---- surface subsidence profile: end − rest, both solvers ------------------------------------
  {
    const fs::path sf = run_dir / output::dir::dem / output::file::surface;
    const auto snaps =
        read_pvd_entries(run_dir / output::dir::continuum / output::file::continuum_pvd);
    if (fs::exists(sf) && !snaps.empty()) {
      const CsvTable t = read_csv(sf);
      const auto time = t.column(output::col::time.name);
      const std::size_t nb = t.columns.size() > 1 ? t.columns.size() - 1 : 0;
      double x0 = 0.0, x1 = 1.0;
      if (options.scene && !options.scene->domain.empty()) {
        x0 = x1 = options.scene->domain[0].x;
        for (const auto& q : options.scene->domain) {
          x0 = std::min(x0, q.x);
          x1 = std::max(x1, q.x);
        }
      }
      auto row_at = [&](double at) {
        std::size_t best = 0;
        for (std::size_t r = 0; r < time.size(); ++r)
          if (std::abs(time[r] - at) < std::abs(time[best] - at)) best = r;
        return best;
      };
      if (nb > 0 && !time.empty()) {
        const double tr = so.load_start, te = std::min(time.back(), snaps.back().time);
        const auto r0 = row_at(tr), r1 = row_at(te);
        std::vector<double> zc0, zc1;
        try {
          zc0 = continuum_surface(read_continuum_vtu(snaps[nearest_entry(snaps, tr)].file), x0, x1,
                                  static_cast<int>(nb));
          zc1 = continuum_surface(read_continuum_vtu(snaps[nearest_entry(snaps, te)].file), x0, x1,
                                  static_cast<int>(nb));
        } catch (const std::exception&) {
        }
        if (zc0.size() == nb && zc1.size() == nb) {
          const std::vector<double> zd = followed_dem_settlement(run_dir, tr, te, x0, x1, nb);
          const bool dem_followed = !zd.empty();
          Series sd{"DEM", {}, {}, "linespoints", "lw 2 pt 7 lc rgb '#1f78b4'"};
          Series sc{"continuum", {}, {}, "linespoints", "lw 2 pt 5 lc rgb '#e31a1c'"};
          nlohmann::json js = nlohmann::json::array();
          for (std::size_t b = 0; b < nb; ++b) {
            const double x =
                x0 + (x1 - x0) * (static_cast<double>(b) + 0.5) / static_cast<double>(nb);
            const double d = dem_followed ? zd[b] // subsidence: rest − end
                                          : t.rows[r0][b + 1] - t.rows[r1][b + 1];
            const double c = zc0[b] - zc1[b];
            sd.x.push_back(x);
            sd.y.push_back(d); // [m] here, scaled for the plot below
            sc.x.push_back(x);
            sc.y.push_back(c);
            js.push_back(
                {{"x_m", x},
                 {"dem_m", std::isfinite(d) ? nlohmann::json(d) : nlohmann::json(nullptr)},
                 {"continuum_m", std::isfinite(c) ? nlohmann::json(c) : nlohmann::json(nullptr)}});
          }
          // Both ways: a dilating continuum may rise more beside a footing than it settles.
          const auto de = profile_extremes(sd.x, sd.y), ce = profile_extremes(sc.x, sc.y);
          const double largest =
              std::max(std::max(de.down, -de.up), std::max(ce.down, -ce.up)); // [m]
          const bool mm = largest < 0.01;
          for (auto* s : {&sd, &sc})
            for (double& y : s->y) y *= mm ? 1e3 : 1e2;
          PlotSpec spec;
          spec.title =
              fmt::format("surface subsidence, t = {:.3g} s − t = {:.3g} s (down positive; "
                          "DEM {:.3g} … {:.3g} mm, continuum {:.3g} … {:.3g} mm)",
                          te, tr, de.up * 1e3, de.down * 1e3, ce.up * 1e3, ce.down * 1e3);
          spec.xlabel = "x [m]";
          spec.ylabel = mm ? "subsidence [mm] (down positive)" : "subsidence [cm] (down positive)";
          spec.series = {sd, sc};
          spec.height = 450;
          const fs::path png = figdir / "surface_subsidence_profile.png";
          std::string err;
          if (plot(spec, png, &err))
            res.profile_figures.push_back(fs::relative(png, run_dir).string());
          const std::string note =
              subsidence_summary(tr, te, de, ce) +
              (dem_followed
                   ? " DEM: the mean settlement of the particles that formed the surface at rest "
                     "(within one mean diameter of the top of their bin), followed to the end, as "
                     "the continuum's surface nodes are."
                   : " DEM: the top of the bed in each bin (no particle snapshots at both times).");
          res.profile_notes.push_back(note);
          const auto xj = [](double x) {
            return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr);
          };
          metrics["surface_subsidence_profile"] = {
              {"rest_s", tr},
              {"end_s", te},
              {"largest_dem_m", de.down},
              {"largest_continuum_m", ce.down},
              {"largest_dem_x_m", xj(de.x_down)},
              {"largest_continuum_x_m", xj(ce.x_down)},
              {"largest_rise_dem_m", -de.up},
              {"largest_rise_continuum_m", -ce.up},
              {"largest_rise_dem_x_m", xj(de.x_up)},
              {"largest_rise_continuum_x_m", xj(ce.x_up)},
              {"summary", note},
              {"dem_surface", dem_followed ? "surface particles followed" : "top of the bed"},
              {"bins", js}};
        }
      }
    }
  }

  // ---- coarse-grained fields ---------------------------------------------------------------
  if (options.fields) {
    double rho = 2650.0;
    if (options.scene && options.scene->soil.dem) rho = options.scene->soil.dem->density;
    res.fields = compare_fields(run_dir, so.load_start, rho, options.kernel_width);
    nlohmann::json jf = nlohmann::json::array();
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

  // ---- the two models: what differs, parameters, run records, studies ------------------------
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
  {
    nlohmann::json jd = nlohmann::json::array();
    for (const auto& r : res.differences)
      jd.push_back({{"aspect", r.aspect},
                    {"dem", r.dem},
                    {"continuum", r.continuum},
                    {"consequence", r.consequence},
                    {"matched", r.matched}});
    metrics["what_differs"] = jd;
    nlohmann::json jp = nlohmann::json::array();
    for (const auto& r : res.parameters)
      jp.push_back(
          {{"model", r.model}, {"key", r.name}, {"value", r.value}, {"provenance", r.provenance}});
    metrics["parameters"] = jp;
    nlohmann::json jt = nlohmann::json::object();
    for (const SolverRun* r : {&facts.dem, &facts.continuum})
      if (r->present)
        jt[r == &facts.dem ? "dem" : "continuum"] = {{"ok", r->ok},
                                                     {"solver_seconds", r->solver_seconds},
                                                     {"total_seconds", r->total_seconds},
                                                     {"steps", r->steps},
                                                     {"dt_s", r->dt}};
    if (facts.calibration) jt["calibration_seconds_when_computed"] = facts.cal_wall_seconds;
    metrics["run_times"] = jt;
    nlohmann::json js = nlohmann::json::array();
    for (const auto& st : res.studies)
      js.push_back({{"kind", st.kind},
                    {"scene", st.scene},
                    {"html", st.html.string()},
                    {"summary", st.summary}});
    metrics["studies"] = js;
  }

  res.metrics_json = run_dir / "metrics.json";
  scene::write_file_atomic(res.metrics_json, metrics.dump(2) + "\n"); // throws WriteError

  // ---- HTML -------------------------------------------------------------------------------
  std::string h;
  h += "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>" + html_escape(options.title) +
       "</title><style>body{font-family:sans-serif;max-width:1200px;margin:2em auto;color:#222;"
       "padding:0 1em}table{border-collapse:collapse;margin:1em 0;font-size:90%}td,th{border:1px "
       "solid #ccc;padding:3px 6px;text-align:right;vertical-align:top}th{background:#f3f3f3}"
       "table.v{font-size:78%}table.v td{white-space:nowrap}table.v "
       "td.l{white-space:normal;min-width:9em}td.l,th.l{text-align:left}figure{margin:1em "
       "0}img{max-width:100%;border:1px solid #eee}"
       "table.d{font-size:82%}table.d td{max-width:26em}"
       ".note{background:#fff6d6;padding:.6em 1em;border-left:4px solid #e6b800}"
       ".div{color:#b00;font-weight:bold}.ok{color:#070;font-weight:bold}"
       "h2{border-bottom:1px solid #ddd;padding-bottom:.2em;margin-top:2em}</style></head><body>\n";
  h += "<!--report-body-->\n";
  h += "<h1>" + html_escape(options.title) + "</h1>\n";
  for (const auto& note : options.notes) h += "<p class=\"note\">" + html_escape(note) + "</p>\n";
  for (const auto& w : set.warnings) h += "<p class=\"note\">" + html_escape(w) + "</p>\n";
  h += fmt::format("<p>Run directory: <code>{}</code>. Quantities compared: {} (each once; "
                   "{} solver column(s) folded into them, {} zero in both).</p>\n",
                   html_escape(run_dir.string()), res.compared.size(), res.aliases.size(),
                   res.zero.size());
  h += "<p>Sections: <a href=\"#verdicts\">verdicts</a>, <a href=\"#what-differs\">what differs "
       "between the two models</a>, <a href=\"#metrics\">metric table</a>, <a "
       "href=\"#parameters\">parameters and calibration</a>, <a "
       "href=\"#studies\">studies</a>.</p>\n";
  h += detail::runs_section(facts, command);
  if (!res.compared.empty()) {
    h += fmt::format(
        "<h2 id=\"verdicts\">Verdicts</h2><p>Each series is split into its <b>static</b> value "
        "({}), its "
        "<b>increment</b> (series − "
        "static; the table gives its mean over the late window {:.3g}–{:.3g} s) and its "
        "<b>oscillation</b> (increment − its moving mean over {:.3g} s of whole loading periods; "
        "the table gives the amplitude √2·RMS over the late window). Relative difference = "
        "(continuum − DEM)/|DEM|. A quantity <b>agrees</b> when the mean increments and the "
        "oscillation amplitudes are both within ±{:.0f} % of the DEM's, and <b>diverges</b> "
        "otherwise. First divergence: the first time after the load starts at which |continuum − "
        "DEM| of the increments (of their moving means) exceeds {:.0f} % of the DEM's largest "
        "|increment| (|moving mean|).</p>\n",
        so.load_start > 0.2
            ? fmt::format(
                  "the mean at rest, {:.3g}–{:.3g} s, before the loading starts at {:.3g} s",
                  0.5 * so.load_start, so.load_start, so.load_start)
            : fmt::format("the sample at t = {:.3g} s: the loading starts then", so.load_start),
        so.late_from, so.late_to, so.window, 100 * thr, 100 * thr);
    // A deposited bed is one realisation of the soil: say so, and how to measure the spread.
    if (options.scene && options.scene->soil.dem && options.scene->soil.dem->particles.empty() &&
        options.scene->soil.dem->particles_file.empty()) {
      const unsigned long s0 = options.scene->info.seed;
      h += fmt::format(
          "<p>The DEM column is one realisation of the bed (packing seed {0}); another "
          "realisation of the same soil gives another DEM answer, and a verdict near the "
          "threshold can change with it. <code>{1} --seeds {0},{2},{3}</code> runs one comparison "
          "per seed and reports the spread (ensemble.html).</p>\n",
          s0, html_escape(detail::default_command(*options.scene)), s0 + 1, s0 + 2);
    }
    h += "<div style=\"overflow-x:auto\"><table class=\"v\"><tr><th class=\"l\" rowspan=\"2\">"
         "quantity [unit]</th>"
         "<th colspan=\"4\">static (at rest)</th><th colspan=\"4\">mean increment (late)</th>"
         "<th colspan=\"4\">oscillation amplitude (late)</th><th colspan=\"2\">first divergence "
         "[s]</th><th rowspan=\"2\">verdict</th></tr><tr>";
    for (int k = 0; k < 3; ++k) h += "<th>DEM</th><th>continuum</th><th>diff.</th><th>rel.</th>";
    h += "<th>incr.</th><th>mean</th></tr>\n";
    for (const auto& r : res.compared) {
      h += fmt::format("<tr><td class=\"l\">{} [{}]</td>", html_escape(r.def.quantity),
                       html_escape(r.def.unit));
      for (const Part* p : {&r.static_part, &r.increment, &r.amplitude})
        h += fmt::format("<td>{}</td><td>{}</td><td>{}</td><td>{}</td>", num(p->dem),
                         num(p->continuum), num(p->difference()), pct(p->relative()));
      h += fmt::format("<td>{}</td><td>{}</td><td class=\"{}\">{}</td></tr>\n",
                       when(r.first_divergence), when(r.first_divergence_mean),
                       !r.comparable ? ""
                       : r.diverges  ? "div"
                                     : "ok",
                       !r.comparable ? "n/a"
                       : r.diverges  ? "diverge"
                                     : "agree");
    }
    h += "</table></div>\n<ul>\n";
    for (const auto& r : res.compared)
      h += "<li><b>" + html_escape(r.def.quantity) + "</b>: " + html_escape(r.verdict) + "</li>\n";
    h += "</ul>\n";
  }
  if (!res.zero.empty()) {
    h += "<p>Not compared (zero in both solvers): ";
    for (std::size_t k = 0; k < res.zero.size(); ++k)
      h += (k ? "; " : "") + html_escape(res.zero[k].def.quantity) + " (" +
           html_escape(res.zero[k].note) + ")";
    h += ".</p>\n";
  }
  h += detail::differences_section(res.differences);
  if (!res.compared.empty()) {
    h += "<h2 id=\"metrics\">Metric table</h2><p>Each quantity is defined once; the columns of the "
         "solvers' "
         "files it is read from are named.</p><table><tr><th class=\"l\">key</th>"
         "<th class=\"l\">quantity</th><th>unit</th><th class=\"l\">DEM</th>"
         "<th class=\"l\">continuum</th><th class=\"l\">meaning</th></tr>\n";
    for (const auto& r : res.compared)
      h += fmt::format(
          "<tr><td class=\"l\"><code>{}</code></td><td class=\"l\">{}</td><td>{}</td>"
          "<td class=\"l\">{}</td><td class=\"l\">{}</td><td class=\"l\">{}</td></tr>\n",
          html_escape(r.def.key), html_escape(r.def.quantity), html_escape(r.def.unit),
          html_escape(r.def.dem_source), html_escape(r.def.continuum_source),
          html_escape(r.def.meaning));
    h += "</table>\n";
    if (!res.aliases.empty()) {
      h += "<p>Solver columns that are one of these quantities under another name (not compared "
           "twice):</p><ul>\n";
      for (const auto& a : res.aliases)
        h += fmt::format("<li><code>{}</code> = <code>{}</code>: {}</li>\n", html_escape(a.column),
                         html_escape(a.same_as), html_escape(a.why));
      h += "</ul>\n";
    }
    h += "<h2>Time series</h2>\n";
    for (const auto& r : res.compared) {
      const fs::path png = figdir / (safe_name(r.def.key) + ".png");
      h += img(png, r.def.quantity + ": increment from rest, DEM and continuum");
    }
  }
  if (!res.profile_figures.empty()) {
    h += "<h2>Profiles</h2>\n";
    for (const auto& n : res.profile_notes) h += "<p>" + html_escape(n) + "</p>\n";
    for (const auto& f : res.profile_figures) h += img(run_dir / f, fs::path(f).stem().string());
  }
  if (!res.fields.figures.empty() || !res.fields.notes.empty()) {
    h += "<h2>Fields: coarse-grained DEM against the continuum</h2>\n";
    for (const auto& n : res.fields.notes) h += "<p>" + html_escape(n) + "</p>\n";
    if (!res.fields.summaries.empty()) {
      h += "<table><tr><th class=\"l\">field</th><th>mean DEM</th><th>mean continuum</th>"
           "<th>RMS difference</th></tr>\n";
      for (const auto& s : res.fields.summaries)
        h += fmt::format("<tr><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                         html_escape(s.field), num(s.mean_dem), num(s.mean_continuum),
                         num(s.rms_difference));
      h += "</table>\n";
    }
    for (const auto& f : res.fields.figures) h += img(run_dir / f, fs::path(f).stem().string());
  }
  h += detail::parameters_section(run_dir, res.parameters, facts, options.scene);
  h += detail::studies_section(run_dir, res.studies, options.scene);
  for (const char* solver : {"dem", "continuum"}) {
    const fs::path sd = run_dir / solver;
    if (!fs::is_directory(sd)) continue;
    const bool dem = std::string(solver) == "dem";
    h += fmt::format("<h2>{}</h2>\n", dem ? "Granular assembly (DEM)" : "Continuum (FEM)");
    // The solver's own records (headline numbers, log), linked: the compared quantities are
    // above, each once.
    std::string files;
    for (const fs::path& f :
         dem ? std::vector<fs::path>{run_dir / "summary.json", sd / output::file::packing,
                                     sd / output::file::energy_budget, run_dir / "run_dem.json"}
             : std::vector<fs::path>{run_dir / "run_continuum.json", sd / output::file::log})
      if (fs::exists(f))
        files += fmt::format("{}<a href=\"{}\">{}</a>", files.empty() ? "" : ", ",
                             html_escape(fs::relative(f, run_dir).generic_string()),
                             html_escape(fs::relative(f, run_dir).generic_string()));
    if (!files.empty()) h += "<p>Records: " + files + ".</p>\n";
    std::vector<fs::path> pngs;
    std::vector<fs::path> dirs{sd / "figures"};
    if (std::string(solver) == "dem") dirs.push_back(run_dir / "figures"); // per-run DEM figures
    for (const auto& fd : dirs)
      if (fs::is_directory(fd))
        for (const auto& e : fs::directory_iterator(fd))
          if (e.path().extension() == ".png") pngs.push_back(e.path());
    std::sort(pngs.begin(), pngs.end());
    // Figures above 1 MB (the snapshot series) are linked, not embedded, to keep the page small.
    std::string linked;
    for (const auto& p : pngs) {
      std::error_code ec;
      const auto size = fs::file_size(p, ec);
      if (!ec && size > 1000000)
        linked += fmt::format("{}<a href=\"{}\">{}</a> ({:.1f} MB)", linked.empty() ? "" : ", ",
                              html_escape(fs::relative(p, run_dir).string()),
                              html_escape(p.stem().string()), static_cast<double>(size) / 1e6);
      else
        h += img(p, p.stem().string());
    }
    if (!linked.empty()) h += "<p>Not embedded (large): " + linked + ".</p>\n";
  }
  h += "<!--/report-body-->\n</body></html>\n";
  res.html = run_dir / "report.html";
  scene::write_file_atomic(res.html, h);
  return res;
}

} // namespace demfem::compare
