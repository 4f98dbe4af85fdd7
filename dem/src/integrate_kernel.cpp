// The vectorised time integration (integrate_kernel.hpp). Compiled, like the whole DEM library,
// with -ffp-contract=off: the AVX2 and AVX-512 builds round as the baseline build does.
#include "integrate_kernel.hpp"

#include <cmath>
#include <initializer_list>
#include <limits>

namespace demfem::dem::detail {

namespace {

constexpr std::size_t kLanes = 8;

using V = double __attribute__((vector_size(kLanes * sizeof(double)))); // 8 lanes

// Lane sums, added in one fixed order whatever the vector width.
double lane_total(const V& v) {
  return ((v[0] + v[1]) + (v[2] + v[3])) + ((v[4] + v[5]) + (v[6] + v[7]));
}

template <bool Damped, bool Displacements>
[[gnu::always_inline]] inline IntegrateSums
body(const IntegrateConstants& c, const IntegrateArrays& a, std::size_t i0, std::size_t i1) {
  // Lane sums; lane l takes the particles i0 + l, i0 + l + 8, …
  V w = {}, ed = {}, bad = {}, ta = {}, tb = {};
  const V vmax = V{} + std::numeric_limits<double>::max();
  // One particle or 8 (T = double or V) into the lanes: their sums, and each squared displacement
  // into its lane's two largest (branch-free: tb ← max(tb, min(ta, d²)), ta ← max(ta, d²), as
  // Top2::add).
  std::size_t i = i0;
  for (; i + kLanes <= i1; i += kLanes) {
    const Advanced<V> r = advance_particle<Damped, V>(c, a, i);
    w += r.w;
    ed += r.ed;
    const V abs_s = r.s < 0.0 ? -r.s : r.s;
    bad += __builtin_convertvector(abs_s <= vmax, V) + 1.0; // −1 + 1 when finite, else 1
    if constexpr (Displacements) {
      const V dx = load<V>(a.x, i) - load<V>(a.x_ref, i),
              dz = load<V>(a.z, i) - load<V>(a.z_ref, i);
      const V d2 = dx * dx + dz * dz;
      const V lo = d2 < ta ? d2 : ta;
      tb = lo > tb ? lo : tb;
      ta = d2 > ta ? d2 : ta;
    }
  }
  for (std::size_t l = 0; i < i1; ++i, ++l) {
    const Advanced<double> r = advance_particle<Damped>(c, a, i);
    w[l] += r.w;
    ed[l] += r.ed;
    bad[l] += std::abs(r.s) <= std::numeric_limits<double>::max() ? 0.0 : 1.0;
    if constexpr (Displacements) {
      const double dx = a.x[i] - a.x_ref[i], dz = a.z[i] - a.z_ref[i];
      const double d2 = dx * dx + dz * dz;
      const double lo = d2 < ta[l] ? d2 : ta[l];
      tb[l] = lo > tb[l] ? lo : tb[l];
      ta[l] = d2 > ta[l] ? d2 : ta[l];
    }
  }
  IntegrateSums s;
  s.work = lane_total(w);
  s.damping = lane_total(ed);
  s.any_bad = !(lane_total(bad) == 0.0);
  if constexpr (Displacements)
    for (std::size_t l = 0; l < kLanes; ++l) // the two largest of the lanes' two largest
      for (const double v : {ta[l], tb[l]})
        if (v > s.top_b) {
          if (v > s.top_a) {
            s.top_b = s.top_a;
            s.top_a = v;
          } else {
            s.top_b = v;
          }
        }
  return s;
}

// The four cases, each its own loop (called from functions built for one instruction set each).
[[gnu::always_inline]] inline IntegrateSums
cases(const IntegrateConstants& c, const IntegrateArrays& a, std::size_t i0, std::size_t i1) {
  const bool damped = c.C != 0.0 || c.D != 0.0, disp = a.x_ref != nullptr;
  if (damped) return disp ? body<true, true>(c, a, i0, i1) : body<true, false>(c, a, i0, i1);
  return disp ? body<false, true>(c, a, i0, i1) : body<false, false>(c, a, i0, i1);
}

IntegrateSums integrate_portable(const IntegrateConstants& c, const IntegrateArrays& a,
                                 std::size_t i0, std::size_t i1) {
  return cases(c, a, i0, i1);
}

#if defined(__x86_64__) && defined(__GNUC__)
[[gnu::target("avx2")]] IntegrateSums integrate_avx2(const IntegrateConstants& c,
                                                     const IntegrateArrays& a, std::size_t i0,
                                                     std::size_t i1) {
  return cases(c, a, i0, i1);
}
[[gnu::target("avx512f,avx512dq,avx512vl,prefer-vector-width=512")]] IntegrateSums
integrate_avx512(const IntegrateConstants& c, const IntegrateArrays& a, std::size_t i0,
                 std::size_t i1) {
  return cases(c, a, i0, i1);
}
#else
IntegrateSums integrate_avx2(const IntegrateConstants& c, const IntegrateArrays& a, std::size_t i0,
                             std::size_t i1) {
  return integrate_portable(c, a, i0, i1);
}
IntegrateSums integrate_avx512(const IntegrateConstants& c, const IntegrateArrays& a,
                               std::size_t i0, std::size_t i1) {
  return integrate_portable(c, a, i0, i1);
}
#endif

} // namespace

IntegrateSums integrate_particles(const IntegrateConstants& c, const IntegrateArrays& a,
                                  std::size_t i0, std::size_t i1, Isa isa) {
  switch (isa) {
  case Isa::avx512:
    return integrate_avx512(c, a, i0, i1);
  case Isa::avx2:
    return integrate_avx2(c, a, i0, i1);
  case Isa::portable:
    break;
  }
  return integrate_portable(c, a, i0, i1);
}

} // namespace demfem::dem::detail
