// Text for HTML pages (report, study pages): one escaping for every page compare/ writes.
#pragma once

#include <string>

namespace demfem::compare {

// &, <, > and " as entities (safe in element text and in double-quoted attributes).
inline std::string html_escape(const std::string& s) {
  std::string o;
  o.reserve(s.size());
  for (const char c : s) {
    switch (c) {
    case '&':
      o += "&amp;";
      break;
    case '<':
      o += "&lt;";
      break;
    case '>':
      o += "&gt;";
      break;
    case '"':
      o += "&quot;";
      break;
    default:
      o += c;
    }
  }
  return o;
}

} // namespace demfem::compare
