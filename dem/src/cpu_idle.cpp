// Idle processor time from /proc/stat, for the adaptive thread team (cpu_idle.hpp).
#include "demfem/dem/cpu_idle.hpp"

#include <charconv>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>
#include <system_error>

#ifdef __linux__
#include <sched.h>
#include <unistd.h>
#endif

namespace demfem::dem {

double idle_seconds_from_proc_stat(std::string_view text, const std::vector<bool>& allowed,
                                   double ticks_per_second) {
  double ticks = 0.0;
  bool any = false;
  while (!text.empty()) {
    const auto eol = text.find('\n');
    std::string_view line = text.substr(0, eol);
    text = eol == std::string_view::npos ? std::string_view{} : text.substr(eol + 1);
    // Per-CPU lines: "cpuN user nice system idle iowait irq softirq …" (proc(5)); the aggregate
    // "cpu " line is skipped, so that the affinity mask can pick CPUs.
    if (line.size() < 4 || line.substr(0, 3) != "cpu" || line[3] < '0' || line[3] > '9') continue;
    std::size_t cpu = 0;
    const char* p = line.data() + 3;
    const char* end = line.data() + line.size();
    auto r = std::from_chars(p, end, cpu);
    if (r.ec != std::errc{}) continue;
    p = r.ptr;
    unsigned long long field[5] = {};
    int got = 0;
    for (; got < 5; ++got) {
      while (p < end && *p == ' ') ++p;
      r = std::from_chars(p, end, field[got]);
      if (r.ec != std::errc{}) break;
      p = r.ptr;
    }
    if (got < 4) continue; // iowait is absent on kernels before 2.5.41: idle alone then
    if (!allowed.empty() && (cpu >= allowed.size() || !allowed[cpu])) continue;
    ticks += static_cast<double>(field[3]) + (got > 4 ? static_cast<double>(field[4]) : 0.0);
    any = true;
  }
  return any ? ticks / ticks_per_second : std::numeric_limits<double>::quiet_NaN();
}

namespace {

// The whole of a small /proc file (its size reads as 0, so it is read to the end); false when it
// cannot be opened.
[[maybe_unused]] bool read_text(const char* path, std::string& text) {
  std::FILE* f = std::fopen(path, "r");
  if (!f) return false;
  text.clear();
  char buf[4096];
  std::size_t got = 0;
  while ((got = std::fread(buf, 1, sizeof buf, f)) > 0) text.append(buf, got);
  std::fclose(f);
  return true;
}

} // namespace

double idle_cpu_seconds() {
  const double nan = std::numeric_limits<double>::quiet_NaN();
#ifdef __linux__
  std::string text;
  if (!read_text("/proc/stat", text)) return nan;
  std::vector<bool> allowed;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0) {
    allowed.assign(CPU_SETSIZE, false);
    for (int c = 0; c < CPU_SETSIZE; ++c) allowed[static_cast<std::size_t>(c)] = CPU_ISSET(c, &set);
  }
  const long tck = sysconf(_SC_CLK_TCK);
  return idle_seconds_from_proc_stat(text, allowed, tck > 0 ? static_cast<double>(tck) : 100.0);
#else
  return nan;
#endif
}

int procs_running_from_proc_stat(std::string_view text) {
  constexpr std::string_view key = "procs_running ";
  std::size_t at = 0;
  while (at < text.size()) {
    const auto eol = text.find('\n', at);
    const std::string_view line =
        text.substr(at, eol == std::string_view::npos ? std::string_view::npos : eol - at);
    at = eol == std::string_view::npos ? text.size() : eol + 1;
    if (line.substr(0, key.size()) != key) continue;
    int n = -1;
    const auto r = std::from_chars(line.data() + key.size(), line.data() + line.size(), n);
    return r.ec == std::errc{} ? n : -1;
  }
  return -1;
}

bool task_stat_is_running(std::string_view stat_line) {
  // "tid (comm) S …" (proc(5)): comm may hold ')' itself, so the state follows the last ')'.
  const auto close = stat_line.rfind(')');
  if (close == std::string_view::npos || close + 2 >= stat_line.size()) return false;
  return stat_line[close + 2] == 'R';
}

int other_runnable_tasks() {
#ifdef __linux__
  std::string text;
  if (!read_text("/proc/stat", text)) return -1;
  const int all = procs_running_from_proc_stat(text);
  if (all < 0) return -1;
  int own = 0;
  std::error_code ec;
  for (const auto& task : std::filesystem::directory_iterator("/proc/self/task", ec)) {
    if (read_text((task.path() / "stat").c_str(), text) && task_stat_is_running(text)) ++own;
  }
  if (ec) return -1;
  // The reading thread is running and counted in both; a thread that ran between the two
  // readings may be counted in one only: never below zero.
  return all > own ? all - own : 0;
#else
  return -1;
#endif
}

int free_cpus_now() {
#ifdef __linux__
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) != 0) return -1;
  const int cpus = CPU_COUNT(&set);
  const int others = other_runnable_tasks();
  if (others < 0) return -1;
  return cpus - 1 - others > 0 ? cpus - 1 - others : 0;
#else
  return -1;
#endif
}

} // namespace demfem::dem
