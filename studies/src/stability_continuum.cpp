#include "demfem/studies/stability_continuum.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace demfem::studies {

std::vector<StabilityRow>
continuum_stability_rows(const continuum::ModuleApi& cm, const scene::Scene& sc0,
                         const std::function<scene::Scene(const scene::Scene&)>& calibrated) {
  std::vector<StabilityRow> rows;
  const auto add = [&rows](const continuum::StabilityCase& c) {
    StabilityRow r;
    r.solver = "continuum";
    r.name = c.name;
    r.description = c.description;
    r.outcome = c.outcome;
    r.cause = c.cause;
    r.measure = c.measure;
    r.iterations = c.newton_iterations;
    r.residuals = c.residuals;
    r.steps = c.load_steps;
    r.wall_seconds = c.wall_seconds;
    spdlog::info("continuum {:<22} {:<10} {} {}", c.name, c.outcome, c.measure, c.cause);
    rows.push_back(r);
    return c.value;
  };
  const int degree = std::max(1, sc0.continuum.degree);
  // ν → 0.5: locking shown by the rocking stiffness without B-bar against the B-bar run
  for (const double nu : {0.49, 0.499}) {
    const double kb = add(cm.rocking_locking_case(nu, true, degree));
    const double kn = add(cm.rocking_locking_case(nu, false, degree));
    if (std::isfinite(kb) && std::isfinite(kn) && kb > 0.0)
      rows.back().measure += fmt::format("; {:.4f} × the B-bar run (locking)", kn / kb);
  }
  add(cm.stiff_structure_case(1.0e6, degree));
  // the scene's own continuum (calibrated moduli) for the explicit step guard
  const scene::Scene sc = calibrated(sc0);
  // ν → 0.5 on the scene's own mesh and seating: the seated settlement without B-bar against the
  // B-bar row (no closed form there: the built-in rows above carry it)
  for (const double nu : {0.49, 0.499}) {
    const double wb = add(cm.scene_locking_case(sc, nu, true));
    const double wn = add(cm.scene_locking_case(sc, nu, false));
    if (std::isfinite(wb) && std::isfinite(wn) && wb != 0.0)
      rows.back().measure +=
          fmt::format("; settlement {:.4f} × the B-bar run's (locking)", wn / wb);
  }
  add(cm.explicit_step_case(sc, 1.5));
  for (const double f : {0.9, 1.1}) add(cm.bearing_capacity_case(f, degree));
  return rows;
}

} // namespace demfem::studies
