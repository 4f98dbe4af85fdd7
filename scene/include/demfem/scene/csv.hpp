// CSV time series shared by the DEM and continuum solvers' probes.
//
// File layout: optional comment lines starting with "# " (e.g. "# demfem 0.1.0"), one header
// row of column names ("time [s]", "force [N]", …; quoted per RFC 4180 when needed), then one
// row per append(), every value printed with {:.9g}.
#pragma once

#include <cstddef>
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace demfem::scene {

class CsvError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

struct TimeSeriesOptions {
  std::vector<std::string> comments; // each written as "# <text>" before the header row
  std::size_t flush_every_rows = 1;  // flush to the OS after this many rows (1: every row)
  // Resume a run: when set and the file exists, keep its rows whose first value is ≤ this
  // (the checkpoint time), drop the rest, and append after them. The header row must match
  // `columns`, else CsvError. When the file does not exist a new one is started.
  std::optional<double> resume_after;
};

class TimeSeriesWriter {
public:
  // Creates (truncates) path and writes the comments and header row. Throws CsvError when the
  // file cannot be opened or columns is empty.
  TimeSeriesWriter(std::filesystem::path path, std::vector<std::string> columns,
                   TimeSeriesOptions options = {});
  ~TimeSeriesWriter();
  TimeSeriesWriter(const TimeSeriesWriter&) = delete;
  TimeSeriesWriter& operator=(const TimeSeriesWriter&) = delete;
  TimeSeriesWriter(TimeSeriesWriter&& other) noexcept;
  TimeSeriesWriter& operator=(TimeSeriesWriter&& other) noexcept;

  // One row; values.size() must equal the number of columns (else CsvError).
  void append(std::span<const double> values);
  void append(std::initializer_list<double> values) {
    append(std::span<const double>(values.begin(), values.size()));
  }
  void flush();

  [[nodiscard]] const std::vector<std::string>& columns() const { return columns_; }
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  [[nodiscard]] std::size_t rows() const { return rows_; } // rows in the file, kept ones included

private:
  std::filesystem::path path_;
  std::vector<std::string> columns_;
  std::size_t flush_every_ = 1;
  std::size_t rows_ = 0;
  std::size_t unflushed_ = 0;
  std::FILE* file_ = nullptr;
  std::string line_;
};

// Header cell as written: quoted with doubled quotes when it holds , " or a line break.
[[nodiscard]] std::string csv_quote(const std::string& field);

} // namespace demfem::scene
