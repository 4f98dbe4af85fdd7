#include <cmath>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "demfem/dem/cpu_idle.hpp"
#include "demfem/dem/stable_step.hpp"
#include "demfem/output/contract.hpp"
#include "demfem/scene/load.hpp"
#if __has_include("demfem/dem/pack.hpp")
#include "demfem/dem/pack.hpp"
#define DEMFEM_DEM_HAS_PACK 1
#endif
#include "hooks.hpp"

namespace demfem::dem::run_detail {

std::string set_up(const scene::Scene& scene, const RunOptions& options,
                   const std::filesystem::path& out, Engine& e, LoopState& ls, bool& resuming) {
  e.set_threads(options.threads);
  // the adaptive team probes 2 threads only when a CPU idles; it starts on 2 when one is free now
  e.set_idle_source(idle_cpu_seconds, free_cpus_now);
  const auto ckpt_path = out / output::file::checkpoint;
  std::optional<io::Checkpoint> resume_from;
  if (options.resume) {
    try {
      resume_from = io::read_checkpoint(ckpt_path);
    } catch (const io::IoError& err) {
      return fmt::format("cannot resume: {}", err.what());
    }
    if (resume_from->meta.label != scene.label())
      return fmt::format("cannot resume: {} is a checkpoint of '{}', not of '{}'",
                         ckpt_path.string(), resume_from->meta.label, scene.label());
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
    // The packing's density and contacts, for the run's summary.
    write_packing_json(pr, scene, out / output::file::packing);
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
  resuming = resume_from.has_value();
  if (resuming) {
    try {
      ls = unpack_state(e, std::move(resume_from->particles), resume_from->extra);
    } catch (const std::runtime_error& err) {
      return fmt::format("cannot resume from {}: {}", ckpt_path.string(), err.what());
    }
  }
  return {};
}

} // namespace demfem::dem::run_detail
