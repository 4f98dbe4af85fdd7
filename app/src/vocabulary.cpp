#include "demfem/app/vocabulary.hpp"

#include "demfem/dem/vocabulary.hpp"

#ifdef DEMFEM_WITH_CONTINUUM
#include <exception>
#include <filesystem>
#include <system_error>

#include "demfem/compare/calibrate.hpp"

#include "continuum_module.hpp"
#endif

namespace demfem::app {

namespace {

#ifdef DEMFEM_WITH_CONTINUUM
// The continuum's explicit stable step for the scene check: with calibrate = "dem", from the
// cached calibration (unknown until it exists: the run, which calibrates first, refuses the same
// step at the same key).
std::optional<scene::ContinuumStepLimit> continuum_step_limit(const scene::Scene& s) {
  namespace fs = std::filesystem;
  scene::Scene r = s;
  if (r.soil.continuum && r.soil.continuum->calibrate_dem) {
    const compare::CalibrateOptions o;
    const fs::path f = compare::calibration_cache_dir(r, o) /
                       ("calibration-" + compare::calibration_key(r, o) + ".json");
    std::error_code ec;
    if (!fs::exists(f, ec)) return std::nullopt;
    try {
      compare::apply_calibration(r, compare::load_or_calibrate(r, o));
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

scene::Vocabulary build() {
  scene::Vocabulary v = dem::vocabulary();
#ifdef DEMFEM_WITH_CONTINUUM
  v.continuum_step_limit = &continuum_step_limit;
#endif
  return v;
}

} // namespace

const scene::Vocabulary& vocabulary() {
  static const scene::Vocabulary v = build();
  return v;
}

} // namespace demfem::app
