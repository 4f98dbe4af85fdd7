// Internal to compare/: runs gnuplot on scripts, several at once. Each script's console goes to
// "<script>.log", which is removed when gnuplot succeeds and kept (named in the error) when not.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace demfem::compare::detail {

// One entry per script, in order: empty when gnuplot exited 0, else the error. At most
// `parallel` processes run at once (0: one per core).
std::vector<std::string> run_gnuplot_scripts(const std::vector<std::filesystem::path>& scripts,
                                             unsigned parallel = 0);

// Several scripts per process: job k runs gnuplot on jobs[k] in order, with `reset` between them
// (each script sets its own terminal, output and directory); its console goes to the first
// script's ".log". One entry per job, as above.
std::vector<std::string>
run_gnuplot_jobs(const std::vector<std::vector<std::filesystem::path>>& jobs,
                 unsigned parallel = 0);

} // namespace demfem::compare::detail
