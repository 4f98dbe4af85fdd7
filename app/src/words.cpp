#include "words.hpp"

#include <algorithm>
#include <cstdlib>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

namespace demfem::app {

std::size_t edit_distance(std::string_view a, std::string_view b) {
  // rows i − 2, i − 1 and i of the distance table between a[0, i) and b[0, j)
  std::vector<std::size_t> two(b.size() + 1), one(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) one[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      cur[j] = std::min({one[j] + 1, cur[j - 1] + 1, one[j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        cur[j] = std::min(cur[j], two[j - 2] + 1); // adjacent transposition
    }
    std::swap(two, one);
    std::swap(one, cur);
  }
  return one[b.size()];
}

std::vector<std::string> nearest_words(const std::string& word,
                                       const std::vector<std::string>& candidates) {
  const std::string_view bare = std::string_view(word).substr(
      std::min(word.find_first_not_of('-'), word.size())); // "--sovler" → "sovler"
  std::vector<std::string> begun;
  if (bare.size() >= 2)
    for (const auto& c : candidates)
      if (c.size() > word.size() && c.starts_with(word)) begun.push_back(c);
  if (begun.size() == 1) return begun;
  const std::size_t limit = std::max<std::size_t>(1, bare.size() / 3);
  std::size_t best = limit;
  std::vector<std::string> out;
  for (const auto& c : candidates) {
    const std::size_t d = edit_distance(word, c);
    if (d > best) continue;
    if (d < best) {
      best = d;
      out.clear();
    }
    if (d == best && std::find(out.begin(), out.end(), c) == out.end()) out.push_back(c);
  }
  return out;
}

std::string did_you_mean(const std::vector<std::string>& words) {
  if (words.empty()) return {};
  std::string s = "; did you mean ";
  for (std::size_t k = 0; k < words.size(); ++k)
    s += fmt::format("{}'{}'", k == 0 ? "" : k + 1 == words.size() ? " or " : ", ", words[k]);
  return s + "?";
}

const CLI::App* find_command(const CLI::App& root, const std::string& name) {
  for (const CLI::App* sub : root.get_subcommands([](const CLI::App*) { return true; }))
    if (sub->check_name(name)) return sub;
  return nullptr;
}

std::vector<std::string> command_names(const CLI::App& root) {
  std::vector<std::string> names;
  for (const CLI::App* sub : root.get_subcommands([](const CLI::App*) { return true; }))
    names.push_back(sub->get_name());
  return names;
}

void report_unknown_command(const CLI::App& root, const std::string& word) {
  std::vector<std::string> shown; // the hidden ones are not offered
  for (const CLI::App* sub : root.get_subcommands([](const CLI::App*) { return true; }))
    if (!sub->get_group().empty()) shown.push_back(sub->get_name());
  const auto near = nearest_words(word, shown);
  fmt::print(stderr, "demfem: '{}' is not a demfem command{}\n", word,
             near.empty() ? fmt::format(" (see 'demfem help')") : did_you_mean(near));
}

namespace {

bool is_number(const std::string& s) {
  char* end = nullptr;
  std::strtod(s.c_str(), &end);
  return end != s.c_str() && *end == '\0';
}

// The options of `app` as the command line spells them: --long, -s.
std::vector<std::string> option_words(const CLI::App& app) {
  std::vector<std::string> words;
  for (const CLI::Option* o : app.get_options()) {
    for (const auto& l : o->get_lnames()) words.push_back("--" + l);
    for (const auto& s : o->get_snames()) words.push_back("-" + s);
  }
  return words;
}

} // namespace

bool check_words(const CLI::App& root, int argc, const char* const* argv) {
  const CLI::App* app = &root;
  std::string where = "demfem";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--") break; // what follows is positional
    if (a.size() > 1 && a.front() == '-' && !is_number(a)) {
      // --name=value, -xVALUE: the name alone
      const std::string name = a.starts_with("--")
                                   ? a.substr(0, a.find('='))
                                   : a.substr(0, std::min<std::size_t>(2, a.size()));
      const auto words = option_words(*app);
      if (std::find(words.begin(), words.end(), name) != words.end()) continue;
      const auto near = nearest_words(name, words);
      fmt::print(stderr, "{}: unknown option '{}'{}\n", where, name,
                 near.empty()
                     ? fmt::format(" (see '{}')", app == &root ? std::string("demfem help")
                                                               : "demfem help " + app->get_name())
                     : did_you_mean(near));
      return false;
    }
    if (app != &root) continue; // a positional or an option's value
    const CLI::App* sub = find_command(root, a);
    if (!sub) {
      report_unknown_command(root, a);
      return false;
    }
    app = sub;
    where = "demfem " + sub->get_name();
  }
  return true;
}

} // namespace demfem::app
