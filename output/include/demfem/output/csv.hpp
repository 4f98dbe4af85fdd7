// The run directory's CSV files: one streamed, checked writer and one reader.
//
// File layout: optional comment lines "# <text>", one header row of column names ("time [s]",
// "wall.thrust [N]", …; quoted per RFC 4180 when a name holds a comma, a quote or a line break),
// then one row per append(). Each value is printed with its column's format (CsvFormat; {:.9g}
// unless the writer is told otherwise).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace demfem::output {

// A failed write ("cannot write <path>: <cause> (<step>)") or a misuse of the writer (a row of the
// wrong length, no columns).
class CsvError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

// How one column's values are printed: general ({:.Pg}), fixed ({:.Pf}), scientific ({:.Pe}) or
// an integer ({} of the value cast to long long).
struct CsvFormat {
  enum class Kind : std::uint8_t { General, Fixed, Scientific, Integer };
  Kind kind = Kind::General;
  int precision = 9;

  static constexpr CsvFormat general(int p = 9) { return {Kind::General, p}; }
  static constexpr CsvFormat fixed(int p) { return {Kind::Fixed, p}; }
  static constexpr CsvFormat scientific(int p) { return {Kind::Scientific, p}; }
  static constexpr CsvFormat integer() { return {Kind::Integer, 0}; }
};

struct CsvOptions {
  std::vector<std::string> comments; // each written as "# <text>" before the header row
  std::size_t flush_every_rows = 1;  // flush to the OS after this many rows (1: every row)
  // Resume a run: when set and the file exists, keep its rows whose first value is ≤ this
  // (the checkpoint time), drop the rest, and append after them. The header row must match
  // the columns, else CsvError. When the file does not exist a new one is started.
  std::optional<double> resume_after;
  // Per column (missing entries: general, 9 digits).
  std::vector<CsvFormat> formats;
  // false: a failed write throws CsvError at once. true: the first failure is kept (error()) and
  // later rows are dropped; the caller raises it where every MPI rank can stop together.
  bool keep_errors = false;
};

class CsvWriter {
public:
  // Creates (truncates) path and writes the comments and header row.
  CsvWriter(std::filesystem::path path, std::vector<std::string> columns, CsvOptions options = {});
  ~CsvWriter();
  CsvWriter(const CsvWriter&) = delete;
  CsvWriter& operator=(const CsvWriter&) = delete;
  CsvWriter(CsvWriter&& other) noexcept;
  CsvWriter& operator=(CsvWriter&& other) noexcept;

  // One row; values.size() must equal the number of columns (else CsvError).
  void append(std::span<const double> values);
  void append(std::initializer_list<double> values) {
    append(std::span<const double>(values.begin(), values.size()));
  }
  void flush();
  // Flushes and closes; a failure is reported as by append. Later appends are dropped.
  void close();

  [[nodiscard]] const std::vector<std::string>& columns() const { return columns_; }
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  [[nodiscard]] std::size_t rows() const { return rows_; } // rows in the file, kept ones included
  // The first failed write when options.keep_errors is set ("" while none).
  [[nodiscard]] const std::string& error() const { return error_; }

private:
  void fail(const char* step, int err);
  std::filesystem::path path_;
  std::vector<std::string> columns_;
  std::vector<CsvFormat> formats_;
  std::size_t flush_every_ = 1;
  std::size_t rows_ = 0;
  std::size_t unflushed_ = 0;
  bool keep_errors_ = false;
  std::FILE* file_ = nullptr;
  std::string line_;
  std::string error_;
};

// Header cell as written: quoted with doubled quotes when it holds , " or a line break.
[[nodiscard]] std::string csv_quote(std::string_view field);

// A CSV file of the run directory read back: comment lines, the header's column names and the
// numeric rows (a cell that is not a number reads as NaN).
struct CsvTable {
  std::vector<std::string> comments; // without the leading "# "
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;

  // Index of the column whose name is `name` or starts with `name + " ["`; -1 if none.
  [[nodiscard]] int find(std::string_view name) const;
  [[nodiscard]] std::vector<double> column(std::string_view name) const; // empty if missing
};

// The table of `path`; an empty table when the file is missing or unreadable.
[[nodiscard]] CsvTable read_csv(const std::filesystem::path& path);

} // namespace demfem::output
