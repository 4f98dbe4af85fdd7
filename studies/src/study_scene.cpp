// `demfem study error-vs-time` on scenes without a closed form: each solver
// swept over its resolution knobs, every run measured with the comparison layer's metric table
// against the most resolved run of the same solver.
#include "demfem/studies/error_study.hpp"
#include "study_runs.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "demfem/compare/metrics.hpp"
#include "demfem/dem/contact/registry.hpp"
#include "demfem/dem/io.hpp"
#include "demfem/dem/pack.hpp"
#include "demfem/dem/stable_step.hpp"
#include "demfem/scene/load.hpp"
#include "demfem/scene/write_file.hpp"

namespace demfem::studies {

using compare::collect_solver_metrics;
using compare::MetricSet;
using compare::Split;
using compare::split_options;
using compare::split_series;
using compare::TimeSeries;

namespace fs = std::filesystem;
using namespace study_detail;

namespace {

// The metric table's key quantities (compare::kKeyRanks: wall thrust, structure settlement and
// rotation, surface subsidence) of the scene's structures (the boundary walls' reactions are not
// studied) and of the scene.
bool studied(const compare::MetricDef& d, const scene::Scene& s) {
  if (d.rank >= compare::kKeyRanks) return false;
  return d.owner.empty() ||
         std::any_of(s.structures.begin(), s.structures.end(),
                     [&](const scene::Structure& st) { return st.name == d.owner; });
}

// Static value, mean increment and oscillation amplitude (metrics.hpp split_series) of every
// studied quantity of one solver's run, named "<key>.<part>".
std::map<std::string, double> measure(const fs::path& run, const scene::Scene& s,
                                      scene::Solver solver,
                                      std::map<std::string, std::string>* desc) {
  const MetricSet set = collect_solver_metrics(run, &s, solver);
  std::map<std::string, double> out;
  for (const auto& m : set.series) {
    if (!studied(m.def, s)) continue;
    const TimeSeries& ts = solver == scene::Solver::Dem ? m.dem : m.continuum;
    if (ts.t.empty()) continue;
    const Split sp = split_series(ts, split_options(&s, ts.t.back()));
    const bool surface = m.def.key == "surface.elevation";
    const std::pair<const char*, double> parts[] = {
        {"static", sp.static_value}, {"increment", sp.mean_increment}, {"amplitude", sp.amplitude}};
    for (const auto& [part, v] : parts) {
      // the surface's static height is the packing's (or the calibrated surface): not a
      // resolution error; its increment is minus the subsidence
      if (surface && std::string(part) == "static") continue;
      if (!std::isfinite(v)) continue;
      const std::string name = m.def.key + "." + part;
      out[name] = v;
      if (desc)
        (*desc)[name] = fmt::format(
            "|x − x_ref| / |x_ref| of the {} {} [{}]{}, x_ref from the same solver's most "
            "resolved run",
            m.def.quantity,
            std::string(part) == "static"      ? "static value (at rest, before the load)"
            : std::string(part) == "increment" ? "mean increment over the late window"
                                               : "oscillation amplitude over the late window",
            m.def.unit,
            surface && std::string(part) == "increment" ? " (minus the subsidence)" : "");
    }
  }
  return out;
}

// Mean radius of a distribution [m] (uniform: the midpoint; table: frequency-weighted).
double mean_radius(const scene::RadiusDistribution& r) {
  if (r.kind != scene::RadiusDistribution::Kind::Table) return 0.5 * (r.min + r.max);
  double sw = 0.0, swr = 0.0;
  for (const auto& [rad, w] : r.table) {
    sw += w;
    swr += w * rad;
  }
  return sw > 0.0 ? swr / sw : 0.0;
}

std::string dir_name(std::string n) {
  std::replace(n.begin(), n.end(), '/', '_');
  return n;
}

// The loading period of the scene (shaking, or a structure's periodic load) [s]; 0 when none.
double load_period(const scene::Scene& s) {
  return split_options(&s, s.info.duration).period;
}

} // namespace

void study_detail::use_packing(const fs::path& from, scene::Scene& s, const fs::path& cache_dir) {
  fs::create_directories(cache_dir);
  s.soil.dem->packing.cache = fs::absolute(cache_dir).string();
  const fs::path to = dem::packing_path(s, cache_dir);
  auto ck = dem::io::read_checkpoint(from);
  // the label pack_or_load checks (dem/src/pack.cpp): this scene's key
  ck.meta.label = "packing " + dem::packing_key(s) + " " + s.info.name;
  dem::io::write_checkpoint(to, ck.particles, ck.meta, ck.extra);
}

ErrorStudy scene_error_study(const scene::Scene& base0, const ErrorStudyOptions& o) {
  scene::Scene base = base0;
  if (o.duration) base.info.duration = *o.duration;
  base.output.figures = false;
  base.output.force_chains = false;
  const bool want_dem = o.solvers != "continuum" && base.soil.dem && base.uses(scene::Solver::Dem);
  const bool want_cont =
      o.solvers != "dem" && base.soil.continuum && base.uses(scene::Solver::Continuum);
  if (!want_dem && !want_cont)
    throw std::runtime_error(fmt::format("{}: no solver to study (--solver {}; the scene lists {})",
                                         base.label(), o.solvers,
                                         base.uses(scene::Solver::Dem) ? "dem" : "continuum"));
  ErrorStudy st;
  st.solver = want_dem && want_cont ? "both" : want_dem ? "dem" : "continuum";
  st.scene = base.label();
  st.source = base.source_file;
  st.repeats = o.repeats;
  st.jobs = o.jobs;
  st.expected_order = 0.0;
  st.expected_order_note =
      "no theoretical order: the reference is the most resolved run of the sweep, not the exact "
      "solution, and a granular or elastoplastic history need not converge smoothly";
  st.closed_form["duration"] = base.info.duration;
  const fs::path runs = o.out_dir / "runs";
  std::vector<std::vector<Job>> groups; // each knob's points, coarse (cheap) to fine

  const auto job_for = [&](const std::string& solver, const std::string& knob,
                           const std::string& name, double value, const scene::Scene& s) {
    Job j;
    j.point.solver = solver;
    j.point.knob = knob;
    j.point.name = name;
    j.point.value = value;
    j.timeout = o.max_run_seconds;
    const fs::path dir = runs / dir_name(name);
    fs::create_directories(dir);
    const fs::path toml = dir / "scene.toml";
    scene::write_file_atomic(toml, scene::to_toml(s));
    for (int k = 0; k < o.repeats; ++k) {
      const fs::path rd = dir / fmt::format("rep-{}", k);
      j.dirs.push_back(rd);
      j.argv.push_back({o.exe.string(), "study-point", solver, "--scene", toml.string(), "--out",
                        rd.string(), "--json", rd.string() + ".json"});
    }
    const scene::Solver sv = solver == "dem" ? scene::Solver::Dem : scene::Solver::Continuum;
    j.evaluate = [s, sv](ErrorPoint& p, const fs::path& rd) {
      for (const auto& [k, v] : measure(rd, s, sv, nullptr)) p.results[k] = v;
      std::ifstream in(rd.string() + ".json");
      if (in) {
        const auto js = nlohmann::json::parse(in);
        p.dofs = js.value("dofs", std::size_t{0});
        if (sv == scene::Solver::Dem) {
          p.dt = js.value("dt", p.dt);
          if (p.knob != "size") p.x = p.dt; // the size points' abscissa is the mean radius
        } else {
          p.dt = js.value("dt", 0.0);
          p.x = p.knob == "cont-dt" ? p.dt : js.value("h_min", 0.0);
        }
      }
      if (p.results.empty() || (p.results.size() == 1 && p.results.count("porosity")))
        throw std::runtime_error("no metric of the table in the run's output");
    };
    return j;
  };

  // ---- DEM: Δt on one packing, K_n with its own packing ----
  if (want_dem) {
    const auto bound = dem::scene_critical_step(base);
    if (!bound || !(bound->dt > 0.0) || !std::isfinite(bound->dt))
      throw std::runtime_error(base.label() + ": no DEM stable step bound");
    st.closed_form["dem_critical_step"] = bound->dt;
    // The scene's packing, deposited once (or read from the cache) before any timed run.
    const fs::path pk_dir = o.out_dir / "packings";
    fs::create_directories(pk_dir);
    std::string base_pk;
    if (base.soil.dem->particles.empty()) {
      const auto pr = dem::pack_or_load(base, o.out_dir, o.progress);
      base_pk = dem::packing_path(base, o.out_dir).string();
      st.closed_form["dem_porosity"] = pr.measure.porosity;
      st.notes.push_back(fmt::format(
          "DEM Δt points: all on the scene's packing ({}, porosity {:.4f}), copied into {} under "
          "each point's cache key (the key includes Δt), so only the step differs",
          base_pk, pr.measure.porosity, pk_dir.string()));
    }
    // A copy of the scene's packing under the cache key of `s` in the study's own cache, so that
    // the run of `s` starts from the same particles (the key includes Δt and K_n: without the copy
    // each setting would deposit its own bed).
    const auto same_packing = [&](scene::Scene& s) {
      if (!base_pk.empty()) use_packing(base_pk, s, pk_dir);
    };
    std::vector<Job> dt_jobs;
    std::vector<double> fr = o.scene_dt_fractions;
    std::sort(fr.rbegin(), fr.rend()); // coarse first
    for (const double f : fr) {
      scene::Scene s = base;
      s.output.vtk = false;
      s.soil.dem->dt = f * bound->dt;
      same_packing(s);
      auto j = job_for("dem", "dt", "dem-dt-" + frac_label(f), f, s);
      j.point.dt = j.point.x = s.soil.dem->dt;
      dt_jobs.push_back(std::move(j));
    }
    if (!dt_jobs.empty()) groups.push_back(std::move(dt_jobs));
    std::vector<Job> kn_jobs;
    std::vector<double> kf = o.scene_kn_factors;
    std::sort(kf.begin(), kf.end()); // soft (large automatic Δt) first
    for (const double f : kf) {
      scene::Scene s = base;
      s.output.vtk = false;
      auto& d = *s.soil.dem;
      dem::contact::scale_stiffness(d, f);
      d.dt = 0.0; // automatic
      double porosity = NAN;
      if (d.particles.empty() && o.kn_same_packing) {
        same_packing(s);
      } else if (d.particles.empty()) {
        // deposited with this K_n (the packing key includes K_n), before the timed run, into a
        // cache the run reads (without one it would deposit again into its own directory)
        if (d.packing.cache.empty()) d.packing.cache = fs::absolute(pk_dir).string();
        const auto pr = dem::pack_or_load(s, o.out_dir, o.progress);
        porosity = pr.measure.porosity;
      }
      const auto b = dem::scene_critical_step(s);
      auto j = job_for("dem", "kn", fmt::format("dem-kn-x{:g}", f), f, s);
      j.point.dt = j.point.x = b ? d.dt_safety * b->dt : 0.0;
      if (std::isfinite(porosity)) j.point.results["porosity"] = porosity;
      kn_jobs.push_back(std::move(j));
    }
    if (!kn_jobs.empty()) {
      groups.push_back(std::move(kn_jobs));
      if (base.soil.dem->particles.empty() && o.kn_same_packing)
        st.notes.push_back(
            "DEM K_n points: K_n and K_s scaled, automatic Δt, on the scene's packing (deposited "
            "with the scene's K_n): its overlaps carry the weight at the scene's K_n, so at t = 0 "
            "a point's contact forces are f × those that balance the weight — the bed rises "
            "(f > 1) or sinks (f < 1) until its overlaps are 1/f of the packing's, and that "
            "transient is part of the point's error (--kn-packing deposit gives each K_n its own "
            "deposition instead)");
      else if (base.soil.dem->particles.empty())
        st.notes.push_back(
            "DEM K_n points: K_n and K_s scaled, automatic Δt; each K_n deposits its own packing "
            "(the packing cache key includes K_n), so a K_n point changes the bed as well as the "
            "contact stiffness; each point's porosity is in its results");
    }
    // Particle size at fixed geometry: count × f and every radius / √f keep the
    // solid area, so the same domain holds the same bed of smaller disks; in 2D the assembly's
    // stiffness scales with K_n / thickness, not with the radius (e.g. the regular disk array's
    // elastic moduli, Rothenburg & Bathurst 1989), so K_n, K_s and the thickness stay.
    std::vector<double> sf = o.scene_size_factors;
    std::sort(sf.begin(), sf.end()); // few large disks (cheap) first
    sf.erase(std::unique(sf.begin(), sf.end()), sf.end());
    if (!sf.empty() && !base.soil.dem->particles.empty()) {
      st.notes.push_back("particle size at fixed geometry (N × f): not applicable, the scene "
                         "lists its particles");
    } else if (!sf.empty()) {
      std::vector<Job> size_jobs;
      for (const double f : sf) {
        scene::Scene s = base;
        s.output.vtk = false;
        auto& d = *s.soil.dem;
        const double c = f * d.count;
        if (!(c >= 1.0) || !(c <= 1.0e8) || std::abs(c - std::round(c)) > 1e-9 * c)
          throw std::runtime_error(fmt::format(
              "{}: size factor {:g} gives {:g} particles (count {}); use a factor that makes "
              "a whole count",
              base.label(), f, c, d.count));
        d.count = static_cast<int>(std::lround(c));
        const double k = 1.0 / std::sqrt(f);
        d.radius.min *= k;
        d.radius.max *= k;
        for (auto& [r, w] : d.radius.table) r *= k;
        d.dt = 0.0; // automatic: Δt ∝ √m_min ∝ r_min
        // The deposition's damping is a ratio of the mean particle's critical one, C = 2ζ√(K_n/m̄)
        // (pack.cpp), so C ∝ 1/r and the capped fall speed g/C ∝ r: smaller disks fall √f times
        // slower and need √f times the deposition time to land (without it the × 4 wall bed was
        // still raining at the scene's 40 s: 10 % rattlers, coordination 3.27 against 3.70).
        d.packing.max_time *= std::max(1.0, std::sqrt(f));
        // deposited before the timed run, into the study's cache (the key includes count and radii)
        if (d.packing.cache.empty()) d.packing.cache = fs::absolute(pk_dir).string();
        const auto pr = dem::pack_or_load(s, o.out_dir, o.progress);
        const auto b = dem::scene_critical_step(s);
        auto j = job_for("dem", "size", fmt::format("dem-size-x{:g}", f), f, s);
        j.point.dt = b ? d.dt_safety * b->dt : 0.0;
        j.point.x = mean_radius(d.radius);
        j.point.results["porosity"] = pr.measure.porosity;
        j.point.results["count"] = d.count;
        if (!pr.converged)
          st.notes.push_back(fmt::format(
              "dem-size-x{:g}: its packing stopped at packing.max_time = {:g} s without meeting "
              "the deposition's stop criterion (kinetic energy {:.2g} of the released, checked "
              "only after the top particles' damped fall time); if its coordination or "
              "porosity differs from the other sizes' (packing record {}), the bed may not "
              "have landed: raise soil.dem.packing.max_time",
              f, d.packing.max_time, pr.ke_ratio,
              dem::packing_path(s, o.out_dir).replace_extension(".json").string()));
        size_jobs.push_back(std::move(j));
      }
      groups.push_back(std::move(size_jobs));
      st.notes.push_back(fmt::format(
          "DEM particle size points: count × f and radii / √f at fixed geometry (f = {}), K_n, "
          "K_s and thickness kept, automatic Δt, each f with its own deposited packing "
          "(packing.max_time × √f: the damped fall is √f times slower); errors "
          "against the finest (f = {:g}). Each packing is another realisation, so a size point's "
          "error is the size effect and the realisation's scatter together (`demfem compare "
          "--seeds` measures the scatter alone){}",
          fmt::join(sf, ", "), sf.back(),
          base.soil.dem->sphere_mass ? "; particle_mass = \"sphere\": m ∝ r³, so the bed's "
                                       "mass per area falls as 1/√f"
                                     : ""));
    }
  }

  // ---- continuum: refinement × degree × integrator ----
  if (want_cont) {
    std::vector<int> refs = o.scene_refinements;
    if (refs.empty())
      for (int r = std::max(0, base.continuum.refinement - 2); r <= base.continuum.refinement; ++r)
        refs.push_back(r);
    std::sort(refs.begin(), refs.end());
    std::vector<std::string> integ = o.integrators;
    if (integ.empty())
      integ = {base.continuum.integrator,
               base.continuum.integrator == "explicit" ? "implicit" : "explicit"};
    const double period = load_period(base);
    // one continuum run of the sweep: refinement r, degree p, integrator `in`, graded mesh `near`
    const auto cont_scene = [&](int r, int p, const std::string& in, double near) {
      scene::Scene s = base;
      // the surface comes from the .vtu snapshots: at least 8 per loading period (the metric
      // split's amplitude needs 4), else 20 over the run
      s.output.vtk = true;
      s.output.interval =
          std::min(s.output.interval, period > 0.0 ? period / 8.0 : s.info.duration / 20.0);
      s.continuum.refinement = r;
      s.continuum.degree = p;
      s.continuum.integrator = in;
      s.continuum.mesh_size_near = near;
      s.continuum.dt_line = s.continuum.dt_column = 0;
      if (in == "explicit") {
        s.continuum.dt = 0.0; // automatic: the stable step
      } else if (!(base.continuum.integrator == "implicit" && base.continuum.dt > 0.0)) {
        // Newmark average acceleration: 40 steps per loading period (period error (ωΔt)²/12 ≈
        // 0.2 %, Hughes 1987 §9.3), else the probe interval
        s.continuum.dt = period > 0.0 ? period / 40.0 : s.output.probe_interval;
      }
      return s;
    };
    for (const auto& in : integ) {
      if (in == "implicit" && base.continuum.interface == "coulomb") {
        // not a resolution of the same model: implicit needs another boundary model
        for (const int p : o.scene_degrees)
          st.notes.push_back(fmt::format(
              "mesh-q{}-implicit skipped: continuum.interface = \"coulomb\" (zero-thickness "
              "Coulomb contact with the walls and structures) needs the explicit integrator; an "
              "implicit run would need a tied or frictional interface, another model",
              p));
        continue;
      }
      for (const int p : o.scene_degrees) {
        std::vector<Job> js;
        for (const int r : refs) {
          const std::string knob = fmt::format("mesh-q{}-{}", p, in);
          js.push_back(job_for("continuum", knob, fmt::format("cont-q{}-r{}-{}", p, r, in), r,
                               cont_scene(r, p, in, base.continuum.mesh_size_near)));
        }
        groups.push_back(std::move(js));
      }
    }
    // The graded mesh's cells next to the structures (mesh_size_near), at the scene's
    // refinement, degree and integrator; coarse to fine.
    std::vector<double> nf = o.scene_near_factors;
    std::sort(nf.rbegin(), nf.rend());
    nf.erase(std::unique(nf.begin(), nf.end()), nf.end());
    const double near = base.continuum.mesh_size_near;
    if (!nf.empty() && !(near > 0.0)) {
      st.notes.push_back(
          "mesh_size_near points: not applicable, the scene's continuum mesh is "
          "uniform (continuum.mesh_size_near = 0); the refinement points resolve it");
    } else if (!nf.empty()) {
      std::vector<Job> js;
      const auto& c = base.continuum;
      for (const double f : nf)
        js.push_back(job_for(
            "continuum", "mesh-near",
            fmt::format("cont-near-x{:g}-q{}-r{}-{}", f, c.degree, c.refinement, c.integrator), f,
            cont_scene(c.refinement, c.degree, c.integrator, f * near)));
      groups.push_back(std::move(js));
      st.notes.push_back(fmt::format(
          "continuum mesh_size_near points: the scene's {:g} m × {} at refinement {}, degree {}, "
          "{} (cells next to the structures {:g} m / 2^refinement, graded by {:g} per cell away "
          "from them){}",
          near, fmt::join(nf, ", "), c.refinement, c.degree, c.integrator, near, c.mesh_grading,
          std::find(nf.begin(), nf.end(), 1.0) != nf.end()
              ? "; × 1 is the scene's own mesh, run again under this knob (its own timing)"
              : ""));
    }
    // The continuum's time step, at the scene's degree and integrator on the sweep's
    // coarsest mesh (cheap; the time error at a fixed mesh), smallest step first as reference.
    std::vector<double> tf = o.scene_cont_dt_factors;
    std::sort(tf.rbegin(), tf.rend());
    tf.erase(std::unique(tf.begin(), tf.end()), tf.end());
    const auto& c = base.continuum;
    if (!tf.empty() && !refs.empty()) {
      std::vector<Job> js;
      std::vector<double> ran;
      const int r = refs.front();
      for (const double f : tf) {
        if (c.integrator == "explicit" && c.explicit_safety * f > 1.0) {
          // above the critical step: a stability question (`demfem study stability`), not a
          // resolution; the scene loader would refuse explicit_safety > 1
          st.notes.push_back(fmt::format(
              "continuum Δt × {:g} skipped: explicit_safety {:g} × {:g} is above the critical step "
              "(`demfem study stability` runs the explicit step above its limit)",
              f, c.explicit_safety, f));
          continue;
        }
        scene::Scene s = cont_scene(r, c.degree, c.integrator, c.mesh_size_near);
        if (c.integrator == "explicit")
          s.continuum.explicit_safety = c.explicit_safety * f; // automatic step × f
        else
          s.continuum.dt *= f;
        js.push_back(job_for("continuum", "cont-dt",
                             fmt::format("cont-dt-x{:g}-q{}-r{}-{}", f, c.degree, r, c.integrator),
                             f, s));
        ran.push_back(f);
      }
      if (!js.empty()) groups.push_back(std::move(js));
      st.notes.push_back(fmt::format(
          "continuum Δt points: {} × {} at refinement {}, degree {}, {}; errors against the "
          "smallest step (reference_runs.continuum-dt), the time discretisation error on that "
          "mesh",
          c.integrator == "explicit"
              ? fmt::format("the automatic step (explicit_safety {:g} of the critical step)",
                            c.explicit_safety)
              : std::string("the Newmark step"),
          fmt::join(ran, ", "), r, c.degree, c.integrator));
    }
  }

  // ---- run: wave k = the k-th (coarse to fine) setting of every knob; a knob whose run hit the
  // time limit skips its finer settings ----
  std::vector<std::size_t> next(groups.size(), 0);
  std::vector<ErrorPoint> done;
  for (;;) {
    std::vector<Job> wave;
    std::vector<std::size_t> from;
    for (std::size_t g = 0; g < groups.size(); ++g)
      if (next[g] < groups[g].size()) {
        wave.push_back(std::move(groups[g][next[g]]));
        from.push_back(g);
      }
    if (wave.empty()) break;
    run_jobs(wave, o);
    for (std::size_t i = 0; i < wave.size(); ++i) {
      const std::size_t g = from[i];
      ++next[g];
      done.push_back(wave[i].point);
      if (wave[i].timed_out) {
        for (std::size_t k = next[g]; k < groups[g].size(); ++k)
          st.notes.push_back(fmt::format(
              "{} skipped: the coarser {} ran past the study's per-run limit of {:.0f} s "
              "(--max-run-seconds)",
              groups[g][k].point.name, wave[i].point.name, o.max_run_seconds));
        next[g] = groups[g].size();
      }
    }
  }
  st.points = std::move(done);

  // ---- references: the most resolved run of each solver ----
  // (the DEM particle size points have their own: the most particles, "dem-size")
  const auto ref_key = [](const ErrorPoint& p) {
    return p.knob == "size"      ? std::string("dem-size")
           : p.knob == "cont-dt" ? std::string("continuum-dt")
                                 : p.solver;
  };
  std::map<std::string, const ErrorPoint*> ref;
  for (const auto& p : st.points) {
    if (!p.ok) continue;
    const ErrorPoint*& r = ref[ref_key(p)];
    if (p.knob == "size") {
      if (!r || p.value > r->value) r = &p;
    } else if (p.knob == "cont-dt") {
      if (!r || p.value < r->value) r = &p; // the smallest step
    } else if (p.solver == "dem") {
      // the finest Δt at the scene's K_n (the kn ×1 point when no Δt point ran)
      const bool cand = p.knob == "dt" || (p.knob == "kn" && p.value == 1.0);
      if (!cand) continue;
      if (!r || (r->knob != "dt" && p.knob == "dt") || (p.knob == r->knob && p.dt < r->dt)) r = &p;
    } else {
      // the most dofs; at equal size the scene's integrator
      const bool own = p.knob.ends_with(base.continuum.integrator);
      if (!r || p.dofs > r->dofs ||
          (p.dofs == r->dofs && own && !r->knob.ends_with(base.continuum.integrator)))
        r = &p;
    }
  }
  std::string refs_text;
  for (const auto& [solver, r] : ref) {
    if (!r) continue;
    st.reference_runs[solver] = r->name;
    refs_text += fmt::format(
        "{}{}: {} ({})", refs_text.empty() ? "" : "; ",
        solver == "dem-size"       ? "DEM particle size"
        : solver == "continuum-dt" ? "continuum Δt"
                                   : solver,
        r->name,
        solver == "dem-size"
            ? fmt::format("{:g} particles, mean radius {:.3g} m",
                          r->results.count("count") ? r->results.at("count") : 0.0, r->x)
        : solver == "dem" || solver == "continuum-dt"
            ? fmt::format("Δt = {:.3g} s", r->dt)
            : fmt::format("{} dofs, h = {:.3g} m", r->dofs, r->x));
  }
  st.reference = fmt::format(
      "no closed form: each run is measured against the most resolved run of the same solver's "
      "sweep ({}), with the comparison layer's metric table (static value, late mean increment and "
      "oscillation amplitude; compare/metrics.hpp); the error is the discretisation error relative "
      "to that run, not to the truth",
      refs_text.empty() ? "none completed" : refs_text);

  // metric descriptions from the reference runs (names shared by both solvers)
  for (const auto& [solver, r] : ref) {
    if (!r) continue;
    const fs::path rd = o.out_dir / "runs" / dir_name(r->name) / "rep-0";
    scene::Scene s = base;
    try {
      (void)measure(rd, s,
                    solver.starts_with("dem") ? scene::Solver::Dem : scene::Solver::Continuum,
                    &st.metric_descriptions);
    } catch (const std::exception&) {
    }
  }
  for (auto& p : st.points) {
    if (!p.ok) continue;
    const auto it = ref.find(ref_key(p));
    if (it == ref.end() || !it->second) continue;
    const ErrorPoint& r = *it->second;
    for (const auto& [name, v] : p.results) {
      if (!st.metric_descriptions.count(name)) continue;
      const auto rv = r.results.find(name);
      if (rv == r.results.end() || !(std::abs(rv->second) > 0.0)) continue;
      if (p.name == r.name) continue; // the reference: no error of its own
      p.errors[name] = std::abs(v - rv->second) / std::abs(rv->second);
    }
  }
  // primary metric: the first key quantity every reference has
  for (const char* k :
       {".thrust.amplitude", ".thrust.increment", ".rotation.amplitude", ".rotation.increment",
        ".settlement.increment", "surface.elevation.increment"}) {
    for (const auto& [name, d] : st.metric_descriptions) {
      if (!name.ends_with(k)) continue;
      bool all = true;
      for (const auto& [solver, r] : ref) all = all && r && r->results.count(name);
      if (all) {
        st.primary_metric = name;
        break;
      }
    }
    if (!st.primary_metric.empty()) break;
  }
  if (st.primary_metric.empty() && !st.metric_descriptions.empty())
    st.primary_metric = st.metric_descriptions.begin()->first;

  // fits, fronts, figure groups
  std::vector<std::string> dem_knobs, cont_knobs, all;
  for (const auto& p : st.points) {
    auto& v = p.solver == "dem" ? dem_knobs : cont_knobs;
    if (std::find(v.begin(), v.end(), p.knob) == v.end()) v.push_back(p.knob);
    if (std::find(all.begin(), all.end(), p.knob) == all.end()) all.push_back(p.knob);
  }
  for (const auto& k : all) {
    // DEM size: against the mean radius ("r", the point's x)
    const std::string against = k == "dt" || k == "cont-dt" ? "dt"
                                : k == "kn"                 ? ""
                                : k == "size"               ? "r"
                                                            : "h";
    if (!against.empty()) add_fit(st, k, st.primary_metric, against, 0.0);
    add_fit(st, k, st.primary_metric, "wall", 0.0);
  }
  // the continuum's meshes share one reference (the most dofs); its Δt points have their own
  std::vector<std::string> mesh_knobs;
  for (const auto& k : cont_knobs)
    if (k != "cont-dt") mesh_knobs.push_back(k);
  const bool cont_dt = mesh_knobs.size() != cont_knobs.size();
  std::vector<std::vector<std::string>> front_groups;
  for (const auto& k : dem_knobs) front_groups.push_back({k});
  if (!mesh_knobs.empty()) front_groups.push_back(mesh_knobs);
  if (cont_dt) front_groups.push_back({"cont-dt"});
  mark_fronts(st, front_groups);
  for (const auto& k : dem_knobs)
    st.wall_groups.push_back({{k},
                              "error_vs_wall_dem_" + k,
                              k == "dt"   ? "DEM, Δt as a fraction of the critical step"
                              : k == "kn" ? "DEM, K_n scaling with the automatic Δt"
                                          : "DEM, particle size at fixed geometry (count × f, "
                                            "against the most particles)",
                              ""});
  if (!mesh_knobs.empty())
    st.wall_groups.push_back(
        {mesh_knobs, "error_vs_wall_continuum", "continuum, refinement × degree × integrator", ""});
  if (cont_dt)
    st.wall_groups.push_back({{"cont-dt"},
                              "error_vs_wall_continuum_dt",
                              "continuum, Δt as a fraction of the automatic step",
                              ""});
  if (!dem_knobs.empty() && !cont_knobs.empty())
    st.wall_groups.push_back(
        {all, "error_vs_wall_both", "both solvers, each against its own most resolved run", ""});
  if (std::find(dem_knobs.begin(), dem_knobs.end(), "dt") != dem_knobs.end())
    st.convergence_groups.push_back({{"dt"}, "convergence_dt", "", "dt"});
  if (std::find(dem_knobs.begin(), dem_knobs.end(), "size") != dem_knobs.end())
    st.convergence_groups.push_back({{"size"}, "convergence_size", "", "r"});
  if (!mesh_knobs.empty()) st.convergence_groups.push_back({mesh_knobs, "convergence_h", "", "h"});
  if (cont_dt) st.convergence_groups.push_back({{"cont-dt"}, "convergence_continuum_dt", "", "dt"});
  return st;
}

} // namespace demfem::studies
