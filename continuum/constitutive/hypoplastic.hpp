// The "hypoplastic" model: hypoplasticity for sand after von Wolffersdorff (1996) with the
// intergranular strain of Niemunis & Herle (1997). A rate-type law without an elastic range of
// its own: the stress rate is T̊ = L:D + N‖D‖ (its stiffness depends on the stress and the void
// ratio e), and the intergranular strain δ, a strain memory of radius R, raises the stiffness
// after a reversal of the strain path (m_R) and scales the non-linear term by ρ^χ (ρ = ‖δ‖/R:
// nearly off inside the memory). The void ratio follows ė = (1 + e) tr D, so that a point compacts
// under cyclic shear.
//
// Integrated by explicit sub-stepping with local error control (the modified Euler scheme with
// error estimate of Sloan 1987 and Sloan, Abbo & Sheng 2001): a sub-step whose estimated relative
// error exceeds a tolerance is refused and retried smaller. Low stress and tension: the model is
// undefined at zero stress (T̂ = T/tr T) and gives no stiffness there (f_b ∝ p^(1−n)); its rate is
// evaluated at the point's stress shifted isotropically to a mean stress of at least
// `minimum_mean_stress` and with its principal stresses kept compressive, and a point's stress
// itself is cut to no tension (a principal stress above zero is set to zero: a granular soil
// carries none). A point at zero stress therefore has the small stiffness of the floor and
// recovers when compressed again.
//
// Pure C++ without deal.II; C++17-compatible. Conventions: seam.hpp (tension positive, Voigt
// (xx, zz, xz) in the plane with engineering shear, σyy apart). The rate is evaluated with all
// three normal components (plane strain: εyy = 0, σyy carried), so the same code drives the
// isotropic and triaxial element tests (element_test.hpp). The objective (Jaumann) rate is taken
// as the material rate: the continuum is small-strain and its increments carry no spin.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

#include "elastic.hpp"
#include "mohr_coulomb.hpp" // kRadPerDeg
#include "seam.hpp"

namespace demfem::scene {
class ParamCheck;
} // namespace demfem::scene

namespace demfem::continuum::constitutive {

namespace hypoplastic {

// A symmetric tensor whose y axis is a principal direction (plane-strain, axisymmetric and
// isotropic states): tensor components (xx, zz, xz, yy); xz is the tensor component (γxz / 2
// for a strain).
struct Tensor {
  double xx = 0.0, zz = 0.0, xz = 0.0, yy = 0.0;
};
inline Tensor operator+(const Tensor& a, const Tensor& b) {
  return {a.xx + b.xx, a.zz + b.zz, a.xz + b.xz, a.yy + b.yy};
}
inline Tensor operator-(const Tensor& a, const Tensor& b) {
  return {a.xx - b.xx, a.zz - b.zz, a.xz - b.xz, a.yy - b.yy};
}
inline Tensor operator*(double s, const Tensor& a) {
  return {s * a.xx, s * a.zz, s * a.xz, s * a.yy};
}
inline double trace(const Tensor& a) {
  return a.xx + a.zz + a.yy;
}
// a : b
inline double dot(const Tensor& a, const Tensor& b) {
  return a.xx * b.xx + a.zz * b.zz + a.yy * b.yy + 2.0 * a.xz * b.xz;
}
inline double norm(const Tensor& a) {
  return std::sqrt(dot(a, a));
}
inline Tensor isotropic(double s) {
  return {s, s, 0.0, s};
}
// The principal values: the in-plane pair (larger first) and yy.
struct Principal {
  double a = 0.0, b = 0.0, y = 0.0;
  double angle = 0.0; // direction of `a` from the x axis [rad]
};
Principal principal(const Tensor& t);
Tensor from_principal(const Principal& p);

// The material constants of a point (Hypoplastic::Parameters, with the constant factors).
struct Constants {
  double h_s = 1.0e9; // granular hardness [Pa]
  double n = 0.25;    // compression exponent
  double e_d0 = 0.55, e_c0 = 0.95, e_i0 = 1.05;
  double alpha = 0.25, beta = 1.0;
  double a = 0.0; // a = √3 (3 − sin φ_c) / (2√2 sin φ_c)
  // (h_s / n) (e_i0/e_c0)^β / [3 + a² − a√3 ((e_i0 − e_d0)/(e_c0 − e_d0))^α], f_b's constant part
  double fb0 = 0.0;
  bool igs = true; // intergranular strain
  double R = 1e-4, m_R = 5.0, m_T = 2.0, beta_r = 0.5, chi = 6.0;
  double p_min = 1.0e3;    // [Pa]
  double tolerance = 1e-4; // relative local error of a sub-step
};

// A point's state.
struct PointState {
  Tensor stress;        // T, tension positive
  double e = 0.0;       // void ratio
  Tensor delta;         // intergranular strain δ (tensor components)
  double substep = 0.0; // ‖Δε‖ of the last accepted sub-step (0: none yet)
};

// The limit void ratios e_i, e_c, e_d at mean stress p = −tr T / 3 [Pa] (compression positive):
// e_x = e_x0 exp(−(3p/h_s)^n): Bauer's (1996) compression law, taken by von Wolffersdorff (1996)
// for all three limit void ratios.
[[nodiscard]] inline double bauer_factor(const Constants& k, double p) {
  return std::exp(-std::pow(std::max(3.0 * p, 0.0) / k.h_s, k.n));
}

// The state change of one explicit evaluation of the rate law at `y` for the strain increment
// `d` (tensor components): ΔT = M:d (with the intergranular strain) or L:d + N‖d‖, Δe and Δδ.
struct Change {
  Tensor stress;
  double e = 0.0;
  Tensor delta;
};
Change rate(const Constants& k, const PointState& y, const Tensor& d);

// How an integration went.
struct Report {
  int substeps = 0; // accepted
  int rejected = 0;
  bool tension_cut = false; // a principal stress was cut to zero
  bool forced = false;      // a sub-step was accepted at the smallest size despite its error
};
// The accepted sub-steps of an integration, as fractions of its increment (a consistent
// numerical tangent integrates the perturbed increments along the same sub-steps).
struct Schedule {
  static constexpr int kMax = 64;
  int count = 0; // −1: more than kMax
  double fraction[kMax] = {};
  static Schedule single() {
    Schedule s;
    s.count = 1;
    s.fraction[0] = 1.0;
    return s;
  }
};
// Integrates the strain increment `deps` (tensor components) from `y` into `y`: sub-steps of the
// modified Euler scheme with error estimate (Sloan 1987; Sloan, Abbo & Sheng 2001), starting from
// the point's last accepted sub-step size. `schedule`, when given, receives the accepted sub-steps.
Report integrate(const Constants& k, PointState& y, const Tensor& deps,
                 Schedule* schedule = nullptr);
// The same scheme along given sub-steps, without error control (y.substep kept).
void replay(const Constants& k, PointState& y, const Tensor& deps, const Schedule& schedule);

} // namespace hypoplastic

struct Hypoplastic {
  static constexpr const char* keyword = "hypoplastic";
  // The parameter block (soil.continuum keys, each with its source in fields()). Defaults: the
  // Hochstetten sand constants of von Wolffersdorff (1996) and the intergranular-strain constants
  // of Niemunis & Herle (1997). The model has no other block: its reference elasticity comes from
  // these constants (elasticity()), not from young and poisson.
  struct Parameters {
    static constexpr const char* kName = "hypoplastic";
    double critical_friction_angle = 33.0 * kRadPerDeg; // φ_c [rad]; the file states degrees
    double granular_hardness = 1.0e9;                   // h_s [Pa]
    double compression_exponent = 0.25;                 // n
    double densest_void_ratio = 0.55;                   // e_d0 (at p = 0)
    double critical_void_ratio = 0.95;                  // e_c0 (at p = 0)
    double loosest_void_ratio = 1.05;                   // e_i0 (at p = 0)
    double density_peak_exponent = 0.25;                // α: peak friction with density (f_d)
    double density_stiffness_exponent = 1.0;            // β: stiffness with density (f_e)
    bool intergranular_strain = true;                   // off: the plain von Wolffersdorff model
    double igs_radius = 1e-4;           // R: size of the elastic range in strain space
    double igs_reversal_factor = 5.0;   // m_R: stiffness factor after a 180° reversal
    double igs_transverse_factor = 2.0; // m_T: after a 90° change of direction
    double igs_beta_r = 0.5;            // β_r: evolution exponent of δ
    double igs_chi = 6.0;               // χ: interpolation exponent of the stiffness
    double initial_void_ratio = 0.75;   // e of a point when it is placed (initial stress)
    // true: `initial_void_ratio` is the value at zero stress and a point placed at mean stress p
    // gets initial_void_ratio × exp(−(3p/h_s)^n) (the same relative density at every depth)
    bool initial_void_ratio_at_zero_stress = false;
    double minimum_mean_stress = 1.0e3; // [Pa] the rate is evaluated at no less
    double substep_tolerance = 1e-3;    // relative local error of a sub-step (Sloan's STOL)
    void fields(scene::ParamVisitor& v);
    // e_d0 < e_c0 < e_i0, f_b's denominator positive, m_T ≤ m_R, the initial void ratio below
    // e_i0 (and above e_d0 when it is the value at zero stress)
    void check(scene::ParamCheck& c) const;
  };
  // The mean stress of the reference elasticity [Pa] (elasticity()).
  static constexpr double kReferenceStress = 1.0e5;
  struct Internal {
    double e = 0.0;            // void ratio (0: not yet placed; set_stress sets it)
    hypoplastic::Tensor delta; // intergranular strain (tensor components)
    double substep = 0.0;      // ‖Δε‖ of the last accepted sub-step
  };

  hypoplastic::Constants k;
  Elasticity el; // the reference elasticity (see elasticity())
  double e_init = 0.75;
  bool e_init_at_zero_stress = false;

  // Throws std::invalid_argument for a value outside its key's range or an inconsistent set
  // (Parameters::check).
  explicit Hypoplastic(const Parameters& p);
  // The registry's entry (keyword, summary, block) and the model of a scene's choice.
  static scene::ModelEntry entry();
  static Hypoplastic from(const scene::ModelChoice& choice);

  // The stiffness after a reversal (m_R L, or L without the intergranular strain) at an
  // isotropic state of mean stress kReferenceStress and the initial void ratio, as isotropic
  // elastic constants (L is isotropic there: 2G = 3 f_s, λ = f_s a²/3), with E following
  // p^(1−n) (f_b ∝ p^(1−n)) from `minimum_mean_stress` on. The integrators take wave speeds and
  // the explicit stable step from it; the model's own stress update does not use it.
  [[nodiscard]] const Elasticity& elasticity() const { return el; }
  [[nodiscard]] bool symmetric_tangent() const { return false; }
  // The void ratio of a point placed at mean stress p [Pa].
  [[nodiscard]] double initial_void_ratio(double p) const {
    return e_init_at_zero_stress ? e_init * hypoplastic::bauer_factor(k, p) : e_init;
  }
  // A point placed at its stress (the initial-stress procedure): its void ratio and a zero
  // intergranular strain the first time; later calls keep the state it has reached.
  void set_stress(PointStress& s, Internal& i) const {
    if (i.e > 0.0) return;
    i.e = initial_void_ratio(-(s.stress[0] + s.stress[1] + s.syy) / 3.0);
    i.delta = hypoplastic::Tensor{};
    i.substep = 0.0;
  }
  // Integrates Δε (εyy = 0) from the committed state; the tangent is numerical (seam.hpp
  // numerical_tangent: six more integrations, along the update's own sub-steps). Returns Elastic
  // (the model has no surfaces).
  Return update(const PointStress& c0, const Internal& i0, const Voigt& deps, PointStress& s,
                Internal& i, VoigtMatrix* tangent, bool predictor) const;
  // No plastic strain in hypoplasticity.
  [[nodiscard]] double equivalent_plastic_strain(const Internal&) const { return 0.0; }
  // In the snapshots: the void ratio e and the intergranular strain's magnitude ‖δ‖ (≤ R).
  static constexpr std::array<const char*, 2> output_names{{"void_ratio", "intergranular_strain"}};
  void output(const Internal& i, double* v) const {
    v[0] = i.e;
    v[1] = hypoplastic::norm(i.delta);
  }

  // A point's state as the rate law sees it, and back.
  [[nodiscard]] hypoplastic::PointState point(const PointStress& s, const Internal& i) const;
  static void store(const hypoplastic::PointState& y, PointStress& s, Internal& i);
};

} // namespace demfem::continuum::constitutive
