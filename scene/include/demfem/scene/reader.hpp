// The scene file's reader: walks one TOML table, reads typed values, records every problem as a
// Diagnostic with its file:line:col, and remembers which keys were read, so that finish() reports
// the rest as unknown with the valid keys. The loader (load.cpp) reads every section with it; a
// model outside scene/ reads its keys through a parameter block (params.hpp), which uses it, or
// with a Reader of its own table directly.
//
// Every check states what would be valid: "must be > 0, got -3", "must be in [0, 1], got 2",
// "unknown keyword 'x'; valid: a, b". A missing key takes the default given by the caller.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <toml++/toml.h>

#include "demfem/scene/load.hpp"
#include "demfem/scene/params.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::scene {

class Reader {
public:
  // `table` read under the dotted `path` ("" at the top, e.g. "soil.dem"); `file` names the scene
  // file in diagnostics; `where` locates errors about the table as a whole.
  Reader(const toml::table& table, std::string path, std::string file,
         std::vector<Diagnostic>& diags, const toml::source_region& where);
  ~Reader() = default;
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  // The dotted path of one of this table's keys ("soil.dem.kn").
  [[nodiscard]] std::string key_path(std::string_view key) const;

  // Diagnostics: at a source position, at a key of this table (or the table when absent), or at
  // the table itself.
  void error_at(const toml::source_region& src, const std::string& key, const std::string& msg);
  void error(std::string_view key, const std::string& msg);
  void error_here(const std::string& msg);

  [[nodiscard]] bool has(std::string_view key) const;
  // The key's node (nullptr when absent), marked as read.
  const toml::node* node(std::string_view key);

  // A finite number (integers accepted). Missing: the default, or an error if required.
  std::optional<double> opt_number(std::string_view key);
  double number(std::string_view key, double def);
  double required_number(std::string_view key);
  double positive(std::string_view key, double def, bool required = false);
  double non_negative(std::string_view key, double def);
  // In [lo, hi], or [lo, hi) with open_hi.
  double in_range(std::string_view key, double def, double lo, double hi, bool open_hi = false);
  int integer(std::string_view key, int def, int lo, int hi);
  bool boolean(std::string_view key, bool def);
  std::optional<std::string> opt_string(std::string_view key);
  std::string string(std::string_view key, const std::string& def);
  // The index of the key's string in `names`; an unknown word is an error listing the valid ones.
  template <std::size_t N>
  std::optional<std::size_t> keyword(std::string_view key,
                                     const std::array<const char*, N>& names) {
    const auto s = opt_string(key);
    if (!s) return std::nullopt;
    for (std::size_t i = 0; i < N; ++i)
      if (*s == names[i]) return i;
    error(key, fmt::format("unknown keyword '{}'; valid: {}", *s, fmt::join(names, ", ")));
    return std::nullopt;
  }

  std::optional<Vec2> point(std::string_view key);
  std::optional<Vec2> as_point(const toml::node& n, const std::string& kp);
  // A list of points. Missing → empty without error.
  std::vector<Vec2> points(std::string_view key, std::size_t min_count);
  // A simple polygon of at least 3 points, stored counter-clockwise.
  Polygon polygon(std::string_view key, bool required);

  // A sub-table (nullptr when absent or not a table: the latter is an error).
  const toml::table* table(std::string_view key);
  const toml::array* array_of_tables(std::string_view key);

  void mark_used(std::string_view key);
  // Reports the keys that were never read, listing `valid`.
  void finish(const std::vector<std::string>& valid);

  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] const std::string& file() const { return file_; }
  [[nodiscard]] std::vector<Diagnostic>& diags() { return diags_; }
  [[nodiscard]] const toml::table& raw() const { return t_; }

  // "a table", "the integer 3", "the string \"x\"", … for messages.
  static std::string type_name(const toml::node& n);

private:
  const toml::table& t_;
  std::string path_;
  std::string file_;
  std::vector<Diagnostic>& diags_;
  toml::source_region where_;
  std::set<std::string> used_;
};

// ---- parameter blocks and model slots through the reader (params.hpp) ---------------------------

// Reads each key of the block (missing: the block's value stays, the default), with the rule's
// message for a value outside it.
void read_params(ParamBlock& block, Reader& r);
// Reads a slot: its keyword (unknown: an error listing the valid ones), then every key of every
// model of the slot, then the chosen model's checks. Appends the keys it read to `valid` (for
// Reader::finish).
[[nodiscard]] ModelChoice read_model(Reader& r, const ModelSlot& slot,
                                     std::vector<std::string>& valid);
// Writes the block's keys into `t` (the resolved scene).
void write_params(const ParamBlock& block, toml::table& t);
// Writes the slot's keyword and keys into `t` when it is written (ModelChoice::written).
void write_model(const ModelChoice& choice, toml::table& t);

} // namespace demfem::scene
