#include "demfem/compare/figures.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <vtkDataArray.h>
#include <vtkDataArraySelection.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkXMLPolyDataReader.h>

#include "demfem/compare/plot.hpp"
#include "demfem/compare/series.hpp"
#include "demfem/dem/contact/registry.hpp"
#include "demfem/dem/io.hpp"
#include "demfem/dem/pack.hpp"
#include "demfem/output/contract.hpp"
#include "demfem/scene/write_file.hpp"

namespace demfem::compare {

namespace fs = std::filesystem;
using nlohmann::json;
namespace col = output::col;
namespace dir = output::dir;
namespace file = output::file;

double loop_area(const std::vector<double>& x, const std::vector<double>& y) {
  const std::size_t n = std::min(x.size(), y.size());
  double a = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t j = (i + 1) % n;
    a += x[i] * y[j] - x[j] * y[i]; // shoelace formula
  }
  return 0.5 * std::abs(a);
}

// Largest particle speed over the snapshots, of all particles and of those whose centre is at or
// above `zmin`, in one pass that decodes only the `speed` array (and the points, which the reader
// always reads): two full passes were ≈ 0.5 s of a 3,400-disk wall run's 53 snapshots.
PeakSpeeds peak_snapshot_speeds(const fs::path& vtk_dir, double zmin) {
  PeakSpeeds pk;
  std::error_code ec;
  if (!fs::is_directory(vtk_dir, ec)) return pk;
  for (const auto& f : fs::directory_iterator(vtk_dir, ec)) {
    const auto name = f.path().filename().string();
    if (name.rfind("particles_", 0) != 0 || f.path().extension() != ".vtp") continue;
    auto reader = vtkSmartPointer<vtkXMLPolyDataReader>::New();
    reader->SetFileName(f.path().string().c_str());
    reader->UpdateInformation();
    reader->GetPointDataArraySelection()->DisableAllArrays();
    reader->GetPointDataArraySelection()->EnableArray("speed");
    reader->Update();
    auto* pd = reader->GetOutput();
    if (!pd || !pd->GetPointData()) continue;
    vtkDataArray* s = pd->GetPointData()->GetArray("speed");
    if (!s) continue;
    for (vtkIdType i = 0; i < s->GetNumberOfTuples(); ++i) {
      const double v = s->GetTuple1(i);
      pk.all = std::max(pk.all, v);
      if (pd->GetPoint(i)[1] >= zmin) pk.above = std::max(pk.above, v); // VTK y = scene z
    }
  }
  return pk;
}

namespace {

double mean_between(const std::vector<double>& t, const std::vector<double>& y, double a,
                    double b) {
  double s = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < std::min(t.size(), y.size()); ++i)
    if (t[i] >= a && t[i] <= b) {
      s += y[i];
      ++n;
    }
  return n ? s / n : std::nan("");
}

double max_abs(const std::vector<double>& y) {
  double m = 0.0;
  for (double v : y) m = std::max(m, std::abs(v));
  return m;
}

CsvTable try_csv(const fs::path& p, RunFigures& out) {
  std::error_code ec;
  if (!fs::exists(p, ec)) return {};
  try {
    return read_csv(p);
  } catch (const std::exception& e) {
    out.problems.push_back(fmt::format("{}: {}", p.string(), e.what()));
    return {};
  }
}

Series ser(std::string label, std::vector<double> x, std::vector<double> y,
           std::string style = "lines", std::string extra = "") {
  Series r;
  r.label = std::move(label);
  r.x = std::move(x);
  r.y = std::move(y);
  r.style = std::move(style);
  r.extra = std::move(extra);
  return r;
}

PlotSpec spec_of(std::string title, std::string xl, std::string yl, std::vector<Series> series) {
  PlotSpec p;
  p.title = std::move(title);
  p.xlabel = std::move(xl);
  p.ylabel = std::move(yl);
  p.series = std::move(series);
  return p;
}

// Queues the figure (drawn with the others by draw_figures); a figure with nothing to draw is a
// problem at once.
void draw(const PlotSpec& spec, const fs::path& png, RunFigures& out, PlotQueue& queue) {
  std::string err;
  if (!plot(spec, png, &err, &queue))
    out.problems.push_back(fmt::format("{}: {}", png.filename().string(), err));
}

// Draws the queued figures, a few scripts per gnuplot process (gnuplot's start, ≈ 0.08 s, was
// most of each small plot's time), and lists each as a figure or a problem.
void draw_figures(PlotQueue& queue, RunFigures& out) {
  const auto err = draw_queued(queue);
  for (std::size_t k = 0; k < err.size(); ++k)
    if (err[k].empty())
      out.figures.push_back(queue.pngs[k]);
    else
      out.problems.push_back(fmt::format("{}: {}", queue.pngs[k].filename().string(), err[k]));
  queue = PlotQueue{};
}

std::string strip_unit(const std::string& c) {
  const auto k = c.find(" [");
  return k == std::string::npos ? c : c.substr(0, k);
}

} // namespace

RunFigures write_run_figures(const scene::Scene& scene, const fs::path& run_dir,
                             double wall_seconds, long long steps) {
  RunFigures out;
  PlotQueue queue; // the figures before the snapshot series, drawn together (draw_figures)
  const fs::path dem = run_dir / dir::dem;
  const fs::path fig = run_dir / dir::figures;
  fs::create_directories(fig);
  json sum;
  sum["scene"] = scene.label();
  sum["duration_s"] = scene.info.duration;
  if (wall_seconds > 0.0) sum["run_wall_seconds"] = wall_seconds;
  if (steps > 0) sum["steps"] = steps;
  if (scene.soil.dem) sum["particles"] = scene.soil.dem->count;
  // The initial packing's density and contacts (dem/packing.json).
  {
    std::ifstream pj(dem / file::packing);
    if (pj) try {
        sum["packing"] = json::parse(pj);
      } catch (const std::exception& e) {
        out.problems.push_back(std::string("packing.json: ") + e.what());
      }
  }

  // ---- structures: settlement, rotation, moment, M–θ loops --------------------------------
  const auto st = try_csv(dem / file::structures, out);
  if (!st.rows.empty()) {
    const auto t = st.column(col::time.name);
    json js = json::object();
    for (const auto& s : scene.structures) {
      const auto settle = st.column(output::key(s.name, col::settlement));
      const auto rot = st.column(output::key(s.name, col::rotation));
      const auto mom = st.column(output::key(s.name, col::moment));
      if (settle.empty()) continue;
      json j;
      j["final_settlement_m"] = settle.back();
      j["max_settlement_m"] = *std::max_element(settle.begin(), settle.end());
      std::vector<double> theta(rot.size()); // paper's θ: clockwise positive
      for (std::size_t i = 0; i < rot.size(); ++i) theta[i] = -rot[i];
      j["max_abs_rotation_rad"] = max_abs(rot);
      if (!rot.empty()) j["final_rotation_paper_theta_rad"] = theta.back();
      draw(spec_of(fmt::format("{}: settlement (penetration) — {}", s.name, scene.label()),
                   "time [s]", "settlement [m] (down +)", {ser(s.name, t, settle)}),
           fig / (s.name + "_settlement.png"), out, queue);
      if (s.dof_rotation != scene::DofMode::Fixed && !rot.empty()) {
        draw(spec_of(fmt::format("{}: rotation θ (clockwise +) — {}", s.name, scene.label()),
                     "time [s]", "θ [rad]", {ser(s.name, t, theta)}),
             fig / (s.name + "_rotation.png"), out, queue);
        draw(spec_of(fmt::format("{}: soil moment about the pivot — {}", s.name, scene.label()),
                     "time [s]", "M [N·m]", {ser(s.name, t, mom)}),
             fig / (s.name + "_moment.png"), out, queue);
        draw(spec_of(fmt::format("{}: moment–rotation — {}", s.name, scene.label()), "θ [rad]",
                     "M [N·m]", {ser(s.name, theta, mom)}),
             fig / (s.name + "_moment_rotation.png"), out, queue);
        // Loop area per load period (energy dissipated per cycle) when the load is A·t·sin ωt.
        const auto& f = s.force_x.kind == scene::TimeFunction::Kind::TSine ? s.force_x : s.moment;
        if (f.kind == scene::TimeFunction::Kind::TSine && f.omega > 0.0 && !mom.empty()) {
          const double T = 2.0 * std::numbers::pi / f.omega;
          json areas = json::array();
          for (double a = 0.0; a + T <= t.back() + 1e-9; a += T) {
            std::vector<double> xs, ys;
            for (std::size_t i = 0; i < t.size(); ++i)
              if (t[i] >= a && t[i] < a + T) {
                xs.push_back(theta[i]);
                ys.push_back(mom[i]);
              }
            areas.push_back(loop_area(xs, ys));
          }
          j["loop_area_per_cycle_J"] = areas;
          j["load_period_s"] = T;
        }
      }
      js[s.name] = j;
    }
    sum["structures"] = js;
  }

  // ---- walls: thrust and its running mean ---------------------------------------------------
  const auto wl = try_csv(dem / file::walls, out);
  if (!wl.rows.empty()) {
    const auto t = wl.column(col::time.name);
    json jw = json::object();
    const std::string thrust = fmt::format(".{}", output::heading(col::thrust)); // ".thrust [N]"
    for (const auto& c : wl.columns) {
      if (c.size() <= thrust.size() || c.compare(c.size() - thrust.size(), thrust.size(), thrust))
        continue;
      const std::string name = strip_unit(c);
      const auto y = wl.column(name);
      const double dtp = t.size() > 1 ? t[1] - t[0] : 0.01;
      // Mean (DC) part: a window of whole shaking periods (≈ 1 s) cancels the oscillating part.
      double window_s = 1.0;
      if (scene.load.shaking && scene.load.shaking->acceleration.frequency > 0.0) {
        const double f = scene.load.shaking->acceleration.frequency;
        window_s = std::max(1.0, std::round(f)) / f;
      }
      const auto avg =
          running_mean(y, static_cast<std::size_t>(std::max(1.0, std::round(window_s / dtp))));
      draw(spec_of(fmt::format("{} — {}", name, scene.label()), "time [s]", "force [N]",
                   {ser("thrust", t, y), ser(fmt::format("running mean ({:.3g} s)", window_s), t,
                                             avg, "lines", "lw 3")}),
           fig / (name + ".png"), out, queue);
      json j;
      // Static value: the mean before the shaking starts (or over the first 0.1 s if it starts at
      // 0).
      const double ts = scene.load.shaking ? scene.load.shaking->acceleration.start : 0.0;
      const double stat =
          ts > 0.2 ? mean_between(t, y, 0.5 * ts, ts) : mean_between(t, y, 0.0, 0.1);
      const double tend = t.empty() ? 0.0 : t.back();
      const double late = mean_between(t, y, std::max(ts, tend - 3.0), tend);
      j["static_N"] = stat;
      j["shaking_starts_s"] = ts;
      j["mean_early_N"] = mean_between(t, y, ts, ts + 2.0);
      j["mean_late_N"] = late;
      if (std::isfinite(stat) && stat != 0.0) j["late_over_static"] = late / stat;
      // When the mean stops rising: first time the running mean reaches 90 % of its final rise.
      if (std::isfinite(stat) && late > stat) {
        for (std::size_t i = 0; i < t.size() && i < avg.size(); ++i)
          if (t[i] >= ts && avg[i] >= stat + 0.9 * (late - stat)) {
            j["mean_reaches_90pct_of_rise_after_shaking_start_s"] = t[i] - ts;
            break;
          }
      }
      jw[name] = j;
    }
    sum["walls"] = jw;
  }

  // ---- force distribution along each recorded wall: pressure per bin, bin 0 at the bottom -------
  for (const auto& wall : scene.structures) {
    const auto pr = try_csv(dem / file::pressure(wall.name), out);
    if (pr.rows.empty() || pr.columns.size() < 2) continue;
    const auto t = pr.column(col::time.name);
    const std::size_t nb = pr.columns.size() - 1;
    const double ts = scene.load.shaking ? scene.load.shaking->acceleration.start : 0.0;
    const double tend = t.empty() ? 0.0 : t.back();
    Series before{"at rest (mean before shaking)", {}, {}, "linespoints", "lw 2 pt 7"};
    Series during{"shaking (time mean)", {}, {}, "linespoints", "lw 2 pt 5"};
    Series last{"last snapshot", {}, {}, "lines", "dt 2"};
    for (std::size_t b = 0; b < nb; ++b) {
      const auto y = pr.column(strip_unit(pr.columns[b + 1]));
      const double h = (static_cast<double>(b) + 0.5) / static_cast<double>(nb) * wall.height;
      before.x.push_back(ts > 0.2 ? mean_between(t, y, 0.5 * ts, ts)
                                  : mean_between(t, y, 0.0, 0.1));
      during.x.push_back(mean_between(t, y, ts, tend));
      last.x.push_back(y.empty() ? std::nan("") : y.back());
      before.y.push_back(h);
      during.y.push_back(h);
      last.y.push_back(h);
    }
    draw(spec_of(fmt::format("{}: pressure along the wall — {}", wall.name, scene.label()),
                 "normal pressure [Pa] (compression positive)", "height above the wall base [m]",
                 {before, during, last}),
         fig / (wall.name + "_pressure_profile.png"), out, queue);
  }

  // ---- surface profile: initial vs final, subsidence ------------------------------------------
  const auto sf = try_csv(dem / file::surface, out);
  if (sf.rows.size() >= 2) {
    const std::size_t nb = sf.columns.size() - 1;
    double x0 = 0, x1 = 1;
    if (!scene.domain.empty()) {
      x0 = x1 = scene.domain[0].x;
      for (const auto& q : scene.domain) {
        x0 = std::min(x0, q.x);
        x1 = std::max(x1, q.x);
      }
    }
    std::vector<double> xb(nb), z0(nb), z1(nb), dz(nb);
    double max_sub = 0.0, max_rise = 0.0;
    for (std::size_t b = 0; b < nb; ++b) {
      xb[b] = x0 + (x1 - x0) * (static_cast<double>(b) + 0.5) / static_cast<double>(nb);
      z0[b] = sf.rows.front()[b + 1];
      z1[b] = sf.rows.back()[b + 1];
      dz[b] = z1[b] - z0[b];
      if (std::isfinite(dz[b])) {
        max_sub = std::max(max_sub, -dz[b]);
        max_rise = std::max(max_rise, dz[b]);
      }
    }
    draw(spec_of(fmt::format("surface — {}", scene.label()), "x [m]", "z [m]",
                 {ser("start", xb, z0), ser("end", xb, z1, "lines", "lw 2")}),
         fig / "surface_profile.png", out, queue);
    if (std::any_of(dz.begin(), dz.end(), [](double v) { return std::isfinite(v); })) {
      draw(spec_of(fmt::format("surface change (end − start) — {}", scene.label()), "x [m]",
                   "Δz [m]", {ser("Δz", xb, dz, "linespoints")}),
           fig / "surface_change.png", out, queue);
      sum["surface"]["max_subsidence_m"] = max_sub;
      sum["surface"]["max_rise_m"] = max_rise;
    } else { // e.g. a slide: the bins that hold soil at the end held none at the start
      sum["surface"]["change"] =
          "none: no surface bin holds particles both at the start and at the end (the soil moved "
          "on; surface_profile.png shows both)";
    }
  }

  // ---- loci -----------------------------------------------------------------------------------
  const auto lc = try_csv(dem / file::loci, out);
  if (!lc.rows.empty()) {
    PlotSpec ps =
        spec_of(fmt::format("loci of tagged particles — {}", scene.label()), "x [m]", "z [m]", {});
    ps.equal_axes = true;
    const auto t = lc.column(col::time.name);
    double vmax = 0.0;
    for (std::size_t c = 1; c + 1 < lc.columns.size(); c += 2) {
      const auto x = lc.column(strip_unit(lc.columns[c]));
      const auto z = lc.column(strip_unit(lc.columns[c + 1]));
      ps.series.push_back(
          ser(strip_unit(lc.columns[c]).substr(0, strip_unit(lc.columns[c]).find('.')), x, z));
      for (std::size_t i = 1; i < std::min({x.size(), z.size(), t.size()}); ++i)
        if (t[i] > t[i - 1])
          vmax = std::max(vmax, std::hypot(x[i] - x[i - 1], z[i] - z[i - 1]) / (t[i] - t[i - 1]));
    }
    draw(ps, fig / "loci.png", out, queue);
    sum["loci_peak_speed_m_s"] = vmax;
  }

  // ---- energy ---------------------------------------------------------------------------------
  const auto en = try_csv(dem / file::energy, out);
  if (!en.rows.empty()) {
    const auto t = en.column(col::time.name);
    draw(spec_of(fmt::format("energy — {}", scene.label()), "time [s]", "[J]",
                 {ser("kinetic", t, en.column(col::kinetic.name)),
                  ser("friction (cum.)", t, en.column(col::friction.name)),
                  ser("rebound (cum.)", t, en.column(col::rebound.name))}),
         fig / "energy.png", out, queue);
  }

  // ---- peak speed over the snapshots; final snapshot with force chains -------------------------
  double zg = -1e300; // lowest ground point
  if (!scene.walls.empty()) {
    zg = 1e300;
    for (const auto& w : scene.walls)
      for (const auto& q : w.points) zg = std::min(zg, q.z);
  }
  const PeakSpeeds pk = peak_snapshot_speeds(dem / "vtk", zg);
  if (pk.all > 0.0) {
    sum["snapshot_peak_speed_m_s"] = pk.all;
    sum["snapshot_peak_speed_km_h"] = pk.all * 3.6;
  }
  if (!scene.walls.empty()) {
    sum["peak_speed_above_lowest_ground_m_s"] = pk.above;
    sum["peak_speed_above_lowest_ground_km_h"] = pk.above * 3.6;
  }
  std::error_code ec;
  if (fs::exists(dem / file::final_state, ec)) {
    try {
      const auto ck = dem::io::read_checkpoint(dem / file::final_state);
      const auto& p = ck.particles;
      // Particles that left the scene, and those of them that left while no wall was open
      // (through a gap the scene did not plan; dem::run warns above 1 % of the count).
      {
        std::size_t left = 0, unplanned = 0;
        for (const auto f : p.flags) {
          left += (f & dem::kFlagRemoved) ? 1 : 0;
          unplanned += (f & dem::kFlagLeftUnplanned) ? 1 : 0;
        }
        sum["particles_left"] = left;
        sum["particles_left_unplanned"] = unplanned;
      }
      // Size segregation (Ontake: "large particles gather at the toe"): mean radius of the leading
      // tenth of the particles still in the model (largest x) over the mean radius of all of them.
      {
        std::vector<std::pair<double, double>> xr;
        for (std::size_t i = 0; i < p.size(); ++i)
          if (!(p.flags[i] & dem::kFlagRemoved)) xr.emplace_back(p.x[i], p.radius[i]);
        if (xr.size() >= 20) {
          std::sort(xr.begin(), xr.end());
          const std::size_t lead = xr.size() / 10;
          double all = 0.0, front = 0.0;
          for (std::size_t k = 0; k < xr.size(); ++k) {
            all += xr[k].second;
            if (k >= xr.size() - lead) front += xr[k].second;
          }
          sum["leading_tenth_mean_radius_over_mean"] =
              (front / static_cast<double>(lead)) / (all / static_cast<double>(xr.size()));
          sum["particles_remaining"] = xr.size();
        }
      }
      // Density at the end of the run (the same window rule as the packing's).
      if (scene.soil.dem) {
        const auto m = dem::measure_packing(scene, p);
        sum["packing_final"] = {{"porosity", m.porosity},
                                {"void_ratio", m.void_ratio},
                                {"coordination", m.coordination}};
      }
      // Chains from the overlaps: the law's elastic force at each overlap (K_n δ for the linear
      // laws, paper eq. 2.6; the Hertz force for hertz-mindlin).
      const auto law = dem::contact::make_law(scene.soil.dem ? *scene.soil.dem : scene::DemSoil{});
      std::vector<dem::ContactView> cv;
      std::visit(
          [&](const auto& m) {
            for (const auto& [i, j] : dem::overlapping_pairs(p)) {
              dem::ContactView c;
              c.i = i;
              c.j = static_cast<std::int64_t>(j);
              const double delta =
                  p.radius[i] + p.radius[j] - std::hypot(p.x[i] - p.x[j], p.z[i] - p.z[j]);
              c.fn =
                  m.elastic_force(delta, p.radius[i] * p.radius[j] / (p.radius[i] + p.radius[j]));
              cv.push_back(c);
            }
          },
          law);
      std::vector<dem::BoundaryView> bv;
      for (const auto& w : scene.walls) {
        dem::BoundaryView b;
        b.name = w.name;
        for (const auto& q : w.points) {
          b.x.push_back(q.x);
          b.z.push_back(q.z);
        }
        bv.push_back(b);
      }
      for (const auto& body : scene.structures) { // outlines where the scene puts them (initial)
        dem::BoundaryView b;
        b.name = body.name;
        b.closed = true;
        for (const auto& q : body.outline) {
          b.x.push_back(q.x);
          b.z.push_back(q.z);
        }
        bv.push_back(b);
      }
      SnapshotSpec ss;
      ss.title = fmt::format("end of run (t = {:.3g} s), colour = speed, chains = {} — {}",
                             ck.meta.time, dem::contact::force_formula(law), scene.label());
      std::string err;
      if (!plot_particles(p, cv, bv, ss, fig / "snapshot_final.png", &err, &queue))
        out.problems.push_back("snapshot_final: " + err);
      // Velocity field at the end of the run (the paper's Figs. 3.6 and 6.x).
      SnapshotSpec vs = ss;
      vs.velocity_arrows = true;
      vs.title = fmt::format("velocity field at t = {:.3g} s (arrows: mean velocity of the "
                             "particles in each cell) — {}",
                             ck.meta.time, scene.label());
      if (!plot_particles(p, cv, bv, vs, fig / "velocity_field_final.png", &err, &queue))
        out.problems.push_back("velocity_field_final: " + err);
    } catch (const std::exception& e) {
      out.problems.push_back(std::string("final.ckpt: ") + e.what());
    }
  }

  draw_figures(queue, out);

  // ---- snapshot series at the paper's times (output.series; series.hpp) ------------
  {
    const auto ser_out = write_snapshot_series(scene, run_dir);
    out.figures.insert(out.figures.end(), ser_out.figures.begin(), ser_out.figures.end());
    out.problems.insert(out.problems.end(), ser_out.problems.begin(), ser_out.problems.end());
    if (!ser_out.times.empty()) {
      sum["snapshot_series"]["requested_s"] = ser_out.requested;
      sum["snapshot_series"]["drawn_s"] = ser_out.times;
    }
  }

  if (!out.problems.empty()) sum["figure_problems"] = out.problems;
  out.summary = run_dir / "summary.json";
  scene::write_file_atomic(out.summary, sum.dump(2) + "\n"); // throws WriteError naming it
  return out;
}

} // namespace demfem::compare
