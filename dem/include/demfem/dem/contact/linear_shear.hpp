// Tangential sub-model `linear shear spring`: the incremental shear spring e_s ← e_s − K_s v_s Δt
// (paper eq. 2.9: e_s ← e_s + K_s Δu_s) with the static/dynamic Coulomb limit (eqs. 2.12, 2.13;
// coulomb.hpp) on the elastic normal force. At release the spring's energy counts as dissipated.
#pragma once

#include <vector>

#include "demfem/dem/contact/coulomb.hpp"
#include "demfem/scene/params.hpp"

namespace demfem::dem::contact {

struct LinearShear {
  struct Params {
    static constexpr const char* kName = "linear-shear";
    double ks = 3.0e5; // [N/m]
    void fields(scene::ParamVisitor& v) {
      v.number({"ks", "K_s", "N/m",
                "shear spring stiffness of the linear laws: the tangential force grows by K_s "
                "per metre of slip until the Coulomb limit μ f_n (paper eqs. 2.9, 2.13)",
                scene::Scale::stiffness},
               ks, scene::positive());
    }
  } p;

  static std::vector<scene::ParamBlock> blocks() { return {scene::ParamBlock(Params{})}; }
  static LinearShear from(const scene::ModelChoice& c) { return {c.get<Params>()}; }

  // The contact ended: the history is reset, the remaining spring energy dissipated.
  void release(ContactHistory& h, ContactResult& r) const {
    if (h.flags != 0) detail::end_contact(h, p.ks, r);
  }
  // h.ft after the step: the elastic increment (eq. 2.9), then the Coulomb limit on the elastic
  // normal force fn; the energy taken out of the spring goes to r.e_friction.
  void update(const ContactInput& in, double fn, ContactHistory& h, ContactResult& r) const {
    const double ft_trial = h.ft - p.ks * in.vs * in.dt; // eq. 2.9 (e_s ← e_s + K_s Δu_s)
    h.ft = detail::coulomb(ft_trial, fn, in.mu_s, in.mu_d, p.ks, h.flags, r.e_friction);
  }
  [[nodiscard]] double energy(const ContactInput& /*in*/, const ContactHistory& h) const {
    return 0.5 * h.ft * h.ft / p.ks;
  }
  [[nodiscard]] double step_ks(double /*r_min*/) const { return p.ks; }
};

} // namespace demfem::dem::contact
