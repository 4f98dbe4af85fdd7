// `demfem study stability`: stiff and extreme variants of a scene's DEM model.
#include "demfem/studies/study.hpp"
#include "demfem/compare/html.hpp"
#include "study_runs.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "demfem/dem/contact/registry.hpp"
#include "demfem/dem/pack.hpp"
#include "demfem/dem/run.hpp"
#include "demfem/dem/stable_step.hpp"
#include "demfem/scene/load.hpp"
#include "demfem/scene/write_file.hpp"

namespace demfem::studies {

using compare::html_escape;

namespace {

struct Variant {
  std::string name, description;
  // Edits the scene copy; returns "" or why the variant does not apply to this scene.
  std::function<std::string(scene::Scene&)> apply;
  // Runs on the scene's own packing (only the run changes: Δt, shaking); otherwise a packed
  // scene's row deposits its own (K_n, μ, radii are deposition parameters).
  bool same_packing = false;
};

double limit_of(const scene::Scene& s) {
  const auto b = dem::scene_critical_step(s);
  return b ? b->dt : 0.0;
}

std::vector<Variant> dem_variants(const scene::Scene& base) {
  std::vector<Variant> v;
  v.push_back({"base", "the scene as given", [](scene::Scene&) { return std::string(); }, true});
  for (const double f : {10.0, 100.0, 1000.0})
    v.push_back({fmt::format("kn-x{:g}", f),
                 fmt::format("K_n and K_s (hertz-mindlin: E) × {:g}, automatic Δt", f),
                 [f](scene::Scene& s) {
                   auto& d = *s.soil.dem;
                   dem::contact::scale_stiffness(d, f);
                   d.dt = 0.0;
                   return std::string();
                 }});
  const double lim = limit_of(base);
  for (const double f : {0.5, 0.9, 1.1, 2.0})
    v.push_back({fmt::format("dt-{:g}", f), fmt::format("Δt = {:g} × the stable limit", f),
                 [f, lim](scene::Scene& s) {
                   if (!(lim > 0.0)) return std::string("no stable limit (no particle radius)");
                   s.soil.dem->dt = f * lim;
                   return std::string();
                 },
                 true});
  for (const double mu : {0.0, 2.0})
    v.push_back(
        {fmt::format("mu-{:g}", mu), fmt::format("μ_s = μ_D = {:g}", mu), [mu](scene::Scene& s) {
           s.soil.dem->mu_static = s.soil.dem->mu_dynamic = mu;
           return std::string();
         }});
  v.push_back({"radius-ratio-10", "radii uniform in [r_max/10, r_max] (packed scenes)",
               [](scene::Scene& s) {
                 auto& d = *s.soil.dem;
                 if (!d.particles.empty())
                   return std::string("the scene lists its particles; their radii are given");
                 const double rmax =
                     d.radius.kind == scene::RadiusDistribution::Kind::Table ? 0.0 : d.radius.max;
                 if (!(rmax > 0.0)) return std::string("radius table: not rescaled");
                 d.radius.kind = scene::RadiusDistribution::Kind::Uniform;
                 d.radius.min = rmax / 10.0;
                 d.radius.max = rmax;
                 d.dt = 0.0;
                 return std::string();
               }});
  v.push_back({"shaking-2000gal-20hz", "base shaking 20 m/s² (2000 gal) at 20 Hz along x",
               [](scene::Scene& s) {
                 scene::Shaking sh;
                 sh.direction = 'x';
                 sh.acceleration = scene::TimeFunction::sine(20.0, 20.0);
                 s.load.shaking = sh;
                 return std::string();
               },
               true});
  v.push_back({"overlap-20pct", "listed radii × 1.1: touching neighbours overlap by 0.2 r",
               [](scene::Scene& s) {
                 auto& d = *s.soil.dem;
                 if (d.particles.empty())
                   return std::string("packed scene: the packing sets the overlaps");
                 for (auto& q : d.particles) q[2] *= 1.1;
                 d.radius.min *= 1.1;
                 d.radius.max *= 1.1;
                 d.dt = 0.0;
                 return std::string();
               }});
  for (const char* pk : {"loose", "dense"})
    v.push_back({fmt::format("{}-packing", pk), fmt::format("{} packing", pk), [pk](scene::Scene&) {
                   return fmt::format("run the scene's {} packing variant ([soil.dem.packing] "
                                      "target) as its own study",
                                      pk);
                 }});
  return v;
}

std::string md_escape(std::string s) {
  std::string out;
  for (const char c : s) {
    if (c == '|')
      out += "\\|";
    else if (c == '\n')
      out += ' ';
    else
      out += c;
  }
  return out;
}

} // namespace

std::vector<StabilityRow> stability_study(const scene::Scene& base, const StudyOptions& o) {
  const bool cont = base.soil.continuum && o.continuum_rows;
  if (!base.soil.dem && !cont) {
    scene::Diagnostic d;
    d.file = base.source_file;
    d.key = "soil.dem";
    d.message = "the stability study runs the DEM or the continuum model: the scene needs a "
                "[soil.dem] or a [soil.continuum] section";
    throw scene::SceneError({d});
  }
  std::vector<StabilityRow> rows;
  for (const auto& var : base.soil.dem ? dem_variants(base) : std::vector<Variant>{}) {
    if (o.interrupt && o.interrupt->load()) return rows;
    StabilityRow row;
    row.name = var.name;
    row.description = var.description;
    scene::Scene s = base;
    if (o.duration) s.info.duration = *o.duration;
    s.output.vtk = false;
    s.output.figures = false;
    if (auto why = var.apply(s); !why.empty()) {
      row.outcome = "not applicable";
      row.cause = why;
      rows.push_back(row);
      continue;
    }
    row.dt_limit = limit_of(s);
    if (var.same_packing && s.soil.dem->particles.empty() &&
        dem::packing_key(s) != dem::packing_key(base)) {
      // the scene's packing (deposited or read from the cache once), under this row's key
      const std::filesystem::path base_pk = dem::packing_path(base, o.out_dir);
      if (!std::filesystem::exists(base_pk)) (void)dem::pack_or_load(base, o.out_dir);
      study_detail::use_packing(base_pk, s, o.out_dir / "packings");
    }
    if (!o.repack && s.soil.dem->particles.empty() &&
        dem::packing_key(s) != dem::packing_key(base) &&
        !std::filesystem::exists(dem::packing_path(s, o.out_dir / "rows" / var.name))) {
      const auto& d = *s.soil.dem;
      const auto b = dem::scene_critical_step(s);
      const double dt = d.dt > 0.0 ? d.dt : b ? d.dt_safety * b->dt : 0.0;
      row.outcome = "skipped";
      row.cause = fmt::format(
          "needs its own packing (K_n, K_s, μ and the radii are in the packing key), not in the "
          "cache: a deposition of up to {:g} s simulated{}; run with --repack to deposit it",
          d.packing.max_time,
          dt > 0.0
              ? fmt::format(" ≈ {:.3g} steps of {} particles", d.packing.max_time / dt, d.count)
              : std::string());
      rows.push_back(row);
      continue;
    }
    dem::RunOptions ro;
    ro.out_dir = o.out_dir / "rows" / var.name;
    ro.threads = o.threads;
    ro.interrupt = o.interrupt;
    std::filesystem::remove_all(ro.out_dir);
    const auto t0 = std::chrono::steady_clock::now();
    try {
      const auto r = dem::run(s, ro);
      row.outcome = r.ok ? "completed" : "stopped";
      row.cause = r.message;
      row.dt = r.dt;
      row.closure = r.closure_error;
      row.max_overlap_ratio = r.max_overlap_ratio;
      row.steps = r.steps;
      row.simulated_time = r.simulated_time;
    } catch (const scene::SceneError& e) {
      row.outcome = "refused";
      row.cause = e.diagnostics().empty() ? e.what() : e.diagnostics().front().message;
    } catch (const std::exception& e) {
      row.outcome = "stopped";
      row.cause = e.what();
    }
    row.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    rows.push_back(row);
  }
  if (cont && !(o.interrupt && o.interrupt->load())) {
    scene::Scene s = base;
    if (o.duration) s.info.duration = *o.duration;
    for (auto& r : o.continuum_rows(s)) {
      r.solver = "continuum";
      rows.push_back(std::move(r));
    }
  }
  return rows;
}

void write_stability_study(const std::vector<StabilityRow>& rows, const scene::Scene& s,
                           const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  nlohmann::json j;
  j["study"] = "stability";
  j["scene"] = s.label();
  j["source"] = s.source_file;
  bool any_cont = false, any_dem = false;
  for (const auto& r : rows) (r.solver == "dem" ? any_dem : any_cont) = true;
  j["solver"] = any_dem && any_cont ? "both" : any_cont ? "continuum" : "dem";
  j["duration"] = s.info.duration;
  auto& jr = j["rows"];
  jr = nlohmann::json::array();
  for (const auto& r : rows)
    jr.push_back({{"solver", r.solver},
                  {"name", r.name},
                  {"description", r.description},
                  {"outcome", r.outcome},
                  {"cause", r.cause},
                  {"dt", r.dt},
                  {"dt_limit", r.dt_limit},
                  {"dt_over_limit", r.dt_limit > 0.0 ? r.dt / r.dt_limit : 0.0},
                  {"energy_closure", r.closure},
                  {"max_overlap_ratio", r.max_overlap_ratio},
                  {"steps", r.steps},
                  {"simulated_time", r.simulated_time},
                  {"wall_seconds", r.wall_seconds},
                  {"newton_iterations", r.iterations},
                  {"residuals", r.residuals},
                  {"measure", r.measure}});
  scene::write_file_atomic(dir / "study.json", j.dump(2) + "\n");

  auto num = [](double v, const char* f) {
    return v > 0.0 ? fmt::format(fmt::runtime(f), v) : std::string("–");
  };
  const std::string title = fmt::format("Stability study: {}", s.label());
  std::string md = fmt::format("# {}\n\n", title);
  std::string html = fmt::format(
      "<!doctype html><html><head><meta charset=\"utf-8\"><title>{0}</title>"
      "<style>body{{font-family:sans-serif}}table{{border-collapse:collapse}}td,th{{border:1px "
      "solid #aaa;padding:3px 6px;font-size:13px}}.completed{{background:#e6f4e6}}.refused{{"
      "background:#fff4d6}}.stopped{{background:#fbe3e3}}</style></head><body><h1>{0}</h1>\n",
      html_escape(title));
  // one table: a heading, a note, the column names and the rows' cells
  const auto table =
      [&](const std::string& heading, const std::string& note, const std::vector<std::string>& cols,
          const std::vector<std::pair<std::string, std::vector<std::string>>>& body) {
        md += fmt::format("## {}\n\n{}\n\n|", heading, note);
        html +=
            fmt::format("<h2>{}</h2><p>{}</p><table><tr>", html_escape(heading), html_escape(note));
        for (const auto& c : cols) {
          md += ' ';
          md += c;
          md += " |";
          html += "<th>" + html_escape(c) + "</th>";
        }
        md += "\n|";
        for (std::size_t i = 0; i < cols.size(); ++i) md += "---|";
        md += "\n";
        html += "</tr>\n";
        for (const auto& [cls, cells] : body) {
          md += "|";
          html += fmt::format("<tr class=\"{}\">", cls);
          for (const auto& c : cells) {
            // appended piecewise: GCC 12 reports a false -Wrestrict on "…" + std::string + "…" here
            md += ' ';
            md += md_escape(c);
            md += " |";
            html += "<td>";
            html += html_escape(c);
            html += "</td>";
          }
          md += "\n";
          html += "</tr>\n";
        }
        md += "\n";
        html += "</table>\n";
      };
  std::vector<std::pair<std::string, std::vector<std::string>>> dem_body, cont_body;
  for (const auto& r : rows) {
    const std::string cls =
        r.outcome == "not applicable" || r.outcome == "skipped" ? "na" : r.outcome;
    const bool ran = r.outcome == "completed" || r.outcome == "stopped";
    const std::string wall = r.outcome == "not applicable" || r.outcome == "skipped"
                                 ? "–"
                                 : fmt::format("{:.2f}", r.wall_seconds);
    if (r.solver == "continuum") {
      std::string res = "–";
      if (!r.residuals.empty())
        res = fmt::format("{} steps: first {:.2e}, last {:.2e}, max {:.2e}", r.residuals.size(),
                          r.residuals.front(), r.residuals.back(),
                          *std::max_element(r.residuals.begin(), r.residuals.end()));
      cont_body.push_back(
          {cls,
           {r.name, r.description, r.outcome, r.measure, res,
            r.iterations > 0 ? fmt::format("{}", r.iterations) : "–", wall, r.cause}});
      continue;
    }
    const std::string ratio = r.dt_limit > 0.0 && r.dt > 0.0
                                  ? fmt::format("{:.3g}", r.dt / r.dt_limit)
                                  : std::string("–");
    dem_body.push_back({cls,
                        {r.name, r.description, r.outcome, num(r.dt, "{:.3e}"), ratio,
                         ran ? fmt::format("{:.3e}", r.closure) : "–",
                         ran ? fmt::format("{:.3g}", r.max_overlap_ratio) : "–",
                         ran ? fmt::format("{}", r.steps) : "–", wall, r.cause}});
  }
  if (!dem_body.empty())
    table("DEM",
          "Outcome: completed, refused at setup (the cause), or stopped (step, time, particle, "
          "cause). Energy closure: |imbalance| / the largest energy put in (gravity and external "
          "work, springs) at the end. "
          "Overlap: the largest δ/r seen at the probes.",
          {"row", "change", "outcome", "Δt [s]", "Δt / limit", "energy closure", "max δ/r", "steps",
           "wall [s]", "cause"},
          dem_body);
  if (!cont_body.empty())
    table("Continuum",
          "Built-in problems with a closed form or bound (continuum/src/stability.cpp), at the "
          "scene's degree, and the scene's own continuum for the explicit step. Outcome: "
          "completed, refused at setup (the located diagnostic), or stopped (the diagnostic). "
          "Residuals: the final Newton residual of each load step; iterations: Newton iterations "
          "in all. Locking: a row without B-bar is compared with the same ν with B-bar.",
          {"row", "case", "outcome", "measured", "residuals", "Newton iterations", "wall [s]",
           "cause"},
          cont_body);
  html += "</body></html>\n";
  scene::write_file_atomic(dir / "study.md", md);
  scene::write_file_atomic(dir / "study.html", html);
}

} // namespace demfem::studies
