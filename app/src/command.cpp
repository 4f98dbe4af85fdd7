#include "command.hpp"

#include <algorithm>

namespace demfem::app {

const char* const kExitCodes =
    "Exit codes: 0 success, 1 the run failed (a comparison: a solver failed or stopped early), 2 "
    "bad input or usage (a run directory that is not demfem's, holds another scene or is in use), "
    "3 stopped by SIGINT/SIGTERM/SIGHUP (the message gives the command that continues).";

namespace {
std::vector<Command>& registry() {
  static std::vector<Command> r; // filled during static initialisation, before main
  return r;
}
} // namespace

bool register_command(Command command) {
  registry().push_back(std::move(command));
  return true;
}

std::vector<Command> commands() {
  std::vector<Command> c = registry();
  std::stable_sort(c.begin(), c.end(),
                   [](const Command& a, const Command& b) { return a.order < b.order; });
  return c;
}

} // namespace demfem::app
