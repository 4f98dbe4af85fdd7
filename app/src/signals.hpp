// Ctrl-C, a batch scheduler's stop (SIGTERM) and a closed terminal (SIGHUP): the first of them
// asks the running work to stop (exit kInterrupted, with the command that continues); a second
// one kills the process the usual way. The DEM finishes its step and writes a checkpoint; a
// continuum run finishes its step (the explicit integrator then writes a checkpoint); work
// without a checkpoint of its own (a calibration, a study's rows) stops at its next progress
// report (Stopped). SIGXFSZ is ignored, so that a write past the file size limit fails
// with EFBIG and is reported ("cannot write …: File too large") instead of killing the process.
#pragma once

#include <atomic>
#include <stdexcept>
#include <string>

#include "demfem/scene/progress.hpp"

namespace demfem::app {

void install_stop_signals();
// Set by the first stop signal; the DEM and continuum runs poll it (RunOptions::interrupt).
[[nodiscard]] std::atomic<bool>& stop_requested();
// "SIGINT", "SIGTERM" or "SIGHUP": the signal that asked to stop.
[[nodiscard]] const char* stop_signal_name();

// Thrown by stoppable() progress reports once a stop signal has arrived; main reports it (exit
// kInterrupted) with the command line to run again.
class Stopped : public std::runtime_error {
public:
  Stopped();
};
// `progress` (may be empty) preceded by a check that throws Stopped once a stop signal has
// arrived: for work that has no checkpoint and stops at its next progress report.
[[nodiscard]] scene::ProgressFn stoppable(scene::ProgressFn progress);

// The command line as typed (each word shell-quoted), for "run it again" messages.
void set_command_line(int argc, char** argv);
[[nodiscard]] const std::string& command_line();

} // namespace demfem::app
