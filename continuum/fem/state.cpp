// The explicit integrator's state at a step boundary as bytes (a checkpoint's model part) and back
// (Model::explicit_state, Model::restore_explicit_state). What a central-difference step reads
// besides what the problem and the initialisation rebuild: the time, the replicated nodal vectors
// (u, v, a and the last force sums), every rigid body's generalised motion, every contact node's
// force and active-set state, the planes' contact work, this rank's quadrature points' states, and
// the .pvd's records written so far. Native byte order: a checkpoint is read back by the build and
// machine that wrote it (the run's digest, run.cpp, refuses another scene).
#include <cstring>
#include <string_view>
#include <type_traits>

#include "impl.hpp"

namespace demfem::continuum::fem {

namespace {

constexpr std::uint32_t kStateMagic = 0x45584331; // "EXC1"
constexpr std::uint32_t kStateVersion = 1;

static_assert(std::is_trivially_copyable_v<QpState>,
              "a quadrature point's state is saved as its bytes: keep it trivially copyable");

class Writer {
public:
  template <class T> void value(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  template <class T> void vector(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    value<std::uint64_t>(v.size());
    out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  void string(const std::string& s) {
    value<std::uint64_t>(s.size());
    out += s;
  }
  std::string out;
};

class Reader {
public:
  explicit Reader(std::string_view in) : in_(in) {}
  template <class T> T value() {
    static_assert(std::is_trivially_copyable_v<T>);
    T v;
    take(&v, sizeof(T));
    return v;
  }
  // A vector of exactly `expected` entries (the model's own size): another size is another model.
  template <class T> void vector(std::vector<T>& v, std::size_t expected, const char* what) {
    const auto n = value<std::uint64_t>();
    if (n != expected)
      fail(std::string(what) + ": " + std::to_string(n) + " entries saved, this model has " +
           std::to_string(expected));
    v.resize(n);
    take(v.data(), n * sizeof(T));
  }
  std::string string() {
    const auto n = value<std::uint64_t>();
    if (n > in_.size() - pos_) fail("truncated");
    std::string s(in_.substr(pos_, n));
    pos_ += n;
    return s;
  }
  void count(std::size_t expected, const char* what) {
    const auto n = value<std::uint64_t>();
    if (n != expected)
      fail(std::string(what) + ": " + std::to_string(n) + " saved, this model has " +
           std::to_string(expected));
  }
  void end() const {
    if (pos_ != in_.size()) fail("trailing bytes");
  }
  [[noreturn]] static void fail(const std::string& why) {
    throw std::runtime_error("the explicit state does not fit this model (" + why + ")");
  }

private:
  void take(void* p, std::size_t n) {
    if (n > in_.size() - pos_) fail("truncated");
    if (n > 0) std::memcpy(p, in_.data() + pos_, n);
    pos_ += n;
  }
  std::string_view in_;
  std::size_t pos_ = 0;
};

} // namespace

std::string Model::explicit_state() const {
  const Impl& m = *impl_;
  const Explicit::State& e = m.ex.state;
  if (!m.is_explicit() || !e.ready)
    throw std::logic_error("Model::explicit_state: no explicit step taken yet");
  Writer w;
  w.value(kStateMagic);
  w.value(kStateVersion);
  w.value<std::uint32_t>(Utilities::MPI::n_mpi_processes(m.comm));
  w.value<std::uint32_t>(sizeof(QpState)); // another build's point layout is refused
  w.value(m.t);
  w.value(m.lambda);
  for (const auto* v : {&e.u, &e.v, &e.a, &e.f, &e.f_int}) w.vector(*v);
  w.value<std::uint64_t>(e.bodies.size());
  for (const auto& b : e.bodies) {
    for (const double* x : {b.q, b.qv, b.qa, b.q_prev})
      for (int k = 0; k < 3; ++k) w.value(x[k]);
    w.value(b.passes);
    w.value(b.unsettled);
  }
  w.value<std::uint64_t>(e.contacts.size());
  for (const auto& c : e.contacts) {
    for (const double x : {c.fx, c.fz, c.N, c.Ft, c.sign}) w.value(x);
    w.value<std::uint8_t>(c.slide ? 1 : 0);
    w.value<std::int32_t>(c.status);
  }
  w.vector(e.contact_work);
  w.value(e.contact_dt);
  w.value(e.contact_tau);
  w.value(e.steps);
  for (const double s : {e.step_s, e.cells_s, e.reduce_s}) w.value(s);
  w.vector(m.committed);
  w.value<std::uint64_t>(m.pvd_records.size());
  for (const auto& [t, name] : m.pvd_records) {
    w.value(t);
    w.string(name);
  }
  return std::move(w.out);
}

void Model::restore_explicit_state(std::string_view bytes) {
  Impl& m = *impl_;
  if (!m.is_explicit())
    throw std::logic_error("Model::restore_explicit_state: the integrator is not explicit");
  Explicit::State& e = m.ex.state;
  if (!e.ready) { // the dof classes, masses, loads and cells of the first step (Explicit::advance)
    m.lambda = 1.0;
    m.ex.prepare();
  }
  Reader r(bytes);
  if (r.value<std::uint32_t>() != kStateMagic) Reader::fail("not an explicit state");
  if (const auto v = r.value<std::uint32_t>(); v != kStateVersion)
    Reader::fail("version " + std::to_string(v) + ", this demfem reads version " +
                 std::to_string(kStateVersion));
  if (const auto ranks = r.value<std::uint32_t>(); ranks != Utilities::MPI::n_mpi_processes(m.comm))
    Reader::fail("saved on " + std::to_string(ranks) + " MPI ranks, running on " +
                 std::to_string(Utilities::MPI::n_mpi_processes(m.comm)));
  if (const auto bytes_per_point = r.value<std::uint32_t>(); bytes_per_point != sizeof(QpState))
    Reader::fail("a quadrature point's state has " + std::to_string(bytes_per_point) +
                 " bytes there, " + std::to_string(sizeof(QpState)) +
                 " in this demfem (another build)");
  m.t = r.value<double>();
  m.lambda = r.value<double>();
  const std::size_t N = e.u.size();
  r.vector(e.u, N, "displacement");
  r.vector(e.v, N, "velocity");
  r.vector(e.a, N, "acceleration");
  r.vector(e.f, N, "force");
  r.vector(e.f_int, N, "internal force");
  r.count(e.bodies.size(), "rigid bodies");
  for (auto& b : e.bodies) {
    for (double* x : {b.q, b.qv, b.qa, b.q_prev})
      for (int k = 0; k < 3; ++k) x[k] = r.value<double>();
    b.passes = r.value<long>();
    b.unsettled = r.value<long>();
  }
  r.count(e.contacts.size(), "contact nodes");
  for (auto& c : e.contacts) {
    for (double* x : {&c.fx, &c.fz, &c.N, &c.Ft, &c.sign}) *x = r.value<double>();
    c.slide = r.value<std::uint8_t>() != 0;
    c.status = r.value<std::int32_t>();
  }
  r.vector(e.contact_work, e.contact_work.size(), "contact planes");
  e.contact_dt = r.value<double>();
  e.contact_tau = r.value<double>();
  e.steps = r.value<long>();
  for (double* s : {&e.step_s, &e.cells_s, &e.reduce_s}) *s = r.value<double>();
  r.vector(m.committed, m.committed.size(), "quadrature points");
  const auto records = r.value<std::uint64_t>();
  if (records > bytes.size()) Reader::fail("truncated");
  m.pvd_records.resize(records);
  for (auto& [t, name] : m.pvd_records) {
    t = r.value<double>();
    name = r.string();
  }
  r.end();
  m.dyn_init = true; // the initial acceleration is the saved one
  m.ex.publish();
}

} // namespace demfem::continuum::fem
