// Normal sub-model `hertz`: the Hertz force of two elastic spheres, the 3D law most 2D DEM codes
// use (its force is in N whatever the thickness):
//   f_n = (4/3) E* √(R*) δ^{3/2},  E* = E/(2(1 − ν²))   (Johnson, Contact Mechanics, eq. 4.22)
// with R* the contact's effective radius. Zero stiffness at touch: no touch/release correction.
// Its parameter block (E, ν) also serves the Mindlin tangential stiffness (mindlin.hpp).
#pragma once

#include <cmath>
#include <vector>

#include "demfem/dem/contact/contact.hpp"
#include "demfem/scene/params.hpp"

namespace demfem::dem::contact {

struct Hertz {
  struct Params {
    static constexpr const char* kName = "hertz";
    double young = 7.0e10; // [Pa]
    double poisson = 0.25;
    void fields(scene::ParamVisitor& v) {
      v.number({"young", "E", "Pa",
                "hertz-mindlin: Young's modulus of the particles' material; f_n = (4/3) E* √R* "
                "δ^{3/2} with E* = E/(2(1 − ν²)) (Johnson, Contact Mechanics, eq. 4.22)",
                scene::Scale::stiffness},
               young, scene::positive());
      v.number({"poisson", "ν", "",
                "hertz-mindlin: Poisson's ratio of the particles' material (Hertz E*, Mindlin G*)"},
               poisson, scene::in_range(-1.0, 0.5, true));
    }
  };
  double e_star = 1.0; // E/(2(1 − ν²)), equal materials [Pa]

  static constexpr const char* kForceFormula = "(4/3)E*√(R*δ)·δ";
  static std::vector<scene::ParamBlock> blocks() { return {scene::ParamBlock(Params{})}; }
  static Hertz from(const scene::ModelChoice& c) {
    const auto& p = c.get<Params>();
    return {p.young / (2.0 * (1.0 - p.poisson * p.poisson))}; // E* for equal materials
  }

  [[nodiscard]] bool bonded(const ContactHistory& /*h*/) const { return false; }
  [[nodiscard]] bool holds(double /*delta*/) const { return false; }
  void on_first_touch(ContactHistory& /*h*/) const {}
  [[nodiscard]] double force(const ContactInput& in, double /*vn*/, bool /*bonded*/) const {
    const double sq = std::sqrt(in.r_eff * in.delta);
    return 4.0 / 3.0 * e_star * sq * in.delta; // Hertz
  }
  [[nodiscard]] double energy(const ContactInput& in, double f, bool /*bonded*/) const {
    return 0.4 * f * in.delta; // ∫ f_n dδ = (2/5) f_n δ
  }
  // Tangent stiffness k_n = df/dδ = 2E*√(R*δ) (Johnson, Contact Mechanics, eq. 4.22) at δ = 5 %
  // of the smallest radius, R* = r_min/2.
  [[nodiscard]] double step_kn(double r_min) const {
    const double root = std::sqrt(0.5 * r_min * kReferenceOverlap * r_min);
    return 2.0 * e_star * root;
  }
  [[nodiscard]] double stiffness(double r_eff, double delta) const {
    return 2.0 * e_star * std::sqrt(r_eff * delta); // df/dδ (Johnson eq. 4.22)
  }
  [[nodiscard]] double elastic_force(double delta, double r_eff) const {
    return delta > 0.0 ? 4.0 / 3.0 * e_star * std::sqrt(r_eff * delta) * delta : 0.0;
  }
  // δ = (3f/(4E*√R*))^{2/3}, the inverse of the Hertz force
  [[nodiscard]] double overlap(double f, double r_eff) const {
    return f > 0.0 ? std::cbrt(std::pow(0.75 * f / (e_star * std::sqrt(r_eff)), 2.0)) : 0.0;
  }
};

} // namespace demfem::dem::contact
