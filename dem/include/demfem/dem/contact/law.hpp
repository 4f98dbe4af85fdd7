// A contact law composed of sub-models, as LAMMPS's pair granular composes them: a normal force
// (linear spring, bonded linear spring, Hertz), a damping (none, rebound, dashpot, restitution)
// and a tangential force (linear shear spring, Mindlin), each a header of this folder with its
// parameter block. A rolling resistance sub-model is added on top (ContactModel). The composition
// is resolved at compile time: the engine's pair loop is instantiated once per law and rolling
// model (registry.hpp), with no virtual call or switch per contact.
//
// Sub-model interfaces (what Law<N, D, T> calls; see the headers for each one's physics):
//   normal N:      bonded(h), holds(δ), on_first_touch(h), force(in, v_n, bonded),
//                  energy(in, f, bonded), step_kn(r_min), stiffness(R*, δ),
//                  elastic_force(δ, R*), overlap(f, R*), kForceFormula
//   damping D:     kDashpot, on_first_touch(in, r, v_n of the spring), normal(f_el, in, N),
//                  shear(in, flags, T) (when kDashpot), step_xi(k_n, k_s, m*)
//   tangential T:  release(h, r), update(in, f_el, h, r), energy(in, h), step_ks(r_min)
//   rolling R:     kActive, kHistory, evaluate(in, h, extra, r), release(in, h, extra, r),
//                  add_step(stiffness, r_min, m_min), flip_owner(extra)
// and each: blocks() (its parameter blocks with their defaults) and from(choice) (built from the
// scene's values, at set-up).
#pragma once

#include <cstddef>
#include <vector>

#include "demfem/dem/contact/contact.hpp"
#include "demfem/scene/params.hpp"

namespace demfem::dem::contact {

template <class N, class D, class T> struct Law {
  N normal;
  D damping;
  T tangential;
  // Raised when a law's results change (a fix): packings deposited with it are made again.
  static constexpr int kVersion = 1;

  static std::vector<scene::ParamBlock> blocks() {
    std::vector<scene::ParamBlock> b = N::blocks();
    for (auto& x : T::blocks()) b.push_back(std::move(x));
    for (auto& x : D::blocks()) b.push_back(std::move(x));
    return b;
  }
  template <class Self> static Self make(const scene::ModelChoice& c) {
    Self s;
    s.normal = N::from(c);
    s.damping = D::from(c);
    s.tangential = T::from(c);
    return s;
  }

  [[nodiscard]] StepStiffness step_stiffness(double r_min, double m_star) const {
    StepStiffness s;
    s.kn = normal.step_kn(r_min);
    s.ks = tangential.step_ks(r_min);
    s.xi = damping.step_xi(s.kn, s.ks, m_star);
    return s;
  }

  ContactResult evaluate(const ContactInput& in, ContactHistory& h) const {
    ContactResult r;
    const bool bonded = normal.bonded(h);
    if (in.delta <= 0.0 && !(bonded && normal.holds(in.delta))) {
      tangential.release(h, r); // eq. 2.8: no tension (unless a bond holds)
      return r;
    }
    double vn_spring = in.vn;
    if (!(h.flags & kHistActive)) { // first touch
      h.flags |= kHistActive;
      normal.on_first_touch(h);
      damping.on_first_touch(in, r, vn_spring);
    }
    const double en = normal.force(in, vn_spring, bonded); // the elastic force
    const double fn = damping.normal(en, in, normal);
    tangential.update(in, en, h, r); // Coulomb on the elastic force
    if constexpr (D::kDashpot) {
      const double ds = damping.shear(in, h.flags, tangential);
      r.ft = h.ft + ds;
      r.e_damping = ((fn - en) * in.vn - ds * in.vs) * in.dt; // power of the dashpots
    } else {
      r.ft = h.ft;
    }
    r.fn = fn;
    h.fn = static_cast<float>(fn);
    r.e_normal = normal.energy(in, en, bonded);
    r.e_shear = tangential.energy(in, h);
    r.touching = true;
    return r;
  }
};

// No damping in the contact (hertz-mindlin): energy leaves by friction only.
struct NoDamping {
  static constexpr bool kDashpot = false;
  static std::vector<scene::ParamBlock> blocks() { return {}; }
  static NoDamping from(const scene::ModelChoice& /*c*/) { return {}; }
  void on_first_touch(const ContactInput&, ContactResult&, double&) const {}
  template <class N> [[nodiscard]] double normal(double en, const ContactInput&, const N&) const {
    return en;
  }
  [[nodiscard]] double step_xi(double, double, double) const { return 0.0; }
};

// No rolling resistance: disks roll freely (the paper's model).
struct NoRolling {
  static constexpr const char* name = "none";
  static constexpr const char* summary = "no rolling resistance: disks roll freely (the paper)";
  static constexpr bool kActive = false;
  static constexpr std::size_t kHistory = 0;
  static std::vector<scene::ParamBlock> blocks() { return {}; }
  static NoRolling from(const scene::ModelChoice& /*c*/) { return {}; }
  void add_step(StepStiffness& /*s*/, double /*r_min*/, double /*m_min*/) const {}
  static void flip_owner(double* /*extra*/) {}
};

// A law with a rolling resistance sub-model: what the engine evaluates per contact. kHistory
// extra values per contact are kept by the engine (contact.hpp, ContactHistory).
template <class L, class R> struct ContactModel {
  L law;
  R rolling;
  using Law = L;
  using Rolling = R;
  static constexpr std::size_t kHistory = R::kHistory;

  [[nodiscard]] StepStiffness step_stiffness(double r_min, double m_star) const {
    StepStiffness s = law.step_stiffness(r_min, m_star);
    rolling.add_step(s, r_min, 2.0 * m_star);
    return s;
  }
  // `extra`: the contact's kHistory values (nullptr when there are none).
  ContactResult evaluate(const ContactInput& in, ContactHistory& h, double* extra) const {
    if constexpr (R::kActive) {
      ContactResult r = law.evaluate(in, h);
      if (r.touching)
        rolling.evaluate(in, h, extra, r);
      else
        rolling.release(in, h, extra, r);
      return r;
    } else {
      (void)extra;
      return law.evaluate(in, h);
    }
  }
  // A pair's extra history when its owner and partner swap (the neighbour list keeps owner <
  // partner, and particles are renumbered): the rolling sub-model's moment on the owner.
  static void flip_owner(double* extra) { R::flip_owner(extra); }
  // The normal sub-model's answers (law.hpp): tangent stiffness at an overlap, elastic force at an
  // overlap, overlap of an elastic force (R*: the contact's effective radius).
  [[nodiscard]] double normal_stiffness(double r_eff, double delta) const {
    return law.normal.stiffness(r_eff, delta);
  }
  [[nodiscard]] double elastic_force(double delta, double r_eff) const {
    return law.normal.elastic_force(delta, r_eff);
  }
  [[nodiscard]] double overlap(double f, double r_eff) const {
    return law.normal.overlap(f, r_eff);
  }
};

} // namespace demfem::dem::contact
