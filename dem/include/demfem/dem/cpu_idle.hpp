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

// The "procs_running" count of a /proc/stat text (tasks runnable at that instant, on the whole
// machine, the reader included); −1 when the text has none.
[[nodiscard]] int procs_running_from_proc_stat(std::string_view text);

// Whether a /proc/<pid>/task/<tid>/stat line says the task is running or runnable (state 'R',
// the field after the parenthesised command name, which may itself hold spaces and ')').
[[nodiscard]] bool task_stat_is_running(std::string_view stat_line);

// Tasks of other processes that are runnable on this machine now: procs_running less this
// process's threads in state R (so a worker thread spinning in the OpenMP pool is not counted as
// another process); −1 where /proc cannot be read. One instantaneous reading: the adaptive team
// uses it only for its first choice, before any idle counter can be read over a span.
[[nodiscard]] int other_runnable_tasks();

// CPUs of this process's affinity mask left free now besides the caller's own: their count less
// one, less other_runnable_tasks() (never below 0); −1 where unknown.
[[nodiscard]] int free_cpus_now();

} // namespace demfem::dem
