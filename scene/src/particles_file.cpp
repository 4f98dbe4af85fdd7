#include "demfem/scene/particles_file.hpp"

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <optional>
#include <stdexcept>
#include <string_view>

#include <fmt/format.h>

#include <fmt/ranges.h>

#include "demfem/scene/names.hpp"
#include "demfem/scene/resources.hpp"
#include "demfem/scene/validate.hpp"
#include "demfem/scene/write_file.hpp"

namespace demfem::scene {

namespace {

constexpr std::array<std::string_view, 6> kColumns = {"x", "z", "r", "vx", "vz", "omega"};

std::string lower_ext(const std::filesystem::path& p) {
  std::string e = p.extension().string();
  for (auto& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

class Collector {
public:
  Collector(std::string file, std::string key, std::vector<Diagnostic>& diags, std::size_t max)
      : file_(std::move(file)), key_(std::move(key)), diags_(diags), max_(max) {}
  void add(int line, int col, const std::string& msg) {
    if (count_++ < max_) diags_.push_back({file_, line, col, key_, msg});
  }
  void finish() {
    if (count_ > max_)
      diags_.push_back({file_, 0, 0, key_,
                        fmt::format("{} more problems in this file not shown", count_ - max_)});
  }
  [[nodiscard]] std::size_t count() const { return count_; }

private:
  std::string file_, key_;
  std::vector<Diagnostic>& diags_;
  std::size_t max_, count_ = 0;
};

// The memory a particle file may take: rows × kBytesPerParticle (what the DEM holds per
// particle) against the limit, checked before the rows are read (.npy) or as they are (.csv).
struct Budget {
  std::size_t max_rows = kMaxParticleFileRows;
  std::optional<double> bytes; // unset: no memory limit known
  std::string source;
  [[nodiscard]] bool fits(std::size_t rows) const {
    return !bytes || static_cast<double>(rows) * kBytesPerParticle <= *bytes;
  }
  [[nodiscard]] std::string too_many(std::size_t rows, bool at_least) const {
    return fmt::format("{}{} particles need about {} of memory ({:.0f} B each: state, neighbour "
                       "lists, contacts), but this machine has {} available ({}); at most about "
                       "{:.0f} particles fit",
                       at_least ? "about " : "", rows,
                       format_bytes(static_cast<double>(rows) * kBytesPerParticle),
                       kBytesPerParticle, format_bytes(bytes.value_or(0.0)), source,
                       std::floor(bytes.value_or(0.0) / kBytesPerParticle));
  }
};

// One line of `in` (without its '\n') into `line`, at most kMaxLine + 1 characters of it kept (a
// longer one is refused by the caller); false at the end of the file.
constexpr std::size_t kMaxLine = 4096;
bool next_line(std::istream& in, std::string& line) {
  line.clear();
  std::streambuf* sb = in.rdbuf();
  bool any = false;
  for (int c = sb->sbumpc(); c != std::char_traits<char>::eof(); c = sb->sbumpc()) {
    any = true;
    if (c == '\n') return true;
    if (line.size() <= kMaxLine) line.push_back(static_cast<char>(c));
  }
  return any;
}

// Streams the file line by line: memory grows with the rows kept, not with the file.
std::vector<ParticleRow> read_csv(std::istream& in, std::uintmax_t file_size, const Budget& budget,
                                  Collector& err) {
  std::vector<ParticleRow> rows;
  std::string text;
  std::uintmax_t consumed = 0;
  int line = 0;
  std::size_t ncols = 0; // fixed by the header or the first data row
  bool seen_data_or_header = false;
  while (next_line(in, text)) {
    consumed += text.size() + 1;
    ++line;
    if (text.size() > kMaxLine) {
      err.add(line, 1,
              fmt::format("the line is longer than {} characters: not a particle row (is this "
                          "a CSV file?)",
                          kMaxLine));
      return rows;
    }
    std::size_t skip = 0;
    // a UTF-8 byte-order mark (spreadsheets write one) before the first line
    if (line == 1 && text.rfind("\xEF\xBB\xBF", 0) == 0) skip = 3;
    const std::string_view raw = std::string_view(text).substr(skip);
    const std::string_view s = trim(raw);
    if (s.empty() || s.front() == '#') continue;
    // Split into fields, remembering each field's 1-based column (in characters after the mark).
    std::array<std::string_view, 7> field{};
    std::array<int, 7> col{};
    std::size_t nf = 0;
    std::size_t k = 0;
    const std::size_t lead = static_cast<std::size_t>(s.data() - raw.data());
    while (true) {
      const std::size_t c = s.find(',', k);
      const std::string_view f = s.substr(k, c == std::string_view::npos ? s.npos : c - k);
      if (nf < field.size()) {
        const std::string_view t = trim(f);
        field[nf] = t;
        col[nf] = static_cast<int>(lead + k + static_cast<std::size_t>(t.data() - f.data()) + 1);
      }
      ++nf;
      if (c == std::string_view::npos) break;
      k = c + 1;
    }
    if (!seen_data_or_header) {
      seen_data_or_header = true;
      double probe = 0.0;
      const auto [p, ec] =
          std::from_chars(field[0].data(), field[0].data() + field[0].size(), probe);
      if (ec != std::errc() || p != field[0].data() + field[0].size()) { // a header row
        bool ok = nf == 3 || nf == 6;
        for (std::size_t q = 0; ok && q < nf; ++q) ok = field[q] == kColumns[q];
        if (!ok)
          err.add(line, col[0],
                  fmt::format("header must be 'x,z,r' or 'x,z,r,vx,vz,omega', got '{}'",
                              printable(s, 60)));
        ncols = nf == 6 ? 6 : 3;
        continue;
      }
    }
    if (nf != 3 && nf != 6) {
      err.add(line, 1,
              fmt::format("expected 3 (x, z, r) or 6 (x, z, r, vx, vz, omega) fields, "
                          "got {}",
                          nf));
      continue;
    }
    if (ncols == 0) ncols = nf;
    if (nf != ncols) {
      err.add(line, 1, fmt::format("expected {} fields like the rows before, got {}", ncols, nf));
      continue;
    }
    ParticleRow q{};
    bool ok = true;
    for (std::size_t f = 0; f < nf; ++f) {
      const auto [p, ec] =
          std::from_chars(field[f].data(), field[f].data() + field[f].size(), q[f]);
      if (ec != std::errc() || p != field[f].data() + field[f].size() || !std::isfinite(q[f])) {
        err.add(line, col[f],
                fmt::format("{}: expected a finite number, got '{}'", kColumns[f],
                            printable(field[f])));
        ok = false;
        break;
      }
    }
    if (ok && !(q[2] > 0.0)) {
      err.add(line, col[2], fmt::format("r: radius must be > 0, got {}", q[2]));
      ok = false;
    }
    if (!ok) continue;
    if (rows.size() >= budget.max_rows) {
      err.add(line, 1,
              fmt::format("more than {} particles (the most a particle file may hold, like "
                          "soil.dem.count); split the set or thin it",
                          budget.max_rows));
      return rows;
    }
    if (!budget.fits(rows.size() + 1)) {
      // the whole file, from the bytes per row so far
      const double total = static_cast<double>(rows.size() + 1) * static_cast<double>(file_size) /
                           static_cast<double>(std::max<std::uintmax_t>(consumed, 1));
      err.add(line, 1,
              fmt::format("stopped reading here: {}",
                          budget.too_many(static_cast<std::size_t>(std::max(
                                              total, static_cast<double>(rows.size() + 1))),
                                          true)));
      return rows;
    }
    rows.push_back(q);
  }
  if (rows.empty() && err.count() == 0)
    err.add(0, 0,
            fmt::format("the file holds no particles ({} line(s): comments, blank lines or a "
                        "header only); zero particles cannot be run",
                        line));
  return rows;
}

// NumPy .npy format (numpy.lib.format, versions 1.0, 2.0, 3.0), read in blocks of rows after the
// header is checked against the file's size. Problems are located by byte offset (and row).
std::vector<ParticleRow> read_npy(std::istream& in, std::uintmax_t file_size, const Budget& budget,
                                  Collector& err) {
  std::vector<ParticleRow> rows;
  char pre[12] = {};
  in.read(pre, static_cast<std::streamsize>(std::min<std::uintmax_t>(file_size, 12)));
  if (file_size < 10 || std::memcmp(pre, "\x93NUMPY", 6) != 0) {
    err.add(0, 0, "at byte 0: not a .npy file (no \\x93NUMPY magic)");
    return rows;
  }
  const auto major = static_cast<unsigned char>(pre[6]);
  std::uintmax_t hlen = 0, hstart = 0;
  if (major == 1) {
    hlen = static_cast<unsigned char>(pre[8]) |
           (static_cast<std::uintmax_t>(static_cast<unsigned char>(pre[9])) << 8);
    hstart = 10;
  } else if ((major == 2 || major == 3) && file_size >= 12) {
    for (std::size_t q = 0; q < 4; ++q)
      hlen |= static_cast<std::uintmax_t>(static_cast<unsigned char>(pre[8 + q])) << (8 * q);
    hstart = 12;
  } else {
    err.add(0, 0,
            fmt::format("at byte 6: .npy format version {} is not supported (1, 2 or 3)", major));
    return rows;
  }
  if (hlen > file_size - hstart) {
    err.add(0, 0,
            fmt::format("at byte 8: the .npy header claims {} bytes, but the file has {} after "
                        "byte {}: truncated",
                        hlen, file_size - hstart, hstart));
    return rows;
  }
  constexpr std::uintmax_t kMaxHeader = 1u << 20; // numpy writes a few hundred bytes
  if (hlen > kMaxHeader) {
    err.add(0, 0,
            fmt::format("at byte 8: a .npy header of {} bytes (at most {} accepted)", hlen,
                        kMaxHeader));
    return rows;
  }
  std::string hs(static_cast<std::size_t>(hlen), '\0');
  in.seekg(static_cast<std::streamoff>(hstart));
  in.read(hs.data(), static_cast<std::streamsize>(hlen));
  const std::string_view h(hs);
  const std::string where = fmt::format("at byte {} (the header)", hstart);
  const bool f8 = h.find("'descr': '<f8'") != h.npos || h.find("'descr': '=f8'") != h.npos;
  if (!f8) {
    err.add(0, 0,
            fmt::format("{}: .npy array must be little-endian float64 ('<f8'); header: {}", where,
                        printable(trim(h), 120)));
    return rows;
  }
  if (h.find("'fortran_order': False") == h.npos) {
    err.add(0, 0, fmt::format("{}: .npy array must be in C order (fortran_order False)", where));
    return rows;
  }
  const std::size_t sp = h.find("'shape': (");
  std::uint64_t n = 0, m = 0;
  bool shape_ok = false;
  if (sp != h.npos) { // from_chars fails (result_out_of_range) past 2^64 − 1: no wrap-around
    const char* p = h.data() + sp + 10;
    const char* end = h.data() + h.size();
    auto r1 = std::from_chars(p, end, n);
    if (r1.ec == std::errc() && r1.ptr < end && *r1.ptr == ',') {
      const char* q = r1.ptr + 1;
      while (q < end && *q == ' ') ++q;
      auto r2 = std::from_chars(q, end, m);
      shape_ok = r2.ec == std::errc() && r2.ptr < end && *r2.ptr == ')';
    }
  }
  if (!shape_ok || (m != 3 && m != 6)) {
    err.add(0, 0,
            fmt::format("{}: .npy array must have shape (N, 3) or (N, 6); header: {}", where,
                        printable(trim(h), 120)));
    return rows;
  }
  if (n == 0) {
    err.add(0, 0,
            fmt::format("{}: the .npy array has shape (0, {}): no particles; zero particles "
                        "cannot be run",
                        where, m));
    return rows;
  }
  const std::uintmax_t data = hstart + hlen;
  const std::uintmax_t row_bytes = m * sizeof(double);
  const std::uintmax_t present = file_size - data;
  if (n > present / row_bytes) { // n·row_bytes > present, without forming the product
    err.add(0, 0,
            fmt::format("{}: the header's shape ({}, {}) needs {} × {} bytes of data after byte "
                        "{}, but the file holds {} bytes there (room for {} rows): truncated, or "
                        "a wrong shape",
                        where, n, m, n, row_bytes, data, present, present / row_bytes));
    return rows;
  }
  if (n > budget.max_rows) {
    err.add(0, 0,
            fmt::format("{}: {} particles, more than {} (the most a particle file may hold, like "
                        "soil.dem.count)",
                        where, n, budget.max_rows));
    return rows;
  }
  if (!budget.fits(static_cast<std::size_t>(n))) {
    err.add(0, 0,
            fmt::format("{}: {}", where, budget.too_many(static_cast<std::size_t>(n), false)));
    return rows;
  }
  rows.resize(static_cast<std::size_t>(n));
  constexpr std::size_t kBlock = 1u << 14; // rows read at once
  std::vector<double> buf(kBlock * m);
  in.seekg(static_cast<std::streamoff>(data));
  for (std::size_t i0 = 0; i0 < rows.size(); i0 += kBlock) {
    const std::size_t nb = std::min(kBlock, rows.size() - i0);
    in.read(reinterpret_cast<char*>(buf.data()), static_cast<std::streamsize>(nb * row_bytes));
    if (!in) {
      err.add(0, 0,
              fmt::format("row {} (0-based), at byte {}: cannot read the data", i0,
                          data + i0 * row_bytes));
      return rows;
    }
    for (std::size_t b = 0; b < nb; ++b) {
      const std::size_t i = i0 + b;
      ParticleRow q{};
      std::memcpy(q.data(), buf.data() + b * m, row_bytes);
      bool ok = true;
      for (std::size_t f = 0; f < m; ++f) ok = ok && std::isfinite(q[f]);
      if (!ok || !(q[2] > 0.0))
        err.add(
            0, 0,
            fmt::format("row {} (0-based), at byte {}: need finite values and r > 0, got [{}]", i,
                        data + i * row_bytes,
                        fmt::join(q.begin(), q.begin() + static_cast<std::ptrdiff_t>(m), ", ")));
      rows[i] = q;
    }
  }
  return rows;
}

} // namespace

std::vector<ParticleRow> read_particles_file(const std::filesystem::path& path,
                                             const std::string& key, std::vector<Diagnostic>& diags,
                                             std::size_t max_errors,
                                             const ParticleFileLimits& limits) {
  Collector err(path.string(), key, diags, max_errors);
  const std::string ext = lower_ext(path);
  std::vector<ParticleRow> rows;
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  std::ifstream in(path, std::ios::binary);
  if (ext != ".csv" && ext != ".npy") {
    err.add(0, 0, "particle files must end in .csv or .npy");
  } else if (!in || ec) {
    err.add(0, 0, "cannot open the particle file (does it exist?)");
  } else {
    Budget budget;
    budget.max_rows = limits.max_rows;
    if (limits.memory_bytes) {
      budget.bytes = limits.memory_bytes;
      budget.source = limits.memory_source;
    } else if (const auto avail = available_memory()) {
      budget.bytes = avail->bytes;
      budget.source = avail->source;
    }
    rows = ext == ".csv" ? read_csv(in, size, budget, err) : read_npy(in, size, budget, err);
  }
  err.finish();
  if (err.count() > 0) rows = {};
  return rows;
}

void write_particles_file(const std::filesystem::path& path, const std::vector<ParticleRow>& rows) {
  std::string s;
  if (lower_ext(path) == ".npy") {
    std::string h =
        fmt::format("{{'descr': '<f8', 'fortran_order': False, 'shape': ({}, 6), }}", rows.size());
    const std::size_t total = 10 + h.size() + 1;
    h.append((64 - total % 64) % 64, ' ');
    h.push_back('\n');
    s.append("\x93NUMPY\x01\x00", 8);
    const auto len = static_cast<std::uint16_t>(h.size());
    s.push_back(static_cast<char>(len & 0xff));
    s.push_back(static_cast<char>(len >> 8));
    s += h;
    for (const auto& q : rows)
      s.append(reinterpret_cast<const char*>(q.data()), sizeof(double) * q.size());
  } else {
    s = "x,z,r,vx,vz,omega\n";
    for (const auto& q : rows)
      s += fmt::format("{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g}\n", q[0], q[1], q[2], q[3],
                       q[4], q[5]);
  }
  // checked and atomic: a full disk or an unwritable folder throws WriteError naming the file
  write_file_atomic(path, s);
}

} // namespace demfem::scene
