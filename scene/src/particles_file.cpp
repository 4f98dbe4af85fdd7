#include "demfem/scene/particles_file.hpp"

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string_view>

#include <fmt/format.h>

#include "demfem/scene/write_file.hpp"
#include <fmt/ranges.h>

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

std::vector<ParticleRow> read_csv(const std::string& text, Collector& err) {
  std::vector<ParticleRow> rows;
  rows.reserve(text.size() / 40);
  std::size_t pos = 0;
  int line = 0;
  std::size_t ncols = 0; // fixed by the header or the first data row
  bool seen_data_or_header = false;
  while (pos < text.size()) {
    std::size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) eol = text.size();
    const std::string_view raw(text.data() + pos, eol - pos);
    const std::size_t line_start = pos;
    pos = eol + 1;
    ++line;
    const std::string_view s = trim(raw);
    if (s.empty() || s.front() == '#') continue;
    // Split into fields, remembering each field's 1-based column.
    std::array<std::string_view, 7> field{};
    std::array<int, 7> col{};
    std::size_t nf = 0;
    std::size_t k = 0;
    const std::size_t lead = static_cast<std::size_t>(s.data() - (text.data() + line_start));
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
        if (!ok) err.add(line, col[0], "header must be 'x,z,r' or 'x,z,r,vx,vz,omega'");
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
                fmt::format("{}: expected a finite number, got '{}'", kColumns[f], field[f]));
        ok = false;
        break;
      }
    }
    if (ok && !(q[2] > 0.0)) {
      err.add(line, col[2], fmt::format("r: radius must be > 0, got {}", q[2]));
      ok = false;
    }
    if (ok) rows.push_back(q);
  }
  if (rows.empty() && err.count() == 0) err.add(0, 0, "the file holds no particles");
  return rows;
}

// NumPy .npy format (numpy.lib.format, versions 1.0, 2.0, 3.0).
std::vector<ParticleRow> read_npy(const std::string& b, Collector& err) {
  std::vector<ParticleRow> rows;
  if (b.size() < 10 || std::memcmp(b.data(), "\x93NUMPY", 6) != 0) {
    err.add(0, 0, "not a .npy file (no \\x93NUMPY magic)");
    return rows;
  }
  const auto major = static_cast<unsigned char>(b[6]);
  std::size_t hlen = 0, hstart = 0;
  if (major == 1) {
    hlen = static_cast<unsigned char>(b[8]) |
           (static_cast<std::size_t>(static_cast<unsigned char>(b[9])) << 8);
    hstart = 10;
  } else if ((major == 2 || major == 3) && b.size() >= 12) {
    for (int q = 0; q < 4; ++q)
      hlen |=
          static_cast<std::size_t>(static_cast<unsigned char>(b[8 + static_cast<std::size_t>(q)]))
          << (8 * q);
    hstart = 12;
  } else {
    err.add(0, 0, fmt::format(".npy format version {} is not supported (1, 2 or 3)", major));
    return rows;
  }
  if (hstart + hlen > b.size()) {
    err.add(0, 0, ".npy header is truncated");
    return rows;
  }
  const std::string_view h(b.data() + hstart, hlen);
  const bool f8 = h.find("'descr': '<f8'") != h.npos || h.find("'descr': '=f8'") != h.npos;
  if (!f8) {
    err.add(0, 0,
            fmt::format(".npy array must be little-endian float64 ('<f8'); header: {}", trim(h)));
    return rows;
  }
  if (h.find("'fortran_order': False") == h.npos) {
    err.add(0, 0, ".npy array must be in C order (fortran_order False)");
    return rows;
  }
  const std::size_t sp = h.find("'shape': (");
  std::size_t n = 0, m = 0;
  bool shape_ok = false;
  if (sp != h.npos) {
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
    err.add(0, 0, fmt::format(".npy array must have shape (N, 3) or (N, 6); header: {}", trim(h)));
    return rows;
  }
  const std::size_t data = hstart + hlen;
  if (b.size() - data < n * m * sizeof(double)) {
    err.add(0, 0,
            fmt::format(".npy data is truncated: {} × {} doubles need {} bytes, {} present", n, m,
                        n * m * sizeof(double), b.size() - data));
    return rows;
  }
  rows.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    ParticleRow q{};
    std::memcpy(q.data(), b.data() + data + i * m * sizeof(double), m * sizeof(double));
    bool ok = true;
    for (std::size_t f = 0; f < m; ++f) ok = ok && std::isfinite(q[f]);
    if (!ok || !(q[2] > 0.0))
      err.add(0, 0,
              fmt::format("row {} (0-based): need finite values and r > 0, got [{}]", i,
                          fmt::join(q.begin(), q.begin() + static_cast<std::ptrdiff_t>(m), ", ")));
    rows[i] = q;
  }
  return rows;
}

} // namespace

std::vector<ParticleRow> read_particles_file(const std::filesystem::path& path,
                                             const std::string& key, std::vector<Diagnostic>& diags,
                                             std::size_t max_errors) {
  Collector err(path.string(), key, diags, max_errors);
  const std::string ext = lower_ext(path);
  std::vector<ParticleRow> rows;
  if (ext != ".csv" && ext != ".npy") {
    err.add(0, 0, "particle files must end in .csv or .npy");
  } else {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
      err.add(0, 0, "cannot open the particle file (does it exist?)");
    } else {
      std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      rows = ext == ".csv" ? read_csv(text, err) : read_npy(text, err);
    }
  }
  err.finish();
  if (err.count() > 0) rows.clear();
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
