#include "demfem/compare/report.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
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
    const int tc = t.find("time");
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

std::string html_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
    case '&':
      o += "&amp;";
      break;
    case '<':
      o += "&lt;";
      break;
    case '>':
      o += "&gt;";
      break;
    case '"':
      o += "&quot;";
      break;
    default:
      o += c;
    }
  }
  return o;
}

std::string img(const fs::path& png, const std::string& caption) {
  if (!fs::exists(png)) return {};
  return fmt::format("<figure><img alt=\"{0}\" src=\"data:image/png;base64,{1}\"/><figcaption>{0}"
                     "</figcaption></figure>\n",
                     html_escape(caption), base64(read_all(png)));
}

std::string safe_name(const std::string& s) {
  std::string o;
  for (char c : s)
    o += (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-') ? c : '_';
  while (!o.empty() && o.back() == '_') o.pop_back();
  return o;
}

std::string summary_table(const fs::path& json_path) {
  if (!fs::exists(json_path)) return {};
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(read_all(json_path));
  } catch (const std::exception&) {
    return "<p>(summary.json could not be read)</p>";
  }
  std::string rows;
  for (const auto& [k, v] : j.items()) {
    if (v.is_object() || v.is_array()) continue;
    rows += fmt::format("<tr><td>{}</td><td>{}</td></tr>", html_escape(k), html_escape(v.dump()));
  }
  return rows.empty() ? std::string() : "<table>" + rows + "</table>\n";
}

// "<wall>.bin<k> [Pa]" columns form a pressure profile, compared as a profile, not as 14 series.
bool is_profile_bin(const std::string& name, std::string* wall = nullptr, int* bin = nullptr) {
  const auto p = name.find(".bin");
  if (p == std::string::npos) return false;
  std::size_t q = p + 4;
  int k = 0;
  bool digits = false;
  while (q < name.size() && std::isdigit(static_cast<unsigned char>(name[q]))) {
    k = 10 * k + (name[q] - '0');
    ++q;
    digits = true;
  }
  if (!digits || (q < name.size() && name[q] != ' ')) return false;
  if (wall) *wall = name.substr(0, p);
  if (bin) *bin = k;
  return true;
}

// The quantities a reader looks for first come first.
int priority(const std::string& name) {
  for (const auto& [key, rank] : {std::pair<const char*, int>{".thrust", 0},
                                  {".rotation", 1},
                                  {".settlement", 2},
                                  {".moment", 3},
                                  {".force", 4}})
    if (name.find(key) != std::string::npos) return rank;
  return 10;
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

double finite_or_zero(double v) {
  return std::isfinite(v) ? v : 0.0;
}

} // namespace

ReportResult write_report(const fs::path& run_dir, const ReportOptions& options) {
  ReportResult res;
  const auto dem = collect(run_dir / "dem");
  const auto cont = collect(run_dir / "continuum");
  res.dem_series = dem.size();
  res.continuum_series = cont.size();
  const fs::path figdir = run_dir / "compare"; // the report's own folder: rewritten whole
  fs::remove_all(figdir);
  fs::create_directories(figdir);

  nlohmann::json metrics = nlohmann::json::object();
  metrics["run_dir"] = run_dir.string();
  metrics["divergence_threshold"] = options.divergence_threshold;
  metrics["series"] = nlohmann::json::array();

  std::vector<std::string> names;
  for (const auto& [name, d] : dem)
    if (cont.count(name) && !is_profile_bin(name)) names.push_back(name);
  std::stable_sort(names.begin(), names.end(), [](const std::string& a, const std::string& b) {
    return priority(a) < priority(b);
  });
  for (const auto& name : names) {
    const auto& d = dem.at(name);
    const auto& c = cont.at(name);
    double scale = 0.0;
    for (double v : d.y) scale = std::max(scale, std::abs(finite_or_zero(v)));
    for (double v : c.y) scale = std::max(scale, std::abs(finite_or_zero(v)));
    if (scale == 0.0) continue; // identically zero in both (e.g. a fixed wall's rotation)
    SeriesMetrics m;
    m.name = name;
    // Common time base: the DEM samples inside the continuum's time span.
    const double t0 = std::max(d.t.front(), c.t.front());
    const double t1 = std::min(d.t.back(), c.t.back());
    double sum2 = 0.0;
    std::size_t n = 0;
    for (double v : d.y) m.max_abs_dem = std::max(m.max_abs_dem, std::abs(v));
    std::vector<double> tt, diff;
    for (std::size_t k = 0; k < d.t.size(); ++k) {
      if (d.t[k] < t0 || d.t[k] > t1) continue;
      const double e = interpolate(c.t, c.y, d.t[k]) - d.y[k];
      sum2 += e * e;
      ++n;
      tt.push_back(d.t[k]);
      diff.push_back(e);
      if (m.first_divergence_time < 0 && m.max_abs_dem > 0 &&
          std::abs(e) > options.divergence_threshold * m.max_abs_dem)
        m.first_divergence_time = d.t[k];
    }
    m.rms_difference = n ? std::sqrt(sum2 / static_cast<double>(n)) : NAN;
    m.relative_rms = m.max_abs_dem > 0 ? m.rms_difference / m.max_abs_dem : NAN;
    m.final_dem = d.y.empty() ? NAN : d.y.back();
    m.final_continuum = c.y.empty() ? NAN : c.y.back();
    // Mean over the last third of the common span: the slowly varying (DC) part of a shaken signal.
    m.late_mean_dem = mean_over(d.t, d.y, t1 - (t1 - t0) / 3.0, t1);
    m.late_mean_continuum = mean_over(c.t, c.y, t1 - (t1 - t0) / 3.0, t1);
    PlotSpec spec;
    spec.title = name + ": DEM vs continuum";
    spec.xlabel = "time [s]";
    spec.ylabel = name;
    spec.series.push_back({"DEM", d.t, d.y, "lines", "lw 1.5 lc rgb '#1f78b4'"});
    spec.series.push_back({"continuum", c.t, c.y, "lines", "lw 2 lc rgb '#e31a1c'"});
    spec.series.push_back({"continuum − DEM", tt, diff, "lines", "dt 2 lc rgb '#777777'"});
    const fs::path png = figdir / (safe_name(name) + ".png");
    std::string err;
    if (plot(spec, png, &err)) m.figure = fs::relative(png, run_dir).string();
    metrics["series"].push_back({{"name", m.name},
                                 {"rms_difference", m.rms_difference},
                                 {"relative_rms", m.relative_rms},
                                 {"max_abs_dem", m.max_abs_dem},
                                 {"final_dem", m.final_dem},
                                 {"final_continuum", m.final_continuum},
                                 {"first_divergence_time", m.first_divergence_time},
                                 {"late_mean_dem", m.late_mean_dem},
                                 {"late_mean_continuum", m.late_mean_continuum},
                                 {"figure", m.figure}});
    res.compared.push_back(std::move(m));
  }

  // ---- pressure profiles: time-mean pressure per bin along each wall, bin 0 at the bottom -----
  std::map<std::string, std::map<int, std::pair<double, double>>>
      profiles; // wall → bin → (dem, cont)
  for (const auto& [name, d] : dem) {
    std::string wall;
    int bin = 0;
    if (!is_profile_bin(name, &wall, &bin) || !cont.count(name)) continue;
    const auto& c = cont.at(name);
    const double t1 = std::min(d.t.back(), c.t.back());
    profiles[wall][bin] = {mean_over(d.t, d.y, 0.0, t1), mean_over(c.t, c.y, 0.0, t1)};
  }
  for (const auto& [wall, bins] : profiles) {
    const int n = bins.rbegin()->first + 1;
    Series sd{"DEM", {}, {}, "linespoints", "lw 2 pt 7 lc rgb '#1f78b4'"};
    Series sc{"continuum", {}, {}, "linespoints", "lw 2 pt 5 lc rgb '#e31a1c'"};
    nlohmann::json jp = nlohmann::json::array();
    for (const auto& [k, v] : bins) {
      const double h = (k + 0.5) / n; // bin centre as a fraction of the wall height
      sd.x.push_back(v.first);
      sd.y.push_back(h);
      sc.x.push_back(v.second);
      sc.y.push_back(h);
      jp.push_back({{"height_fraction", h}, {"dem_Pa", v.first}, {"continuum_Pa", v.second}});
    }
    PlotSpec spec;
    spec.title = wall + ": time-mean pressure along the wall";
    spec.xlabel = "pressure [Pa] (compression positive)";
    spec.ylabel = "height / wall height";
    spec.series = {sd, sc};
    const fs::path png = figdir / (safe_name(wall) + "_pressure_profile.png");
    std::string err;
    if (plot(spec, png, &err)) res.profile_figures.push_back(fs::relative(png, run_dir).string());
    metrics["pressure_profiles"][wall] = jp;
  }

  res.metrics_json = run_dir / "metrics.json";
  scene::write_file_atomic(res.metrics_json, metrics.dump(2) + "\n"); // throws WriteError

  // ---- HTML -------------------------------------------------------------------------------
  std::string h;
  h += "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>" + html_escape(options.title) +
       "</title><style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}"
       "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:4px 8px;"
       "text-align:right}th{background:#f3f3f3}td:first-child{text-align:left}figure{margin:1em 0}"
       "img{max-width:100%;border:1px solid #eee}.note{background:#fff6d6;padding:.6em 1em;"
       "border-left:4px solid #e6b800}.div{color:#b00}</style></head><body>\n";
  h += "<h1>" + html_escape(options.title) + "</h1>\n";
  for (const auto& note : options.notes) h += "<p class=\"note\">" + html_escape(note) + "</p>\n";
  h += fmt::format("<p>Run directory: <code>{}</code>. DEM series: {}; continuum series: {}; "
                   "compared (same name in both): {}.</p>\n",
                   html_escape(run_dir.string()), res.dem_series, res.continuum_series,
                   res.compared.size());
  if (!res.compared.empty()) {
    h += fmt::format("<h2>Where the two answers diverge</h2><p>Divergence: |continuum − DEM| above "
                     "{:.0f} % of the largest DEM magnitude.</p><table><tr><th>quantity</th>"
                     "<th>final DEM</th><th>final continuum</th><th>late mean DEM</th>"
                     "<th>late mean continuum</th><th>RMS difference</th>"
                     "<th>relative RMS</th><th>first divergence [s]</th></tr>\n",
                     100 * options.divergence_threshold);
    for (const auto& m : res.compared)
      h += fmt::format("<tr><td>{}</td><td>{:.4g}</td><td>{:.4g}</td><td>{:.4g}</td><td>{:.4g}</td>"
                       "<td>{:.4g}</td><td>{:.1f} %</td><td class=\"{}\">{}</td></tr>\n",
                       html_escape(m.name), m.final_dem, m.final_continuum, m.late_mean_dem,
                       m.late_mean_continuum, m.rms_difference, 100 * m.relative_rms,
                       m.first_divergence_time >= 0 ? "div" : "",
                       m.first_divergence_time >= 0 ? fmt::format("{:.3g}", m.first_divergence_time)
                                                    : std::string("never"));
    h += "</table>\n";
    for (const auto& f : res.profile_figures) h += img(run_dir / f, fs::path(f).stem().string());
    for (const auto& m : res.compared)
      if (!m.figure.empty()) h += img(run_dir / m.figure, m.name);
  }
  for (const char* solver : {"dem", "continuum"}) {
    const fs::path sd = run_dir / solver;
    if (!fs::is_directory(sd)) continue;
    h += fmt::format("<h2>{}</h2>\n",
                     std::string(solver) == "dem" ? "Granular assembly (DEM)" : "Continuum (FEM)");
    h += summary_table(sd / "summary.json");
    std::vector<fs::path> pngs;
    std::vector<fs::path> dirs{sd / "figures"};
    if (std::string(solver) == "dem") dirs.push_back(run_dir / "figures"); // per-run DEM figures
    for (const auto& fd : dirs)
      if (fs::is_directory(fd))
        for (const auto& e : fs::directory_iterator(fd))
          if (e.path().extension() == ".png") pngs.push_back(e.path());
    std::sort(pngs.begin(), pngs.end());
    for (const auto& p : pngs) h += img(p, p.stem().string());
  }
  h += "</body></html>\n";
  res.html = run_dir / "report.html";
  scene::write_file_atomic(res.html, h);
  return res;
}

} // namespace demfem::compare
