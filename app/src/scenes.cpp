#include "scenes.hpp"

#include <optional>

#include <fmt/format.h>

#include "command.hpp"
#include "demfem/calibrate/calibrate.hpp"
#include "demfem/dem/stable_step.hpp"
#include "demfem/scene/validate.hpp"
#include "run_dir.hpp"
#ifdef DEMFEM_WITH_CONTINUUM
#include "continuum_module.hpp"
#endif

namespace fs = std::filesystem;

namespace demfem::app {

namespace {

#ifdef DEMFEM_WITH_CONTINUUM
// The continuum's explicit stable step for the scene check (scene::set_continuum_step_limit):
// with calibrate = "dem", from the cached calibration (unknown until it exists: the run, which
// calibrates first, refuses the same step at the same key).
std::optional<scene::ContinuumStepLimit> continuum_step_limit(const scene::Scene& s) {
  scene::Scene r = s;
  if (r.soil.continuum && r.soil.continuum->calibrate_dem) {
    const calibrate::CalibrateOptions o;
    const fs::path f = calibrate::calibration_cache_dir(r, o) /
                       ("calibration-" + calibrate::calibration_key(r, o) + ".json");
    std::error_code ec;
    if (!fs::exists(f, ec)) return std::nullopt;
    try {
      calibrate::apply_calibration(r, calibrate::load_or_calibrate(r, o));
    } catch (const std::exception&) {
      return std::nullopt;
    }
  }
  try {
    return continuum_module().stable_step(r, {});
  } catch (const std::exception&) { // a scene the continuum cannot mesh: the run says why
    return std::nullopt;
  }
}
#endif

} // namespace

void prepare_scene_loading() {
  // soil.dem.dt against the DEM's stable limit …
  scene::set_dem_step_limit(&dem::scene_step_limit);
#ifdef DEMFEM_WITH_CONTINUUM
  // … and an explicit-integrator continuum.dt against the continuum's stable step.
  scene::set_continuum_step_limit(&continuum_step_limit);
#endif
}

scene::SceneFile load_or_report(const std::string& path, int& rc) {
  try {
    rc = kOk;
    return scene::load_scene_file(path);
  } catch (const scene::SceneError& e) {
    fmt::print(stderr, "{}\n", e.what());
    fmt::print(stderr, "demfem: {} problem(s) in {}\n", e.diagnostics().size(), path);
    rc = kBadInput;
    return {};
  }
}

scene::SceneFile load_for(const RunArgs& a, int& rc) {
  auto f = load_or_report(a.scene, rc);
  if (rc == kOk && a.seed >= 0) {
    f.base.info.seed = static_cast<unsigned long>(a.seed);
    for (auto& v : f.variants) v.info.seed = static_cast<unsigned long>(a.seed);
  }
  return f;
}

fs::path with_seed_dir(fs::path out, const RunArgs& a) {
  if (a.seed >= 0 && a.out.empty()) out /= fmt::format("seed-{}", a.seed);
  return out;
}

std::vector<const scene::Scene*> pick(const scene::SceneFile& f, const RunArgs& a, int& rc) {
  std::vector<const scene::Scene*> out;
  rc = kOk;
  try {
    if (a.all_variants) {
      if (f.variants.empty()) out.push_back(&f.base);
      for (const auto& v : f.variants) out.push_back(&v);
    } else if (a.variants.empty()) {
      out.push_back(&f.base);
    } else {
      for (const auto& v : a.variants) out.push_back(&f.select(v));
    }
    // every folder name the chosen scenes give, before anything runs (run_dir.hpp)
    for (const scene::Scene* s : out) {
      if (a.out.empty()) (void)child_dir("runs", s->info.name, "scene name");
      if (!s->variant.empty()) (void)child_dir(a.out, s->variant, "variant name");
    }
  } catch (const scene::SceneError& e) {
    fmt::print(stderr, "{}\n", e.what());
    rc = kBadInput;
  } catch (const UsageError& e) {
    fmt::print(stderr, "demfem: {}\n", e.what());
    rc = kBadInput;
  }
  return out;
}

} // namespace demfem::app
