#include <cmath>

#include <fmt/format.h>

#include "demfem/output/contract.hpp"
#include "demfem/scene/write_file.hpp"
#include "hooks.hpp"

namespace demfem::continuum::run_detail {

namespace col = output::col;
using output::CsvFormat;

void StepRecord::open(const std::filesystem::path& dir) {
  open(dir, -1);
}

void StepRecord::open(const std::filesystem::path& dir, long long keep) {
  std::vector<std::string> columns;
  for (const auto& c : output::kStepsColumns) columns.push_back(output::heading(c));
  output::CsvOptions o;
  o.keep_errors = true;
  // step, time, Newton, linear, cuts, converged, residual, wall, substeps
  o.formats = {CsvFormat::integer(),     CsvFormat::general(6), CsvFormat::integer(),
               CsvFormat::integer(),     CsvFormat::integer(),  CsvFormat::integer(),
               CsvFormat::scientific(3), CsvFormat::fixed(4),   CsvFormat::integer()};
  if (keep >= 0) o.resume_after = static_cast<double>(keep) + 0.5; // the step column
  csv_.emplace(dir / output::file::steps, std::move(columns), std::move(o));
}

void StepRecord::add(long long step, double t, const fem::StepStats& st, double wall_seconds) {
  if (!csv_) return;
  csv_->append({static_cast<double>(step), t, static_cast<double>(st.newton_iterations),
                static_cast<double>(st.linear_iterations), static_cast<double>(st.cuts),
                st.converged ? 1.0 : 0.0, st.residual, wall_seconds,
                static_cast<double>(st.substeps)});
}

void StepRecord::flush() {
  if (csv_) csv_->flush();
}

void StepRecord::close() {
  if (csv_) csv_->close();
}

Snapshots::Snapshots(fem::Model& m, const scene::Scene& scene, std::filesystem::path dir)
    : m_(m), vtk_(scene.output.vtk), interval_(scene.output.interval), next_(scene.output.interval),
      dir_(dir.string()) {}

void Snapshots::write(double t) {
  if (!vtk_) return;
  m_.write_vtu(dir_, std::string(output::file::continuum_basename), index_++);
  last_ = t;
}

void Snapshots::at(double t, double dt, bool last) {
  if (t >= next_ - 1e-9 * dt || last) {
    write(t);
    next_ += interval_;
  }
}

void Snapshots::write_if_missed(double t) {
  if (last_ != t) write(t);
}

void Snapshots::finish() {
  if (vtk_) m_.write_pvd(dir_, std::string(output::file::continuum_basename));
}

std::string beyond_small_strain(const fem::Model& m, const scene::Scene& scene) {
  const double limit = scene.continuum.max_displacement;
  if (!(limit > 0.0)) return {};
  for (std::size_t k = 0; k < scene.structures.size(); ++k) {
    const auto mo = m.region_motion(k);
    const double moved = std::hypot(mo.ux, mo.uz);
    if (moved > limit) return fmt::format("{} moved {:.4g} m", scene.structures[k].name, moved);
  }
  return {};
}

void report_progress(const RunOptions& options, long long step, long long nsteps, double t,
                     double duration, std::chrono::steady_clock::time_point t_start) {
  if (!options.progress || (step % 10 != 0 && step != nsteps)) return;
  scene::Progress p;
  p.stage = "continuum";
  p.time = t;
  p.end_time = duration;
  p.step = step;
  p.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  options.progress(p);
}

std::string write_surface_profile(const fem::Model& m, std::span<const fem::Point> top,
                                  const std::filesystem::path& dir, bool root) {
  std::vector<std::pair<double, double>> profile;
  for (const auto& p : top) profile.emplace_back(p.x, -m.displacement(p).z); // collective
  if (!root) return {};
  std::string csv =
      fmt::format("{},{}\n", output::heading(col::x), output::heading(col::surface_settlement));
  for (const auto& [x, s] : profile) csv += fmt::format("{:.6g},{:.9g}\n", x, s);
  try {
    scene::write_file_atomic(dir / output::file::surface_profile, csv);
  } catch (const scene::WriteError& e) {
    return e.what();
  }
  return {};
}

} // namespace demfem::continuum::run_detail
