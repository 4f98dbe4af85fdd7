// Words on the command line that demfem does not know: what it did not understand and the
// nearest valid word, as git suggests one.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace CLI {
class App;
}

namespace demfem::app {

// Optimal string alignment distance: an insertion, deletion, substitution or transposition of two
// adjacent characters each costs 1 (Damerau 1964), so "rnu" is 1 from "run".
[[nodiscard]] std::size_t edit_distance(std::string_view a, std::string_view b);

// The candidates near enough to `word` to be what was meant: the unique one it begins, else those
// at the smallest distance when that is at most a third of its length (at least 1); empty when
// none is.
[[nodiscard]] std::vector<std::string> nearest_words(const std::string& word,
                                                     const std::vector<std::string>& candidates);

// " did you mean 'a'?" / " did you mean 'a' or 'b'?" ("" for none).
[[nodiscard]] std::string did_you_mean(const std::vector<std::string>& words);

// The subcommand of `root` named `name` (nullptr when there is none).
[[nodiscard]] const CLI::App* find_command(const CLI::App& root, const std::string& name);
// Every subcommand's name, the hidden ones included.
[[nodiscard]] std::vector<std::string> command_names(const CLI::App& root);

// Prints "demfem: 'rnu' is not a demfem command; did you mean 'run'?" to stderr.
void report_unknown_command(const CLI::App& root, const std::string& word);

// Reads argv as the parser will, before it does: the first word that is not an option must name
// a subcommand, and every option must be one of that subcommand's (or, before it, of demfem's).
// The first one that is not is reported on stderr with the nearest valid word; returns false
// then. Values that start with '-' are told from options by being numbers.
[[nodiscard]] bool check_words(const CLI::App& root, int argc, const char* const* argv);

} // namespace demfem::app
