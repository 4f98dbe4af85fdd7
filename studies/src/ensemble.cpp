// Seed ensembles of comparisons (issue 9): summary over the members' metrics.json, ensemble.json
// and ensemble.html. Report-side code.
#include "demfem/studies/ensemble.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <utility>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "demfem/compare/html.hpp"
#include "demfem/compare/plot.hpp"
#include "demfem/scene/write_file.hpp"

namespace demfem::studies {

using compare::html_escape;
using compare::PlotSpec;
using compare::Series;

namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Two magnitudes within 0.1 % of each other are equal (e.g. a weight both models carry by
// construction): neither solver's is the larger.
constexpr double kEqual = 1e-3;

double number(const nlohmann::json& j) {
  return j.is_number() ? j.get<double>() : kNaN;
}

EnsembleStat stat_of(std::vector<double> v) {
  std::erase_if(v, [](double x) { return !std::isfinite(x); });
  EnsembleStat s;
  s.count = static_cast<int>(v.size());
  if (v.empty()) return {kNaN, kNaN, kNaN, 0};
  std::sort(v.begin(), v.end());
  s.min = v.front();
  s.max = v.back();
  const std::size_t n = v.size();
  s.median = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  return s;
}

void finish(EnsemblePart& p) {
  p.dem_stat = stat_of(p.dem);
  p.continuum_stat = stat_of(p.continuum);
  std::vector<double> ratio;
  p.dem_larger = p.continuum_larger = p.both = 0;
  for (std::size_t k = 0; k < p.dem.size(); ++k) {
    const double d = p.dem[k], c = p.continuum[k];
    if (!std::isfinite(d) || !std::isfinite(c)) continue;
    ++p.both;
    const double ad = std::abs(d), ac = std::abs(c);
    if (c != 0.0) ratio.push_back(ad / ac);
    if (std::abs(ad - ac) <= kEqual * std::max(ad, ac)) continue; // equal: neither is larger
    if (ad > ac)
      ++p.dem_larger;
    else
      ++p.continuum_larger;
  }
  p.ratio = stat_of(ratio);
}

std::string g3(double v) {
  return std::isfinite(v) ? fmt::format("{:.3g}", v) : "n/a";
}

std::string range(const EnsembleStat& s) {
  if (s.count == 0) return "n/a";
  if (s.count == 1 || s.min == s.max) return g3(s.min);
  return fmt::format("{} … {}", g3(s.min), g3(s.max));
}

// "×51" when a positive range spans more than 10 %, "" otherwise.
std::string spread(const EnsembleStat& s) {
  if (s.count < 2 || !(s.min > 0.0) || s.max < 1.1 * s.min) return "";
  return fmt::format(" (×{:.3g} across realisations)", s.max / s.min);
}

// What the ensemble decides about one part.
std::string decision(const EnsemblePart& p) {
  if (p.both == 0) return "not measured by both";
  if (p.dem_larger == 0 && p.continuum_larger == 0)
    return p.both < 2 ? "equal (within 0.1 %)" : "equal (within 0.1 %) in every realisation";
  if (p.both < 2) return "one realisation: its spread is unknown";
  if (p.dem_larger == p.both) return "the DEM's is larger in every realisation";
  if (p.continuum_larger == p.both) return "the continuum's is larger in every realisation";
  return "which is larger depends on the realisation: not decided";
}

// One part in plain words: both ranges, in how many realisations the DEM's is larger, and what
// that decides.
std::string part_words(const char* what, const EnsemblePart& p) {
  if (p.both == 0) return fmt::format("{}: no realisation has both values", what);
  std::string w =
      fmt::format("{}: DEM {}{}, continuum {}{}; |DEM| > |continuum| in {} of {}, < in {}", what,
                  range(p.dem_stat), spread(p.dem_stat), range(p.continuum_stat),
                  spread(p.continuum_stat), p.dem_larger, p.both, p.continuum_larger);
  if (p.ratio.count > 0) w += fmt::format(" (|DEM|/|continuum| {})", range(p.ratio));
  return w + " — " + decision(p);
}

nlohmann::json part_json(const EnsemblePart& p) {
  auto arr = [](const std::vector<double>& v) {
    nlohmann::json a = nlohmann::json::array();
    for (double x : v) a.push_back(std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr));
    return a;
  };
  auto st = [](const EnsembleStat& s) {
    auto f = [](double x) {
      return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr);
    };
    return nlohmann::json{
        {"min", f(s.min)}, {"median", f(s.median)}, {"max", f(s.max)}, {"count", s.count}};
  };
  return {{"dem", arr(p.dem)},
          {"continuum", arr(p.continuum)},
          {"dem_stats", st(p.dem_stat)},
          {"continuum_stats", st(p.continuum_stat)},
          {"abs_ratio_dem_over_continuum", st(p.ratio)},
          {"dem_larger", p.dem_larger},
          {"continuum_larger", p.continuum_larger},
          {"decision", decision(p)},
          {"with_both", p.both}};
}

std::string safe(const std::string& key) {
  std::string s;
  for (char c : key) s += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  return s;
}

} // namespace

Ensemble summarise_ensemble(const std::vector<EnsembleMember>& members) {
  Ensemble e;
  std::vector<nlohmann::json> metrics;
  for (const auto& m : members) {
    const fs::path f = m.run_dir / "metrics.json";
    std::ifstream in(f);
    if (!in) {
      e.missing.push_back(fmt::format("seed {}: no {}", m.seed, f.string()));
      continue;
    }
    try {
      metrics.push_back(nlohmann::json::parse(in));
      e.members.push_back(m);
    } catch (const std::exception& ex) {
      e.missing.push_back(fmt::format("seed {}: {}: {}", m.seed, f.string(), ex.what()));
    }
  }
  // Rows: every key any member compared, in first-seen order.
  for (const auto& j : metrics) {
    if (!j.contains("rows")) continue;
    for (const auto& r : j["rows"]) {
      const std::string key = r.value("key", "");
      if (key.empty() || std::any_of(e.rows.begin(), e.rows.end(),
                                     [&](const EnsembleRow& x) { return x.key == key; }))
        continue;
      EnsembleRow row;
      row.key = key;
      row.quantity = r.value("quantity", key);
      row.unit = r.value("unit", "");
      e.rows.push_back(row);
    }
  }
  for (auto& row : e.rows) {
    for (const auto& j : metrics) {
      const nlohmann::json* r = nullptr;
      if (j.contains("rows"))
        for (const auto& x : j["rows"])
          if (x.value("key", "") == row.key) r = &x;
      auto take = [&](EnsemblePart& p, const char* name) {
        const bool has = r && r->contains(name);
        p.dem.push_back(has ? number((*r)[name].value("dem", nlohmann::json())) : kNaN);
        p.continuum.push_back(has ? number((*r)[name].value("continuum", nlohmann::json())) : kNaN);
      };
      take(row.static_part, "static");
      take(row.increment, "mean_increment");
      take(row.amplitude, "oscillation_amplitude");
    }
    finish(row.static_part);
    finish(row.increment);
    finish(row.amplitude);
    // The parts some realisation measured in both solvers (the dynamic ones first).
    for (const auto& [name, part] :
         {std::pair<const char*, const EnsemblePart*>{"oscillation amplitude", &row.amplitude},
          {"mean increment", &row.increment}})
      if (part->both > 0)
        row.verdict += (row.verdict.empty() ? "" : "; ") + part_words(name, *part);
    if (row.verdict.empty() && row.static_part.both > 0) // no loading part: the value at rest
      row.verdict = part_words("static value", row.static_part);
    if (row.verdict.empty()) row.verdict = "no realisation has this quantity from both solvers";
  }
  return e;
}

EnsembleFiles write_ensemble(const fs::path& dir, Ensemble& e, const std::string& title,
                             const std::string& command) {
  std::error_code ec;
  const fs::path figdir = dir / "figures";
  fs::create_directories(figdir, ec);

  // Figures: per metric, the oscillation amplitude and |mean increment| of each solver against
  // the seed (log y when every value is positive and they span more than 20×).
  for (auto& row : e.rows) {
    PlotSpec spec;
    spec.title = fmt::format("{}: per realisation", row.quantity);
    spec.xlabel = "packing seed (scene.seed)";
    spec.ylabel = fmt::format("{} [{}]", row.quantity, row.unit);
    spec.height = 420;
    double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
    bool positive = true;
    auto add = [&](const char* label, const std::vector<double>& v, bool absolute,
                   const char* style) {
      Series s{label, {}, {}, "points", style};
      for (std::size_t k = 0; k < v.size() && k < e.members.size(); ++k) {
        if (!std::isfinite(v[k])) continue;
        const double y = absolute ? std::abs(v[k]) : v[k];
        s.x.push_back(static_cast<double>(e.members[k].seed));
        s.y.push_back(y);
        positive = positive && y > 0.0;
        lo = std::min(lo, y);
        hi = std::max(hi, y);
      }
      if (!s.x.empty()) spec.series.push_back(std::move(s));
    };
    add("DEM, oscillation amplitude", row.amplitude.dem, false, "pt 7 ps 1.6 lc rgb '#1f78b4'");
    add("continuum, oscillation amplitude", row.amplitude.continuum, false,
        "pt 7 ps 1.6 lc rgb '#e31a1c'");
    add("DEM, |mean increment|", row.increment.dem, true, "pt 6 ps 1.6 lw 2 lc rgb '#1f78b4'");
    add("continuum, |mean increment|", row.increment.continuum, true,
        "pt 6 ps 1.6 lw 2 lc rgb '#e31a1c'");
    if (spec.series.empty()) continue;
    spec.log_y = positive && hi > 20.0 * lo;
    const fs::path png = figdir / ("ensemble_" + safe(row.key) + ".png");
    if (plot(spec, png)) row.figure = fs::relative(png, dir).string();
  }

  // ---- ensemble.json
  nlohmann::json j;
  j["title"] = title;
  j["command"] = command;
  j["members"] = nlohmann::json::array();
  for (const auto& m : e.members)
    j["members"].push_back({{"seed", m.seed},
                            {"run_dir", m.run_dir.string()},
                            {"report", (m.run_dir / "report.html").string()}});
  j["missing"] = e.missing;
  j["rows"] = nlohmann::json::array();
  for (const auto& r : e.rows)
    j["rows"].push_back({{"key", r.key},
                         {"quantity", r.quantity},
                         {"unit", r.unit},
                         {"static", part_json(r.static_part)},
                         {"mean_increment", part_json(r.increment)},
                         {"oscillation_amplitude", part_json(r.amplitude)},
                         {"verdict", r.verdict},
                         {"figure", r.figure}});
  EnsembleFiles files{dir / "ensemble.json", dir / "ensemble.html"};
  scene::write_file_atomic(files.json, j.dump(2) + "\n");

  // ---- ensemble.html
  std::string h =
      "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>" + html_escape(title) +
      "</title><style>body{font-family:sans-serif;max-width:1200px;margin:2em auto;color:#222;"
      "padding:0 1em}table{border-collapse:collapse;margin:1em 0;font-size:88%}td,th{border:1px "
      "solid #ccc;padding:3px 6px;text-align:right;vertical-align:top}th{background:#f3f3f3}"
      "td.l,th.l{text-align:left}img{max-width:100%;border:1px solid #eee}"
      ".note{background:#fff6d6;padding:.6em 1em;border-left:4px solid #e6b800}"
      ".dec{font-weight:bold}"
      "h2{border-bottom:1px solid #ddd;padding-bottom:.2em;margin-top:2em}</style></head><body>\n";
  h += "<h1>" + html_escape(title) + "</h1>\n";
  h += fmt::format(
      "<p>The same scene compared in {} realisations of the DEM bed (<code>scene.seed</code>: "
      "the packing's radii and placement), each with the continuum calibrated from its own bed "
      "where the scene calibrates it. Per metric: the range of each solver's value over the "
      "realisations and in how many the DEM's magnitude exceeds the continuum's. A difference that "
      "changes sign between realisations is not decided by this ensemble.</p>\n",
      e.members.size());
  h += "<p>Reproduce: <code>" + html_escape(command) + "</code></p>\n";
  for (const auto& m : e.missing) h += "<p class=\"note\">Left out: " + html_escape(m) + "</p>\n";
  h += "<h2>Realisations</h2><table><tr><th>seed</th><th class=\"l\">report</th></tr>\n";
  for (const auto& m : e.members) {
    const fs::path rel = fs::relative(m.run_dir / "report.html", dir, ec);
    h += fmt::format("<tr><td>{}</td><td class=\"l\"><a href=\"{}\">{}</a></td></tr>\n", m.seed,
                     html_escape(rel.string()), html_escape(rel.string()));
  }
  h += "</table>\n";
  h += "<h2 id=\"summary\">Summary over the realisations</h2><table><tr><th class=\"l\">quantity "
       "[unit]</th><th class=\"l\">part</th><th>DEM min … max</th><th>DEM median</th>"
       "<th>continuum min … max</th><th>continuum median</th><th>|DEM|/|continuum|</th>"
       "<th>|DEM| larger in</th><th class=\"l\">decision (bold: decided)</th></tr>\n";
  for (const auto& r : e.rows)
    for (const auto& [name, p] :
         {std::pair<const char*, const EnsemblePart*>{"static", &r.static_part},
          {"mean increment (late)", &r.increment},
          {"oscillation amplitude (late)", &r.amplitude}}) {
      // bold: the same solver's value is the larger in every realisation (decided)
      const char* cls =
          p->both >= 2 && (p->dem_larger == p->both || p->continuum_larger == p->both) ? "dec" : "";
      h += fmt::format("<tr><td class=\"l\">{} [{}]</td><td class=\"l\">{}</td><td>{}</td>"
                       "<td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{} of {}</td><td "
                       "class=\"l {}\">{}</td></tr>\n",
                       html_escape(r.quantity), html_escape(r.unit), name, range(p->dem_stat),
                       g3(p->dem_stat.median), range(p->continuum_stat),
                       g3(p->continuum_stat.median), range(p->ratio), p->dem_larger, p->both, cls,
                       decision(*p));
    }
  h += "</table>\n<h2>Verdicts</h2><ul>\n";
  for (const auto& r : e.rows)
    h += "<li><b>" + html_escape(r.quantity) + "</b>: " + html_escape(r.verdict) + "</li>\n";
  h += "</ul>\n<h2>Per realisation</h2>\n";
  for (const auto& r : e.rows)
    if (!r.figure.empty())
      h += fmt::format("<figure><img src=\"{}\" alt=\"{}\"></figure>\n", html_escape(r.figure),
                       html_escape(r.quantity));
  h += "<table><tr><th class=\"l\">quantity [unit]</th><th class=\"l\">part</th>";
  for (const auto& m : e.members)
    h += fmt::format("<th>seed {} DEM</th><th>continuum</th>", m.seed);
  h += "</tr>\n";
  for (const auto& r : e.rows)
    for (const auto& [name, p] :
         {std::pair<const char*, const EnsemblePart*>{"mean increment", &r.increment},
          {"oscillation amplitude", &r.amplitude}}) {
      h += fmt::format("<tr><td class=\"l\">{} [{}]</td><td class=\"l\">{}</td>",
                       html_escape(r.quantity), html_escape(r.unit), name);
      for (std::size_t k = 0; k < e.members.size(); ++k)
        h += fmt::format("<td>{}</td><td>{}</td>", g3(p->dem[k]), g3(p->continuum[k]));
      h += "</tr>\n";
    }
  h += "</table>\n</body></html>\n";
  scene::write_file_atomic(files.html, h);
  return files;
}

} // namespace demfem::studies
