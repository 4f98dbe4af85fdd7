#include "report_sections.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "demfem/calibrate/calibrate.hpp"
#include "demfem/compare/html.hpp"
#include "demfem/dem/verification.hpp"

namespace fs = std::filesystem;

namespace demfem::compare {

namespace {

std::string h(const std::string& s) {
  return html_escape(s);
}

std::string seconds(double s) {
  if (!(s > 0.0)) return "—";
  if (s < 120.0) return fmt::format("{:.1f} s", s);
  return fmt::format("{:.1f} min ({:.0f} s)", s / 60.0, s);
}

// Link target relative to the report (run_dir/report.html) when possible.
std::string href(const fs::path& run_dir, const fs::path& target) {
  std::error_code ec;
  const auto a = fs::weakly_canonical(fs::absolute(target), ec);
  const auto b = fs::weakly_canonical(fs::absolute(run_dir), ec);
  auto rel = fs::relative(a, b, ec);
  if (ec || rel.empty()) return "file://" + a.string();
  return rel.generic_string();
}

std::string study_summary(const nlohmann::json& j) {
  const std::string kind = j.value("study", std::string());
  if (kind == "stability" && j.contains("rows") && j["rows"].is_array()) {
    std::map<std::string, int> n;
    for (const auto& r : j["rows"]) ++n[r.value("outcome", std::string("?"))];
    std::string s = fmt::format("{} rows", j["rows"].size());
    std::string parts;
    for (const auto& [k, v] : n) parts += fmt::format("{}{} {}", parts.empty() ? "" : ", ", v, k);
    return s + (parts.empty() ? "" : ": " + parts);
  }
  if (kind == "error-vs-time" && j.contains("reference_runs") && j["reference_runs"].is_object() &&
      j.contains("points") && j["points"].is_array()) {
    // a scene without a closed form: each solver against its most resolved run
    std::string refs, front;
    for (const auto& [solver, name] : j["reference_runs"].items())
      refs += fmt::format("{}{}: {}", refs.empty() ? "" : ", ", solver,
                          name.is_string() ? name.get<std::string>() : std::string("?"));
    for (const auto& p : j["points"])
      if (p.value("pareto", false))
        front += (front.empty() ? "" : ", ") + p.value("name", std::string("?"));
    return fmt::format("{} ({}), {} runs against the most resolved run of each solver ({}); "
                       "primary metric {}; Pareto front {}",
                       j.value("solver", std::string("?")),
                       j.value("duration", 0.0) > 0.0
                           ? fmt::format("{:g} s simulated", j.value("duration", 0.0))
                           : std::string("scene duration"),
                       j["points"].size(), refs, j.value("primary_metric", std::string("?")),
                       front.empty() ? std::string("–") : front);
  }
  if (kind == "error-vs-time" && j.contains("fits") && j["fits"].is_array()) {
    std::string s;
    for (const auto& f : j["fits"]) {
      if (!f.contains("order") || !f["order"].is_number()) continue;
      s += fmt::format("{}order {:.2f} in {} ({} against {})", s.empty() ? "" : "; ",
                       f["order"].get<double>(), f.value("knob", std::string("?")),
                       f.value("metric", std::string("?")), f.value("against", std::string("?")));
    }
    return s.empty() ? "no fitted order" : s;
  }
  return {};
}

} // namespace

std::vector<StudyLink> find_studies(const fs::path& run_dir, const scene::Scene& scene) {
  std::vector<StudyLink> out;
  std::vector<fs::path> roots{run_dir, run_dir.parent_path(), fs::path("runs") / scene.info.name};
  std::vector<fs::path> seen;
  auto consider = [&](const fs::path& dir) {
    const fs::path js = dir / "study.json", page = dir / "study.html";
    if (!fs::is_regular_file(js) || !fs::is_regular_file(page)) return;
    std::error_code ec;
    const auto canon = fs::weakly_canonical(fs::absolute(page), ec);
    if (std::find(seen.begin(), seen.end(), canon) != seen.end()) return;
    nlohmann::json j;
    try {
      std::ifstream in(js);
      j = nlohmann::json::parse(in);
    } catch (const std::exception&) {
      return;
    }
    if (!j.is_object()) return;
    const std::string label = j.value("scene", std::string());
    if (label != scene.info.name && label.rfind(scene.info.name + "/", 0) != 0) return;
    seen.push_back(canon);
    out.push_back({canon, j.value("study", std::string("?")), label, study_summary(j)});
  };
  for (const auto& root : roots) {
    std::error_code ec;
    if (root.empty() || !fs::is_directory(root, ec)) continue;
    for (const auto& e : fs::directory_iterator(root, ec)) {
      if (!e.is_directory() || e.path().filename().string().rfind("study", 0) != 0) continue;
      consider(e.path());
      std::error_code ec2;
      for (const auto& sub : fs::directory_iterator(e.path(), ec2))
        if (sub.is_directory()) consider(sub.path());
    }
  }
  const std::string own = scene.label();
  std::stable_sort(out.begin(), out.end(), [&](const StudyLink& a, const StudyLink& b) {
    const bool ea = a.scene == own, eb = b.scene == own;
    if (ea != eb) return ea;
    if (a.kind != b.kind) return a.kind < b.kind;
    return a.scene < b.scene;
  });
  return out;
}

// Shell-safe word (single quotes when needed).
std::string shell_quote(const std::string& w) {
  if (!w.empty() && w.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                        "0123456789_-./=:+,@%") == std::string::npos)
    return w;
  std::string q = "'";
  for (const char c : w) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

namespace detail {

std::string default_command(const scene::Scene& s) {
  std::string c =
      "demfem compare " + shell_quote(s.source_file.empty() ? "SCENE.toml" : s.source_file);
  if (!s.variant.empty()) c += " --variant " + shell_quote(s.variant);
  return c;
}

std::string runs_section(const ModelFacts& f, const std::string& command) {
  std::string o = "<h2>Reproduce and run times</h2>\n";
  o += "<p>Reproduce: <code>" + h(command) + "</code></p>\n";
  o += "<table><tr><th class=\"l\">solver</th><th class=\"l\">outcome</th><th>solver wall "
       "time</th><th>with packing, set-up and figures</th><th>steps</th><th>Δt [s]</th>"
       "<th>simulated [s]</th><th>threads</th><th class=\"l\">finished</th></tr>\n";
  for (const SolverRun* r : {&f.dem, &f.continuum}) {
    const bool dem = r == &f.dem;
    const char* name = dem ? "DEM" : "continuum";
    if (!r->present) {
      o += fmt::format("<tr><td class=\"l\">{}</td><td class=\"l\" colspan=\"8\">not recorded "
                       "(no run_{}.json: the solver did not run here, or an older demfem ran "
                       "it)</td></tr>\n",
                       name, dem ? "dem" : "continuum");
      continue;
    }
    std::string outcome = r->ok ? "completed" : "failed: " + r->message;
    if (!r->note.empty()) outcome += " (" + r->note + ")";
    o += fmt::format("<tr><td class=\"l\">{}</td><td class=\"l\">{}</td><td>{}</td><td>{}</td>"
                     "<td>{}</td><td>{:.3g}</td><td>{:.4g}</td><td>{}</td><td "
                     "class=\"l\">{}</td></tr>\n",
                     name, h(outcome), seconds(r->solver_seconds), seconds(r->total_seconds),
                     dem || r->integrator != "explicit"
                         ? fmt::format("{}", r->steps)
                         : fmt::format("{} ({} probe steps)", r->substeps, r->steps),
                     r->dt, r->simulated_time, r->threads > 0 ? std::to_string(r->threads) : "—",
                     h(r->finished_utc));
  }
  o += "</table>\n";
  if (f.calibration)
    o += fmt::format("<p>Calibration {}: {} when computed ({} specimen(s) of {} disks; cached and "
                     "reused by every run with the same packing and contact parameters).</p>\n",
                     h(f.calibration_key), seconds(f.cal_wall_seconds), f.cal_specimens,
                     f.cal_particles);
  return o;
}

std::string differences_section(const std::vector<DiffRow>& rows) {
  if (rows.empty()) return {};
  int differ = 0;
  for (const auto& r : rows) differ += r.matched ? 0 : 1;
  std::string o = "<h2 id=\"what-differs\">What differs between the two models</h2>\n";
  o += fmt::format("<p>What each solver does for this scene, read from the resolved scene, the "
                   "calibration and the solvers' run records (not fixed text). {} of {} aspects "
                   "differ; a difference in the results may come from any of them.</p>\n",
                   differ, rows.size());
  o += "<table class=\"d\"><tr><th class=\"l\">aspect</th><th class=\"l\">DEM</th><th "
       "class=\"l\">continuum</th><th class=\"l\">consequence</th><th>status</th></tr>\n";
  for (const auto& r : rows)
    o += fmt::format("<tr><td class=\"l\"><b>{}</b></td><td class=\"l\">{}</td><td "
                     "class=\"l\">{}</td><td class=\"l\">{}</td><td class=\"{}\">{}</td></tr>\n",
                     h(r.aspect), h(r.dem), h(r.continuum), h(r.consequence),
                     r.matched ? "ok" : "div", r.matched ? "matched" : "differs");
  o += "</table>\n";
  return o;
}

std::string parameters_section(const fs::path& run_dir, const std::vector<ParamRow>& rows,
                               const ModelFacts& f, const scene::Scene* scene) {
  if (rows.empty()) return {};
  std::string o = "<h2 id=\"parameters\">Parameters of both models</h2>\n";
  o += "<table class=\"d\"><tr><th class=\"l\">model</th><th class=\"l\">key</th><th "
       "class=\"l\">value</th><th class=\"l\">provenance</th></tr>\n";
  for (const auto& r : rows)
    o += fmt::format("<tr><td class=\"l\">{}</td><td class=\"l\"><code>{}</code></td><td "
                     "class=\"l\">{}</td><td class=\"l\">{}</td></tr>\n",
                     h(r.model), h(r.name), h(r.value), h(r.provenance));
  o += "</table>\n";
  const fs::path cal = run_dir / "calibration";
  o += "<h3>Calibration</h3>\n";
  if (!f.calibration) {
    o += "<p>This run has no calibration (<code>soil.continuum.calibrate</code> is not "
         "<code>\"dem\"</code>): the continuum's parameters are the scene's.";
    if (scene && scene->soil.dem && scene->soil.continuum) {
      std::string c = "demfem calibrate " + shell_quote(scene->source_file);
      if (!scene->variant.empty()) c += " --variant " + shell_quote(scene->variant);
      o += " <code>" + h(c) + "</code> computes them from DEM element tests.";
    }
    return o + "</p>\n";
  }
  o += fmt::format(
      "<p>DEM element tests on {} specimen(s) of {} disks made by the scene's packing procedure "
      "(calibration {}; <a href=\"{}\">calibration.json</a>, <a href=\"{}\">calibration.toml</a>); "
      "the continuum values they gave are in the table above. Also measured: the critical-state "
      "friction angle φ_cv = {:.1f}°, the affine (upper-bound) in-plane E' = {:.3g} MPa and "
      "G = {:.3g} MPa.</p>\n",
      f.cal_specimens, f.cal_particles, h(f.calibration_key),
      h(href(run_dir, cal / "calibration.json")), h(href(run_dir, cal / "calibration.toml")),
      f.cal_phi_cv, f.cal_affine_e / 1e6, f.cal_affine_g / 1e6);
  if (f.cal_specimen_fits.size() > 1)
    o += fmt::format("<p>Envelope of all peaks: φ = {:.1f}°, c = {:.3g} kPa; each specimen's "
                     "peaks alone give φ / c = {} (the realisation spread one specimen would "
                     "carry).</p>\n",
                     f.cal_phi_fit, f.cal_cohesion_fit / 1e3,
                     h(calibrate::specimen_fits_text(f.cal_specimen_fits)));
  if (!f.cal_cyclic.empty()) {
    o += fmt::format("<table><tr><th colspan=\"3\">cyclic biaxial at σ_c = {:.4g} kPa</th></tr>"
                     "<tr><th>γ</th><th>G [MPa]</th><th>ξ [%]</th></tr>\n",
                     f.cal_cyclic_sigma / 1e3);
    for (const auto& l : f.cal_cyclic)
      o += fmt::format("<tr><td>{:.2g}</td><td>{:.3g}</td><td>{:.1f}</td></tr>\n", l.gamma,
                       l.g / 1e6, 100.0 * l.xi);
    o += "</table>\n";
  }
  std::vector<fs::path> pngs;
  std::error_code ec;
  if (fs::is_directory(cal / "figures", ec))
    for (const auto& e : fs::directory_iterator(cal / "figures", ec))
      if (e.path().extension() == ".png") pngs.push_back(e.path());
  std::sort(pngs.begin(), pngs.end());
  for (const auto& p : pngs) o += embed_png(p, "calibration: " + p.stem().string());
  if (pngs.empty())
    o += "<p>(No calibration figures in this run directory; <code>demfem calibrate</code> draws "
         "them.)</p>\n";
  return o;
}

std::string studies_section(const fs::path& run_dir, const std::vector<StudyLink>& studies,
                            const scene::Scene* scene) {
  std::string o = "<h2 id=\"studies\">Studies</h2>\n";
  if (!studies.empty()) {
    o += "<p><code>demfem study</code> pages of this scene (found beside this run directory or "
         "under <code>runs/&lt;scene&gt;/</code>):</p><ul>\n";
    for (const auto& s : studies)
      o += fmt::format("<li><a href=\"{}\">{} study of {}</a>{}</li>\n", h(href(run_dir, s.html)),
                       h(s.kind), h(s.scene), s.summary.empty() ? "" : ": " + h(s.summary));
    o += "</ul>\n";
  } else {
    o += "<p>No <code>demfem study</code> page of this scene was found (looked for "
         "<code>study*/study.json</code> in this run directory, its parent and "
         "<code>runs/&lt;scene&gt;/</code>).</p>\n";
  }
  if (!scene) return o;
  std::string var;
  if (!scene->variant.empty()) var = " --variant " + shell_quote(scene->variant);
  const std::string stab = "demfem study stability " + shell_quote(scene->source_file) + var;
  const std::string where = "runs/" + scene->info.name + "/study-";
  const std::string sub = scene->variant.empty() ? "" : "/" + scene->variant;
  o += "<p>Stability under stiff and extreme variants of this scene (DEM rows, and continuum rows "
       "when it has a continuum): <code>" +
       h(stab) + "</code> (writes <code>" + h(where + "stability" + sub) +
       "/study.html</code>, which this report then links). ";
  std::string evt = "demfem study error-vs-time " + shell_quote(scene->source_file) + var;
  if (dem::head_on_closed_form(*scene))
    o += "Error against run time (against the closed form): <code>" + h(evt) + "</code>.</p>\n";
  else
    o += "Error against run time, each solver against its most resolved run (this scene has no "
         "closed form): <code>" +
         h(evt + " --duration T --repeats 1") + "</code> (writes <code>" +
         h(where + "error-vs-time" + sub) +
         "/study.html</code>); the closed-form convergence orders are measured on <code>demfem "
         "study error-vs-time cases/verification/head_on_collision.toml</code> (DEM) and "
         "<code>demfem study error-vs-time flamant</code> (continuum).</p>\n";
  return o;
}

} // namespace detail
} // namespace demfem::compare
