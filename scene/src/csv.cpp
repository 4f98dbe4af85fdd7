#include "demfem/scene/csv.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <utility>

#include <fmt/format.h>

namespace demfem::scene {
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

[[noreturn]] void fail(const std::string& what, const std::filesystem::path& p) {
  throw CsvError(fmt::format("{} '{}': {}", what, p.string(), std::strerror(errno)));
}

// Rewrites an existing series keeping its comment lines, header and the rows whose first value
// is ≤ t; returns the number of rows kept.
std::size_t truncate_after(const std::filesystem::path& path, const std::string& header, double t) {
  std::ifstream in(path);
  if (!in) fail("cannot read", path);
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
      throw CsvError(fmt::format("cannot write '{}': {} (rewriting it for the resume)",
                                 path.string(), std::strerror(err)));
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    throw CsvError(fmt::format("cannot write '{}': {} (renaming the temporary file over it)",
                               path.string(), ec.message()));
  }
  return rows;
}

} // namespace

std::string csv_quote(const std::string& field) {
  if (field.find_first_of(",\"\r\n") == std::string::npos) return field;
  std::string out = "\"";
  for (const char c : field) {
    if (c == '"') out += '"';
    out += c;
  }
  out += '"';
  return out;
}

TimeSeriesWriter::TimeSeriesWriter(std::filesystem::path path, std::vector<std::string> columns,
                                   TimeSeriesOptions options)
    : path_(std::move(path)), columns_(std::move(columns)),
      flush_every_(options.flush_every_rows == 0 ? 1 : options.flush_every_rows) {
  if (columns_.empty()) {
    throw CsvError(fmt::format("time series '{}' needs at least one column", path_.string()));
  }
  const std::string header = header_row(columns_);
  if (options.resume_after && std::filesystem::exists(path_)) {
    rows_ = truncate_after(path_, header, *options.resume_after);
    file_ = std::fopen(path_.c_str(), "ab");
    if (file_ == nullptr) fail("cannot open", path_);
    return;
  }
  file_ = std::fopen(path_.c_str(), "wb");
  if (file_ == nullptr) fail("cannot create", path_);
  std::string head;
  for (const std::string& c : options.comments) head += "# " + c + '\n';
  head += header;
  if (std::fwrite(head.data(), 1, head.size(), file_) != head.size() || std::fflush(file_) != 0) {
    fail("cannot write", path_);
  }
}

TimeSeriesWriter::~TimeSeriesWriter() {
  if (file_ != nullptr) std::fclose(file_);
}

TimeSeriesWriter::TimeSeriesWriter(TimeSeriesWriter&& other) noexcept
    : path_(std::move(other.path_)), columns_(std::move(other.columns_)),
      flush_every_(other.flush_every_), rows_(other.rows_), unflushed_(other.unflushed_),
      file_(std::exchange(other.file_, nullptr)) {}

TimeSeriesWriter& TimeSeriesWriter::operator=(TimeSeriesWriter&& other) noexcept {
  if (this != &other) {
    if (file_ != nullptr) std::fclose(file_);
    path_ = std::move(other.path_);
    columns_ = std::move(other.columns_);
    flush_every_ = other.flush_every_;
    rows_ = other.rows_;
    unflushed_ = other.unflushed_;
    file_ = std::exchange(other.file_, nullptr);
  }
  return *this;
}

void TimeSeriesWriter::append(std::span<const double> values) {
  if (file_ == nullptr) throw CsvError("time series writer has been moved from");
  if (values.size() != columns_.size()) {
    throw CsvError(fmt::format("time series '{}': row of {} values for {} columns", path_.string(),
                               values.size(), columns_.size()));
  }
  line_.clear();
  for (std::size_t k = 0; k < values.size(); ++k) {
    if (k > 0) line_ += ',';
    fmt::format_to(std::back_inserter(line_), "{:.9g}", values[k]);
  }
  line_ += '\n';
  if (std::fwrite(line_.data(), 1, line_.size(), file_) != line_.size()) {
    fail("cannot write", path_);
  }
  ++rows_;
  if (++unflushed_ >= flush_every_) flush();
}

void TimeSeriesWriter::flush() {
  if (file_ == nullptr) return;
  if (std::fflush(file_) != 0) fail("cannot write", path_);
  unflushed_ = 0;
}

} // namespace demfem::scene
