// `demfem calibrate SCENE`: continuum parameters from DEM element tests → calibration.json,
// calibration.toml, figures.
#include <memory>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "command.hpp"
#include "demfem/calibrate/calibrate.hpp"
#include "progress.hpp"
#include "run_dir.hpp"
#include "scenes.hpp"
#include "signals.hpp"

namespace fs = std::filesystem;

namespace demfem::app {

namespace {

struct CalibrateArgs {
  int particles = 1000;
  int specimens = calibrate::CalibrateOptions{}.specimens;
  std::vector<double> depths = calibrate::CalibrateOptions{}.depth_fractions;
  bool cyclic = true;
  bool force = false;
};
int cmd_calibrate(const RunArgs& a, const CalibrateArgs& ca) {
  int rc = kOk;
  const auto file = load_for(a, rc);
  if (rc != kOk) return rc;
  const auto scenes = pick(file, a, rc);
  if (rc != kOk) return rc;
  for (const scene::Scene* s : scenes) {
    const fs::path out = run_dir_for(*s, a, scenes.size(), "calibration");
    Ownership own; // the folder's lock, held while the calibration runs
    OwnRequest req;
    req.command = "calibrate";
    req.writes = {"calibration.json", "calibration.toml", "figures", "cache", "packing"};
    if (const int p = take_ownership(out, req, own); p != kOk) return p;
    own.commit();
    calibrate::CalibrateOptions o;
    o.out_dir = out;
    o.particles = ca.particles;
    o.specimens = ca.specimens;
    o.depth_fractions = ca.depths;
    o.cyclic = ca.cyclic;
    ProgressReporter reporter;
    // no checkpoint: a stop signal ends it at its next progress report (Stopped, exit 3)
    o.progress = stoppable([&](const scene::Progress& p) { reporter(p); });
    try {
      const auto c = ca.force ? calibrate::calibrate(*s, o) : calibrate::load_or_calibrate(*s, o);
      reporter.finish();
      const auto files = calibrate::write_calibration(c, out, true);
      fmt::print("{}: calibration {} ({}, {:.1f} s when computed)\n", s->label(), c.key,
                 c.from_cache ? "found in the cache" : "computed", c.wall_seconds);
      fmt::print("  bed: porosity {:.4f}, bulk density {:.5g} kg/m³, K0 {:.3f}, surface {:.4g} m "
                 "(mass-matched; mean column top {:.4g} m)\n",
                 c.porosity, c.bulk_density, c.k0, c.surface, c.surface_top_mean);
      for (const auto& t : c.tests)
        fmt::print("  biaxial σ_c = {:8.4g} kPa, specimen {}: φ_peak {:5.1f}°  φ_cv {:5.1f}°  ψ "
                   "{:5.1f}°  E50' {:.3g} MPa  ν' {:.3f}  n {:.4f}{}\n",
                   t.sigma_c / 1e3, t.specimen + 1, t.phi_peak, t.phi_cv, t.psi, t.e50 / 1e6,
                   t.nu_inplane, t.porosity, t.failure.empty() ? "" : "  FAILED: " + t.failure);
      fmt::print("  envelope ({} specimen(s)): φ {:.2f}°, c {:.4g} kPa; affine E' {:.3g} MPa, G "
                 "{:.3g} MPa\n",
                 c.specimens, c.phi_fit, c.cohesion_fit / 1e3, c.affine_e / 1e6, c.affine_g / 1e6);
      for (std::size_t k = 0; k < c.specimen_fits.size(); ++k)
        fmt::print("    specimen {} (seed {}) alone: φ {:.2f}°, c {:.4g} kPa\n", k + 1,
                   k < c.specimen_seeds.size() ? c.specimen_seeds[k] : 0ul,
                   c.specimen_fits[k].first, c.specimen_fits[k].second / 1e3);
      for (const auto& p : c.cyclic)
        fmt::print("  cyclic γ = {:.3g}: G {:.3g} MPa, ξ {:.1f} %, ν' {:.3f}\n", p.gamma, p.g / 1e6,
                   100.0 * p.xi, p.nu);
      fmt::print("{}", calibrate::continuum_block(c));
      for (const auto& f : files.written) fmt::print("  wrote {}\n", f.string());
      bool unwritten = false; // a figure a full disk or a file size limit kept out: a failure
      for (const auto& p : files.problems) {
        fmt::print(stderr, "figure: {}\n", p);
        unwritten = unwritten || p.starts_with("cannot write") || p.starts_with("gnuplot failed (");
      }
      if (unwritten) return kRunFailed;
    } catch (const scene::SceneError& e) {
      reporter.finish();
      fmt::print(stderr, "{}\n", e.what());
      return kBadInput;
    }
  }
  return kOk;
}

[[maybe_unused]] const bool registered = register_command(
    {"calibrate",
     "Continuum parameters from DEM element tests (biaxial, cyclic) on specimens of the scene's "
     "packing, and the deposited bed's density, K0 and surface; writes calibration.json, "
     "calibration.toml and figures (cached).",
     60, false, [](CLI::App&, CLI::App& sub) -> std::function<int()> {
       auto ra = std::make_shared<RunArgs>();
       auto ca = std::make_shared<CalibrateArgs>();
       sub.add_option("scene", ra->scene, "Scene file")->required()->check(CLI::ExistingFile);
       sub.add_option("--variant", ra->variants, "Variant name (repeatable)");
       sub.add_option("--out", ra->out, "Output directory (default runs/<scene>/calibration)");
       sub.add_option("--particles", ca->particles, "Specimen size (disks)")
           ->default_val(1000)
           ->check(CLI::Range(50, 100000));
       sub.add_option("--specimens", ca->specimens,
                      "Specimen realisations, each tested at every confinement (the envelope "
                      "is fitted to all of them)")
           ->capture_default_str()
           ->check(CLI::Range(1, 20));
       sub.add_option("--depths", ca->depths,
                      "Confinements σ_c = ρ_b g z at these fractions of the bed height "
                      "(comma-separated)")
           ->delimiter(',')
           ->capture_default_str()
           ->check(CLI::Range(0.01, 1.0));
       sub.add_flag("!--no-cyclic", ca->cyclic, "Skip the cyclic tests (G/G0, damping)");
       sub.add_flag("--force", ca->force, "Recompute even when the calibration is cached");
       sub.add_option("--seed", ra->seed, "Packing seed (scene.seed) instead of the file's")
           ->check(CLI::Range(0LL, 2147483647LL)); // scene.seed's range
       return [ra, ca] { return cmd_calibrate(*ra, *ca); };
     }});

} // namespace

} // namespace demfem::app
