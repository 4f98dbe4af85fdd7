// --threads above the cores this process may run on (its CPU affinity: taskset, a batch
// scheduler's or a container's cpuset) is warned about and capped: more threads than cores only
// queue, and results are bit-reproducible per thread count, so the count used is the one printed.
#pragma once

#include <sched.h>
#include <string>
#include <thread>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

namespace demfem::app {

// The cores this process may use (at least 1).
inline int usable_cores() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) == 0 && CPU_COUNT(&set) > 0) return CPU_COUNT(&set);
  const unsigned n = std::thread::hardware_concurrency();
  return n > 0 ? static_cast<int>(n) : 1;
}

// `requested` (0 = all cores), capped at usable_cores() with a warning when above it.
inline int capped_threads(int requested) {
  const int cores = usable_cores();
  if (requested <= cores) return requested;
  spdlog::warn("--threads {} is more than the {} core(s) this process may use: using {} (results "
               "are reproducible for a given thread count; pass --threads {} to repeat them)",
               requested, cores, cores, cores);
  return cores;
}

// The --threads options' transform: a count above the usable cores becomes that many (a count
// that is no number is left to the option's own check).
inline CLI::Validator threads_capped_at_cores() {
  return CLI::Validator(
      [](std::string& value) {
        int n = 0;
        if (CLI::detail::lexical_cast(value, n)) value = std::to_string(capped_threads(n));
        return std::string();
      },
      "");
}

} // namespace demfem::app
