#include "demfem/app/vocabulary.hpp"

#include "constitutive/registry.hpp"
#include "demfem/dem/vocabulary.hpp"

#ifdef DEMFEM_WITH_CONTINUUM
#include <exception>
#include <filesystem>
#include <system_error>

#include "demfem/calibrate/calibrate.hpp"

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

scene::Vocabulary build() {
  scene::Vocabulary v = dem::vocabulary();
  // [soil.continuum]: the constitutive models (continuum/constitutive/, no deal.II: built with
  // or without the continuum solver)
  v.continuum.push_back(continuum::constitutive::model_slot());
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
