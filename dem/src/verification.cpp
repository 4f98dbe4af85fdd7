#include "demfem/dem/verification.hpp"

#include <cmath>
#include <numbers>

#include "demfem/dem/contact/registry.hpp"

namespace demfem::dem {

std::optional<HeadOnClosedForm> head_on_closed_form(const scene::Scene& s, std::string* why) {
  const auto fail = [&](const std::string& w) -> std::optional<HeadOnClosedForm> {
    if (why) *why = w;
    return std::nullopt;
  };
  if (!s.soil.dem) return fail("the scene has no [soil.dem]");
  const auto& d = *s.soil.dem;
  if (d.particles.size() != 2) return fail("not two listed particles");
  const scene::ModelChoice law = contact::law_of(d);
  if (law.keyword != contact::CundallRebound::name)
    return fail("contact law is not cundall-rebound");
  if (s.load.gravity != 0.0 || s.load.shaking || !s.walls.empty() || !s.structures.empty())
    return fail("gravity, shaking, walls or structures act on the pair");
  if (d.damping_c != 0.0 || d.damping_d != 0.0) return fail("global damping");
  const auto& a = d.particles[0];
  const auto& b = d.particles[1];
  const double dx = b[0] - a[0], dz = b[1] - a[1], dist = std::hypot(dx, dz);
  const double nx = dx / dist, nz = dz / dist;
  const double rvx = b[3] - a[3], rvz = b[4] - a[4];
  const double vn = -(rvx * nx + rvz * nz); // approach speed
  const double vt = -rvx * nz + rvz * nx;   // tangential relative speed of the centres
  if (!(vn > 0.0) || std::abs(vt) > 1e-12 * std::abs(vn) || a[5] != 0.0 || b[5] != 0.0)
    return fail("the disks do not approach head-on without spin");
  const double rs = a[2] + b[2];
  if (!(dist > rs)) return fail("the disks touch at the start");
  HeadOnClosedForm c;
  const double m1 = d.density * std::numbers::pi * a[2] * a[2] * d.thickness; // m = ρπr²t
  const double m2 = d.density * std::numbers::pi * b[2] * b[2] * d.thickness;
  if (d.sphere_mass) return fail("sphere mass convention");
  c.m_star = m1 * m2 / (m1 + m2); // reduced mass of the pair
  c.approach = vn;
  // Newton restitution above V_0 (paper §2.1.2 iv, dem/contact/rebound.hpp): the pair separates
  // at K v_n; slower contacts are elastic.
  const auto& rebound = law.get<contact::Rebound::Params>();
  const double k = vn > rebound.rebound_speed ? rebound.rebound : 1.0;
  c.separation = k * vn;
  c.dissipated = 0.5 * c.m_star * vn * vn * (1.0 - k * k); // ½ m* v² (1 − K²)
  c.touch_time = (dist - rs) / vn;
  // half period of the linear pair oscillator, π √(m*/K_n) (paper §2.1.2), amplitude-free
  c.contact_time =
      std::numbers::pi * std::sqrt(c.m_star / law.get<contact::LinearSpring::Params>().kn);
  c.radius_sum = rs;
  const double vcx = (m1 * a[3] + m2 * b[3]) / (m1 + m2), vcz = (m1 * a[4] + m2 * b[4]) / (m1 + m2);
  c.kinetic_cm = 0.5 * (m1 + m2) * (vcx * vcx + vcz * vcz);
  if (!(c.touch_time + c.contact_time < s.info.duration))
    return fail("the pair has not separated by the end of the run");
  return c;
}

} // namespace demfem::dem
