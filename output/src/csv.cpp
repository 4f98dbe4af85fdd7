#include "demfem/output/csv.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <utility>

#include <fmt/format.h>

namespace demfem::output {
namespace {

std::string header_row(const std::vector<std::string>& columns) {
  std::string row;
  for (std::size_t k = 0; k < columns.size(); ++k) {
    if (k > 0) row += ',';
    row += csv_quote(columns[k]);
  }
  row += '\n';
  return row;
}

std::string cannot_write(const std::filesystem::path& p, const std::string& cause,
                         const char* step) {
  return fmt::format("cannot write {}: {} ({})", p.string(), cause, step);
}

// Rewrites an existing series keeping its comment lines, header and the rows whose first value
// is ≤ t; returns the number of rows kept.
std::size_t truncate_after(const std::filesystem::path& path, const std::string& header, double t) {
  std::ifstream in(path);
  if (!in) throw CsvError(cannot_write(path, std::strerror(errno), "reading it for the resume"));
  std::string kept;
  std::string line;
  bool header_seen = false;
  std::size_t rows = 0;
  while (std::getline(in, line)) {
    if (!header_seen) {
      if (line.rfind("#", 0) == 0) {
        kept += line + '\n';
        continue;
      }
      if (line + '\n' != header) {
        throw CsvError(fmt::format("cannot resume '{}': its header row '{}' differs from '{}'",
                                   path.string(), line, header.substr(0, header.size() - 1)));
      }
      kept += line + '\n';
      header_seen = true;
      continue;
    }
    if (line.empty()) continue;
    const std::string first = line.substr(0, line.find(','));
    double v = 0.0;
    try {
      v = std::stod(first);
    } catch (const std::exception&) {
      break; // a torn last line from a crash: stop here
    }
    if (!(v <= t)) break;
    kept += line + '\n';
    ++rows;
  }
  if (!header_seen) {
    throw CsvError(fmt::format("cannot resume '{}': no header row", path.string()));
  }
  in.close();
  std::filesystem::path tmp = path;
  tmp += ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << kept;
    out.flush();
    if (!out) {
      const int err = errno;
      std::error_code ec;
      std::filesystem::remove(tmp, ec);
      throw CsvError(cannot_write(path, std::strerror(err), "rewriting it for the resume"));
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw CsvError(cannot_write(path, ec.message(), "renaming the temporary file over it"));
  return rows;
}

void format_value(std::string& out, double v, const CsvFormat& f) {
  auto it = std::back_inserter(out);
  switch (f.kind) {
  case CsvFormat::Kind::General:
    fmt::format_to(it, "{:.{}g}", v, f.precision);
    break;
  case CsvFormat::Kind::Fixed:
    fmt::format_to(it, "{:.{}f}", v, f.precision);
    break;
  case CsvFormat::Kind::Scientific:
    fmt::format_to(it, "{:.{}e}", v, f.precision);
    break;
  case CsvFormat::Kind::Integer:
    fmt::format_to(it, "{}", static_cast<long long>(v));
    break;
  }
}

// The cells of one line, RFC 4180 quoting undone.
std::vector<std::string> split_cells(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        cur += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        cur += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      out.push_back(std::move(cur));
      cur.clear();
    } else if (c != '\r') {
      cur += c;
    }
  }
  out.push_back(std::move(cur));
  return out;
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  const auto e = s.find_last_not_of(" \t");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

} // namespace

std::string csv_quote(std::string_view field) {
  if (field.find_first_of(",\"\r\n") == std::string_view::npos) return std::string(field);
  std::string out = "\"";
  for (const char c : field) {
    if (c == '"') out += '"';
    out += c;
  }
  out += '"';
  return out;
}

CsvWriter::CsvWriter(std::filesystem::path path, std::vector<std::string> columns,
                     CsvOptions options)
    : path_(std::move(path)), columns_(std::move(columns)), formats_(std::move(options.formats)),
      flush_every_(options.flush_every_rows == 0 ? 1 : options.flush_every_rows),
      keep_errors_(options.keep_errors) {
  if (columns_.empty()) {
    throw CsvError(fmt::format("time series '{}' needs at least one column", path_.string()));
  }
  formats_.resize(columns_.size(), CsvFormat::general());
  const std::string header = header_row(columns_);
  if (options.resume_after && std::filesystem::exists(path_)) {
    try {
      rows_ = truncate_after(path_, header, *options.resume_after);
    } catch (const CsvError& e) {
      if (!keep_errors_) throw;
      error_ = e.what();
      return;
    }
    file_ = std::fopen(path_.c_str(), "ab");
    if (file_ == nullptr) fail("opening", errno);
    return;
  }
  errno = 0;
  file_ = std::fopen(path_.c_str(), "wb");
  if (file_ == nullptr) {
    fail("creating", errno);
    return;
  }
  std::string head;
  for (const std::string& c : options.comments) head += "# " + c + '\n';
  head += header;
  if (std::fwrite(head.data(), 1, head.size(), file_) != head.size() || std::fflush(file_) != 0)
    fail("writing", errno);
}

CsvWriter::~CsvWriter() {
  if (file_ != nullptr) std::fclose(file_);
}

CsvWriter::CsvWriter(CsvWriter&& other) noexcept
    : path_(std::move(other.path_)), columns_(std::move(other.columns_)),
      formats_(std::move(other.formats_)), flush_every_(other.flush_every_), rows_(other.rows_),
      unflushed_(other.unflushed_), keep_errors_(other.keep_errors_),
      file_(std::exchange(other.file_, nullptr)), error_(std::move(other.error_)) {}

CsvWriter& CsvWriter::operator=(CsvWriter&& other) noexcept {
  if (this != &other) {
    if (file_ != nullptr) std::fclose(file_);
    path_ = std::move(other.path_);
    columns_ = std::move(other.columns_);
    formats_ = std::move(other.formats_);
    flush_every_ = other.flush_every_;
    rows_ = other.rows_;
    unflushed_ = other.unflushed_;
    keep_errors_ = other.keep_errors_;
    file_ = std::exchange(other.file_, nullptr);
    error_ = std::move(other.error_);
  }
  return *this;
}

// The first failure: thrown, or kept with the file closed (later rows are dropped).
void CsvWriter::fail(const char* step, int err) {
  const std::string message =
      cannot_write(path_, err != 0 ? std::strerror(err) : "the stream failed", step);
  if (!keep_errors_) throw CsvError(message);
  if (error_.empty()) error_ = message;
  if (file_ != nullptr) std::fclose(file_);
  file_ = nullptr;
}

void CsvWriter::append(std::span<const double> values) {
  if (values.size() != columns_.size()) {
    throw CsvError(fmt::format("time series '{}': row of {} values for {} columns", path_.string(),
                               values.size(), columns_.size()));
  }
  if (file_ == nullptr) {
    if (keep_errors_) return; // after a kept failure or close()
    throw CsvError(fmt::format("time series '{}' is closed", path_.string()));
  }
  line_.clear();
  for (std::size_t k = 0; k < values.size(); ++k) {
    if (k > 0) line_ += ',';
    format_value(line_, values[k], formats_[k]);
  }
  line_ += '\n';
  if (std::fwrite(line_.data(), 1, line_.size(), file_) != line_.size()) {
    fail("writing", errno);
    return;
  }
  ++rows_;
  if (++unflushed_ >= flush_every_) flush();
}

void CsvWriter::flush() {
  if (file_ == nullptr) return;
  if (std::fflush(file_) != 0) {
    fail("writing", errno);
    return;
  }
  unflushed_ = 0;
}

void CsvWriter::close() {
  if (file_ == nullptr) return;
  flush();
  if (file_ == nullptr) return;
  std::FILE* f = std::exchange(file_, nullptr);
  if (std::fclose(f) != 0) fail("closing", errno);
}

int CsvTable::find(std::string_view name) const {
  for (std::size_t i = 0; i < columns.size(); ++i) {
    const std::string_view c = columns[i];
    if (c == name || (c.size() > name.size() + 2 && c.substr(0, name.size()) == name &&
                      c.substr(name.size(), 2) == " ["))
      return static_cast<int>(i);
  }
  return -1;
}

std::vector<double> CsvTable::column(std::string_view name) const {
  const int c = find(name);
  std::vector<double> out;
  if (c < 0) return out;
  out.reserve(rows.size());
  for (const auto& r : rows)
    out.push_back(static_cast<std::size_t>(c) < r.size() ? r[static_cast<std::size_t>(c)] : NAN);
  return out;
}

CsvTable read_csv(const std::filesystem::path& path) {
  CsvTable t;
  std::ifstream in(path);
  std::string line;
  bool header = false;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') {
      if (!line.empty()) t.comments.push_back(trim(line.substr(1)));
      continue;
    }
    if (!header) {
      for (const auto& c : split_cells(line)) t.columns.push_back(trim(c));
      header = true;
      continue;
    }
    std::vector<double> row;
    const char* p = line.c_str();
    while (true) {
      char* end = nullptr;
      const double v = std::strtod(p, &end);
      const char* comma = std::strchr(p, ',');
      // a cell that holds no number: NaN
      row.push_back(end == p || (comma != nullptr && end > comma) ? NAN : v);
      if (comma == nullptr) break;
      p = comma + 1;
    }
    t.rows.push_back(std::move(row));
  }
  return t;
}

} // namespace demfem::output
