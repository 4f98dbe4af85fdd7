// report.html: the page assembled from its sections (the models' and the run's sections are in
// report_sections.cpp).
#include "demfem/compare/html.hpp"
#include "demfem/output/contract.hpp"
#include "profiles.hpp"
#include "report_sections.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

namespace fs = std::filesystem;

namespace demfem::compare::detail {
namespace {

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

std::string num(double v) {
  return std::isfinite(v) ? fmt::format("{:.3g}", v) : std::string("—");
}
std::string pct(double v) {
  return std::isfinite(v) ? fmt::format("{:+.0f} %", 100 * v) : std::string("—");
}
std::string when(double t) {
  return t >= 0 ? fmt::format("{:.3g}", t) : std::string("never");
}

std::string head(const std::string& title) {
  return "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>" + html_escape(title) +
         "</title><style>body{font-family:sans-serif;max-width:1200px;margin:2em auto;color:#222;"
         "padding:0 1em}table{border-collapse:collapse;margin:1em 0;font-size:90%}td,th{border:1px "
         "solid #ccc;padding:3px 6px;text-align:right;vertical-align:top}th{background:#f3f3f3}"
         "table.v{font-size:78%}table.v td{white-space:nowrap}table.v "
         "td.l{white-space:normal;min-width:9em}td.l,th.l{text-align:left}figure{margin:1em "
         "0}img{max-width:100%;border:1px solid #eee}"
         "table.d{font-size:82%}table.d td{max-width:26em}"
         ".note{background:#fff6d6;padding:.6em 1em;border-left:4px solid #e6b800}"
         ".div{color:#b00;font-weight:bold}.ok{color:#070;font-weight:bold}"
         "h2{border-bottom:1px solid #ddd;padding-bottom:.2em;margin-top:2em}</style></head><body>"
         "\n";
}

// The title, the notes and warnings, and what the page holds.
std::string intro(const fs::path& run_dir, const ReportOptions& options,
                  const std::vector<std::string>& warnings, const ReportResult& res) {
  std::string h = "<!--report-body-->\n";
  h += "<h1>" + html_escape(options.title) + "</h1>\n";
  for (const auto& i : options.incomplete)
    h += "<p class=\"note incomplete\"><b>Incomplete:</b> " + html_escape(i) + "</p>\n";
  for (const auto& note : options.notes) h += "<p class=\"note\">" + html_escape(note) + "</p>\n";
  for (const auto& w : warnings) h += "<p class=\"note\">" + html_escape(w) + "</p>\n";
  h += fmt::format("<p>Run directory: <code>{}</code>. Quantities compared: {} (each once; "
                   "{} solver column(s) folded into them, {} zero in both).</p>\n",
                   html_escape(run_dir.string()), res.compared.size(), res.aliases.size(),
                   res.zero.size());
  h += "<p>Sections: <a href=\"#verdicts\">verdicts</a>, <a href=\"#what-differs\">what differs "
       "between the two models</a>, <a href=\"#metrics\">metric table</a>, <a "
       "href=\"#parameters\">parameters and calibration</a>, <a "
       "href=\"#studies\">studies</a>.</p>\n";
  return h;
}

// How a series is split and judged, in words.
std::string verdicts_method(const SplitOptions& so, double thr) {
  return fmt::format(
      "<h2 id=\"verdicts\">Verdicts</h2><p>Each series is split into its <b>static</b> value "
      "({}), its <b>increment</b> (series − static; the table gives its mean over the late window "
      "{:.3g}–{:.3g} s) and its <b>oscillation</b> (increment − its moving mean over {:.3g} s of "
      "whole loading periods; the table gives the amplitude √2·RMS over the late window). "
      "Relative difference = (continuum − DEM)/|DEM|. A quantity <b>agrees</b> when the mean "
      "increments and the oscillation amplitudes are both within ±{:.0f} % of the DEM's, and "
      "<b>diverges</b> otherwise. First divergence: the first time after the load starts at which "
      "|continuum − DEM| of the increments (of their moving means) exceeds {:.0f} % of the DEM's "
      "largest |increment| (|moving mean|).</p>\n",
      so.load_start > 0.2
          ? fmt::format("the mean at rest, {:.3g}–{:.3g} s, before the loading starts at {:.3g} s",
                        0.5 * so.load_start, so.load_start, so.load_start)
          : fmt::format("the sample at t = {:.3g} s: the loading starts then", so.load_start),
      so.late_from, so.late_to, so.window, 100 * thr, 100 * thr);
}

// How a check is judged, in words, when the table has one.
std::string checks_method(const std::vector<MetricRow>& rows) {
  if (std::none_of(rows.begin(), rows.end(),
                   [](const MetricRow& r) { return r.def.role == Role::Check; }))
    return {};
  return "<p>A <b>check</b> is an identity both solvers must satisfy: it <b>holds</b> when the "
         "two agree as a verdict would, against the check's own threshold, and <b>fails</b> "
         "otherwise.</p>\n";
}

// A deposited bed is one realisation of the soil: say so, and how to measure the spread.
std::string realisation_note(const scene::Scene* scene) {
  if (!scene || !scene->soil.dem || !scene->soil.dem->particles.empty() ||
      !scene->soil.dem->particles_file.empty())
    return {};
  const unsigned long s0 = scene->info.seed;
  return fmt::format(
      "<p>The DEM column is one realisation of the bed (packing seed {0}); another "
      "realisation of the same soil gives another DEM answer, and a verdict near the "
      "threshold can change with it. <code>{1} --seeds {0},{2},{3}</code> runs one comparison "
      "per seed and reports the spread (ensemble.html).</p>\n",
      s0, html_escape(default_command(*scene)), s0 + 1, s0 + 2);
}

// One row per compared series: static, mean increment and amplitude, first divergence, the word.
std::string verdicts_table(const std::vector<MetricRow>& rows) {
  std::string h =
      "<div style=\"overflow-x:auto\"><table class=\"v\"><tr><th class=\"l\" rowspan=\"2\">"
      "quantity [unit]</th>"
      "<th colspan=\"4\">static (at rest)</th><th colspan=\"4\">mean increment (late)</th>"
      "<th colspan=\"4\">oscillation amplitude (late)</th><th colspan=\"2\">first divergence "
      "[s]</th><th rowspan=\"2\">verdict</th></tr><tr>";
  for (int k = 0; k < 3; ++k) h += "<th>DEM</th><th>continuum</th><th>diff.</th><th>rel.</th>";
  h += "<th>incr.</th><th>mean</th></tr>\n";
  for (const auto& r : rows) {
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
                     outcome_word(r));
  }
  h += "</table></div>\n<ul>\n";
  for (const auto& r : rows)
    h += "<li><b>" + html_escape(r.def.quantity) + "</b>: " + html_escape(r.verdict) + "</li>\n";
  return h + "</ul>\n";
}

std::string verdicts_section(const ReportResult& res, const SplitOptions& so,
                             const ReportOptions& options) {
  std::string h;
  if (!res.compared.empty())
    h += verdicts_method(so, options.divergence_threshold) + checks_method(res.compared) +
         realisation_note(options.scene) + verdicts_table(res.compared);
  if (!res.zero.empty()) {
    h += "<p>Not compared (zero in both solvers): ";
    for (std::size_t k = 0; k < res.zero.size(); ++k)
      h += (k ? "; " : "") + html_escape(res.zero[k].def.quantity) + " (" +
           html_escape(res.zero[k].note) + ")";
    h += ".</p>\n";
  }
  return h;
}

// The compared series' rows of the metric table, the columns folded into them, and their figures.
std::string metric_table_section(const fs::path& run_dir, const ReportResult& res) {
  if (res.compared.empty()) return {};
  std::string h =
      "<h2 id=\"metrics\">Metric table</h2><p>Each quantity is defined once; the columns of the "
      "solvers' files it is read from are named.</p><table><tr><th class=\"l\">key</th>"
      "<th class=\"l\">quantity</th><th>unit</th><th class=\"l\">DEM</th>"
      "<th class=\"l\">continuum</th><th class=\"l\">meaning</th></tr>\n";
  for (const auto& r : res.compared)
    h += fmt::format("<tr><td class=\"l\"><code>{}</code></td><td class=\"l\">{}</td><td>{}</td>"
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
  for (const auto& r : res.compared)
    h += embed_png(run_dir / "compare" / (safe_name(r.def.key) + ".png"),
                   r.def.quantity + ": increment from rest, DEM and continuum");
  return h;
}

std::string profiles_section(const fs::path& run_dir, const ReportResult& res) {
  if (res.profile_figures.empty()) return {};
  std::string h = "<h2>Profiles</h2>\n";
  for (const auto& n : res.profile_notes) h += "<p>" + html_escape(n) + "</p>\n";
  for (const auto& f : res.profile_figures)
    h += embed_png(run_dir / f, fs::path(f).stem().string());
  return h;
}

std::string fields_section(const fs::path& run_dir, const FieldComparison& fields) {
  if (fields.figures.empty() && fields.notes.empty()) return {};
  std::string h = "<h2>Fields: coarse-grained DEM against the continuum</h2>\n";
  for (const auto& n : fields.notes) h += "<p>" + html_escape(n) + "</p>\n";
  if (!fields.summaries.empty()) {
    h += "<table><tr><th class=\"l\">field</th><th>mean DEM</th><th>mean continuum</th>"
         "<th>RMS difference</th></tr>\n";
    for (const auto& s : fields.summaries)
      h += fmt::format("<tr><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                       html_escape(s.field), num(s.mean_dem), num(s.mean_continuum),
                       num(s.rms_difference));
    h += "</table>\n";
  }
  for (const auto& f : fields.figures) h += embed_png(run_dir / f, fs::path(f).stem().string());
  return h;
}

// Each solver's own records (headline numbers, log), linked, and its figures: the compared
// quantities are above, each once.
std::string solver_section(const fs::path& run_dir, bool dem) {
  const fs::path sd = run_dir / (dem ? output::dir::dem : output::dir::continuum);
  if (!fs::is_directory(sd)) return {};
  std::string h = fmt::format("<h2>{}</h2>\n", dem ? "Granular assembly (DEM)" : "Continuum (FEM)");
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
  if (dem) dirs.push_back(run_dir / "figures"); // per-run DEM figures
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
      h += embed_png(p, p.stem().string());
  }
  if (!linked.empty()) h += "<p>Not embedded (large): " + linked + ".</p>\n";
  return h;
}

} // namespace

std::string embed_png(const fs::path& png, const std::string& caption) {
  if (!fs::exists(png)) return {};
  return fmt::format("<figure><img alt=\"{0}\" src=\"data:image/png;base64,{1}\"/><figcaption>{0}"
                     "</figcaption></figure>\n",
                     html_escape(caption), base64(read_all(png)));
}

std::string report_page(const fs::path& run_dir, const ReportOptions& options,
                        const std::vector<std::string>& warnings, const SplitOptions& so,
                        const ReportResult& res, const ModelFacts& facts,
                        const std::string& command) {
  std::string h = head(options.title) + intro(run_dir, options, warnings, res);
  h += runs_section(facts, command);
  h += verdicts_section(res, so, options);
  h += differences_section(res.differences);
  h += metric_table_section(run_dir, res);
  h += profiles_section(run_dir, res);
  h += fields_section(run_dir, res.fields);
  h += parameters_section(run_dir, res.parameters, facts, options.scene);
  h += studies_section(run_dir, res.studies, options.scene);
  h += solver_section(run_dir, true) + solver_section(run_dir, false);
  return h + "<!--/report-body-->\n</body></html>\n";
}

} // namespace demfem::compare::detail
