// The blocked pair kernel of cundall-rebound (see pair_kernel.hpp). Compiled with
// -fno-math-errno -fno-trapping-math (dem/CMakeLists.txt) so that sqrt and the selects vectorise;
// the results are the same.
#include "pair_kernel.hpp"

#include <algorithm>
#include <cmath>

#include "demfem/dem/contact/cundall_rebound.hpp"

namespace demfem::dem::detail {

namespace {

constexpr std::int64_t kSlideBit = kHistSliding;

// One pass over the block, written without branches so that it vectorises. Each line is the
// scalar loop's (engine_forces.cpp, pair_range) or the law's (dem/contact/) operation.
template <bool OneMaterial>
[[gnu::always_inline]] inline void kernel_body(const ReboundConstants& c, const ParticleArrays& p,
                                               PairBlock& __restrict b, std::size_t m) {
  const double kn = c.kn, ks = c.ks, dt = c.dt, max_ov = c.max_overlap, dt2 = c.dt * c.dt;
  const double* __restrict vx = p.vx;
  const double* __restrict vz = p.vz;
  const double* __restrict om = p.omega;
  const double* __restrict rad = p.radius;
  const double* __restrict mass = p.mass;
  for (std::size_t e = 0; e < m; ++e) {
    const std::uint64_t i = b.i[e], j = b.j[e];
    const double dx = b.dx[e], dz = b.dz[e], ri = rad[i], rj = rad[j]; // x_i − x_j (gather)
    const double rsum = ri + rj;
    const double d2 = dx * dx + dz * dz;
    const double dist = std::sqrt(d2);
    const double delta = rsum - dist; // eq. 2.3
    const bool apart = dist > 0.0;
    const double inv1 = 1.0 / (apart ? dist : 1.0);
    const double inv = apart ? inv1 : 0.0;
    const double nx = dx * inv, nz = dz * inv; // from j to i (eq. 2.4)
    const double tx = -nz, tz = nx;
    const double li = ri - 0.5 * delta, lj = rj - 0.5 * delta;
    const double dvx = vx[i] - vx[j], dvz = vz[i] - vz[j];
    const double vn = -(dvx * nx + dvz * nz);                          // eq. 2.5
    const double vs = dvx * tx + dvz * tz - (li * om[i] + lj * om[j]); // eq. 2.5
    const double mi = mass[i], mj = mass[j];
    // A closed contact that stays closed: f_n = K_n δ (eq. 2.6; linear_spring_force's first case)
    const double fc = kn * delta;
    const std::int64_t fl = b.fl[e];
    const double rmin = ri < rj ? ri : rj;
    const bool fast = ((fl & kHistActive) >= 1) & (delta > 0.0) & (fc > 0.0) &
                      contact::detail::stays_closed(delta, vn, dt, dt2, fc, mi, mj) &
                      !(delta > max_ov * rmin);
    // Shear spring and Coulomb limit (eqs. 2.9, 2.13; contact::detail::coulomb with f_n > 0)
    const double ft_trial = b.ft[e] - ks * vs * dt;
    const bool sliding = (fl & kHistSliding) != 0;
    const double mus = OneMaterial ? c.mus0 : b.mus[e], mud = OneMaterial ? c.mud0 : b.mud[e];
    const double limit = (sliding ? mud : mus) * fc;
    const bool over = std::abs(ft_trial) > limit;
    const double ftc = std::copysign(mud * fc, ft_trial);
    // contact::detail::coulomb's two energies share its division: (s ? a : b)/k = s ? a/k : b/k
    // exactly
    const double ef_num =
        sliding ? std::abs(ftc * (ft_trial - ftc)) : 0.5 * (ft_trial * ft_trial - ftc * ftc);
    const double ft = over ? ftc : ft_trial;
    const double ef = ef_num / ks;
    b.e_fric[e] = over ? ef : 0.0;
    const std::int64_t slide_bit = over ? std::int64_t{kSlideBit} : 0;
    const std::int64_t slow_bit = fast ? 0 : std::int64_t{PairBlock::kSlow};
    b.fl_new[e] = ((fl & ~std::int64_t{kSlideBit}) | slide_bit) | slow_bit;
    b.ft_new[e] = ft;
    b.fn[e] = fc;
    b.e_n[e] = 0.5 * kn * delta * delta; // spring energies after the step
    b.e_s[e] = 0.5 * ft * ft / ks;
    b.fx[e] = fc * nx + ft * tx; // eq. 2.15
    b.fz[e] = fc * nz + ft * tz;
    b.ti[e] = li * ft;
    b.tj[e] = lj * ft;
  }
}

void kernel_portable(const ReboundConstants& c, const ParticleArrays& p, PairBlock& b,
                     std::size_t m) {
  if (c.one_material)
    kernel_body<true>(c, p, b, m);
  else
    kernel_body<false>(c, p, b, m);
}

#if defined(__x86_64__) && defined(__GNUC__)
// AVX2 only, no FMA: the operations round as the portable build's do.
[[gnu::target("avx2")]] void kernel_avx2(const ReboundConstants& c, const ParticleArrays& p,
                                         PairBlock& b, std::size_t m) {
  if (c.one_material)
    kernel_body<true>(c, p, b, m);
  else
    kernel_body<false>(c, p, b, m);
}
// AVX-512, 8 entries at once. FMA is available here: the file is compiled with
// -ffp-contract=off (dem/CMakeLists.txt), so the operations still round as the portable build's.
[[gnu::target("avx512f,avx512dq,avx512vl,prefer-vector-width=512")]] void
kernel_avx512(const ReboundConstants& c, const ParticleArrays& p, PairBlock& b, std::size_t m) {
  if (c.one_material)
    kernel_body<true>(c, p, b, m);
  else
    kernel_body<false>(c, p, b, m);
}
Isa widest_isa() {
  static const Isa isa = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
                                 __builtin_cpu_supports("avx512vl")
                             ? Isa::avx512
                         : __builtin_cpu_supports("avx2") ? Isa::avx2
                                                          : Isa::portable;
  return isa;
}
#else
void kernel_avx2(const ReboundConstants& c, const ParticleArrays& p, PairBlock& b, std::size_t m) {
  kernel_portable(c, p, b, m);
}
void kernel_avx512(const ReboundConstants& c, const ParticleArrays& p, PairBlock& b,
                   std::size_t m) {
  kernel_portable(c, p, b, m);
}
Isa widest_isa() {
  return Isa::portable;
}
#endif

} // namespace

Isa isa_up_to(Isa cap) {
  return std::min(cap, widest_isa());
}

void rebound_kernel(const ReboundConstants& c, const ParticleArrays& p, PairBlock& b, std::size_t m,
                    Isa isa) {
  switch (isa) {
  case Isa::avx512:
    kernel_avx512(c, p, b, m);
    return;
  case Isa::avx2:
    kernel_avx2(c, p, b, m);
    return;
  case Isa::portable:
    kernel_portable(c, p, b, m);
    return;
  }
}

} // namespace demfem::dem::detail
