// Idle processor time from /proc/stat, for the adaptive thread team (cpu_idle.hpp).
#include "demfem/dem/cpu_idle.hpp"

#include <charconv>
#include <cstdio>
#include <limits>
#include <string>

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

double idle_cpu_seconds() {
  const double nan = std::numeric_limits<double>::quiet_NaN();
#ifdef __linux__
  std::FILE* f = std::fopen("/proc/stat", "r");
  if (!f) return nan;
  std::string text;
  char buf[4096];
  std::size_t got = 0;
  while ((got = std::fread(buf, 1, sizeof buf, f)) > 0) text.append(buf, got);
  std::fclose(f);
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

} // namespace demfem::dem
