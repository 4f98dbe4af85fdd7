// `demfem check SCENE`: validates a scene file (all its variants) and summarises it, one line per
// variant, or lists its errors with file:line:column.
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "command.hpp"
#include "scenes.hpp"

namespace demfem::app {

namespace {

// The resolved scene as "section.key = value" entries (a continuation line of a multi-line
// value is appended to its entry), for the variant summary of `check`.
std::vector<std::pair<std::string, std::string>> flatten_toml(const std::string& text) {
  std::vector<std::pair<std::string, std::string>> out;
  std::string section;
  std::map<std::string, int> tables;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    const std::string t = line.substr(first);
    const bool header =
        t.front() == '[' && t.back() == ']' &&
        t.find_first_not_of("[]._-abcdefghijklmnopqrstuvwxyz0123456789") == std::string::npos;
    if (header) { // [a.b] or [[a]] (the k-th entry of an array of tables: a[k])
      const bool array = t.starts_with("[[");
      std::string name = t;
      std::erase(name, '[');
      std::erase(name, ']');
      section = array ? fmt::format("{}[{}]", name, tables[name]++) : name;
      continue;
    }
    const auto eq = line.find(" = ");
    if (eq != std::string::npos && line.find_first_of("[{\"") > eq) {
      out.emplace_back((section.empty() ? "" : section + ".") + line.substr(first, eq - first),
                       line.substr(eq + 3));
    } else if (!out.empty()) {
      out.back().second += line.substr(first);
    }
  }
  // Inline tables { a = 1, b = [ 2, 3 ] } → one entry per member (key.a, key.b).
  std::vector<std::pair<std::string, std::string>> flat;
  for (auto& [k, v] : out) {
    if (v.size() < 2 || v.front() != '{' || v.back() != '}' ||
        v.find('{', 1) != std::string::npos) {
      flat.emplace_back(k, v);
      continue;
    }
    int depth = 0;
    std::size_t start = 1;
    for (std::size_t i = 1; i < v.size(); ++i) {
      const char c = v[i];
      if (c == '[' || c == '{') ++depth;
      if ((c == ']' || c == '}') && depth > 0 && i + 1 < v.size()) --depth;
      if ((c == ',' && depth == 0) || i + 1 == v.size()) {
        std::string m = v.substr(start, i - start);
        const auto a = m.find_first_not_of(' '), e = m.find(" = ");
        if (a != std::string::npos && e != std::string::npos) {
          std::string val = m.substr(e + 3);
          while (!val.empty() && val.back() == ' ') val.pop_back();
          flat.emplace_back(k + "." + m.substr(a, e - a), val);
        }
        start = i + 1;
      }
    }
  }
  return flat;
}

// One line per scene: what it is, and for a variant what it changes against the base scene.
void print_summary(const scene::SceneFile& file) {
  const auto& b = file.base;
  const auto solvers = [](const scene::Scene& s) {
    std::vector<std::string> v;
    if (s.uses(scene::Solver::Dem)) v.emplace_back("dem");
    if (s.uses(scene::Solver::Continuum)) v.emplace_back("continuum");
    return fmt::format("{}", fmt::join(v, "+"));
  };
  fmt::print("{} — {}\n  base: {}, {} s{}, {} wall(s), {} structure(s)\n", b.info.name,
             b.info.description, solvers(b), b.info.duration,
             b.soil.dem ? fmt::format(", {} particles", b.soil.dem->count) : std::string(),
             b.walls.size(), b.structures.size());
  const auto base = flatten_toml(scene::to_toml(b));
  const std::map<std::string, std::string> base_map(base.begin(), base.end());
  const auto shorten = [](const std::string& s) {
    return s.size() > 40 ? s.substr(0, 37) + "…" : s;
  };
  for (const auto& v : file.variants) {
    std::vector<std::string> changes;
    for (const auto& [k, val] : flatten_toml(scene::to_toml(v))) {
      const auto it = base_map.find(k);
      const std::string was = it == base_map.end() ? "(none)" : it->second;
      if (was != val) changes.push_back(fmt::format("{} {} → {}", k, shorten(was), shorten(val)));
    }
    fmt::print("  {:<22} {}{}{}\n", v.variant, v.variant_description,
               v.variant_description.empty() ? "" : " — ",
               changes.empty() ? std::string("(no change)")
                               : fmt::format("{}", fmt::join(changes, "; ")));
  }
  fmt::print("  (`demfem check --resolved` prints every resolved value)\n");
}

int cmd_check(const std::string& path, bool quiet, bool resolved) {
  int rc = kOk;
  const auto file = load_or_report(path, rc);
  if (rc != kOk) return rc;
  if (!quiet && !resolved) print_summary(file);
  if (!quiet && resolved) {
    fmt::print("{}", scene::to_toml(file.base));
    for (const auto& v : file.variants) {
      fmt::print("\n# ===== variant {} =====\n", v.variant);
      fmt::print("{}", scene::to_toml(v));
    }
  }
  fmt::print(
      stderr, "{}: OK ({} variant(s){})\n", path, file.variants.size(),
      file.variants.empty() ? "" : ": " + fmt::format("{}", fmt::join(file.variant_names(), ", ")));
  return kOk;
}

struct CheckArgs {
  std::string path;
  bool quiet = false;
  bool resolved = false;
};

[[maybe_unused]] const bool registered = register_command(
    {"check",
     "Validate a scene file (all its variants) and summarise it, one line per variant, or list "
     "its errors with file:line:column.",
     20, false, [](CLI::App&, CLI::App& sub) -> std::function<int()> {
       auto ca = std::make_shared<CheckArgs>();
       sub.add_option("scene", ca->path, "Scene file (TOML)")->required();
       sub.add_flag("-q,--quiet", ca->quiet, "Only report OK or the errors");
       sub.add_flag("--resolved", ca->resolved,
                    "Print the whole resolved scene (all variants) instead of the summary");
       return [ca] { return cmd_check(ca->path, ca->quiet, ca->resolved); };
     }});

} // namespace

} // namespace demfem::app
