// Coarse-graining kernels (see coarse_grain.hpp). No I/O here.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "demfem/compare/coarse_grain.hpp"

namespace demfem::compare {

double lucy_kernel(double r, double c) {
  if (r >= c || c <= 0.0) return 0.0;
  const double q = r / c;
  // Lucy (1977), 2D normalisation 5/(π c²) so that ∫ φ dA = 1
  return 5.0 / (std::numbers::pi * c * c) * (1.0 + 3.0 * q) * std::pow(1.0 - q, 3);
}

namespace {

// Grid nodes inside the box [xa, xb] × [za, zb].
template <class F>
void for_nodes_in(const Grid& g, double xa, double xb, double za, double zb, F&& f) {
  const int i0 = std::max(0, static_cast<int>(std::ceil((xa - g.x0) / g.h)));
  const int i1 = std::min(g.nx - 1, static_cast<int>(std::floor((xb - g.x0) / g.h)));
  const int k0 = std::max(0, static_cast<int>(std::ceil((za - g.z0) / g.h)));
  const int k1 = std::min(g.nz - 1, static_cast<int>(std::floor((zb - g.z0) / g.h)));
  for (int k = k0; k <= k1; ++k)
    for (int i = i0; i <= i1; ++i) f(i, k);
}

// Solves the symmetric 3×3 system A s = b (Cramer); false when singular relative to its scale.
bool solve3(const std::array<double, 9>& A, const std::array<double, 3>& b,
            std::array<double, 3>& s) {
  auto det3 = [](const std::array<double, 9>& m) {
    return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
           m[2] * (m[3] * m[7] - m[4] * m[6]);
  };
  const double d = det3(A);
  const double scale = A[0] * A[4] * A[8];
  if (!(std::abs(d) > 1e-10 * std::abs(scale)) || scale == 0.0) return false;
  for (int c = 0; c < 3; ++c) {
    auto M = A;
    for (int r = 0; r < 3; ++r)
      M[static_cast<std::size_t>(3 * r + c)] = b[static_cast<std::size_t>(r)];
    s[static_cast<std::size_t>(c)] = det3(M) / d;
  }
  return true;
}

} // namespace

CgFields coarse_grain(const CgParticles& p, const std::vector<CgContact>& contacts,
                      const Grid& grid, double width) {
  CgFields f;
  f.grid = grid;
  f.width = width;
  const std::size_t n = grid.size();
  const double nan = std::nan("");
  f.density.assign(n, 0.0);
  f.px.assign(n, 0.0);
  f.pz.assign(n, 0.0);
  f.sxx.assign(n, 0.0);
  f.szz.assign(n, 0.0);
  f.sxz.assign(n, 0.0);
  const double c = width;
  const std::size_t np = p.x.size();
  // mass and momentum
  for (std::size_t i = 0; i < np; ++i)
    for_nodes_in(grid, p.x[i] - c, p.x[i] + c, p.z[i] - c, p.z[i] + c, [&](int a, int b) {
      const double w = lucy_kernel(std::hypot(grid.x(a) - p.x[i], grid.z(b) - p.z[i]), c);
      if (w == 0.0) return;
      const auto k = grid.at(a, b);
      f.density[k] += p.mass[i] * w;
      if (!p.vx.empty()) {
        f.px[k] += p.mass[i] * p.vx[i] * w;
        f.pz[k] += p.mass[i] * p.vz[i] * w;
      }
    });
  // contact stress: σ = Σ f_ij ⊗ (x_j − x_i) ∫_0^1 φ ds (Weinhart et al. 2012, eq. 18), with the
  // line integral by 4-point Gauss–Legendre on [0, 1]
  static constexpr double gs[4] = {0.0694318442029737, 0.3300094782075719, 0.6699905217924281,
                                   0.9305681557970263};
  static constexpr double gw[4] = {0.1739274225687269, 0.3260725774312731, 0.3260725774312731,
                                   0.1739274225687269};
  for (const auto& ct : contacts) {
    const double lx = ct.xj - ct.xi, lz = ct.zj - ct.zi;
    const double xa = std::min(ct.xi, ct.xj) - c, xb = std::max(ct.xi, ct.xj) + c;
    const double za = std::min(ct.zi, ct.zj) - c, zb = std::max(ct.zi, ct.zj) + c;
    for_nodes_in(grid, xa, xb, za, zb, [&](int a, int b) {
      double w = 0.0;
      for (int q = 0; q < 4; ++q)
        w += gw[q] *
             lucy_kernel(std::hypot(grid.x(a) - ct.xi - gs[q] * lx, grid.z(b) - ct.zi - gs[q] * lz),
                         c);
      if (w == 0.0) return;
      const auto k = grid.at(a, b);
      f.sxx[k] += ct.fx * lx * w;
      f.szz[k] += ct.fz * lz * w;
      f.sxz[k] += 0.5 * (ct.fx * lz + ct.fz * lx) * w; // symmetric part
    });
  }
  // kinetic stress −Σ m v'⊗v' φ (velocity fluctuation about the coarse-grained velocity)
  if (!p.vx.empty())
    for (std::size_t i = 0; i < np; ++i)
      for_nodes_in(grid, p.x[i] - c, p.x[i] + c, p.z[i] - c, p.z[i] + c, [&](int a, int b) {
        const double w = lucy_kernel(std::hypot(grid.x(a) - p.x[i], grid.z(b) - p.z[i]), c);
        const auto k = grid.at(a, b);
        if (w == 0.0 || f.density[k] <= 0.0) return;
        const double vx = p.vx[i] - f.px[k] / f.density[k];
        const double vz = p.vz[i] - f.pz[k] / f.density[k];
        f.sxx[k] -= p.mass[i] * vx * vx * w;
        f.szz[k] -= p.mass[i] * vz * vz * w;
        f.sxz[k] -= p.mass[i] * vx * vz * w;
      });
  // displacement: kernel-weighted least-squares affine fit u ≈ a + G (x_i − x) per node
  if (!p.ux.empty()) {
    f.ux.assign(n, nan);
    f.uz.assign(n, nan);
    f.exx.assign(n, nan);
    f.ezz.assign(n, nan);
    f.exz.assign(n, nan);
    f.vol.assign(n, nan);
    f.rotation.assign(n, nan);
    std::vector<std::array<double, 9>> A(n, std::array<double, 9>{});
    std::vector<std::array<double, 3>> bx(n, std::array<double, 3>{}),
        bz(n, std::array<double, 3>{});
    std::vector<int> cnt(n, 0);
    for (std::size_t i = 0; i < np; ++i)
      for_nodes_in(grid, p.x[i] - c, p.x[i] + c, p.z[i] - c, p.z[i] + c, [&](int a, int b) {
        const double dx = p.x[i] - grid.x(a), dz = p.z[i] - grid.z(b);
        const double w = p.mass[i] * lucy_kernel(std::hypot(dx, dz), c);
        if (w == 0.0) return;
        const auto k = grid.at(a, b);
        const double e[3] = {1.0, dx, dz};
        for (int r = 0; r < 3; ++r) {
          for (int s = 0; s < 3; ++s) A[k][static_cast<std::size_t>(3 * r + s)] += w * e[r] * e[s];
          bx[k][static_cast<std::size_t>(r)] += w * e[r] * p.ux[i];
          bz[k][static_cast<std::size_t>(r)] += w * e[r] * p.uz[i];
        }
        ++cnt[k];
      });
    for (std::size_t k = 0; k < n; ++k) {
      if (cnt[k] < 3) continue;
      std::array<double, 3> sx{}, sz{};
      if (!solve3(A[k], bx[k], sx) || !solve3(A[k], bz[k], sz)) continue;
      f.ux[k] = sx[0];
      f.uz[k] = sz[0];
      f.exx[k] = sx[1];                      // ∂u_x/∂x
      f.ezz[k] = sz[2];                      // ∂u_z/∂z
      f.exz[k] = 0.5 * (sx[2] + sz[1]);      // small-strain shear
      f.vol[k] = sx[1] + sz[2];              // ε_vol = tr ε (expansion positive)
      f.rotation[k] = 0.5 * (sz[1] - sx[2]); // ½ (∇ × u), counter-clockwise positive
    }
  }
  return f;
}

} // namespace demfem::compare
