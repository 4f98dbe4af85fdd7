#include "demfem/scene/names.hpp"

#include <fmt/format.h>

namespace demfem::scene {

namespace {

bool name_char(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' ||
         c == '_' || c == '-';
}

constexpr const char* kValidName = "valid: letters, digits, '.', '_' and '-' (e.g. \"case-2\"), "
                                   "not \".\" or \"..\"";

} // namespace

std::string printable(std::string_view s, std::size_t max) {
  std::string out;
  std::size_t shown = 0;
  for (const char c : s) {
    if (shown == max) {
      out += "…";
      break;
    }
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u >= 0x7f)
      out += fmt::format("\\x{:02x}", u);
    else
      out += c;
    ++shown;
  }
  return out;
}

std::optional<std::string> name_problem(std::string_view name) {
  if (name.empty()) return fmt::format("the name is empty; {}", kValidName);
  if (name.size() > kMaxNameLength)
    return fmt::format("the name \"{}\" has {} characters, more than {}; {}", printable(name),
                       name.size(), kMaxNameLength, kValidName);
  if (name == "." || name == "..")
    return fmt::format("\"{}\" names a directory, not a run; {}", name, kValidName);
  for (std::size_t i = 0; i < name.size(); ++i)
    if (!name_char(name[i]))
      return fmt::format("the name \"{}\" holds '{}' at character {}: it names the run "
                         "directory, so it must be a name, not a path; {}",
                         printable(name), printable(name.substr(i, 1)), i + 1, kValidName);
  return std::nullopt;
}

std::optional<std::string> part_name_problem(std::string_view name) {
  if (name.size() > kMaxNameLength)
    return fmt::format("the name \"{}\" has {} characters, more than {}", printable(name),
                       name.size(), kMaxNameLength);
  for (std::size_t i = 0; i < name.size(); ++i) {
    const auto u = static_cast<unsigned char>(name[i]);
    if (name[i] == '/' || name[i] == '\\' || u < 0x20 || u == 0x7f)
      return fmt::format("the name \"{}\" holds '{}' at character {}; it becomes part of file "
                         "names (pressure_<name>.csv): give it without '/', '\\' or control "
                         "characters",
                         printable(name), printable(name.substr(i, 1)), i + 1);
  }
  return std::nullopt;
}

} // namespace demfem::scene
