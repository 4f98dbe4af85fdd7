// ParaView .pvd collection, rewritten atomically after every addition.
#include <fstream>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include "atomic_file.hpp"
#include "demfem/dem/io.hpp"

namespace demfem::dem::io {
namespace {

std::string xml_escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (const char c : s) {
    switch (c) {
    case '&':
      out += "&amp;";
      break;
    case '<':
      out += "&lt;";
      break;
    case '>':
      out += "&gt;";
      break;
    case '"':
      out += "&quot;";
      break;
    case '\'':
      out += "&apos;";
      break;
    default:
      out += c;
    }
  }
  return out;
}

std::string xml_unescape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (s[k] != '&') {
      out += s[k];
      continue;
    }
    const std::size_t semi = s.find(';', k);
    if (semi == std::string::npos) throw IoError("bad XML entity in '" + s + "'");
    const std::string ent = s.substr(k + 1, semi - k - 1);
    if (ent == "amp")
      out += '&';
    else if (ent == "lt")
      out += '<';
    else if (ent == "gt")
      out += '>';
    else if (ent == "quot")
      out += '"';
    else if (ent == "apos")
      out += '\'';
    else
      throw IoError("unknown XML entity '&" + ent + ";'");
    k = semi;
  }
  return out;
}

// Value of attribute `name="…"` in one element's text; empty optional-like flag via `found`.
bool attribute(const std::string& element, const std::string& name, std::string& value) {
  const std::string key = " " + name + "=\"";
  const std::size_t at = element.find(key);
  if (at == std::string::npos) return false;
  const std::size_t begin = at + key.size();
  const std::size_t end = element.find('"', begin);
  if (end == std::string::npos) return false;
  value = xml_unescape(element.substr(begin, end - begin));
  return true;
}

// `file` relative to `dir` when it lies lexically beneath it, else unchanged.
std::string relative_to(const std::filesystem::path& file, const std::filesystem::path& dir) {
  const std::filesystem::path f = file.lexically_normal();
  const std::filesystem::path d = dir.lexically_normal();
  if (d.empty() || d == ".") return f.generic_string();
  auto fi = f.begin();
  for (auto di = d.begin(); di != d.end(); ++di, ++fi) {
    if (di->empty()) continue; // trailing separator
    if (fi == f.end() || *fi != *di) return f.generic_string();
  }
  std::filesystem::path rest;
  for (; fi != f.end(); ++fi) rest /= *fi;
  return rest.empty() ? f.generic_string() : rest.generic_string();
}

} // namespace

PvdCollection::PvdCollection(std::filesystem::path path) : path_(std::move(path)) {}

PvdCollection PvdCollection::resume(std::filesystem::path path, double max_time) {
  PvdCollection c(std::move(path));
  std::ifstream in(c.path_);
  if (!in) return c;
  std::stringstream buf;
  buf << in.rdbuf();
  const std::string text = buf.str();
  if (text.find("<VTKFile") == std::string::npos ||
      text.find("type=\"Collection\"") == std::string::npos ||
      text.find("</VTKFile>") == std::string::npos) {
    throw IoError("'" + c.path_.string() + "' is not a complete .pvd collection");
  }
  std::size_t pos = 0;
  while ((pos = text.find("<DataSet", pos)) != std::string::npos) {
    const std::size_t end = text.find("/>", pos);
    if (end == std::string::npos) {
      throw IoError("'" + c.path_.string() + "': unterminated DataSet element");
    }
    const std::string element = text.substr(pos, end - pos);
    std::string t, f;
    if (!attribute(element, "timestep", t) || !attribute(element, "file", f)) {
      throw IoError("'" + c.path_.string() + "': DataSet without timestep or file");
    }
    double time = 0.0;
    try {
      std::size_t used = 0;
      time = std::stod(t, &used);
      if (used != t.size()) throw std::invalid_argument(t);
    } catch (const std::exception&) {
      throw IoError("'" + c.path_.string() + "': bad timestep '" + t + "'");
    }
    if (time <= max_time) c.entries_.push_back({time, f});
    pos = end;
  }
  c.rewrite();
  return c;
}

void PvdCollection::add(double time, const std::filesystem::path& file) {
  entries_.push_back({time, relative_to(file, path_.parent_path())});
  rewrite();
}

void PvdCollection::rewrite() const {
  std::string xml;
  xml += "<?xml version=\"1.0\"?>\n";
  xml += "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n";
  xml += "  <Collection>\n";
  for (const Entry& e : entries_) {
    xml += fmt::format("    <DataSet timestep=\"{:.17g}\" group=\"\" part=\"0\" file=\"{}\"/>\n",
                       e.time, xml_escape(e.file));
  }
  xml += "  </Collection>\n";
  xml += "</VTKFile>\n";
  detail::AtomicFile out(path_);
  out.write(xml);
  out.commit();
}

} // namespace demfem::dem::io
