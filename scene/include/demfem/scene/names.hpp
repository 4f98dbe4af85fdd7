// Names that become parts of paths. A scene's name and a variant's name name the run directory
// (runs/<scene>[/<variant>]), so they are names, never paths: letters, digits, '.', '_' and '-',
// not "." or "..", at most kMaxNameLength characters. Wall and structure names become parts of
// file names (pressure_<name>.csv) and column headers, so they may hold spaces but no path
// separator or control character.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace demfem::scene {

inline constexpr std::size_t kMaxNameLength = 100;

// Why `name` cannot be a scene or variant name (what is wrong and what would be valid), or
// nothing when it can.
[[nodiscard]] std::optional<std::string> name_problem(std::string_view name);

// Why `name` cannot be a wall or structure name, or nothing when it can.
[[nodiscard]] std::optional<std::string> part_name_problem(std::string_view name);

// `s` for a message: control and non-ASCII bytes as \xNN, cut to `max` characters with "…".
[[nodiscard]] std::string printable(std::string_view s, std::size_t max = 40);

} // namespace demfem::scene
