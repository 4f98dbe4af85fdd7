// Ctrl-C, a batch scheduler's stop (SIGTERM) and a closed terminal (SIGHUP): the first of them
// asks the running solver to finish its step, write a checkpoint and stop (exit kInterrupted); a
// second one kills the process the usual way.
#pragma once

#include <atomic>

namespace demfem::app {

void install_stop_signals();
// Set by the first stop signal; the DEM run polls it (dem::RunOptions::interrupt).
[[nodiscard]] std::atomic<bool>& stop_requested();
// "SIGINT", "SIGTERM" or "SIGHUP": the signal that asked to stop.
[[nodiscard]] const char* stop_signal_name();

} // namespace demfem::app
