// Separate `demfem` processes run side by side: the sweeps of `demfem study` and `demfem run
// --jobs N` (several variants at once where one run cannot use two cores).
#pragma once

#include <atomic>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace demfem::studies {

struct ProcessTask {
  std::vector<std::string> argv; // argv[0]: the executable's path
  std::filesystem::path log;     // stdout and stderr
  double timeout = 0.0;          // [s]; 0 = none
  // Tasks (indices into the same list, earlier ones) that must have exited with 0 before this one
  // starts; when one of them fails, this task is not started (ProcessResult::not_started).
  std::vector<std::size_t> after;
};

struct ProcessResult {
  int exit_code = -1;       // -1: did not exit normally (or could not start)
  bool not_started = false; // a task in `after` failed or was not started
  double wall = 0.0;        // [s] from fork to reaping
  double rss_mib = 0.0;
  bool timed_out = false; // killed (SIGKILL) at its time limit
  bool stopped = false;   // a stop request (stop_children_on) stopped it, or kept it from starting
  int rank = 0;           // the launcher rank that ran it (studies under mpirun)
};

// Makes run_processes stop when `*flag` becomes true (a stop signal, set from a signal handler): no
// further task starts (each is reported not_started and stopped), each running child is sent one
// SIGTERM (demfem stops at its next step, writes its checkpoint and exits 3) and is waited for.
// nullptr: no such flag.
void stop_children_on(const std::atomic<bool>* flag);

// Runs `tasks` as child processes, at most `jobs` at once: a free slot takes the first task in
// list order whose `after` tasks have all succeeded, so a task waits only for what it needs, not
// for every task before it. Each child gets the environment without an MPI launcher's variables
// (a singleton of its own) and runs in a process group of its own (a terminal's Ctrl-C reaches the
// parent, which stops the children once: see stop_children_on); a child is sent SIGTERM when
// the parent dies (PR_SET_PDEATHSIG), so no child runs on as an orphan. Wall time from fork to
// reaping, peak resident set from wait4's rusage. `on_done(i, result)` is called as each one ends,
// and for a task that is not started.
std::vector<ProcessResult>
run_processes(const std::vector<ProcessTask>& tasks, int jobs,
              const std::function<void(std::size_t, const ProcessResult&)>& on_done = {});

} // namespace demfem::studies
