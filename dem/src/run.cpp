// `demfem run SCENE --solver dem`: builds the engine from the scene, runs it to the scene's
// duration, applies events, and writes probes (CSV), snapshots (VTK) and a final checkpoint
// under <out>/dem. Probes are computed here, in the engine layer, never inside kernels.
//
// Files (every CSV has a header naming quantity and unit):
//   energy.csv            energy budget (always)
//   structures.csv        per structure: <s>.settlement [m] (downward positive: −z displacement
//                         of the pivot), <s>.rotation [rad] (counter-clockwise positive; the
//                         paper's foundation θ is clockwise positive, θ = −rotation),
//                         <s>.moment [N·m] (soil reaction about the pivot), <s>.force_x [N],
//                         <s>.force_z [N] (soil reaction), <s>.applied_moment [N·m] (external
//                         loads about the pivot), <s>.displacement_x [m]; a row's pose is the
//                         one its forces were computed at (the start of the last step)
//   walls.csv             <w>.thrust [N] (reaction normal to the wall's chord, signed: > 0 when
//                         the soil presses on it; scene::thrust_normal), <w>.reaction_x,
//                         <w>.reaction_z [N]; for walls with record = true, structures of kind
//                         wall or with record "thrust", and wall-thrust probe targets
//   pressure_<t>.csv      pressure-profile probe: normal contact force per unit area on the
//                         boundary <t> in `bins` height bins [Pa]
//   surface.csv           surface-profile probe: top of the highest particle per x bin [m]
//   loci.csv              loci probe: positions of the particles nearest to the given points
//   coordination.csv      coordination number (2 × particle contacts / particles)
//   packing.json          the initial packing: porosity, void ratio, coordination number, target
#include "demfem/dem/run.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "demfem/dem/cpu_idle.hpp"
#include "demfem/dem/engine.hpp"
#include "demfem/dem/io.hpp"
#include "demfem/dem/stable_step.hpp"
#if __has_include("demfem/dem/pack.hpp")
#include "demfem/dem/pack.hpp"
#define DEMFEM_DEM_HAS_PACK 1
#endif
#include "demfem/scene/csv.hpp"
#include "demfem/scene/load.hpp"
#include "demfem/scene/write_file.hpp"
#include "state_bytes.hpp"

namespace demfem::dem {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

struct ThrustTarget {
  std::string name;
  int boundary = -1;
};

// Energy budget at the end of a run: printed (spdlog, info) and written to energy_budget.json.
// Closure error = |ΔE_total| / E_in, ΔE_total the change of kinetic + potential + springs +
// dissipated + carried out of the scene − external work since the first probe, E_in the largest
// energy put in during the run (|gravity work| + |external work| + spring energy, or the initial
// kinetic energy): the closure watch's scale, so the run's warning and its final number are one
// quantity. (It divided by the work alone: a bed at rest under a gently loaded foundation,
// 1.1e8 J in its springs and 230 J of work, reported 18 % for a 41 J imbalance.)
double log_energy_budget(const EnergyBudget& b, double e0, double t, double scale,
                         const std::filesystem::path& json_path) {
  const double imbalance = b.total() - e0;
  const double closure = scale > 0.0 ? std::abs(imbalance) / scale : 0.0;
  const std::pair<const char*, double> rows[] = {
      {"kinetic", b.kinetic},
      {"rotational", b.rotational},
      {"potential change", b.potential},
      {"springs (normal)", b.spring_normal},
      {"springs (shear)", b.spring_shear},
      {"friction (dissipated)", b.friction},
      {"damping (dissipated)", b.damping},
      {"rebound (dissipated)", b.rebound},
      {"left the scene", b.left_scene},
      {"external work", b.external_work},
      {"gravity work", b.gravity_work},
      {"imbalance", imbalance},
  };
  spdlog::info("DEM energy budget at t = {:.6g} s [J]:", t);
  for (const auto& [name, v] : rows) spdlog::info("  {:<24} {:>14.6e}", name, v);
  spdlog::info("  {:<24} {:>14.6e}", "energy put in", scale);
  spdlog::info("  {:<24} {:>14.3e}  (|imbalance| / energy put in: the largest gravity + external "
               "work + spring energy)",
               "closure error", closure);
  std::string js = "{\n";
  js += fmt::format("  \"time\": {:.17g},\n", t);
  const char* keys[] = {"kinetic",      "rotational",    "potential_change", "spring_normal",
                        "spring_shear", "friction",      "damping",          "rebound",
                        "left_scene",   "external_work", "gravity_work",     "imbalance"};
  for (std::size_t k = 0; k < std::size(keys); ++k)
    js += fmt::format("  \"{}\": {:.17g},\n", keys[k], rows[k].second);
  js += fmt::format("  \"energy_scale\": {:.17g},\n", scale);
  js += fmt::format("  \"closure_error\": {:.17g}\n}}\n", closure);
  scene::write_file_atomic(json_path, js);
  return closure;
}

// Run-loop state stored next to the engine state in a checkpoint's extra blob.
constexpr std::uint32_t kRunMagic = 0x44454d52; // "DEMR"
constexpr std::uint32_t kRunVersion = 1;

struct LoopState {
  std::uint64_t next_event = 0;
  double next_probe = 0.0, next_snap = 0.0, next_ckpt = 0.0;
  std::int64_t snap = 0;
  double e0 = 0.0, energy_scale = 0.0;
  bool e0_set = false;
  std::vector<std::uint32_t> loci_ids;
};

std::vector<std::byte> pack_state(const Engine& e, const LoopState& s) {
  detail::ByteWriter w;
  w.value(kRunMagic);
  w.value(kRunVersion);
  const auto es = e.save_state();
  w.bytes(es);
  w.value(s.next_event);
  w.value(s.next_probe);
  w.value(s.next_snap);
  w.value(s.next_ckpt);
  w.value(s.snap);
  w.value(s.e0);
  w.value(s.energy_scale);
  w.value(static_cast<std::uint8_t>(s.e0_set ? 1 : 0));
  w.vec(s.loci_ids);
  return std::move(w.buffer());
}

// Restores the engine (particles + engine state) and returns the loop state.
LoopState unpack_state(Engine& e, Particles particles, std::span<const std::byte> extra) {
  detail::ByteReader r(extra);
  if (r.value<std::uint32_t>() != kRunMagic) detail::ByteReader::fail("not a DEM run checkpoint");
  if (const auto v = r.value<std::uint32_t>(); v != kRunVersion)
    detail::ByteReader::fail(fmt::format("unsupported run-state version {}", v));
  e.restore_state(std::move(particles), r.bytes());
  LoopState s;
  r.value(s.next_event);
  r.value(s.next_probe);
  r.value(s.next_snap);
  r.value(s.next_ckpt);
  r.value(s.snap);
  r.value(s.e0);
  r.value(s.energy_scale);
  s.e0_set = r.value<std::uint8_t>() != 0;
  r.vec(s.loci_ids);
  if (!r.at_end()) detail::ByteReader::fail("trailing bytes in the run state");
  return s;
}

} // namespace

RunSummary run(const scene::Scene& scene, const RunOptions& options) {
  RunSummary summary;
  const auto t_start = Clock::now();
  if (!scene.soil.dem) {
    scene::Diagnostic d;
    d.file = scene.source_file;
    d.key = "soil.dem";
    d.message = "the DEM solver needs a [soil.dem] section";
    throw scene::SceneError({d});
  }
  const auto out = options.out_dir / "dem";
  std::filesystem::create_directories(out);

  // ---- build ------------------------------------------------------------------------------
  Engine e(make_config(scene));
  e.set_threads(options.threads);
  // the adaptive team probes 2 threads only when a CPU idles; it starts on 2 when one is free now
  e.set_idle_source(idle_cpu_seconds, free_cpus_now);
  const auto ckpt_path = out / "checkpoint.ckpt";
  std::optional<io::Checkpoint> resume_from;
  if (options.resume) {
    try {
      resume_from = io::read_checkpoint(ckpt_path);
    } catch (const io::IoError& err) {
      summary.message = fmt::format("cannot resume: {}", err.what());
      return summary;
    }
    if (resume_from->meta.label != scene.label()) {
      summary.message = fmt::format("cannot resume: {} is a checkpoint of '{}', not of '{}'",
                                    ckpt_path.string(), resume_from->meta.label, scene.label());
      return summary;
    }
  }
  // per structure: where the packing seated it, height and rotation (pack.hpp)
  std::vector<double> seat_dz, seat_rot;
  std::vector<std::byte> history; // the packing's contact history
#ifdef DEMFEM_DEM_HAS_PACK
  // A resumed run takes its particles from the checkpoint, but its structures' seat from the
  // (cached) packing.
  std::optional<PackResult> packed;
  if (!resume_from || (scene.soil.dem->particles.empty() && !scene.structures.empty())) {
    packed = pack_or_load(scene, options.out_dir, options.progress);
    seat_dz = packed->seat_dz;
    seat_rot = packed->seat_rot;
  }
  if (!resume_from) {
    const PackResult& pr = *packed;
    for (std::size_t k = 0; k < seat_dz.size() && k < scene.structures.size(); ++k)
      if (seat_dz[k] != 0.0)
        spdlog::info("packing: structure '{}' seated {:.3g} m {} its stated position (the bed "
                     "carries {:.3g} × its weight there)",
                     scene.structures[k].name, std::abs(seat_dz[k]),
                     seat_dz[k] < 0.0 ? "below" : "above", pr.seat_load);
    for (std::size_t k = 0; k < seat_rot.size() && k < scene.structures.size(); ++k)
      if (seat_rot[k] != 0.0)
        spdlog::info("packing: structure '{}' came to rest on the bed turned {:.3g} rad "
                     "(counter-clockwise, about its pivot); its rotation is counted from there",
                     scene.structures[k].name, seat_rot[k]);
    const auto& p = pr.particles;
    e.reserve_particles(p.size());
    for (std::size_t i = 0; i < p.size(); ++i)
      e.add_particle(p.x[i], p.z[i], p.radius[i], p.vx[i], p.vz[i], p.omega[i]);
    history = pr.contact_history;
    // The packing's density and contacts, for the run's summary (issue 14).
    write_packing_json(pr, scene, out / "packing.json");
    spdlog::info(
        "packing: porosity {:.4f} (void ratio {:.4f}), coordination {:.3f}{}{}",
        pr.measure.porosity, pr.measure.void_ratio, pr.measure.coordination,
        pr.key.empty() ? std::string()
                       : fmt::format(" (key {}, {}, engine {})", pr.key,
                                     pr.from_cache ? "cached" : "deposited", engine_fingerprint()),
        scene.soil.dem->packing.target_porosity
            ? fmt::format(" — target {:.4f} ± {:.4f}{}", *scene.soil.dem->packing.target_porosity,
                          scene.soil.dem->packing.target_tolerance, pr.target_met ? "" : " NOT MET")
            : std::string());
    if (pr.carved > 0)
      spdlog::info("packing: {} particles carved out where embedded structures stand", pr.carved);
  }
  packed.reset(); // its particles are the engine's now (114 B a particle)
#else
  if (!resume_from && scene.soil.dem->particles.empty()) {
    scene::Diagnostic d;
    d.file = scene.source_file;
    d.key = "soil.dem.particles";
    d.message = "this build has no packing generator; list the particles explicitly";
    throw scene::SceneError({d});
  }
  if (!resume_from) {
    e.reserve_particles(scene.soil.dem->particles.size());
    for (const auto& q : scene.soil.dem->particles)
      e.add_particle(q[0], q[1], q[2], q[3], q[4], q[5]);
  }
#endif
  for (const auto& w : scene.walls) e.add_wall(w);
  for (std::size_t k = 0; k < scene.structures.size(); ++k)
    e.add_structure(
        scene::rotated(scene::shifted(scene.structures[k], k < seat_dz.size() ? seat_dz[k] : 0.0),
                       k < seat_rot.size() ? seat_rot[k] : 0.0));
  // The packing's shear springs (ids 0…count−1 match: the particles are added in id order), after
  // the walls and structures, whose contacts a packing with embedded structures keeps too.
  if (!history.empty()) e.load_contact_history(history);
  const double dt_scene = scene.soil.dem->dt;
  try {
    set_scene_dt(e, dt_scene > 0.0 ? dt_scene : e.auto_dt());
  } catch (scene::SceneError& err) {
    auto diags = err.diagnostics();
    for (auto& d : diags) d.file = scene.source_file;
    throw scene::SceneError(diags);
  }
  LoopState ls;
  if (resume_from) {
    try {
      ls = unpack_state(e, std::move(resume_from->particles), resume_from->extra);
    } catch (const std::runtime_error& err) {
      summary.message = fmt::format("cannot resume from {}: {}", ckpt_path.string(), err.what());
      return summary;
    }
  }
  const bool resuming = resume_from.has_value();
  // A resumed run keeps the rows and snapshots written before the checkpoint's time and
  // rewrites those at and after it (the checkpoint holds the state before that time's output).
  const double keep_until = e.time() - 0.5 * e.dt();
  summary.particles = e.particles().size();

  // ---- events: friction changes and wall openings, in time order ----------------------------
  struct Ev {
    double time;
    const scene::Event* event;
    std::string wall;
  };
  std::vector<Ev> events;
  for (const auto& ev : scene.events) events.push_back({ev.time, &ev, ev.wall});
  for (const auto& w : scene.walls)
    if (w.opens_at) events.push_back({*w.opens_at, nullptr, w.name});
  std::stable_sort(events.begin(), events.end(),
                   [](const Ev& a, const Ev& b) { return a.time < b.time; });
  std::size_t next_event = static_cast<std::size_t>(ls.next_event);

  // ---- probes -----------------------------------------------------------------------------
  const double probe_dt = scene.output.probe_interval > 0.0 ? scene.output.probe_interval : 0.01;
  scene::TimeSeriesOptions csv_opt;
  csv_opt.comments = {fmt::format("demfem dem run of {}", scene.label())};
  csv_opt.flush_every_rows = 50;
  if (resuming) csv_opt.resume_after = keep_until;
  scene::TimeSeriesWriter energy_csv(out / "energy.csv",
                                     {"time [s]", "kinetic [J]", "rotational [J]", "potential [J]",
                                      "spring_normal [J]", "spring_shear [J]", "friction [J]",
                                      "damping [J]", "rebound [J]", "external_work [J]",
                                      "gravity_work [J]", "imbalance [J]", "left_scene [J]"},
                                     csv_opt);
  std::optional<scene::TimeSeriesWriter> struct_csv, wall_csv, surface_csv, loci_csv, coord_csv;
  std::vector<std::pair<std::size_t, scene::TimeSeriesWriter>> pressure_csv; // probe index
  if (!e.structures().empty()) {
    std::vector<std::string> cols{"time [s]"};
    for (const auto& s : e.structures())
      for (const char* q : {"settlement [m]", "rotation [rad]", "moment [N·m]", "force_x [N]",
                            "force_z [N]", "applied_moment [N·m]", "displacement_x [m]"})
        cols.push_back(s.name + "." + q);
    struct_csv.emplace(out / "structures.csv", cols, csv_opt);
  }
  std::vector<ThrustTarget> thrust;
  auto add_thrust = [&](const std::string& name) {
    const int b = e.boundary_index(name);
    if (b < 0) return;
    for (const auto& t : thrust)
      if (t.boundary == b) return;
    thrust.push_back({name, b});
  };
  for (const auto& w : scene.walls)
    if (w.record) add_thrust(w.name);
  for (const auto& s : scene.structures)
    if (s.kind == scene::StructureKind::Wall ||
        std::find(s.record.begin(), s.record.end(), "thrust") != s.record.end())
      add_thrust(s.name);
  std::vector<std::uint32_t>& loci_ids = ls.loci_ids;
  const bool loci_restored = resuming;
  std::size_t loci_count = 0;
  int surface_bins = 0;
  for (std::size_t k = 0; k < scene.probes.size(); ++k) {
    const auto& pr = scene.probes[k];
    switch (pr.kind) {
    case scene::ProbeKind::WallThrust:
      add_thrust(pr.target);
      break;
    case scene::ProbeKind::PressureProfile: {
      if (e.boundary_index(pr.target) < 0) break;
      std::vector<std::string> cols{"time [s]"};
      for (int b = 0; b < pr.bins; ++b) cols.push_back(fmt::format("{}.bin{} [Pa]", pr.target, b));
      pressure_csv.emplace_back(
          k, scene::TimeSeriesWriter(out / ("pressure_" + pr.target + ".csv"), cols, csv_opt));
      break;
    }
    case scene::ProbeKind::SurfaceProfile: {
      surface_bins = pr.bins;
      std::vector<std::string> cols{"time [s]"};
      for (int b = 0; b < pr.bins; ++b) cols.push_back(fmt::format("surface.bin{} [m]", b));
      surface_csv.emplace(out / "surface.csv", cols, csv_opt);
      break;
    }
    case scene::ProbeKind::Loci: {
      const auto& p = e.particles();
      std::vector<std::string> cols{"time [s]"};
      if (loci_restored) { // the particles chosen at the start of the run
        for (std::size_t q = 0; q < pr.points.size() && loci_count < loci_ids.size(); ++q) {
          const auto id = loci_ids[loci_count++];
          cols.push_back(fmt::format("p{}.x [m]", id));
          cols.push_back(fmt::format("p{}.z [m]", id));
        }
        loci_csv.emplace(out / "loci.csv", cols, csv_opt);
        break;
      }
      for (const auto& q : pr.points) {
        std::size_t best = 0;
        double bd = 1e300;
        for (std::size_t i = 0; i < p.size(); ++i) {
          const double d = std::hypot(p.x[i] - q.x, p.z[i] - q.z);
          if (d < bd) {
            bd = d;
            best = i;
          }
        }
        if (p.size() == 0) break;
        e.particles().flags[best] |= kFlagTagged;
        loci_ids.push_back(p.id[best]);
        cols.push_back(fmt::format("p{}.x [m]", p.id[best]));
        cols.push_back(fmt::format("p{}.z [m]", p.id[best]));
      }
      loci_csv.emplace(out / "loci.csv", cols, csv_opt);
      break;
    }
    case scene::ProbeKind::Coordination:
      coord_csv.emplace(out / "coordination.csv",
                        std::vector<std::string>{"time [s]", "coordination [-]"}, csv_opt);
      break;
    default:
      break;
    }
  }
  if (!thrust.empty()) {
    std::vector<std::string> cols{"time [s]"};
    for (const auto& t : thrust)
      for (const char* q : {"thrust [N]", "reaction_x [N]", "reaction_z [N]"})
        cols.push_back(t.name + "." + q);
    wall_csv.emplace(out / "walls.csv", cols, csv_opt);
  }
  // Domain extent for profiles.
  double xmin = 0, xmax = 1;
  if (!scene.domain.empty()) {
    xmin = xmax = scene.domain[0].x;
    for (const auto& q : scene.domain) {
      xmin = std::min(xmin, q.x);
      xmax = std::max(xmax, q.x);
    }
  }

  std::vector<ContactView> contacts;
  std::vector<scene::Vec2> verts;
  double& e0 = ls.e0;
  double& energy_scale = ls.energy_scale;
  bool& e0_set = ls.e0_set;
  // The particle with the most kinetic (translational + rotational) energy, for stop messages.
  auto most_energetic = [&] {
    const auto& p = e.particles();
    std::size_t best = p.size();
    double eb = -1.0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      if (p.flags[i] & kFlagRemoved) continue;
      const double ek = 0.5 * p.mass[i] * (p.vx[i] * p.vx[i] + p.vz[i] * p.vz[i]) +
                        0.5 * p.omega[i] * p.omega[i] / p.inv_inertia[i]; // ½mv² + ½Iω²
      if (ek > eb) {
        eb = ek;
        best = i;
      }
    }
    if (best == p.size()) return std::string("no particles");
    return fmt::format("largest-energy particle: id {} at ({:.4g}, {:.4g}) m, r = {:.4g} m, "
                       "{:.4g} J",
                       p.id[best], p.x[best], p.z[best], p.radius[best], eb);
  };
  // Energy-closure watch (issue 11): |imbalance| over the largest energy put in so far.
  const double closure_warn = scene.soil.dem->energy_warning;
  const double closure_stop = scene.soil.dem->energy_limit;
  bool closure_warned = false;
  auto watch_closure = [&](double imbalance, double t) -> std::string {
    if (!(energy_scale > 0.0)) return {};
    const double closure = std::abs(imbalance) / energy_scale;
    if (!std::isfinite(closure) || (closure_stop > 0.0 && closure > closure_stop))
      return fmt::format("energy closure error {:.4g} exceeds soil.dem.energy_limit = {:g} "
                         "(imbalance {:.4g} J against {:.4g} J put in: the time step does not "
                         "resolve the contacts or the motion; lower soil.dem.dt or dt_safety); {}",
                         closure, closure_stop, imbalance, energy_scale, most_energetic());
    // Not in the first 100 steps: the staggered kinetic energy of leapfrog differs from the
    // energy at the positions by ½ m g v Δt, a fraction Δt/(2t) of the work in a free fall.
    if (closure_warn > 0.0 && closure > closure_warn && !closure_warned && e.stats().steps >= 100) {
      closure_warned = true;
      spdlog::warn("energy closure error {:.4g} at step {} (t = {:.6g} s) exceeds "
                   "soil.dem.energy_warning = {:g} (imbalance {:.4g} J against {:.4g} J put in); "
                   "a smaller dt (soil.dem.dt_safety) closes it better",
                   closure, e.stats().steps, t, closure_warn, imbalance, energy_scale);
    }
    return {};
  };
  auto write_probes = [&] {
    const double t = e.time();
    const auto b = e.energy();
    if (!e0_set) energy_scale = std::max(energy_scale, b.kinetic + b.rotational);
    // The budget's reference is the state after the first step: before it the engine has not
    // evaluated the contacts, so the springs of an initially packed (overlapping) bed are unknown.
    energy_csv.append({t, b.kinetic, b.rotational, b.potential, b.spring_normal, b.spring_shear,
                       b.friction, b.damping, b.rebound, b.external_work, b.gravity_work,
                       e0_set ? b.total() - e0 : 0.0, b.left_scene});
    // Blow-up by energy jump: kinetic energy far above everything that was put in.
    energy_scale = std::max(energy_scale, std::abs(b.gravity_work) + std::abs(b.external_work) +
                                              b.spring_normal + b.spring_shear);
    // (energy_scale starts at the initial kinetic energy and never decreases)
    if (b.kinetic + b.rotational > 10.0 * energy_scale + 1e-9 && t > 0.0 && !e.failed())
      return fmt::format("energy jump: kinetic energy {:.4g} J exceeds 10 × the energy put in "
                         "({:.4g} J); {}",
                         b.kinetic + b.rotational, energy_scale, most_energetic());
    if (e0_set) {
      if (auto stop = watch_closure(b.total() - e0, t); !stop.empty()) return stop;
    }
    // Soil forces on structures and walls are evaluated inside a step. Before the first step
    // they are those of the initial positions: a copy of the engine takes one step to get them
    // (the t = 0 row is the at-rest state the comparison's static values read).
    std::optional<Engine> primed;
    if (e.stats().steps == 0 && (struct_csv || wall_csv)) {
      primed.emplace(e);
      primed->step();
    }
    const Engine& forces = primed ? *primed : e;
    if (struct_csv) {
      // One state per row: a step's soil forces and applied loads come from the pose at its
      // start, x_n = x_{n+1} − v_{n+1} Δt (symplectic Euler, Engine::update_structures), so the
      // row writes that pose. (It wrote x_{n+1}: the moment lagged the rotation by one step and
      // the moment–rotation loops lost an area ∝ Δt, 5–55 % of a rocking cycle's at the
      // default step; bench/RESULTS.md, seventeenth session.)
      const double dtf = forces.dt();
      std::vector<double> row{t};
      for (const auto& f : forces.structures())
        row.insert(row.end(), {-(f.uz - f.vz * dtf), f.rot - f.omega * dtf, f.soil_moment,
                               f.soil_fx, f.soil_fz, f.applied_moment, f.ux - f.vx * dtf});
      struct_csv->append(row);
    }
    if (wall_csv) {
      std::vector<double> row{t};
      for (const auto& th : thrust) {
        const auto& B = forces.boundaries()[static_cast<std::size_t>(th.boundary)];
        e.boundary_vertices(th.boundary, verts);
        const auto n = scene::thrust_normal(verts, scene.domain);
        row.insert(row.end(),
                   {B.reaction_x * n.x + B.reaction_z * n.z, B.reaction_x, B.reaction_z});
      }
      wall_csv->append(row);
    }
    // Largest overlap ratio δ/r: pairs from the positions, boundary contacts from the force the
    // law recorded (Engine::largest_overlap_ratio).
    summary.max_overlap_ratio = std::max(summary.max_overlap_ratio, e.largest_overlap_ratio());
    if (!pressure_csv.empty()) e.contacts(contacts, false); // the boundary contacts only
    for (auto& [k, w] : pressure_csv) {
      const auto& pr = scene.probes[k];
      const int bi = e.boundary_index(pr.target);
      e.boundary_vertices(bi, verts);
      double z0 = verts.empty() ? 0 : verts[0].z, z1 = z0;
      for (const auto& v : verts) {
        z0 = std::min(z0, v.z);
        z1 = std::max(z1, v.z);
      }
      const double h = (z1 - z0) / pr.bins;
      std::vector<double> row(static_cast<std::size_t>(pr.bins) + 1, 0.0);
      row[0] = t;
      for (const auto& c : contacts)
        if (c.j == -1 - static_cast<std::int64_t>(bi) && h > 0.0) {
          const auto bin = std::clamp(static_cast<int>((c.cz - z0) / h), 0, pr.bins - 1);
          row[static_cast<std::size_t>(bin) + 1] += c.fn / (h * e.config().thickness);
        }
      w.append(row);
    }
    if (surface_csv) {
      std::vector<double> row(static_cast<std::size_t>(surface_bins) + 1, -1e300);
      row[0] = t;
      const auto& p = e.particles();
      const double h = (xmax - xmin) / surface_bins;
      for (std::size_t i = 0; i < p.size(); ++i) {
        if (p.flags[i] & kFlagRemoved) continue;
        const int bin = static_cast<int>((p.x[i] - xmin) / h);
        if (bin < 0 || bin >= surface_bins) continue;
        auto& v = row[static_cast<std::size_t>(bin) + 1];
        v = std::max(v, p.z[i] + p.radius[i]);
      }
      for (std::size_t k = 1; k < row.size(); ++k)
        if (row[k] < -1e299) row[k] = std::nan("");
      surface_csv->append(row);
    }
    if (loci_csv) {
      std::vector<double> row{t};
      for (auto id : loci_ids) {
        const long i = e.index_of(id);
        row.push_back(i >= 0 ? e.particles().x[static_cast<std::size_t>(i)] : std::nan(""));
        row.push_back(i >= 0 ? e.particles().z[static_cast<std::size_t>(i)] : std::nan(""));
      }
      loci_csv->append(row);
    }
    if (coord_csv) {
      const std::size_t pp = e.pair_contact_count();
      std::size_t active = 0;
      for (auto f : e.particles().flags)
        if (!(f & kFlagRemoved)) ++active;
      coord_csv->append(
          {t, active ? 2.0 * static_cast<double>(pp) / static_cast<double>(active) : 0.0});
    }
    return std::string();
  };

  // ---- snapshots (VTK, through the I/O layer) ------------------------------------------------
  std::optional<io::PvdCollection> pvd_particles, pvd_chains, pvd_bounds;
  std::int64_t& snap = ls.snap;
  std::vector<BoundaryView> bviews;
  auto write_snapshot = [&] {
    if (!scene.output.vtk) return;
    if (!pvd_particles) {
      std::filesystem::create_directories(out / "vtk");
      if (resuming) {
        pvd_particles.emplace(io::PvdCollection::resume(out / "particles.pvd", keep_until));
        pvd_bounds.emplace(io::PvdCollection::resume(out / "boundaries.pvd", keep_until));
        if (scene.output.force_chains)
          pvd_chains.emplace(io::PvdCollection::resume(out / "force_chains.pvd", keep_until));
      } else {
        pvd_particles.emplace(out / "particles.pvd");
        pvd_bounds.emplace(out / "boundaries.pvd");
        if (scene.output.force_chains) pvd_chains.emplace(out / "force_chains.pvd");
      }
    }
    const auto pf = out / "vtk" / io::numbered_file_name("particles", snap, "vtp");
    io::write_particles_vtp(pf, e.particles(), scene.output.vtk_compression);
    pvd_particles->add(e.time(), pf);
    e.boundary_views(bviews);
    const auto bf = out / "vtk" / io::numbered_file_name("boundaries", snap, "vtp");
    io::write_boundaries_vtp(bf, bviews, scene.output.vtk_compression);
    pvd_bounds->add(e.time(), bf);
    if (pvd_chains) {
      e.contacts(contacts);
      const auto cf = out / "vtk" / io::numbered_file_name("force_chains", snap, "vtp");
      io::write_force_chains_vtp(cf, e.particles(), contacts, scene.output.vtk_compression);
      pvd_chains->add(e.time(), cf);
    }
    ++snap;
  };

  // ---- time loop ----------------------------------------------------------------------------
  const double t_end = scene.info.duration;
  const double dt = e.dt();
  double& next_probe = ls.next_probe;
  double& next_snap = ls.next_snap;
  const double snap_dt = scene.output.interval > 0.0 ? scene.output.interval : t_end;
  const double ckpt_dt = scene.output.checkpoint_interval;
  double& next_ckpt = ls.next_ckpt;
  if (!resuming) next_ckpt = ckpt_dt;
  // Checkpoint of the state at the top of the loop (before this time's events and output).
  auto write_state = [&] {
    energy_csv.flush();
    for (auto* w : {&struct_csv, &wall_csv, &surface_csv, &loci_csv, &coord_csv})
      if (*w) (*w)->flush();
    for (auto& pw : pressure_csv) pw.second.flush();
    ls.next_event = next_event;
    io::CheckpointMeta meta;
    meta.time = e.time();
    meta.step = e.stats().steps;
    meta.dt = e.dt();
    meta.label = scene.label();
    io::write_checkpoint(ckpt_path, e.particles(), meta, pack_state(e, ls));
  };
  bool interrupted = false;
  auto last_progress = Clock::now();
  const auto loop_start = Clock::now();
  std::string failure;
  auto report = [&](const char* stage) {
    if (!options.progress) return;
    scene::Progress pg;
    pg.stage = stage;
    pg.time = e.time();
    pg.end_time = t_end;
    pg.step = e.stats().steps;
    pg.wall_seconds = seconds_since(loop_start);
    options.progress(pg);
  };
  report("dem");
  while (e.time() < t_end - 0.5 * dt) {
    if (options.interrupt && options.interrupt->load()) {
      write_state();
      interrupted = true;
      break;
    }
    if (ckpt_dt > 0.0 && e.time() >= next_ckpt - 0.5 * dt) {
      next_ckpt += ckpt_dt;
      write_state();
    }
    while (next_event < events.size() && events[next_event].time <= e.time() + 0.5 * dt) {
      const auto& ev = events[next_event++];
      if (!ev.event || ev.event->action == scene::EventAction::OpenWall) {
        if (e.boundary_index(ev.wall) >= 0) e.open_wall(ev.wall);
      } else if (const auto* g = scene.group(ev.event->group)) {
        e.set_friction(g->region, ev.event->mu_static, ev.event->mu_dynamic);
      }
    }
    if (e.time() >= next_probe - 0.5 * dt) {
      failure = write_probes();
      next_probe += probe_dt;
    }
    if (e.time() >= next_snap - 0.5 * dt) {
      write_snapshot();
      next_snap += snap_dt;
    }
    if (!failure.empty()) break;
    // The steps before the next action at once (Engine::run_until: with a team of threads, in
    // one parallel region): each action above fires at time ≥ t_next − Δt/2, run_until's stop
    // (the same expression, so the same step); an event's test (its time ≤ t + Δt/2) is kept
    // out by a step's margin. The first step alone (e0 below), and at most up to the next
    // multiple of 256 steps (the progress line; the interruption test).
    double t_next = std::min({t_end, next_probe, next_snap});
    if (ckpt_dt > 0.0) t_next = std::min(t_next, next_ckpt);
    if (next_event < events.size()) t_next = std::min(t_next, events[next_event].time - dt);
    const long long to_report = 256 - (e.stats().steps & 255);
    if (e.run_until(t_next, e0_set ? to_report : 1) == 0) e.step(); // an action within a step
    if (!e0_set) {
      const auto b0 = e.energy();
      e0 = b0.total();
      e0_set = true;
      // The springs of initially overlapping particles are known only now: their energy is put
      // in too (else the energy-jump check stops a bed released from overlaps, issue 11).
      energy_scale =
          std::max(energy_scale, b0.kinetic + b0.rotational + b0.spring_normal + b0.spring_shear);
    }
    if (e.failed()) {
      failure = e.failure();
      break;
    }
    if ((e.stats().steps & 255) == 0 && seconds_since(last_progress) > 0.5) {
      last_progress = Clock::now();
      report("dem");
    }
  }
  if (interrupted) {
    report("dem");
    summary.steps = e.stats().steps;
    summary.simulated_time = e.time();
    summary.wall_seconds = seconds_since(t_start);
    summary.interrupted = true;
    summary.message = fmt::format("interrupted at t = {:.6g} s; continue with --resume", e.time());
    return summary;
  }
  if (failure.empty()) {
    write_state(); // end state: a resume with a longer duration continues from here
    failure = write_probes();
    write_snapshot();
  }
  // Every row on the disk (a failed write throws, naming the file).
  energy_csv.flush();
  for (auto* w : {&struct_csv, &wall_csv, &surface_csv, &loci_csv, &coord_csv})
    if (*w) (*w)->flush();
  for (auto& pw : pressure_csv) pw.second.flush();
  report("dem");
  if (const auto& st = e.stats(); st.steps > 0) {
    const double solver = seconds_since(t_start);
    spdlog::info("DEM steps: {}, {} neighbour rebuilds (one per {:.0f} steps), {:.2f} list "
                 "entries per particle; forces{} {:.1f} s, neighbour rebuilds {:.1f} s of {:.1f} s",
                 st.steps, st.neighbour_rebuilds,
                 static_cast<double>(st.steps) /
                     static_cast<double>(std::max<long long>(1, st.neighbour_rebuilds)),
                 static_cast<double>(st.pair_entries) /
                     static_cast<double>(std::max<std::size_t>(1, e.particles().size())),
                 e.threads_in_use() > 1 ? " and integration" : "", st.force_seconds,
                 st.rebuild_seconds, solver);
  }
  if (const auto& st = e.stats(); st.team_full_steps + st.team_one_steps > 0) {
    const double all = static_cast<double>(st.team_full_steps + st.team_one_steps);
    spdlog::info("threads: work cut into {} parts; {:.1f} % of the steps ran on {} threads "
                 "({:.1f} % many to a parallel region, the others one step per region), "
                 "{:.1f} % on one (adaptive team: one thread where the full team measured slower, "
                 "e.g. a core shared with another process; {} probes of the full team left out "
                 "while the other CPUs were busy); results depend on the part count only",
                 e.threads_in_use(), 100.0 * static_cast<double>(st.team_full_steps) / all,
                 e.threads_in_use(), 100.0 * static_cast<double>(st.team_region_steps) / all,
                 100.0 * static_cast<double>(st.team_one_steps) / all, st.team_probes_skipped);
  }
  if (const auto& st = e.stats(); st.rebound_contacts > 0)
    spdlog::info(
        "rebound: {} contacts first touched above V_0, {} of them ({:.2g} %) in collisions "
        "of several such contacts on one particle in one step (their impulses shared)",
        st.rebound_contacts, st.rebound_shared,
        100.0 * static_cast<double>(st.rebound_shared) / static_cast<double>(st.rebound_contacts));
  summary.closure_error =
      log_energy_budget(e.energy(), e0, e.time(), energy_scale, out / "energy_budget.json");
  // Final state as a particle checkpoint (readable without the engine); a failed write throws.
  {
    io::CheckpointMeta meta;
    meta.time = e.time();
    meta.step = e.stats().steps;
    meta.dt = e.dt();
    meta.label = scene.label();
    io::write_checkpoint(out / "final.ckpt", e.particles(), meta);
  }
  summary.steps = e.stats().steps;
  summary.simulated_time = e.time();
  summary.wall_seconds = seconds_since(t_start);
  summary.dt = e.dt();
  if (failure.empty()) {
    summary.ok = true;
  } else {
    summary.ok = false;
    summary.message = fmt::format("DEM run stopped at step {}, t = {:.6g} s: {}", e.stats().steps,
                                  e.time(), failure);
  }
  return summary;
}

} // namespace demfem::dem
