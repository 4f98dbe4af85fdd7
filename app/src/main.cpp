// `demfem`: the same geotechnical scene as a granular assembly (DEM) and as a continuum (FEM), and
// where the two diverge. Each subcommand is one file in app/cli/ (command.hpp); this file builds
// the command line from them, reads it, and runs the one named.
#include <functional>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "command.hpp"
#include "demfem/dem/malloc_tuning.hpp"
#include "demfem/dem/pack.hpp"
#include "demfem/studies/error_study.hpp"
#include "demfem/studies/processes.hpp"
#include "scenes.hpp"
#include "signals.hpp"
#include "words.hpp"

using namespace demfem;

int main(int argc, char** argv) {
  dem::keep_freed_memory_for_reuse(); // the neighbour rebuilds' lists (malloc_tuning.hpp)
  CLI::App cli{"demfem — the same geotechnical scene as a granular assembly (DEM) and as a "
               "continuum (FEM), and where the two diverge."};
  cli.footer(app::kExitCodes);
  // The engine fingerprint (dem/pack.hpp): which DEM, bit for bit, made a run's packings.
  cli.set_version_flag("--version", [] {
    return fmt::format("demfem {}\nDEM engine fingerprint {}", DEMFEM_VERSION,
                       dem::engine_fingerprint());
  });
  cli.require_subcommand(1);

  struct Entry {
    CLI::App* sub;
    app::Command command;
    std::function<int()> run;
  };
  std::vector<Entry> entries;
  for (auto& c : app::commands()) {
    CLI::App* sub = cli.add_subcommand(c.name, c.summary);
    auto run = c.setup(cli, *sub);
    if (!sub->get_group().empty()) sub->footer(app::kExitCodes); // not on the hidden ones
    entries.push_back({sub, std::move(c), std::move(run)});
  }

  app::install_stop_signals();
  app::set_command_line(argc, argv);
  studies::stop_children_on(&app::stop_requested()); // run --jobs, study: children stop too
  if (!app::check_words(cli, argc, argv)) return app::kBadInput;
  try {
    cli.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return cli.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return cli.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return cli.exit(e);
  } catch (const CLI::ParseError& e) {
    cli.exit(e);
    return app::kBadInput;
  }

  for (const auto& e : entries) {
    if (!*e.sub) continue;
    // Under an MPI launcher every rank runs the command: the console and log messages come from
    // the first rank only (each line was printed once per rank; setup_run_log too); warnings
    // and errors from all. A command that spreads its work over the ranks says what each runs.
    if (studies::study_rank() != 0 && !e.command.spreads_over_ranks)
      spdlog::set_level(spdlog::level::warn);
    try {
      return e.run();
    } catch (const app::UsageError& ex) {
      fmt::print(stderr, "demfem {}: {}\n", e.command.name, ex.what());
      return app::kBadInput;
    } catch (const app::Stopped& ex) {
      // work without a checkpoint of its own (a calibration, a study): it starts over
      spdlog::warn("{}: nothing to resume from; run it again:\n  {}", ex.what(),
                   app::command_line());
      return app::kInterrupted;
    } catch (const std::exception& ex) {
      fmt::print(stderr, "demfem: error: {}\n", ex.what());
      return app::kRunFailed;
    }
  }
  return app::kBadInput;
}
