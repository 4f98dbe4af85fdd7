// The explicit continuum run's checkpoint file (hooks.hpp): a header, the run's identity and its
// FNV-1a digest, the loop's position, the output schedules and the model's state
// (fem::Model::explicit_state). Native byte order, as the model's part.
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <type_traits>

#include <fmt/format.h>

#include "demfem/scene/load.hpp"
#include "demfem/scene/write_file.hpp"
#include "hooks.hpp"

namespace demfem::continuum::run_detail {

namespace {

constexpr char kMagic[8] = {'D', 'E', 'M', 'F', 'E', 'M', 'C', 'C'};
constexpr std::uint32_t kVersion = 1;

// FNV-1a, 64 bits (Fowler, Noll & Vo): the identity's digest, checked before its text is compared.
std::uint64_t fnv1a(std::string_view s) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (const unsigned char c : s) {
    h ^= c;
    h *= 0x100000001b3ull;
  }
  return h;
}

struct Bytes {
  std::string out;
  template <class T> void value(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  void string(std::string_view s) {
    value<std::uint64_t>(s.size());
    out += s;
  }
  void doubles(const std::vector<double>& v) {
    value<std::uint64_t>(v.size());
    for (const double x : v) value(x);
  }
};

class Cursor {
public:
  Cursor(std::string_view in, const std::filesystem::path& path) : in_(in), path_(path) {}
  template <class T> T value() {
    static_assert(std::is_trivially_copyable_v<T>);
    T v;
    take(&v, sizeof(T));
    return v;
  }
  std::string string() {
    const auto n = value<std::uint64_t>();
    if (n > in_.size() - pos_) fail("truncated");
    std::string s(in_.substr(pos_, n));
    pos_ += n;
    return s;
  }
  std::vector<double> doubles() {
    const auto n = value<std::uint64_t>();
    if (n > (in_.size() - pos_) / sizeof(double)) fail("truncated");
    std::vector<double> v(n);
    for (double& x : v) x = value<double>();
    return v;
  }
  [[noreturn]] void fail(const std::string& why) const {
    throw std::runtime_error(fmt::format("checkpoint {}: {}", path_.string(), why));
  }
  [[nodiscard]] bool done() const { return pos_ == in_.size(); }

private:
  void take(void* p, std::size_t n) {
    if (n > in_.size() - pos_) fail("truncated (a file cut short?)");
    std::memcpy(p, in_.data() + pos_, n);
    pos_ += n;
  }
  std::string_view in_;
  std::filesystem::path path_;
  std::size_t pos_ = 0;
};

} // namespace

std::filesystem::path checkpoint_path(const std::filesystem::path& dir, int rank) {
  return dir /
         (rank == 0 ? std::string("checkpoint.ckpt") : fmt::format("checkpoint.{}.ckpt", rank));
}

std::string run_identity(const scene::Scene& scene, const fem::Problem& pb, int ranks) {
  return scene::to_toml(scene) +
         fmt::format("\n[run]\nrefinement = {}\ndegree = {}\nmpi_ranks = {}\n", pb.mesh.refinement,
                     pb.degree, ranks);
}

void write_checkpoint(const std::filesystem::path& path, const Checkpoint& c) {
  Bytes b;
  b.out.append(kMagic, sizeof kMagic);
  b.value(kVersion);
  b.value(fnv1a(c.identity));
  b.string(c.identity);
  b.value(c.step);
  b.value(c.nsteps);
  b.value(c.dt);
  b.value(c.time);
  b.value(c.next_checkpoint);
  b.value(c.probes.next_base);
  b.doubles(c.probes.next_own);
  b.value<std::int32_t>(c.snapshots.index);
  b.value(c.snapshots.next);
  b.value<std::uint8_t>(c.snapshots.last.has_value() ? 1 : 0);
  b.value(c.snapshots.last.value_or(0.0));
  for (const long long x : {c.newton, c.linear, c.cuts, c.substeps}) b.value(x);
  b.string(c.model);
  scene::write_file_atomic(path, b.out);
}

std::optional<Checkpoint> read_checkpoint(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return std::nullopt;
  std::ifstream in(path, std::ios::binary);
  std::string data{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  Cursor r(data, path);
  if (!in && !in.eof()) r.fail("cannot be read");
  if (data.size() < sizeof kMagic || std::memcmp(data.data(), kMagic, sizeof kMagic) != 0)
    r.fail("not a continuum checkpoint (no DEMFEMCC header)");
  for (std::size_t k = 0; k < sizeof kMagic; ++k) r.value<char>();
  if (const auto v = r.value<std::uint32_t>(); v != kVersion)
    r.fail(fmt::format("version {}, this demfem reads version {}", v, kVersion));
  Checkpoint c;
  const auto digest = r.value<std::uint64_t>();
  c.identity = r.string();
  if (fnv1a(c.identity) != digest) r.fail("its scene does not match its digest (a damaged file?)");
  c.step = r.value<long long>();
  c.nsteps = r.value<long long>();
  c.dt = r.value<double>();
  c.time = r.value<double>();
  c.next_checkpoint = r.value<double>();
  c.probes.next_base = r.value<double>();
  c.probes.next_own = r.doubles();
  c.snapshots.index = r.value<std::int32_t>();
  c.snapshots.next = r.value<double>();
  const bool has_last = r.value<std::uint8_t>() != 0;
  const double last = r.value<double>();
  if (has_last) c.snapshots.last = last;
  for (long long* x : {&c.newton, &c.linear, &c.cuts, &c.substeps}) *x = r.value<long long>();
  c.model = r.string();
  if (!r.done()) r.fail("trailing bytes");
  return c;
}

std::string identity_difference(const std::string& here, const std::string& saved) {
  if (here == saved) return {};
  std::istringstream a(here), b(saved);
  std::string la, lb, section;
  while (true) {
    const bool ga = static_cast<bool>(std::getline(a, la));
    const bool gb = static_cast<bool>(std::getline(b, lb));
    if (!ga && !gb) return "the same lines in another order";
    if (ga && gb && la == lb) {
      if (!la.empty() && la.front() == '[') section = la;
      continue;
    }
    const std::string where = section.empty() ? std::string() : section + " ";
    return fmt::format("{}'{}' here, '{}' in the checkpoint", where, ga ? la : "(end)",
                       gb ? lb : "(end)");
  }
}

} // namespace demfem::continuum::run_detail
