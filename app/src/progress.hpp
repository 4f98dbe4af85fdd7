// Progress display: one redrawn line on a terminal, periodic plain lines otherwise.
#pragma once

#include <chrono>
#include <cstdio>
#include <string>

#include "demfem/scene/progress.hpp"

namespace demfem::app {

class ProgressReporter {
public:
  explicit ProgressReporter(std::FILE* stream = stderr, double plain_interval_s = 10.0);
  ~ProgressReporter();
  ProgressReporter(const ProgressReporter&) = delete;
  ProgressReporter& operator=(const ProgressReporter&) = delete;

  void operator()(const scene::Progress& p);
  void finish();

private:
  std::FILE* stream_;
  bool tty_;
  double plain_interval_;
  std::chrono::steady_clock::time_point last_;
  bool drawn_ = false;
  bool first_ = true;
  // The previous report, for rates over the last interval (not since the start).
  long long last_step_ = 0;
  double last_time_ = 0.0;
  double last_wall_ = 0.0;
  std::string last_stage_;
};

} // namespace demfem::app
