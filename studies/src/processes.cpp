// Child processes side by side (demfem/studies/processes.hpp).
#include "demfem/studies/processes.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <fcntl.h>
#include <string_view>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace demfem::studies {

namespace {

// The environment without the launcher's variables, so that a child started from a rank is an MPI
// singleton of its own instead of a second copy of that rank (built before fork: the child only
// execs).
std::vector<std::string> child_environment() {
  std::vector<std::string> env;
  for (char** e = environ; e && *e; ++e) {
    const std::string_view v(*e);
    bool launcher = false;
    for (const char* p : {"OMPI_", "PMIX_", "PMI_", "HYDRA_", "MPI_LOCAL"})
      launcher = launcher || v.starts_with(p);
    if (!launcher) env.emplace_back(v);
  }
  return env;
}

std::atomic<const std::atomic<bool>*> g_stop{nullptr};

} // namespace

void stop_children_on(const std::atomic<bool>* flag) {
  g_stop.store(flag);
}

std::vector<ProcessResult>
run_processes(const std::vector<ProcessTask>& tasks, int jobs,
              const std::function<void(std::size_t, const ProcessResult&)>& on_done) {
  using Clock = std::chrono::steady_clock;
  const std::vector<std::string> env = child_environment();
  std::vector<char*> envp;
  for (const auto& e : env) envp.push_back(const_cast<char*>(e.c_str()));
  envp.push_back(nullptr);
  std::vector<ProcessResult> res(tasks.size());
  struct Running {
    std::size_t index;
    Clock::time_point start;
  };
  std::vector<std::pair<pid_t, Running>> running;
  // per task: 0 waiting, 1 started, 2 succeeded, 3 failed or not started
  constexpr unsigned char kWaiting = 0, kStarted = 1, kSucceeded = 2, kFailed = 3;
  std::vector<unsigned char> state(tasks.size(), kWaiting);
  std::size_t left = tasks.size(); // not yet started (or given up)
  jobs = std::max(1, jobs);
  bool any_timeout = false;
  for (const auto& t : tasks) any_timeout = any_timeout || t.timeout > 0.0;
  const std::atomic<bool>* stop = g_stop.load();
  const pid_t parent = ::getpid();
  bool stopping = false; // the stop request has been passed on to the running children
  // On a stop request: the waiting tasks are given up (not started) and each running child is
  // sent SIGTERM once.
  const auto pass_on_stop = [&] {
    if (stopping || !stop || !stop->load()) return;
    stopping = true;
    for (std::size_t i = 0; i < tasks.size(); ++i)
      if (state[i] == kWaiting) {
        state[i] = kFailed;
        --left;
        res[i].not_started = true;
        res[i].stopped = true;
        if (on_done) on_done(i, res[i]);
      }
    for (const auto& [cpid, r] : running) {
      res[r.index].stopped = true;
      ::kill(cpid, SIGTERM);
    }
  };
  // The first waiting task whose prerequisites all succeeded (tasks.size() when none); a task
  // with a failed prerequisite is given up on the way, as not started.
  const auto next_ready = [&]() {
    for (std::size_t i = 0; i < tasks.size(); ++i) {
      if (state[i] != kWaiting) continue;
      bool ready = true, blocked = false;
      for (const std::size_t d : tasks[i].after) {
        const unsigned char st = d < tasks.size() && d != i ? state[d] : kFailed;
        ready = ready && st == kSucceeded;
        blocked = blocked || st == kFailed;
      }
      if (blocked) {
        state[i] = kFailed;
        --left;
        res[i].not_started = true;
        if (on_done) on_done(i, res[i]);
        i = static_cast<std::size_t>(-1); // a task given up may block earlier ones: rescan
        continue;
      }
      if (ready) return i;
    }
    return tasks.size();
  };
  while (left > 0 || !running.empty()) {
    pass_on_stop();
    while (left > 0 && static_cast<int>(running.size()) < jobs) {
      const std::size_t next = next_ready();
      if (next == tasks.size()) break;
      state[next] = kStarted;
      --left;
      const auto& t = tasks[next];
      std::vector<char*> argv; // prepared before fork: the child only opens, dup2s and execs
      for (const auto& a : t.argv) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      const std::string log = t.log.string();
      const auto start = Clock::now();
      const pid_t pid = ::fork();
      if (pid == 0) {
        // its own process group; SIGTERM when the parent dies (checked once more after the
        // request, in case the parent died before it)
        ::setpgid(0, 0);
        ::prctl(PR_SET_PDEATHSIG, SIGTERM);
        if (::getppid() != parent) ::_exit(127);
        const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0) {
          ::dup2(fd, 1);
          ::dup2(fd, 2);
          ::close(fd);
        }
        ::execve(argv[0], argv.data(), envp.data());
        ::_exit(127);
      }
      if (pid < 0) {
        res[next].exit_code = -1;
        state[next] = kFailed;
        if (on_done) on_done(next, res[next]);
      } else {
        running.push_back({pid, {next, start}});
      }
    }
    if (running.empty()) {
      if (left > 0 && next_ready() == tasks.size()) { // waiting on tasks that never start
        for (std::size_t i = 0; i < tasks.size(); ++i)
          if (state[i] == kWaiting) {
            state[i] = kFailed;
            res[i].not_started = true;
            if (on_done) on_done(i, res[i]);
          }
        left = 0;
      }
      continue;
    }
    int status = 0;
    struct rusage ru {};
    // with time limits or a stop flag: poll, and kill (SIGKILL, the child we started) a run past
    // its limit (a stop signal restarts a blocking wait4: SA_RESTART)
    const pid_t pid = ::wait4(-1, &status, any_timeout || stop ? WNOHANG : 0, &ru);
    const auto end = Clock::now();
    if (pid == 0) {
      for (const auto& [cpid, r] : running) {
        const double lim = tasks[r.index].timeout;
        if (lim > 0.0 && std::chrono::duration<double>(end - r.start).count() > lim &&
            !res[r.index].timed_out) {
          res[r.index].timed_out = true;
          ::kill(cpid, SIGKILL);
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      continue;
    }
    if (pid < 0) {
      if (errno == EINTR) continue;
      break;
    }
    const auto it = std::find_if(running.begin(), running.end(),
                                 [pid](const auto& r) { return r.first == pid; });
    if (it == running.end()) continue;
    const std::size_t i = it->second.index;
    auto& r = res[i];
    r.wall = std::chrono::duration<double>(end - it->second.start).count();
    r.rss_mib = static_cast<double>(ru.ru_maxrss) / 1024.0;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    state[i] = r.exit_code == 0 ? kSucceeded : kFailed;
    running.erase(it);
    if (on_done) on_done(i, r);
  }
  return res;
}

} // namespace demfem::studies
