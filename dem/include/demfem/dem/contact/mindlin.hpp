// Tangential sub-model `mindlin`: the incremental shear spring with the Mindlin–Deresiewicz
// (no-slip) tangent stiffness of two elastic spheres at the current overlap,
//   k_t = 8 G* √(R* δ),  G* = E/(4(2 − ν)(1 + ν))   (Mindlin 1949, equal materials)
// and the static/dynamic Coulomb limit (coulomb.hpp). k_t → 0 as δ → 0: at release the spring is
// already unloaded. Reads E and ν from the Hertz block (hertz.hpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "demfem/dem/contact/coulomb.hpp"
#include "demfem/dem/contact/hertz.hpp"

namespace demfem::dem::contact {

struct Mindlin {
  double g_star = 1.0; // G/(2(2 − ν)), G = E/(2(1 + ν)) [Pa]

  static std::vector<scene::ParamBlock> blocks() { return {scene::ParamBlock(Hertz::Params{})}; }
  static Mindlin from(const scene::ModelChoice& c) {
    const auto& p = c.get<Hertz::Params>();
    return {p.young / (4.0 * (2.0 - p.poisson) * (1.0 + p.poisson))};
  }

  void release(ContactHistory& h, ContactResult& /*r*/) const {
    h = ContactHistory{}; // k_t → 0 as δ → 0: the shear spring is already unloaded
  }
  [[nodiscard]] double stiffness(const ContactInput& in) const {
    return 8.0 * g_star * std::sqrt(in.r_eff * std::max(in.delta, 0.0));
  }
  void update(const ContactInput& in, double fn, ContactHistory& h, ContactResult& r) const {
    const double kt = stiffness(in);
    const double ft_trial = h.ft - kt * in.vs * in.dt;
    h.ft = detail::coulomb(ft_trial, fn, in.mu_s, in.mu_d, kt, h.flags, r.e_friction);
  }
  [[nodiscard]] double energy(const ContactInput& in, const ContactHistory& h) const {
    return 0.5 * h.ft * h.ft / stiffness(in);
  }
  // k_s = 8G*√(R*δ) at δ = 5 % of the smallest radius, R* = r_min/2 (Mindlin 1949)
  [[nodiscard]] double step_ks(double r_min) const {
    const double root = std::sqrt(0.5 * r_min * kReferenceOverlap * r_min);
    return 8.0 * g_star * root;
  }
};

} // namespace demfem::dem::contact
