// Where demfem's log lines go: the console, and the run directory's log.txt once it exists.
#pragma once

#include <filesystem>

namespace demfem::app {

// Logs to the console (stdout, as spdlog's default logger) and keeps the lines for the next run
// directory's log.txt (the packing and the calibration a run makes before its directory exists).
// Called before each run's own set-up, so that one run's lines never reach another run's log.
void log_before_run_dir();

// The console (stderr) and dir/log.txt, the lines kept since log_before_run_dir first. A resumed
// run (`append`) appends to the log of the run it continues. Under an MPI launcher ranks > 0 log
// warnings and errors to the console only.
void setup_run_log(const std::filesystem::path& dir, bool append);

} // namespace demfem::app
