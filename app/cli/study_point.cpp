// `demfem study-point dem|continuum|flamant …`: one run of an error-vs-time study as its own
// process (hidden from --help: the study starts it); writes its result and the solver's own wall
// time as JSON.
#include <chrono>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "calibration.hpp"
#include "command.hpp"
#include "demfem/dem/run.hpp"
#include "demfem/scene/write_file.hpp"
#include "log.hpp"
#include "scenes.hpp"
#include "signals.hpp"
#ifdef DEMFEM_WITH_CONTINUUM
#include "continuum_module.hpp"
#endif

namespace demfem::app {

namespace {

struct PointArgs {
  std::string problem, scene, out, json;
  int refinement = 0, degree = 2;
};
int cmd_study_point(const PointArgs& pa) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto seconds = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  if (pa.problem == "dem") {
    int rc = kOk;
    const auto file = load_or_report(pa.scene, rc);
    if (rc != kOk) return rc;
    setup_run_log(pa.out, false);
    dem::RunOptions o;
    o.out_dir = pa.out;
    o.threads = 1;
    o.interrupt = &stop_requested(); // the study stops its runs with SIGTERM
    const auto x = dem::run(file.base, o);
    if (x.interrupted) return kInterrupted;
    scene::write_file_atomic(
        pa.json, fmt::format("{{\"solver_seconds\": {:.9g}, \"process_seconds\": {:.9g}, "
                             "\"steps\": {}, \"dt\": {:.17g}, \"ok\": {}}}\n",
                             x.wall_seconds, seconds(), x.steps, x.dt, x.ok));
    if (!x.ok) fmt::print(stderr, "{}\n", x.message);
    return x.ok ? kOk : kRunFailed;
  }
  if (pa.problem == "continuum") {
#ifdef DEMFEM_WITH_CONTINUUM
    int rc = kOk;
    const auto file = load_or_report(pa.scene, rc);
    if (rc != kOk) return rc;
    setup_run_log(pa.out, false);
    // calibrate = "dem": read from the cache (the study computed it before starting the runs)
    const scene::Scene sc = with_calibration(file.base, pa.out);
    continuum::RunOptions o;
    o.out_dir = pa.out;
    o.progress = stoppable({}); // the study stops its runs with SIGTERM
    const auto x = continuum_module().run(sc, o);
    if (!x.ok && stop_requested().load()) return kInterrupted;
    scene::write_file_atomic(
        pa.json,
        fmt::format("{{\"solver_seconds\": {:.9g}, \"process_seconds\": {:.9g}, "
                    "\"steps\": {}, \"dt\": {:.17g}, \"dofs\": {}, \"h_min\": "
                    "{:.17g}, \"integrator\": \"{}\", \"ok\": {}}}\n",
                    x.wall_seconds, seconds(), x.steps, x.dt, x.dofs, x.h_min, x.integrator, x.ok));
    if (!x.ok) fmt::print(stderr, "{}\n", x.message);
    return x.ok ? kOk : kRunFailed;
#else
    fmt::print(stderr, "demfem study-point: the continuum solver is not in this build\n");
    return kBadInput;
#endif
  }
  if (pa.problem != "flamant") {
    fmt::print(stderr,
               "demfem study-point: unknown problem '{}'; valid: dem, continuum, "
               "flamant\n",
               pa.problem);
    return kBadInput;
  }
#ifdef DEMFEM_WITH_CONTINUUM
  const auto r = continuum_module().flamant_strip_load(pa.refinement, pa.degree);
  scene::write_file_atomic(
      pa.json, fmt::format("{{\"computed\": {:.17g}, \"exact\": {:.17g}, \"dofs\": {}, "
                           "\"h_min\": {:.17g}, \"converged\": {}, \"solver_seconds\": "
                           "{:.9g}}}\n",
                           r.computed, r.exact, r.dofs, r.h_min, r.converged, seconds()));
  return r.converged ? kOk : kRunFailed;
#else
  fmt::print(stderr, "demfem study-point: the continuum solver is not in this build\n");
  return kBadInput;
#endif
}

[[maybe_unused]] const bool registered = register_command(
    {"study-point", "One run of an error-vs-time study", 50, false,
     [](CLI::App&, CLI::App& sub) -> std::function<int()> {
       auto pa = std::make_shared<PointArgs>();
       sub.group(""); // hidden: the study starts it as its own process
       sub.add_option("problem", pa->problem, "dem | continuum | flamant")->required();
       sub.add_option("--scene", pa->scene, "dem, continuum: resolved scene file");
       sub.add_option("--out", pa->out, "dem, continuum: run directory");
       sub.add_option("--refinement", pa->refinement, "flamant: refinement");
       sub.add_option("--degree", pa->degree, "flamant: degree");
       sub.add_option("--json", pa->json, "Result file")->required();
       return [pa] { return cmd_study_point(*pa); };
     }});

} // namespace

} // namespace demfem::app
