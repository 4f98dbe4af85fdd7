#include "element_test.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace demfem::continuum::constitutive {
namespace {

hypoplastic::Tensor tensor_of(const Components& d) {
  return {d[0], d[1], 0.5 * d[2], d[3]};
}

Components components_of(const hypoplastic::Tensor& t) {
  return {{t.xx, t.zz, t.xz, t.yy}};
}

// Solves A x = b for n ≤ 4 unknowns (Gaussian elimination, partial pivoting); false if singular.
bool solve(std::size_t n, double A[4][4], double b[4], double x[4]) {
  double scale = 0.0;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j) scale = std::max(scale, std::abs(A[i][j]));
  if (!(scale > 0.0)) return false;
  for (std::size_t c = 0; c < n; ++c) {
    std::size_t piv = c;
    for (std::size_t i = c + 1; i < n; ++i)
      if (std::abs(A[i][c]) > std::abs(A[piv][c])) piv = i;
    if (std::abs(A[piv][c]) < 1e-14 * scale) return false;
    if (piv != c) {
      for (std::size_t j = 0; j < n; ++j) std::swap(A[c][j], A[piv][j]);
      std::swap(b[c], b[piv]);
    }
    for (std::size_t i = c + 1; i < n; ++i) {
      const double f = A[i][c] / A[c][c];
      for (std::size_t j = c; j < n; ++j) A[i][j] -= f * A[c][j];
      b[i] -= f * b[c];
    }
  }
  for (std::size_t i = n; i-- > 0;) {
    double s = b[i];
    for (std::size_t j = i + 1; j < n; ++j) s -= A[i][j] * x[j];
    x[i] = s / A[i][i];
  }
  return true;
}

} // namespace

ElementTest::ElementTest(Material model, State s) : point_(Plane{std::move(model), std::move(s)}) {
  history_.push_back(sample_of(Components{{0.0, 0.0, 0.0, 0.0}}));
}

namespace {
const Hypoplastic& hypoplastic_of(const Material& m) {
  if (const auto* h = m.get_if<Hypoplastic>()) return *h;
  throw std::invalid_argument(std::string("element test: a free out-of-plane strain needs a "
                                          "hypoplastic point, not ") +
                              m.keyword());
}
} // namespace

ElementTest::ElementTest(const Material& model, const hypoplastic::PointState& s)
    : point_(Free{hypoplastic_of(model), s}) {
  history_.push_back(sample_of(Components{{0.0, 0.0, 0.0, 0.0}}));
}

Sample ElementTest::sample_of(const Components& strain) const {
  Sample out;
  out.strain = strain;
  if (const auto* p = std::get_if<Plane>(&point_)) {
    out.stress = {{p->state.stress[0], p->state.stress[1], p->state.stress[2], p->state.syy}};
    if (const auto* h = p->model.get_if<Hypoplastic>()) {
      if (const auto* i = std::get_if<Hypoplastic::Internal>(&p->state.internal)) {
        out.void_ratio = h->point(p->state, *i).e;
        if (h->k.igs) out.igs = hypoplastic::norm(i->delta) / h->k.R;
      }
    }
  } else {
    const Free& f = std::get<Free>(point_);
    out.stress = components_of(f.state.stress);
    out.void_ratio = f.state.e;
    if (f.model.k.igs) out.igs = hypoplastic::norm(f.state.delta) / f.model.k.R;
  }
  return out;
}

ElementTest::Trial ElementTest::attempt(const Components& d, bool with_tangent) const {
  Trial t;
  if (const auto* p = std::get_if<Plane>(&point_)) {
    t.plane = p->state;
    VoigtMatrix tan{};
    p->model.update(p->state, Voigt{{d[0], d[1], d[2]}}, t.plane, with_tangent ? &tan : nullptr);
    t.stress = {{t.plane.stress[0], t.plane.stress[1], t.plane.stress[2], t.plane.syy}};
    if (with_tangent)
      for (std::size_t i = 0; i < 3; ++i)
        for (std::size_t j = 0; j < 3; ++j) t.tangent[i][j] = tan[i][j];
    return t;
  }
  const Free& f = std::get<Free>(point_);
  const hypoplastic::Constants& k = f.model.k;
  t.free = f.state;
  hypoplastic::Schedule schedule;
  hypoplastic::integrate(k, t.free, tensor_of(d), with_tangent ? &schedule : nullptr);
  t.stress = components_of(t.free.stress);
  if (with_tangent) {
    // central differences along the same sub-steps (hypoplastic.hpp replay)
    if (schedule.count == 0) schedule = hypoplastic::Schedule::single();
    double size = 1e-4;
    for (double v : d) size = std::max(size, std::abs(v));
    const double h = 1e-6 * size;
    for (std::size_t j = 0; j < 4; ++j) {
      Components a = d, b = d;
      a[j] += h;
      b[j] -= h;
      hypoplastic::PointState ya = f.state, yb = f.state;
      if (schedule.count >= 0) {
        hypoplastic::replay(k, ya, tensor_of(a), schedule);
        hypoplastic::replay(k, yb, tensor_of(b), schedule);
      } else {
        hypoplastic::integrate(k, ya, tensor_of(a));
        hypoplastic::integrate(k, yb, tensor_of(b));
      }
      const Components sa = components_of(ya.stress), sb = components_of(yb.stress);
      for (std::size_t i = 0; i < 4; ++i) t.tangent[i][j] = (sa[i] - sb[i]) / (2.0 * h);
    }
  }
  return t;
}

void ElementTest::commit(const Trial& t, const Components& d) {
  if (auto* p = std::get_if<Plane>(&point_))
    p->state = t.plane;
  else
    std::get<Free>(point_).state = t.free;
  Components strain = history_.back().strain;
  for (std::size_t k = 0; k < 4; ++k) strain[k] += d[k];
  history_.push_back(sample_of(strain));
}

void ElementTest::run(const Leg& leg) {
  if (leg.increments < 1) throw std::runtime_error("element test: a leg needs increments ≥ 1");
  if (std::holds_alternative<Plane>(point_) &&
      (leg.control[kYY] != Control::Strain || leg.value[kYY] != 0.0))
    throw std::runtime_error("element test: a plane-strain point keeps εyy = 0 (its yy component "
                             "must be strain-controlled with a zero increment)");
  std::size_t unknown[4];
  std::size_t nu = 0;
  for (std::size_t k = 0; k < 4; ++k)
    if (leg.control[k] == Control::Stress) unknown[nu++] = k;
  const Components s0 = history_.back().stress;
  const double n = leg.increments;
  Components guess{{0.0, 0.0, 0.0, 0.0}}; // the stress-controlled strains of the last increment
  for (int j = 1; j <= leg.increments; ++j) {
    Components d{};
    Components target{};
    for (std::size_t k = 0; k < 4; ++k) {
      if (leg.control[k] == Control::Strain) {
        d[k] = leg.value[k] / n;
      } else {
        d[k] = guess[k];
        target[k] = s0[k] + (leg.value[k] - s0[k]) * (j / n);
      }
    }
    Trial t = attempt(d, nu > 0);
    auto residual = [&](const Trial& tr) {
      double r = 0.0;
      for (std::size_t u = 0; u < nu; ++u)
        r = std::max(r, std::abs(tr.stress[unknown[u]] - target[unknown[u]]));
      return r;
    };
    for (int it = 0; nu > 0; ++it) {
      double snorm = 0.0;
      for (double v : t.stress) snorm += v * v;
      // 10⁻⁶ of the stress: above the jitter of an error-controlled integration, whose
      // sub-steps may differ between two iterations
      const double tol = 1e-6 * (std::sqrt(snorm) + 1e3);
      const double r0 = residual(t);
      if (r0 <= tol) break;
      if (it == 60)
        throw std::runtime_error("element test: stress control not met after 60 Newton "
                                 "iterations (residual " +
                                 std::to_string(r0) + " Pa)");
      double A[4][4] = {}, b[4] = {}, x[4] = {};
      for (std::size_t u = 0; u < nu; ++u) {
        b[u] = target[unknown[u]] - t.stress[unknown[u]];
        for (std::size_t v = 0; v < nu; ++v) A[u][v] = t.tangent[unknown[u]][unknown[v]];
      }
      if (!solve(nu, A, b, x))
        throw std::runtime_error("element test: singular tangent under stress control");
      // backtracking: the first of the steps 1, 1/2, 1/4, … that lowers the residual
      double lam = 1.0;
      for (int ls = 0; ls < 12; ++ls, lam *= 0.5) {
        Components dd = d;
        for (std::size_t u = 0; u < nu; ++u) dd[unknown[u]] += lam * x[u];
        Trial tt = attempt(dd, true);
        if (residual(tt) < r0 || ls == 11) {
          d = dd;
          t = std::move(tt);
          break;
        }
      }
      ++newton_;
    }
    commit(t, d);
    for (std::size_t u = 0; u < nu; ++u) guess[unknown[u]] = d[unknown[u]];
  }
}

} // namespace demfem::continuum::constitutive
