// The subcommands of `demfem`. Each file in app/cli/ registers one (register_command at static
// initialisation); main builds the command line from the registry, so a new subcommand is one new
// file there.
#pragma once

#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace demfem::app {

// Exit codes, documented in --help (kExitCodes) and docs/cli.md.
constexpr int kOk = 0;
constexpr int kRunFailed = 1;
constexpr int kBadInput = 2;
constexpr int kInterrupted = 3;
extern const char* const kExitCodes;

// Bad input found while a command runs (e.g. a name that cannot be a folder name): main prints
// the message and exits kBadInput.
class UsageError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

struct Command {
  std::string name;
  std::string summary; // one line of `demfem --help`
  int order = 0;       // position in `demfem --help` (ascending)
  // Under an MPI launcher the console of ranks > 0 shows warnings only, unless the command
  // spreads its work over the ranks (each says what it runs).
  bool spreads_over_ranks = false;
  // Declares the subcommand's positionals and options on `sub` (`root`: the whole command line,
  // for `help`) and returns what runs it once the line is parsed: its exit code.
  std::function<std::function<int()>(CLI::App& root, CLI::App& sub)> setup;
};

// Always true (the value lets a file register at namespace scope).
bool register_command(Command command);
// Every registered command, in `order`.
[[nodiscard]] std::vector<Command> commands();

} // namespace demfem::app
