// Idle processor time of the CPUs this process may run on, for the adaptive thread team
// (Engine::set_idle_source): a full team is only worth probing when another CPU has been idle.
// Reads /proc/stat (Linux); the engine itself does no I/O.
#pragma once

#include <string_view>
#include <vector>

namespace demfem::dem {

// Idle seconds (the "idle" and "iowait" columns) summed over the CPUs in `allowed` (index = CPU
// number; empty: every CPU) of a /proc/stat text whose counters tick `ticks_per_second` times a
// second. NaN when the text has no per-CPU line.
[[nodiscard]] double idle_seconds_from_proc_stat(std::string_view text,
                                                 const std::vector<bool>& allowed,
                                                 double ticks_per_second);

// The same for this machine now, over this process's CPU affinity mask: a counter that grows by
// the idle CPU time (in CPU-seconds) between two calls. NaN where /proc/stat cannot be read.
[[nodiscard]] double idle_cpu_seconds();

} // namespace demfem::dem
