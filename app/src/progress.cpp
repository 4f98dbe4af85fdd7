#include "progress.hpp"

#include <unistd.h>

#include <fmt/format.h>

namespace demfem::app {

ProgressReporter::ProgressReporter(std::FILE* stream, double plain_interval_s)
    : stream_(stream), tty_(isatty(fileno(stream)) != 0), plain_interval_(plain_interval_s),
      last_(std::chrono::steady_clock::now()) {}

ProgressReporter::~ProgressReporter() {
  finish();
}

void ProgressReporter::operator()(const scene::Progress& p) {
  const auto now = std::chrono::steady_clock::now();
  const double since = std::chrono::duration<double>(now - last_).count();
  const double min_gap = tty_ ? 0.2 : plain_interval_;
  const bool done = p.time >= p.end_time;
  if (!first_ && since < min_gap && !done) return;
  first_ = false;
  last_ = now;
  if (p.stage != last_stage_ || p.step < last_step_) { // a new stage starts its own clock
    last_stage_ = p.stage;
    last_step_ = 0;
    last_time_ = 0.0;
    last_wall_ = 0.0;
  }
  // Rates over the interval since the last report, so a slow start does not skew the ETA.
  const double dwall = p.wall_seconds - last_wall_;
  const double rate = dwall > 0 ? static_cast<double>(p.step - last_step_) / dwall : 0.0;
  const double sim_rate = dwall > 0 ? (p.time - last_time_) / dwall : 0.0;
  const double frac = p.end_time > 0 ? p.time / p.end_time : 1.0;
  const double eta = sim_rate > 0 ? (p.end_time - p.time) / sim_rate : 0.0;
  last_step_ = p.step;
  last_time_ = p.time;
  last_wall_ = p.wall_seconds;
  const std::string line =
      fmt::format("[{}] t = {:.4g} / {:.4g} s ({:5.1f} %)  step {}  {:.3g} steps/s  ETA {:.0f} s",
                  p.stage, p.time, p.end_time, 100.0 * frac, p.step, rate, eta);
  if (tty_) {
    fmt::print(stream_, "\r{:<100}", line);
    drawn_ = true;
  } else {
    fmt::print(stream_, "{}\n", line);
  }
  std::fflush(stream_);
}

void ProgressReporter::finish() {
  if (tty_ && drawn_) {
    fmt::print(stream_, "\n");
    std::fflush(stream_);
  }
  drawn_ = false;
}

} // namespace demfem::app
