// Internal to the DEM engine: the vectorised time integration of a range of particles,
// built for several instruction sets like the pair kernel (pair_kernel.hpp) and chosen
// once at run time.
//
// Each particle's update is the scalar one (paper eqs. 2.1, 2.2, 2.16–2.18), operation for
// operation, without contraction into fused multiply-adds (the file is compiled with
// -ffp-contract=off): positions and velocities are the same bits with every instruction set.
// The sums over the range (external work, damping loss, the count of non-finite states) are
// taken in 8 lanes, lane l holding the particles i0 + l, i0 + l + 8, …, and the lanes added in
// one fixed order, so they too are the same bits with SSE2, AVX2 and AVX-512. The two largest
// squared displacements since the last rebuild (the next step's rebuild test) are exact in any
// order.
#pragma once

#include <cstddef>

#include "pair_kernel.hpp"

namespace demfem::dem::detail {

// The particle arrays (distinct: restrict lets the loop vectorise without overlap checks).
struct IntegrateArrays {
  double* __restrict x, * __restrict z, * __restrict phi, * __restrict vx, * __restrict vz, * __restrict omega;
  const double* __restrict fx, * __restrict fz, * __restrict torque, * __restrict mass, * __restrict inv_mass, * __restrict inv_inertia;
  const double* __restrict x_ref, * __restrict z_ref; // at the last rebuild; null: none
};

struct IntegrateConstants {
  double dt, gravity;
  double ax_body, az_body; // shaking (x, z) [m/s²]
  double C, D;             // damping per unit mass, per unit inertia (eqs. 2.1, 2.2)
};

struct IntegrateSums {
  double work = 0.0, damping = 0.0; // external work of the body force, damping loss [J]
  bool any_bad = false;             // a non-finite position, angle rate or velocity
  double top_a = 0.0, top_b = 0.0;  // the two largest squared displacements (a ≥ b) [m²]
};

// The arithmetic below on one particle (T = double) or on 8 consecutive ones at once (T = an
// 8-double GCC vector: element-wise IEEE operations, the same bits as 8 scalar steps).
template <class T> [[gnu::always_inline]] inline T load(const double* p, std::size_t i) {
  if constexpr (sizeof(T) == sizeof(double)) {
    return p[i];
  } else {
    T v;
    __builtin_memcpy(&v, p + i, sizeof v);
    return v;
  }
}
template <class T> [[gnu::always_inline]] inline void store(double* p, std::size_t i, T v) {
  if constexpr (sizeof(T) == sizeof(double))
    p[i] = v;
  else
    __builtin_memcpy(p + i, &v, sizeof v);
}

// One particle (or 8) one step forward: eq. 2.1 m ü + C u̇ + F = 0 (C per unit mass), eq. 2.2
// likewise with D per inertia, then symplectic Euler (eqs. 2.16–2.18). Returns x + z + ω (finite
// unless the state blew up), the body force's work and the damping loss. `Damped` false (C = D =
// 0, every run after the deposition): the damping terms are left out; they are exact zeros then
// (x − 0 = x), so the result is the same to the bit, without the two divisions per particle that
// would dominate the loop.
template <class T> struct Advanced { T s, w, ed; };
template <bool Damped, class T = double>
[[gnu::always_inline]] inline Advanced<T>
advance_particle(const IntegrateConstants& c, const IntegrateArrays& a, std::size_t i) {
  const double dt = c.dt;
  const T m = load<T>(a.mass, i), im = load<T>(a.inv_mass, i), ii = load<T>(a.inv_inertia, i);
  const T vx0 = load<T>(a.vx, i), vz0 = load<T>(a.vz, i), om0 = load<T>(a.omega, i);
  T fx = load<T>(a.fx, i) + m * c.ax_body, fz = load<T>(a.fz, i) + m * (c.az_body - c.gravity),
    tq = load<T>(a.torque, i);
  if constexpr (Damped) {
    fx -= c.C * m * vx0;
    fz -= c.C * m * vz0;
    tq -= c.D * om0 / ii;
  }
  const T vx1 = vx0 + fx * im * dt; // eq. 2.16
  const T vz1 = vz0 + fz * im * dt;
  const T om1 = om0 + tq * ii * dt; // eq. 2.17
  store<T>(a.vx, i, vx1);
  store<T>(a.vz, i, vz1);
  store<T>(a.omega, i, om1);
  const T x1 = load<T>(a.x, i) + vx1 * dt; // eq. 2.18
  const T z1 = load<T>(a.z, i) + vz1 * dt;
  store<T>(a.x, i, x1);
  store<T>(a.z, i, z1);
  store<T>(a.phi, i, load<T>(a.phi, i) + om1 * dt);
  T ed{};
  if constexpr (Damped) {
    const double Cd = c.C > 0.0 ? c.C : 0.0, Dd = c.D > 0.0 ? c.D : 0.0; // dissipation of C, D ≥ 0
    ed = Cd * m * (0.5 * (vx0 + vx1) * vx1 + 0.5 * (vz0 + vz1) * vz1) * dt +
         Dd / ii * 0.5 * (om0 + om1) * om1 * dt;
  }
  return Advanced<T>{x1 + z1 + om1, m * (c.ax_body * vx1 + c.az_body * vz1) * dt, ed};
}

// Particles i0 … i1 − 1 (none removed) one step forward, with the instruction set `isa`.
IntegrateSums integrate_particles(const IntegrateConstants& c, const IntegrateArrays& a,
                                  std::size_t i0, std::size_t i1, Isa isa);

} // namespace demfem::dem::detail
