// Versioned binary checkpoints of the DEM state (layout documented in io.hpp).
#include <array>
#include <cstring>
#include <fstream>
#include <string>
#include <type_traits>

#include <fmt/format.h>

#include "atomic_file.hpp"
#include "demfem/dem/io.hpp"

namespace demfem::dem::io {
namespace {

constexpr std::array<char, 8> kMagic = {'D', 'E', 'M', 'F', 'E', 'M', 'C', 'K'};
constexpr std::uint32_t kEndianMarker = 0x01020304u;
constexpr std::uint32_t kSwappedEndianMarker = 0x04030201u;
constexpr std::size_t kNameBytes = 16;

constexpr std::uint64_t kFnvOffset = 14695981039346656037ull;
constexpr std::uint64_t kFnvPrime = 1099511628211ull;

std::uint64_t fnv1a(std::uint64_t h, std::span<const std::byte> bytes) {
  for (const std::byte b : bytes) {
    h ^= static_cast<std::uint64_t>(b);
    h *= kFnvPrime;
  }
  return h;
}

// Visits every Particles array with its on-disk name, in table order.
template <class P, class F> void for_each_array(P& p, F&& f) {
  f("x", p.x);
  f("z", p.z);
  f("phi", p.phi);
  f("vx", p.vx);
  f("vz", p.vz);
  f("omega", p.omega);
  f("fx", p.fx);
  f("fz", p.fz);
  f("torque", p.torque);
  f("radius", p.radius);
  f("mass", p.mass);
  f("inv_mass", p.inv_mass);
  f("inv_inertia", p.inv_inertia);
  f("id", p.id);
  f("material", p.material);
  f("flags", p.flags);
}

// Buffers output in chunks and keeps the running checksum.
class Writer {
public:
  explicit Writer(detail::AtomicFile& file) : file_(file) { buf_.reserve(kChunk); }

  void bytes(std::span<const std::byte> b) {
    hash_ = fnv1a(hash_, b);
    if (buf_.size() + b.size() > kChunk) flush();
    if (b.size() >= kChunk) {
      file_.write(b);
    } else {
      buf_.insert(buf_.end(), b.begin(), b.end());
    }
  }
  template <class T> void value(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes(std::as_bytes(std::span<const T>(&v, 1)));
  }
  void finish() {
    const std::uint64_t h = hash_;
    value(h);
    flush();
  }

private:
  void flush() {
    file_.write(buf_);
    buf_.clear();
  }
  static constexpr std::size_t kChunk = 1u << 20;
  detail::AtomicFile& file_;
  std::vector<std::byte> buf_;
  std::uint64_t hash_ = kFnvOffset;
};

// Bounds-checked cursor over the file's bytes.
class Reader {
public:
  Reader(const std::vector<std::byte>& data, const std::filesystem::path& path)
      : data_(data), path_(path) {}

  void bytes(void* dst, std::size_t n, const char* what) {
    if (n > data_.size() - pos_) {
      fail(fmt::format("truncated: {} needs {} bytes at offset {} but the file has {} bytes", what,
                       n, pos_, data_.size()));
    }
    if (n > 0) std::memcpy(dst, data_.data() + pos_, n);
    pos_ += n;
  }
  template <class T> T value(const char* what) {
    T v{};
    bytes(&v, sizeof v, what);
    return v;
  }
  [[nodiscard]] std::size_t pos() const { return pos_; }
  [[nodiscard]] std::size_t remaining() const { return data_.size() - pos_; }
  [[noreturn]] void fail(const std::string& why) const {
    throw IoError(fmt::format("checkpoint '{}': {}", path_.string(), why));
  }

private:
  const std::vector<std::byte>& data_;
  const std::filesystem::path& path_;
  std::size_t pos_ = 0;
};

struct TableEntry {
  std::string name;
  std::uint32_t element_size = 0;
  std::uint64_t count = 0;
};

void parse_body(Reader& r, Checkpoint& cp);

} // namespace

void write_checkpoint(const std::filesystem::path& path, const Particles& particles,
                      const CheckpointMeta& meta, std::span<const std::byte> extra) {
  const std::uint64_t n = particles.size();
  for_each_array(particles, [&](const char* name, const auto& v) {
    if (v.size() != n) {
      throw IoError(fmt::format("cannot write checkpoint '{}': Particles::{} has {} elements, "
                                "x has {}",
                                path.string(), name, v.size(), n));
    }
  });
  if (meta.label.size() > 0xFFFFFFFFu) throw IoError("checkpoint label too long");

  detail::AtomicFile file(path);
  Writer w(file);
  w.bytes(std::as_bytes(std::span<const char>(kMagic)));
  w.value(kCheckpointFormatVersion);
  w.value(kEndianMarker);
  w.value(n);
  w.value(meta.time);
  w.value(meta.step);
  w.value(meta.dt);
  w.value(static_cast<std::uint32_t>(meta.label.size()));
  w.bytes(std::as_bytes(std::span<const char>(meta.label.data(), meta.label.size())));

  std::uint32_t n_arrays = 0;
  for_each_array(particles, [&](const char*, const auto&) { ++n_arrays; });
  w.value(n_arrays);
  for_each_array(particles, [&](const char* name, const auto& v) {
    std::array<char, kNameBytes> fixed{};
    std::strncpy(fixed.data(), name, kNameBytes - 1);
    w.bytes(std::as_bytes(std::span<const char>(fixed)));
    w.value(static_cast<std::uint32_t>(sizeof(typename std::decay_t<decltype(v)>::value_type)));
    w.value(std::uint32_t{0});
    w.value(static_cast<std::uint64_t>(v.size()));
  });
  for_each_array(particles, [&](const char*, const auto& v) {
    w.bytes(std::as_bytes(std::span(v.data(), v.size())));
  });
  w.value(static_cast<std::uint64_t>(extra.size()));
  w.bytes(extra);
  w.finish();
  file.commit();
}

Checkpoint read_checkpoint(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(fmt::format("checkpoint '{}': cannot open the file", path.string()));
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) throw IoError(fmt::format("checkpoint '{}': cannot read the file", path.string()));
  in.seekg(0, std::ios::beg);
  std::vector<std::byte> data(static_cast<std::size_t>(size));
  if (!data.empty() && !in.read(reinterpret_cast<char*>(data.data()), size)) {
    throw IoError(fmt::format("checkpoint '{}': cannot read the file", path.string()));
  }

  Reader r(data, path);
  std::array<char, 8> magic{};
  if (data.size() < magic.size()) {
    r.fail(fmt::format("not a demfem checkpoint (only {} bytes, no DEMFEMCK header)", data.size()));
  }
  r.bytes(magic.data(), magic.size(), "magic");
  if (magic != kMagic) r.fail("not a demfem checkpoint (bad magic, expected \"DEMFEMCK\")");
  const auto version = r.value<std::uint32_t>("format version");
  const auto endian = r.value<std::uint32_t>("byte-order marker");
  if (endian != kEndianMarker) {
    if (endian == kSwappedEndianMarker) {
      r.fail("written on a machine of the other byte order; not supported");
    }
    r.fail(fmt::format("bad byte-order marker 0x{:08x} (corrupted header)", endian));
  }
  if (version != kCheckpointFormatVersion) {
    r.fail(fmt::format("unsupported format version {} (this build reads version {})", version,
                       kCheckpointFormatVersion));
  }

  // FNV-1a of everything before the last 8 bytes against those 8 bytes.
  const auto checksum_ok = [&data]() {
    if (data.size() < sizeof(std::uint64_t)) return false;
    const std::size_t body = data.size() - sizeof(std::uint64_t);
    std::uint64_t stored = 0;
    std::memcpy(&stored, data.data() + body, sizeof stored);
    return stored == fnv1a(kFnvOffset, std::span<const std::byte>(data.data(), body));
  };

  Checkpoint cp;
  try {
    parse_body(r, cp);
  } catch (const IoError& e) {
    if (checksum_ok()) throw;
    throw IoError(std::string(e.what()) + " (checksum mismatch: truncated or corrupted file)");
  }
  if (!checksum_ok()) r.fail("checksum mismatch: the file is corrupted");
  return cp;
}

namespace {
void parse_body(Reader& r, Checkpoint& cp) {
  const auto n = r.value<std::uint64_t>("particle count");
  cp.meta.time = r.value<double>("time");
  cp.meta.step = r.value<std::int64_t>("step");
  cp.meta.dt = r.value<double>("dt");
  const auto label_size = r.value<std::uint32_t>("label length");
  if (label_size > r.remaining()) {
    r.fail(fmt::format("truncated: label needs {} bytes at offset {}", label_size, r.pos()));
  }
  cp.meta.label.resize(label_size);
  r.bytes(cp.meta.label.data(), label_size, "label");

  const auto n_arrays = r.value<std::uint32_t>("array count");
  if (n_arrays > 1024) r.fail(fmt::format("implausible array count {}", n_arrays));
  std::vector<TableEntry> table;
  for (std::uint32_t k = 0; k < n_arrays; ++k) {
    std::array<char, kNameBytes> fixed{};
    r.bytes(fixed.data(), fixed.size(), "array name");
    TableEntry e;
    e.name.assign(fixed.data(), strnlen(fixed.data(), fixed.size()));
    e.element_size = r.value<std::uint32_t>("element size");
    (void)r.value<std::uint32_t>("reserved");
    e.count = r.value<std::uint64_t>("element count");
    table.push_back(std::move(e));
  }

  for (const TableEntry& e : table) {
    bool found = false;
    for_each_array(cp.particles, [&](const char* name, auto& v) {
      if (found || e.name != name) return;
      found = true;
      using T = typename std::decay_t<decltype(v)>::value_type;
      if (e.element_size != sizeof(T)) {
        r.fail(fmt::format("array '{}' has element size {}, expected {}", e.name, e.element_size,
                           sizeof(T)));
      }
      if (e.count != n) {
        r.fail(fmt::format("array '{}' has {} elements for {} particles", e.name, e.count, n));
      }
      if (!v.empty()) r.fail(fmt::format("array '{}' appears twice", e.name));
      if (e.count > r.remaining() / sizeof(T)) {
        r.fail(fmt::format("truncated: array '{}' needs {} bytes at offset {}", e.name,
                           e.count * sizeof(T), r.pos()));
      }
      v.resize(static_cast<std::size_t>(e.count));
      r.bytes(v.data(), v.size() * sizeof(T), e.name.c_str());
    });
    if (!found) r.fail(fmt::format("unknown array '{}'", e.name));
  }
  for_each_array(cp.particles, [&](const char* name, const auto& v) {
    if (v.size() != n) r.fail(fmt::format("array '{}' is missing", name));
  });

  const auto extra_size = r.value<std::uint64_t>("extra size");
  if (extra_size > r.remaining()) {
    r.fail(fmt::format("truncated: extra data needs {} bytes at offset {}", extra_size, r.pos()));
  }
  cp.extra.resize(static_cast<std::size_t>(extra_size));
  r.bytes(cp.extra.data(), cp.extra.size(), "extra data");
  (void)r.value<std::uint64_t>("checksum");
  if (r.remaining() != 0) r.fail(fmt::format("{} unexpected trailing bytes", r.remaining()));
}
} // namespace

} // namespace demfem::dem::io
