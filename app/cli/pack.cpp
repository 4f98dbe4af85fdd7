// `demfem pack SCENE`: deposits (or finds in the cache) the packing of each chosen scene.
#include <memory>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "command.hpp"
#include "demfem/dem/pack.hpp"
#include "progress.hpp"
#include "run_dir.hpp"
#include "scenes.hpp"
#include "signals.hpp"

namespace fs = std::filesystem;

namespace demfem::app {

namespace {

int cmd_pack(const RunArgs& a) {
  int rc = kOk;
  const auto file = load_for(a, rc);
  if (rc != kOk) return rc;
  const auto scenes = pick(file, a, rc);
  if (rc != kOk) return rc;
  int worst = kOk;
  for (const scene::Scene* s : scenes) {
    if (!s->soil.dem) {
      fmt::print(stderr, "demfem pack: scene '{}' has no [soil.dem]\n", s->label());
      return kBadInput;
    }
    const fs::path out = run_dir_for(*s, a, scenes.size());
    Ownership own; // <out>/packing when the scene names no packing cache
    if (s->soil.dem->packing.cache.empty()) {
      OwnRequest req;
      req.command = "pack";
      req.writes = {"packing"};
      if (const int p = take_ownership(out, req, own); p != kOk) return p;
      own.commit();
    }
    ProgressReporter reporter;
    try {
      // no checkpoint: a stop signal ends the deposition at its next progress report (exit 3)
      const auto r =
          dem::pack_or_load(*s, out, stoppable([&](const scene::Progress& p) { reporter(p); }));
      reporter.finish();
      fmt::print(
          "{}: {} particles, {} {} (deposition {:.3g} s simulated, {} steps, KE/PE {:.2e}{}, "
          "{} layer(s), {:.1f} s wall), surface top {:.4g} m\n",
          s->label(), r.particles.size(), r.from_cache ? "found in the cache" : "packed into",
          r.path.string(), r.deposition_time, r.steps, r.ke_ratio,
          r.converged ? "" : " — stopped at packing.max_time", r.layers, r.wall_seconds,
          r.surface_max);
      const auto& pk = s->soil.dem->packing;
      fmt::print("  porosity {:.4f} (void ratio {:.4f}, window z {:.4g}–{:.4g} m), coordination "
                 "number {:.3f}, rattlers {:.1f} %{}\n",
                 r.measure.porosity, r.measure.void_ratio, r.measure.z_bottom, r.measure.z_top,
                 r.measure.coordination, 100.0 * r.measure.rattlers,
                 pk.target_porosity
                     ? fmt::format("; target porosity {:.4f} ± {:.4f}: {} (friction × {:.4g} "
                                   "during deposition, {} deposition(s))",
                                   *pk.target_porosity, pk.target_tolerance,
                                   r.target_met ? "met" : "NOT MET", r.friction_scale, r.trials)
                     : std::string());
      if (r.carved > 0)
        fmt::print("  {} particles carved out where embedded structures stand (deposited without "
                   "them, then settled around them)\n",
                   r.carved);
      if (pk.target_porosity && !r.target_met && !a.target_not_met_ok) worst = kRunFailed;
    } catch (const scene::SceneError& e) {
      reporter.finish();
      fmt::print(stderr, "{}\n", e.what());
      return kBadInput;
    }
  }
  return worst;
}

[[maybe_unused]] const bool registered = register_command(
    {"pack",
     "Deposit the scene's particles and save the packing (reused from the cache when it exists).",
     70, false, [](CLI::App&, CLI::App& sub) -> std::function<int()> {
       auto ra = std::make_shared<RunArgs>();
       sub.add_option("scene", ra->scene, "Scene file")->required()->check(CLI::ExistingFile);
       sub.add_option("--variant", ra->variants,
                      "Variant name (repeatable); default: the base scene");
       sub.add_flag("--all-variants", ra->all_variants, "Every [[variant]] of the file");
       sub.add_option("--out", ra->out,
                      "Run directory (default runs/<scene>[/<variant>]); the "
                      "packing goes to packing.cache or <out>/packing");
       sub.add_option("--seed", ra->seed, "Packing seed (scene.seed) instead of the file's")
           ->check(CLI::Range(0LL, 2147483647LL)); // scene.seed's range
       sub.add_flag("--target-not-met-ok", ra->target_not_met_ok,
                    "Exit 0 when a porosity target is not met (the packing nearest to it is "
                    "kept, and a run uses it and says so; run --jobs prepares packings this way)");
       return [ra] { return cmd_pack(*ra); };
     }});

} // namespace

} // namespace demfem::app
