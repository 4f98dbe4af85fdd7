// `demfem help [COMMAND]`: the commands, or one command's options (as `demfem COMMAND --help`).
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "command.hpp"
#include "words.hpp"

namespace demfem::app {

namespace {

[[maybe_unused]] const bool registered = register_command(
    {"help", "Show the commands, or one command's options.", 80, false,
     [](CLI::App& root, CLI::App& sub) -> std::function<int()> {
       auto command = std::make_shared<std::string>();
       sub.add_option("command", *command, "The command whose options to show");
       return [&root, command] {
         if (command->empty()) {
           // (root.help() would show this command's own help: it is the one parsed)
           fmt::print("{}", root.get_formatter()->make_help(&root, root.get_name(),
                                                            CLI::AppFormatMode::Normal));
           return kOk;
         }
         const CLI::App* c = find_command(root, *command);
         if (!c) {
           report_unknown_command(root, *command);
           return kBadInput;
         }
         fmt::print("{}", c->help(root.get_name()));
         return kOk;
       };
     }});

} // namespace

} // namespace demfem::app
