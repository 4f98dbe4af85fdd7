#include "calibration.hpp"

#include <spdlog/spdlog.h>

#include "demfem/calibrate/calibrate.hpp"
#include "demfem/scene/write_file.hpp"
#include "progress.hpp"
#include "signals.hpp"

namespace fs = std::filesystem;

namespace demfem::app {

scene::Scene with_calibration(const scene::Scene& s, const fs::path& out,
                              std::vector<std::string>* notes, bool figures, bool compute) {
  scene::Scene r = s;
  if (!r.soil.continuum || !r.soil.continuum->calibrate_dem || !r.uses(scene::Solver::Continuum))
    return r;
  calibrate::CalibrateOptions o;
  o.out_dir = out / "calibration";
  if (!compute) {
    std::error_code ec;
    const fs::path f = calibrate::calibration_cache_dir(r, o) /
                       ("calibration-" + calibrate::calibration_key(r, o) + ".json");
    if (!fs::exists(f, ec)) {
      spdlog::info("{}: the continuum is not calibrated yet (a DEM run does not need it; the first "
                   "continuum run, `demfem compare` or `demfem calibrate` makes it)",
                   s.label());
      r.soil.continuum->provenance.emplace_back(
          "calibration", "not made by this DEM run: the [soil.continuum] values here are the "
                         "defaults, a continuum run fills them in");
      return r;
    }
  }
  ProgressReporter reporter;
  o.progress = stoppable([&](const scene::Progress& p) { reporter(p); }); // no checkpoint

  const auto c = calibrate::load_or_calibrate(s, o);
  reporter.finish();
  const auto files = calibrate::write_calibration(c, o.out_dir, figures || !c.from_cache);
  for (const auto& p : files.problems) {
    // a figure a full disk or a file size limit kept out fails the run (the others are notes)
    if (p.starts_with("cannot write") || p.starts_with("gnuplot failed ("))
      throw scene::WriteError(p);
    spdlog::warn("calibration figure: {}", p);
  }
  for (const auto& line : calibrate::apply_calibration(r, c)) {
    spdlog::info("{}: continuum {}", s.label(), line);
    if (notes) notes->push_back("Continuum " + line);
  }
  return r;
}

scene::Scene calibration_of_run(const scene::Scene& s, const fs::path& out) {
  scene::Scene r = s;
  const fs::path f = out / "calibration" / "calibration.json";
  if (!r.soil.continuum || !r.soil.continuum->calibrate_dem || !fs::is_regular_file(f)) return r;
  try {
    calibrate::apply_calibration(r, calibrate::read_calibration(f));
  } catch (const std::exception& e) {
    spdlog::warn("{}: {} unreadable ({}); the report shows the scene's values", s.label(),
                 f.string(), e.what());
    return s;
  }
  return r;
}

} // namespace demfem::app
