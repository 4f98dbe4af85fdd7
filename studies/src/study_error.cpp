// `demfem study error-vs-time`: resolution sweeps, each run a separate process.
#include "demfem/compare/html.hpp"
#include "demfem/studies/error_study.hpp"
#include "study_runs.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <fcntl.h>
#include <fstream>
#include <functional>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string_view>
#include <sys/resource.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "demfem/compare/plot.hpp"
#include "demfem/dem/contact/registry.hpp"
#include "demfem/dem/io.hpp"
#include "demfem/dem/stable_step.hpp"
#include "demfem/dem/verification.hpp"
#include "demfem/scene/load.hpp"
#include "demfem/scene/write_file.hpp"
#include "demfem/studies/processes.hpp"

namespace demfem::studies {

using compare::html_escape;
using compare::PlotSpec;
using compare::read_csv;
using compare::Series;

namespace fs = std::filesystem;

double loglog_slope(const std::vector<double>& x, const std::vector<double>& y) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0, n = 0;
  for (std::size_t i = 0; i < std::min(x.size(), y.size()); ++i) {
    if (!(x[i] > 0.0) || !(y[i] > 0.0) || !std::isfinite(x[i]) || !std::isfinite(y[i])) continue;
    const double lx = std::log(x[i]), ly = std::log(y[i]);
    sx += lx;
    sy += ly;
    sxx += lx * lx;
    sxy += lx * ly;
    n += 1;
  }
  const double den = n * sxx - sx * sx;
  if (n < 2 || !(std::abs(den) > 1e-300)) return std::numeric_limits<double>::quiet_NaN();
  return (n * sxy - sx * sy) / den; // least squares in log–log
}

std::vector<std::size_t> pareto_front(const std::vector<double>& cost,
                                      const std::vector<double>& error) {
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < std::min(cost.size(), error.size()); ++i)
    if (std::isfinite(cost[i]) && std::isfinite(error[i])) idx.push_back(i);
  std::sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) {
    return cost[a] != cost[b] ? cost[a] < cost[b] : error[a] < error[b];
  });
  std::vector<std::size_t> front;
  double best = std::numeric_limits<double>::infinity();
  for (const auto i : idx)
    if (error[i] < best) { // cheapest point so far that is more accurate than every cheaper one
      front.push_back(i);
      best = error[i];
    }
  return front;
}

namespace study_detail {

// ---- separate processes ------------------------------------------------------------------------

std::string env_or(const char* name, const std::string& fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::string(v) : fallback;
}

const Spread& launcher_spread() {
  static const Spread sp = [] {
    Spread r;
    // Open MPI, MPICH/Hydra (and Intel MPI), Slurm's srun
    const std::pair<const char*, const char*> vars[] = {
        {"OMPI_COMM_WORLD_RANK", "OMPI_COMM_WORLD_SIZE"},
        {"PMI_RANK", "PMI_SIZE"},
        {"SLURM_PROCID", "SLURM_NTASKS"}};
    for (const auto& [rank, size] : vars) {
      const char* a = std::getenv(rank);
      const char* b = std::getenv(size);
      if (!a || !b) continue;
      try {
        const int rr = std::stoi(a), nn = std::stoi(b);
        if (nn >= 1 && rr >= 0 && rr < nn) {
          r.rank = rr;
          r.size = nn;
        }
      } catch (const std::exception&) {
      }
      break;
    }
    // one launch, one exchange directory: the launcher's job id where it gives one, else the
    // launcher's process (the ranks' common parent on a node)
    r.token = env_or("PMIX_NAMESPACE", env_or("OMPI_MCA_orte_ess_jobid",
                                              env_or("SLURM_JOB_ID", std::to_string(::getppid()))));
    for (char& c : r.token)
      if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    return r;
  }();
  return sp;
}

fs::path spread_directory(const fs::path& out_dir) {
  return out_dir / (".ranks-" + launcher_spread().token);
}

using Task = ProcessTask;

// Writes this rank's task results of a wave into `dir` and reads the other ranks' back, waiting
// until they are all there (under a launcher a rank that fails ends the whole job).
void exchange_results(std::vector<TaskResult>& res, const std::vector<std::size_t>& mine,
                      const fs::path& dir) {
  const Spread& sp = launcher_spread();
  fs::create_directories(dir);
  for (const std::size_t t : mine) {
    const auto& r = res[t];
    const nlohmann::json j = {{"exit_code", r.exit_code},
                              {"wall", r.wall},
                              {"rss_mib", r.rss_mib},
                              {"timed_out", r.timed_out},
                              {"rank", r.rank}};
    scene::write_file_atomic(dir / fmt::format("task-{}.json", t), j.dump() + "\n");
  }
  using Clock = std::chrono::steady_clock;
  auto last_note = Clock::now();
  std::vector<bool> have(res.size(), false);
  for (const std::size_t t : mine) have[t] = true;
  for (;;) {
    std::size_t missing = 0;
    for (std::size_t t = 0; t < res.size(); ++t) {
      if (have[t]) continue;
      const fs::path f = dir / fmt::format("task-{}.json", t);
      std::ifstream in(f);
      if (!in) {
        ++missing;
        continue;
      }
      const auto j = nlohmann::json::parse(in, nullptr, false);
      if (j.is_discarded()) { // written atomically: a parse failure is a foreign file
        throw std::runtime_error(fmt::format("{}: not a task result", f.string()));
      }
      res[t].exit_code = j.value("exit_code", -1);
      res[t].wall = j.value("wall", 0.0);
      res[t].rss_mib = j.value("rss_mib", 0.0);
      res[t].timed_out = j.value("timed_out", false);
      res[t].rank = j.value("rank", -1);
      have[t] = true;
    }
    if (missing == 0) return;
    if (Clock::now() - last_note > std::chrono::seconds(60)) {
      fmt::print(stderr, "study rank {} of {}: waiting for {} result(s) of the other ranks in {}\n",
                 sp.rank, sp.size, missing, dir.string());
      last_note = Clock::now();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
}

// Runs this rank's share of the tasks (all of them outside a launcher) as child processes, at most
// `jobs` at once (run_processes). Under a launcher the other ranks' results are read back from
// `exchange` (one subdirectory per call, the same sequence on every rank).
std::vector<TaskResult> run_tasks(const std::vector<Task>& all_tasks, int jobs,
                                  const fs::path& exchange) {
  const Spread& sp = launcher_spread();
  static int wave = 0;
  const int this_wave = wave++;
  std::vector<std::size_t> mine;
  for (std::size_t t = 0; t < all_tasks.size(); ++t)
    if (static_cast<int>(t % static_cast<std::size_t>(sp.size)) == sp.rank) mine.push_back(t);
  std::vector<Task> tasks;
  for (const std::size_t t : mine) tasks.push_back(all_tasks[t]);
  const auto res = run_processes(tasks, jobs);
  std::vector<TaskResult> out(all_tasks.size());
  for (std::size_t k = 0; k < mine.size(); ++k) {
    out[mine[k]] = res[k];
    out[mine[k]].rank = sp.rank;
  }
  if (sp.size > 1) exchange_results(out, mine, exchange / fmt::format("wave-{}", this_wave));
  return out;
}

std::string tail_of(const fs::path& log) {
  std::ifstream in(log);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  return last;
}

std::string join_command(const std::vector<std::string>& argv) {
  std::string c;
  for (const auto& a : argv) c += (c.empty() ? "" : " ") + a;
  return c;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Runs every job's repeats (repeat-major order, so that repeats of one point are spread in
// time), fills timings and evaluates each point from its first successful repeat.
void run_jobs(std::vector<Job>& jobs, const ErrorStudyOptions& o) {
  std::vector<Task> tasks;
  std::vector<std::pair<std::size_t, int>> owner;
  for (int k = 0; k < o.repeats; ++k)
    for (std::size_t j = 0; j < jobs.size(); ++j) {
      // each rank clears only the runs it starts (task t runs on rank t mod size)
      if (static_cast<int>(tasks.size() % static_cast<std::size_t>(launcher_spread().size)) ==
          launcher_spread().rank)
        fs::remove_all(jobs[j].dirs[k]);
      fs::create_directories(jobs[j].dirs[k].parent_path());
      tasks.push_back({jobs[j].argv[k], jobs[j].dirs[k].string() + ".log", jobs[j].timeout, {}});
      owner.emplace_back(j, k);
    }
  const auto res = run_tasks(tasks, o.jobs, spread_directory(o.out_dir));
  for (auto& j : jobs) {
    j.point.wall.clear();
    j.point.ok = true;
  }
  std::vector<int> first_ok(jobs.size(), -1);
  for (std::size_t t = 0; t < tasks.size(); ++t) {
    auto& j = jobs[owner[t].first];
    if (res[t].timed_out) {
      j.point.ok = false;
      j.timed_out = true;
      j.point.message = fmt::format("stopped after {:.0f} s, the study's per-run limit "
                                    "(--max-run-seconds)",
                                    tasks[t].timeout);
      continue;
    }
    if (res[t].exit_code != 0) {
      j.point.ok = false;
      if (j.point.message.empty())
        j.point.message = fmt::format("exit {}: {}", res[t].exit_code, tail_of(tasks[t].log));
      continue;
    }
    // the solver's own time, from the point's result file
    double solver = res[t].wall;
    try {
      std::ifstream in(j.dirs[static_cast<std::size_t>(owner[t].second)].string() + ".json");
      solver = nlohmann::json::parse(in).value("solver_seconds", res[t].wall);
    } catch (const std::exception&) {
    }
    j.point.wall.push_back(solver);
    j.point.process_wall.push_back(res[t].wall);
    j.point.peak_rss_mib = std::max(j.point.peak_rss_mib, res[t].rss_mib);
    j.point.rank = res[t].rank;
    if (first_ok[owner[t].first] < 0) first_ok[owner[t].first] = owner[t].second;
  }
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    auto& p = jobs[i].point;
    p.command = join_command(jobs[i].argv[0]);
    if (!p.wall.empty()) {
      p.wall_min = *std::min_element(p.wall.begin(), p.wall.end());
      p.wall_max = *std::max_element(p.wall.begin(), p.wall.end());
      p.wall_median = median(p.wall);
      p.process_min = *std::min_element(p.process_wall.begin(), p.process_wall.end());
      p.process_max = *std::max_element(p.process_wall.begin(), p.process_wall.end());
      p.process_median = median(p.process_wall);
    }
    if (!p.ok) continue;
    try {
      jobs[i].evaluate(p, jobs[i].dirs[static_cast<std::size_t>(first_ok[i])]);
    } catch (const std::exception& e) {
      p.ok = false;
      p.message = e.what();
    }
  }
}

// Marks each knob's Pareto front (median wall time against the primary error).
void mark_fronts(ErrorStudy& st, const std::vector<std::vector<std::string>>& groups) {
  for (const auto& g : groups) {
    std::vector<std::size_t> members;
    std::vector<double> cost, err;
    for (std::size_t i = 0; i < st.points.size(); ++i) {
      const auto& p = st.points[i];
      if (std::find(g.begin(), g.end(), p.knob) == g.end() || !p.ok) continue;
      const auto e = p.errors.find(st.primary_metric);
      if (e == p.errors.end()) continue;
      members.push_back(i);
      cost.push_back(p.wall_median);
      err.push_back(e->second);
    }
    for (const auto f : pareto_front(cost, err)) st.points[members[f]].pareto = true;
  }
}

void add_fit(ErrorStudy& st, const std::string& knob, const std::string& metric,
             const std::string& against, double x_max) {
  std::vector<double> x, y;
  for (const auto& p : st.points) {
    if (p.knob != knob || !p.ok) continue;
    const auto e = p.errors.find(metric);
    if (e == p.errors.end()) continue;
    const double xv = against == "wall" ? p.wall_median : p.x;
    if (x_max > 0.0 && against != "wall" && xv > x_max * (1 + 1e-12)) continue;
    x.push_back(xv);
    y.push_back(e->second);
  }
  ErrorFit f;
  f.knob = knob;
  f.metric = metric;
  f.against = against;
  f.order = loglog_slope(x, y);
  f.points = static_cast<int>(x.size());
  if (!x.empty()) {
    f.x_min = *std::min_element(x.begin(), x.end());
    f.x_max = *std::max_element(x.begin(), x.end());
  }
  // Errors at round-off (all below 1e-8 relative) carry no order.
  if (!y.empty() && *std::max_element(y.begin(), y.end()) < 1e-8)
    f.order = std::numeric_limits<double>::quiet_NaN();
  // Nor does a wall time that the knob hardly changes (fixed costs dominate: start-up, output).
  if (against == "wall" && f.points >= 2 && !(f.x_max > 2.0 * f.x_min)) {
    f.order = std::numeric_limits<double>::quiet_NaN();
    st.notes.push_back(fmt::format("{}: no {}-against-wall-time order: the solver wall time "
                                   "varies only from {:.3g} to {:.3g} s over the sweep (fixed "
                                   "costs dominate)",
                                   knob, metric, f.x_min, f.x_max));
  }
  st.fits.push_back(f);
}

std::string frac_label(double f) {
  const double inv = 1.0 / f;
  if (std::abs(inv - std::round(inv)) < 1e-9 && inv >= 1.0)
    return fmt::format("1/{}", static_cast<long long>(std::llround(inv)));
  return fmt::format("{:g}", f);
}

} // namespace study_detail

using namespace study_detail;

ErrorStudy dem_error_study(const scene::Scene& base, const ErrorStudyOptions& o) {
  std::string why;
  const auto cf0 = dem::head_on_closed_form(base, &why);
  if (!cf0)
    throw std::runtime_error(fmt::format(
        "{}: no closed form for the error-vs-time study ({}); closed-form DEM scenes: two listed "
        "disks meeting head-on (cases/verification/head_on_collision.toml)",
        base.label(), why));
  const auto bound = dem::scene_critical_step(base);
  if (!bound || !(bound->dt > 0.0) || !std::isfinite(bound->dt))
    throw std::runtime_error(base.label() + ": no stable step bound");
  ErrorStudy st;
  st.solver = "dem";
  st.scene = base.label();
  st.source = base.source_file;
  st.repeats = o.repeats;
  st.jobs = o.jobs;
  st.reference = "closed form of the head-on collision: Newton restitution above V_0 (separation "
                 "at K v_n, else v_n), dissipation ½ m* v_n² (1 − K²), contact duration "
                 "π √(m*/K_n); the centre distance at the end is r1 + r2 + v_sep (t − t_touch − "
                 "π √(m*/K_n))";
  st.primary_metric = "distance";
  // The closed-form studies' metrics (these and flamant_error_study's) are not rows of the
  // comparison's metric table (compare/metric_table.hpp): a row is one quantity both solvers write
  // through the run-directory contract, reduced alike for both (rest value, late mean,
  // oscillation, profile per bin); these are one solver's end state (two particles of a
  // checkpoint, the last rebound energy, a study-point result) against a closed form, with no
  // counterpart in the other solver. Scenes without a closed form are measured with the table
  // itself (study_scene.cpp, compare::collect_solver_metrics).
  st.metric_descriptions = {
      {"distance", "|d − d_exact| / (d_exact − r1 − r2): centre distance at the end, relative to "
                   "the gap opened since separation"},
      {"separation_speed", "|v_sep − K v_n| / (K v_n): relative speed after the collision"},
      {"dissipated", "|E_rebound − ½ m* v_n² (1 − K²)| / ½ m* v_n² (1 − K²)"}};
  st.closed_form = {{"m_star", cf0->m_star},
                    {"approach_speed", cf0->approach},
                    {"separation_speed", cf0->separation},
                    {"dissipated", cf0->dissipated},
                    {"touch_time", cf0->touch_time},
                    {"contact_time", cf0->contact_time},
                    {"critical_step", bound->dt}};
  // The engine's symplectic Euler (paper eqs. 2.16–2.18: velocity first, then position) gives
  // the same positions as Störmer–Verlet (leapfrog, velocities at half steps; Hairer, Lubich &
  // Wanner 2006, §I.3), which is second order; the energy-consistent touch and release of the
  // linear spring (contact_laws.hpp) remove the first-order error of seeing first touch up to one
  // Δt late, so positions after the collision converge at order 2.
  st.expected_order = 2.0;
  st.expected_order_note =
      "positions of the engine's symplectic Euler equal those of Störmer–Verlet, second order "
      "(Hairer, Lubich & Wanner 2006, §I.3); the energy-consistent touch and release keep the "
      "non-smooth contact from degrading it";
  const fs::path runs = o.out_dir / "runs";

  const auto make_job = [&](const std::string& knob, const std::string& name, double value,
                            scene::Scene s) {
    Job j;
    s.output.figures = false;
    s.output.vtk = false;
    s.output.force_chains = false;
    const auto cf = dem::head_on_closed_form(s);
    double dt = s.soil.dem->dt;
    if (!(dt > 0.0)) {
      const auto b = dem::scene_critical_step(s);
      dt = b ? s.soil.dem->dt_safety * b->dt : 0.0; // the automatic step (scene.hpp dt_safety)
    }
    j.point.knob = knob;
    j.point.name = name;
    j.point.value = value;
    j.point.x = dt;
    j.point.dt = dt;
    std::string dir_name = name;
    std::replace(dir_name.begin(), dir_name.end(), '/', '_');
    const fs::path dir = runs / dir_name;
    fs::create_directories(dir);
    const fs::path toml = dir / "scene.toml";
    scene::write_file_atomic(toml, scene::to_toml(s));
    for (int k = 0; k < o.repeats; ++k) {
      const fs::path rd = dir / fmt::format("rep-{}", k);
      j.dirs.push_back(rd);
      j.argv.push_back({o.exe.string(), "study-point", "dem", "--scene", toml.string(), "--out",
                        rd.string(), "--json", rd.string() + ".json"});
    }
    j.evaluate = [cf, dt](ErrorPoint& p, const fs::path& rd) {
      if (!cf) throw std::runtime_error("no closed form for this point");
      const auto ck = dem::io::read_checkpoint(rd / "dem" / "checkpoint.ckpt");
      const auto& q = ck.particles;
      if (q.size() != 2) throw std::runtime_error("the run did not end with two particles");
      const double d = std::hypot(q.x[1] - q.x[0], q.z[1] - q.z[0]);
      const double d_exact = cf->distance(ck.meta.time);
      p.errors["distance"] = std::abs(d - d_exact) / (d_exact - cf->radius_sum);
      const double ke = 0.5 * (q.mass[0] * (q.vx[0] * q.vx[0] + q.vz[0] * q.vz[0]) +
                               q.mass[1] * (q.vx[1] * q.vx[1] + q.vz[1] * q.vz[1]));
      const double v_sep = std::sqrt(std::max(0.0, 2.0 * (ke - cf->kinetic_cm) / cf->m_star));
      p.errors["separation_speed"] = std::abs(v_sep - cf->separation) / cf->separation;
      if (cf->dissipated > 0.0) {
        const auto t = read_csv(rd / "dem" / "energy.csv");
        const auto reb = t.column("rebound");
        if (reb.empty()) throw std::runtime_error("energy.csv has no rebound column");
        p.errors["dissipated"] = std::abs(reb.back() - cf->dissipated) / cf->dissipated;
      }
      p.dt = ck.meta.dt > 0.0 ? ck.meta.dt : dt;
      p.x = p.dt;
    };
    return j;
  };

  std::vector<Job> jobs;
  for (const double f : o.dt_fractions) {
    scene::Scene s = base;
    s.soil.dem->dt = f * bound->dt;
    jobs.push_back(make_job("dt", "dt-" + frac_label(f), f, s));
  }
  for (const double f : o.kn_factors) {
    scene::Scene s = base;
    auto& d = *s.soil.dem;
    dem::contact::scale_stiffness(d, f);
    d.dt = 0.0; // automatic
    jobs.push_back(make_job("kn", fmt::format("kn-x{:g}", f), f, s));
  }
  st.notes.push_back("particle size at fixed geometry (N ×1, ×4): not applicable, the scene "
                     "lists its two particles");
  run_jobs(jobs, o);
  for (auto& j : jobs) st.points.push_back(j.point);
  const double fit_max = o.fit_max_fraction > 0.0 ? o.fit_max_fraction * bound->dt : 0.0;
  for (const auto& m : {"distance", "separation_speed", "dissipated"}) {
    add_fit(st, "dt", m, "dt", fit_max);
    add_fit(st, "dt", m, "wall", 0.0);
  }
  add_fit(st, "kn", "distance", "wall", 0.0);
  mark_fronts(st, {{"dt"}, {"kn"}});
  return st;
}

ErrorStudy flamant_error_study(const ErrorStudyOptions& o) {
  ErrorStudy st;
  st.solver = "continuum";
  st.scene = "flamant";
  st.source = "built-in (continuum/src/verification.cpp)";
  st.repeats = o.repeats;
  st.jobs = o.jobs;
  st.reference = "Flamant strip load on an elastic half-plane (Poulos & Davis 1974): "
                 "settlement(centre) − settlement(edge) = (4 ln 2/π)(1 − ν²) q b / E";
  st.primary_metric = "settlement";
  st.metric_descriptions = {
      {"settlement", "|Δs − Δs_exact| / Δs_exact, Δs = settlement(centre) − settlement(edge): "
                     "discretisation and the finite (200 m) block together"},
      {"settlement_vs_finest",
       "|Δs − Δs_finest| / Δs_exact, against the most resolved run: the discretisation error "
       "alone (the block's truncation cancels)"}};
  st.expected_order = 0.0;
  st.expected_order_note =
      "no single theoretical rate: the load's edge is a stress singularity, which limits the "
      "rate of point displacements below the smooth-solution p + 1, and the closed form is for "
      "a half-plane, so `settlement` levels off at the block's truncation error";
  const fs::path runs = o.out_dir / "runs";
  std::vector<Job> jobs;
  for (const int p : o.degrees)
    for (const int r : o.refinements) {
      // size estimate: 22 050 dofs at degree 2, refinement 1 (measured), ∝ (degree · 2^r)²
      const double est = 22050.0 * std::pow(p * std::pow(2.0, r) / 4.0, 2);
      if (est > o.max_dofs) {
        st.notes.push_back(fmt::format("q{} at refinement {} skipped: ≈ {:.2g} dofs, above the "
                                       "study's cap of {:.2g}",
                                       p, r, est, o.max_dofs));
        continue;
      }
      Job j;
      j.point.knob = fmt::format("mesh-q{}", p);
      j.point.name = fmt::format("q{}-r{}", p, r);
      j.point.value = r;
      for (int k = 0; k < o.repeats; ++k) {
        const fs::path rd = runs / j.point.name / fmt::format("rep-{}", k);
        j.dirs.push_back(rd);
        j.argv.push_back({o.exe.string(), "study-point", "flamant", "--refinement",
                          std::to_string(r), "--degree", std::to_string(p), "--json",
                          (rd.string() + ".json")});
      }
      j.evaluate = [](ErrorPoint& pt, const fs::path& rd) {
        std::ifstream in(rd.string() + ".json");
        if (!in) throw std::runtime_error("no result file " + rd.string() + ".json");
        const auto js = nlohmann::json::parse(in);
        if (!js.value("converged", false)) throw std::runtime_error("not converged");
        const double c = js.at("computed").get<double>(), e = js.at("exact").get<double>();
        pt.errors["settlement"] = std::abs(c - e) / e;
        pt.results["settlement"] = c;
        pt.results["settlement_exact"] = e;
        pt.x = js.at("h_min").get<double>();
        pt.dofs = js.at("dofs").get<std::size_t>();
      };
      jobs.push_back(std::move(j));
    }
  run_jobs(jobs, o);
  for (auto& j : jobs) st.points.push_back(j.point);
  // the most resolved run (most dofs; at equal size the higher degree) is the reference of the
  // discretisation error
  const ErrorPoint* ref = nullptr;
  for (const auto& p : st.points)
    if (p.ok && (!ref || p.dofs > ref->dofs || (p.dofs == ref->dofs && p.knob > ref->knob)))
      ref = &p;
  if (ref) {
    const double r = ref->results.at("settlement"), e = ref->results.at("settlement_exact");
    st.closed_form["settlement_exact"] = e;
    st.closed_form["settlement_finest"] = r;
    st.notes.push_back(
        fmt::format("reference of settlement_vs_finest: {} ({} dofs)", ref->name, ref->dofs));
    const std::string ref_name = ref->name;
    for (auto& p : st.points)
      if (p.ok && p.name != ref_name)
        p.errors["settlement_vs_finest"] = std::abs(p.results.at("settlement") - r) / e;
  }
  for (const int p : o.degrees) {
    add_fit(st, fmt::format("mesh-q{}", p), "settlement", "h", 0.0);
    add_fit(st, fmt::format("mesh-q{}", p), "settlement_vs_finest", "h", 0.0);
    add_fit(st, fmt::format("mesh-q{}", p), "settlement", "wall", 0.0);
  }
  std::vector<std::string> all;
  for (const int p : o.degrees) all.push_back(fmt::format("mesh-q{}", p));
  mark_fronts(st, {all});
  return st;
}

// ---- outputs -----------------------------------------------------------------------------------

namespace {

// A knob's name in figure legends: scenes without a closed form mix both solvers' knobs, so the
// DEM's and the continuum's time step are named as such.
std::string knob_label(const ErrorStudy& st, const std::string& k) {
  if (st.reference_runs.empty()) return k;
  if (k == "dt") return "DEM Δt";
  if (k == "kn") return "DEM K_n";
  if (k == "size") return "DEM particle size";
  if (k == "cont-dt") return "continuum Δt";
  return k;
}

std::string fmt_order(double v) {
  return std::isfinite(v) ? fmt::format("{:.2f}", v) : "–";
}

struct Figure {
  std::string file, caption;
};

// Error against wall time (median) of the knobs in `knobs`, with the Pareto front of them all.
std::optional<Figure> wall_figure(const ErrorStudy& st, const std::vector<std::string>& knobs,
                                  const std::string& stem, const std::string& what,
                                  const fs::path& dir) {
  PlotSpec ps;
  ps.title = fmt::format("{}: {} error against wall time\n({})", st.scene, st.primary_metric, what);
  ps.xlabel = "solver wall time per run, median of repeats [s]";
  ps.ylabel = fmt::format("relative error ({})", st.primary_metric);
  ps.log_x = ps.log_y = true;
  Series front{"Pareto front", {}, {}, "lines", "lw 2 lc rgb '#444444' dt 2"};
  std::vector<std::pair<double, double>> fr;
  for (const auto& k : knobs) {
    // scenes without a closed form mix both solvers' knobs: the DEM's are named as such
    Series s{knob_label(st, k), {}, {}, "linespoints", "pt 7 ps 1.2"};
    for (const auto& p : st.points) {
      if (p.knob != k || !p.ok) continue;
      const auto e = p.errors.find(st.primary_metric);
      if (e == p.errors.end()) continue;
      s.x.push_back(p.wall_median);
      s.y.push_back(e->second);
    }
    // the front of the settings drawn here (several knobs: across them all)
    for (std::size_t i = 0; i < s.x.size(); ++i) fr.emplace_back(s.x[i], s.y[i]);
    for (const auto& f : st.fits)
      if (f.knob == k && f.metric == st.primary_metric && f.against == "wall" &&
          std::isfinite(f.order))
        s.label += fmt::format(" (error ∝ wall^{})", fmt_order(f.order));
    // a line joins the settings in knob order only where the cost grows along it
    if (!std::is_sorted(s.x.begin(), s.x.end())) s.style = "points";
    if (!s.x.empty()) ps.series.push_back(s);
  }
  {
    std::vector<double> cx, cy;
    for (const auto& [x, y] : fr) {
      cx.push_back(x);
      cy.push_back(y);
    }
    for (const auto i : pareto_front(cx, cy)) {
      front.x.push_back(cx[i]);
      front.y.push_back(cy[i]);
    }
  }
  if (ps.series.empty()) return std::nullopt;
  ps.series.push_back(front);
  std::string err;
  if (!plot(ps, dir / "figures" / (stem + ".png"), &err)) return std::nullopt;
  return Figure{"figures/" + stem + ".png",
                fmt::format("Error against wall time, {}: each point is one setting (median of {} "
                            "runs); lower-left is better; the dashed line is the Pareto front "
                            "(no other setting is both faster and more accurate).",
                            what, st.repeats)};
}

// Error against the convergence abscissa (Δt or h), with the fitted power laws.
std::optional<Figure> convergence_figure(const ErrorStudy& st,
                                         const std::vector<std::string>& knobs,
                                         const std::string& against, const std::string& stem,
                                         const fs::path& dir) {
  PlotSpec ps;
  ps.title = fmt::format("{}: convergence in {}", st.scene,
                         against == "dt"  ? "Δt"
                         : against == "r" ? "particle size"
                                          : "h");
  ps.xlabel = against == "dt"  ? "Δt [s]"
              : against == "r" ? "mean particle radius [m]"
                               : "smallest cell h [m]";
  ps.ylabel = "relative error";
  ps.log_x = ps.log_y = true;
  for (const auto& k : knobs)
    for (const auto& [metric, desc] : st.metric_descriptions) {
      // scenes without a closed form: the primary metric only (the others are in the tables)
      if (!st.reference_runs.empty() && metric != st.primary_metric) continue;
      Series s{fmt::format("{} {}", knob_label(st, k), metric), {}, {}, "points", "pt 7 ps 1.2"};
      for (const auto& p : st.points) {
        if (p.knob != k || !p.ok) continue;
        const auto e = p.errors.find(metric);
        if (e == p.errors.end() || !(e->second > 0.0)) continue;
        s.x.push_back(p.x);
        s.y.push_back(e->second);
      }
      if (s.x.empty()) continue;
      for (const auto& f : st.fits) {
        if (f.knob != k || f.metric != metric || f.against != against) continue;
        if (!std::isfinite(f.order)) continue;
        // the fitted line through the fitted range: log y = a + p log x (least squares)
        double sx = 0, sy = 0, n = 0;
        for (std::size_t i = 0; i < s.x.size(); ++i)
          if (s.x[i] >= f.x_min * (1 - 1e-12) && s.x[i] <= f.x_max * (1 + 1e-12)) {
            sx += std::log(s.x[i]);
            sy += std::log(s.y[i]);
            n += 1;
          }
        if (n < 2) continue;
        const double a = (sy - f.order * sx) / n;
        Series line{
            fmt::format("fit {} {}: order {}", knob_label(st, k), metric, fmt_order(f.order)),
            {f.x_min, f.x_max},
            {std::exp(a + f.order * std::log(f.x_min)), std::exp(a + f.order * std::log(f.x_max))},
            "lines",
            "lw 2"};
        ps.series.push_back(s);
        ps.series.push_back(line);
        s.x.clear();
      }
      if (!s.x.empty()) ps.series.push_back(s);
    }
  if (ps.series.empty()) return std::nullopt;
  std::string err;
  if (!plot(ps, dir / "figures" / (stem + ".png"), &err)) return std::nullopt;
  return Figure{"figures/" + stem + ".png",
                fmt::format("Error against {}: the slope of each fitted line is the convergence "
                            "order (least squares in log–log over the points it spans); points "
                            "without a line are at round-off or outside the fitted range.",
                            against == "dt"  ? "the time step"
                            : against == "r" ? "the particle size"
                                             : "the cell size")};
}

} // namespace

void write_error_study(const ErrorStudy& st, const fs::path& dir) {
  fs::create_directories(dir / "figures");
  nlohmann::json j;
  j["study"] = "error-vs-time";
  j["solver"] = st.solver;
  j["scene"] = st.scene;
  j["source"] = st.source;
  j["reference"] = st.reference;
  j["primary_metric"] = st.primary_metric;
  j["metrics"] = st.metric_descriptions;
  j["closed_form"] = st.closed_form;
  if (const auto d = st.closed_form.find("duration"); d != st.closed_form.end())
    j["duration"] = d->second;
  j["expected_order"] = st.expected_order;
  j["expected_order_note"] = st.expected_order_note;
  j["repeats"] = st.repeats;
  j["jobs"] = st.jobs;
  j["notes"] = st.notes;
  auto num = [](double v) -> nlohmann::json {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
  };
  auto& jp = j["points"];
  jp = nlohmann::json::array();
  for (const auto& p : st.points) {
    nlohmann::json e = nlohmann::json::object();
    for (const auto& [k, v] : p.errors) e[k] = num(v);
    jp.push_back({{"solver", p.solver},
                  {"knob", p.knob},
                  {"name", p.name},
                  {"value", p.value},
                  {"x", p.x},
                  {"dt", p.dt},
                  {"dofs", p.dofs},
                  {"ok", p.ok},
                  {"message", p.message},
                  {"errors", e},
                  {"results", p.results},
                  {"wall_seconds", p.wall},
                  {"wall_min", p.wall_min},
                  {"wall_median", p.wall_median},
                  {"wall_max", p.wall_max},
                  {"process_seconds", p.process_wall},
                  {"process_min", p.process_min},
                  {"process_median", p.process_median},
                  {"process_max", p.process_max},
                  {"peak_rss_mib", p.peak_rss_mib},
                  {"rank", p.rank},
                  {"pareto", p.pareto},
                  {"command", p.command}});
  }
  auto& jf = j["fits"];
  jf = nlohmann::json::array();
  for (const auto& f : st.fits)
    jf.push_back({{"knob", f.knob},
                  {"metric", f.metric},
                  {"against", f.against},
                  {"order", num(f.order)},
                  {"points", f.points},
                  {"x_min", f.x_min},
                  {"x_max", f.x_max}});

  std::vector<Figure> figs;
  if (!st.reference_runs.empty()) j["reference_runs"] = st.reference_runs;
  std::vector<std::vector<std::string>> groups;
  if (!st.wall_groups.empty()) {
    for (const auto& g : st.wall_groups)
      if (auto f = wall_figure(st, g.knobs, g.stem, g.what, dir)) figs.push_back(*f);
    for (const auto& g : st.convergence_groups)
      if (auto f = convergence_figure(st, g.knobs, g.against, g.stem, dir)) figs.push_back(*f);
  } else if (st.solver == "dem")
    groups = {{"dt"}, {"kn"}};
  else {
    std::vector<std::string> all;
    for (const auto& p : st.points)
      if (std::find(all.begin(), all.end(), p.knob) == all.end()) all.push_back(p.knob);
    groups = {all};
  }
  for (const auto& g : st.wall_groups.empty() ? groups : decltype(groups){}) {
    const std::string what = st.solver == "dem" ? (g[0] == "dt" ? "Δt as a fraction of the "
                                                                  "critical step"
                                                                : "K_n scaling, automatic Δt")
                                                : "refinement and degree";
    std::string stem = "error_vs_wall_";
    for (const auto& k : g) stem += k;
    if (auto f = wall_figure(st, g, stem, what, dir)) figs.push_back(*f);
  }
  if (st.wall_groups.empty() && st.solver == "dem") {
    if (auto f = convergence_figure(st, {"dt"}, "dt", "convergence_dt", dir)) figs.push_back(*f);
  } else if (st.wall_groups.empty()) {
    if (auto f = convergence_figure(st, groups[0], "h", "convergence_h", dir)) figs.push_back(*f);
  }
  j["figures"] = nlohmann::json::array();
  for (const auto& f : figs) j["figures"].push_back({{"file", f.file}, {"caption", f.caption}});
  scene::write_file_atomic(dir / "study.json", j.dump(2) + "\n");

  // study.md and study.html: the fits, then every point.
  std::vector<std::string> metrics;
  for (const auto& [k, v] : st.metric_descriptions) metrics.push_back(k);
  std::string md = fmt::format("# Error against run time: {} ({})\n\nReference: {}.\n\n", st.scene,
                               st.solver, st.reference);
  std::string html = fmt::format(
      "<!doctype html><html><head><meta charset=\"utf-8\"><title>Error against run time: {0}"
      "</title><style>body{{font-family:sans-serif;max-width:1100px}}table{{border-collapse:"
      "collapse}}td,th{{border:1px solid #aaa;padding:3px 6px;font-size:13px}}.fail{{background:"
      "#fbe3e3}}.front{{font-weight:bold}}img{{max-width:100%}}</style></head><body><h1>Error "
      "against run time: {0} ({1})</h1><p>Reference: {2}.</p>",
      html_escape(st.scene), st.solver, html_escape(st.reference));
  md += "Metrics:\n\n";
  html += "<p>Metrics:</p><ul>";
  for (const auto& [k, v] : st.metric_descriptions) {
    md += fmt::format("- `{}`: {}\n", k, v);
    html += fmt::format("<li><code>{}</code>: {}</li>", k, html_escape(v));
  }
  html += "</ul>";
  const std::string timing = fmt::format(
      "Each run is a separate demfem process, {} ({} at once). Solver wall time: "
      "the solver's own timer, the cost the knob controls (the figures, fronts and wall-time "
      "fits use its median). Process wall time: start to exit, adding the start-up. Peak "
      "memory: the largest resident set of the process (getrusage).",
      st.repeats == 1 ? std::string("run once") : fmt::format("repeated {} times", st.repeats),
      st.jobs);
  const std::string expected =
      st.expected_order > 0.0
          ? fmt::format("Expected order of the `{}` error: {:g} ({}).", st.primary_metric,
                        st.expected_order, st.expected_order_note)
          : (st.expected_order_note.empty()
                 ? std::string()
                 : static_cast<char>(
                       std::toupper(static_cast<unsigned char>(st.expected_order_note[0]))) +
                       st.expected_order_note.substr(1) + ".");
  md += fmt::format("\n{}\n\n## Fitted orders\n\nLeast squares of log error against log "
                    "abscissa (Δt, h, mean particle radius r or solver wall time). {}\n\n| knob | "
                    "metric | against | "
                    "order | points | range |\n|---|---|---|---|---|---|\n",
                    timing, expected);
  html += fmt::format("<p>{}</p><h2>Fitted orders</h2><p>Least squares of log error against "
                      "log abscissa (Δt, h, mean particle radius r or solver wall time). "
                      "{}</p><table><tr><th>knob</th>"
                      "<th>metric</th><th>against</th><th>order</th><th>points</th><th>range"
                      "</th></tr>\n",
                      html_escape(timing), html_escape(expected));
  for (const auto& f : st.fits) {
    const std::string range = f.points > 0 ? fmt::format("{:.3g} – {:.3g}", f.x_min, f.x_max) : "–";
    md += fmt::format("| {} | {} | {} | {} | {} | {} |\n", f.knob, f.metric, f.against,
                      fmt_order(f.order), f.points, range);
    html += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>"
                        "</tr>\n",
                        f.knob, f.metric, f.against, fmt_order(f.order), f.points, range);
  }
  html += "</table>";
  for (const auto& f : figs) {
    md += fmt::format("\n![{}]({})\n\n{}\n", f.file, f.file, f.caption);
    html += fmt::format("<figure><img src=\"{}\"><figcaption>{}</figcaption></figure>", f.file,
                        html_escape(f.caption));
  }
  md += "\n## Runs\n\n| point | knob | value | Δt or h | dofs |";
  html += "<h2>Runs</h2><table><tr><th>point</th><th>knob</th><th>value</th><th>Δt or h</th>"
          "<th>dofs</th>";
  for (const auto& m : metrics) {
    md += fmt::format(" {} |", m);
    html += fmt::format("<th>{}</th>", m);
  }
  md += " solver wall min / median / max [s] | process wall min / median / max [s] | peak memory "
        "[MiB] | Pareto | note |\n|---|---|---|---|---|";
  html += "<th>solver wall min / median / max [s]</th><th>process wall min / median / max [s]"
          "</th><th>peak memory [MiB]</th><th>Pareto</th><th>note</th></tr>\n";
  for (std::size_t i = 0; i < metrics.size() + 5; ++i) md += "---|";
  md += "\n";
  for (const auto& p : st.points) {
    std::vector<std::string> cells = {p.name, p.knob, fmt::format("{:g}", p.value),
                                      fmt::format("{:.4g}", p.x),
                                      p.dofs ? fmt::format("{}", p.dofs) : "–"};
    for (const auto& m : metrics) {
      const auto e = p.errors.find(m);
      cells.push_back(e == p.errors.end() ? "–" : fmt::format("{:.3e}", e->second));
    }
    cells.push_back(p.wall.empty() ? "–"
                                   : fmt::format("{:.3f} / {:.3f} / {:.3f}", p.wall_min,
                                                 p.wall_median, p.wall_max));
    cells.push_back(p.process_wall.empty() ? "–"
                                           : fmt::format("{:.3f} / {:.3f} / {:.3f}", p.process_min,
                                                         p.process_median, p.process_max));
    cells.push_back(fmt::format("{:.1f}", p.peak_rss_mib));
    cells.push_back(p.pareto ? "yes" : "");
    cells.push_back(p.ok ? "" : p.message);
    md += "|";
    html += fmt::format("<tr class=\"{}\">", !p.ok ? "fail" : p.pareto ? "front" : "");
    for (const auto& c : cells) {
      std::string m = c;
      std::replace(m.begin(), m.end(), '|', '/');
      md += " " + m + " |";
      html += "<td>" + html_escape(c) + "</td>";
    }
    md += "\n";
    html += "</tr>\n";
  }
  html += "</table>";
  if (!st.notes.empty()) {
    md += "\nNotes:\n\n";
    html += "<h2>Notes</h2><ul>";
    for (const auto& n : st.notes) {
      md += "- " + n + "\n";
      html += "<li>" + html_escape(n) + "</li>";
    }
    html += "</ul>";
  }
  html += "</body></html>\n";
  scene::write_file_atomic(dir / "study.md", md);
  scene::write_file_atomic(dir / "study.html", html);
}

int study_rank() {
  return study_detail::launcher_spread().rank;
}
int study_ranks() {
  return study_detail::launcher_spread().size;
}

void finish_study_ranks(const fs::path& out_dir) {
  const auto& sp = study_detail::launcher_spread();
  if (sp.size <= 1) return;
  const fs::path dir = study_detail::spread_directory(out_dir);
  fs::create_directories(dir);
  scene::write_file_atomic(dir / fmt::format("done-{}", sp.rank), "done\n");
  if (sp.rank != 0) return;
  for (int r = 1; r < sp.size; ++r)
    while (!fs::exists(dir / fmt::format("done-{}", r)))
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
  std::error_code ec;
  fs::remove_all(dir, ec); // every rank has read every result
}

} // namespace demfem::studies
