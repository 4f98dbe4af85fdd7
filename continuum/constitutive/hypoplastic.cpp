#include "hypoplastic.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "demfem/scene/params.hpp"

namespace demfem::continuum::constitutive {
namespace hypoplastic {

Principal principal(const Tensor& t) {
  Principal p;
  const double m = 0.5 * (t.xx + t.zz), d = 0.5 * (t.xx - t.zz);
  const double r = std::hypot(d, t.xz);
  p.a = m + r;
  p.b = m - r;
  p.y = t.yy;
  p.angle = 0.5 * std::atan2(t.xz, d);
  return p;
}

Tensor from_principal(const Principal& p) {
  const double c = std::cos(p.angle), s = std::sin(p.angle);
  return {p.a * c * c + p.b * s * s, p.a * s * s + p.b * c * c, (p.a - p.b) * c * s, p.y};
}

namespace {

// The stress at which the rate law is evaluated: the point's stress shifted isotropically to a
// mean stress of at least p_min, its principal stresses kept below −10⁻³ of the mean stress (the
// factor F is undefined where two principal stresses vanish).
// The largest principal stress (the in-plane pair's larger one or yy).
double largest_principal(const Tensor& t) {
  const double d = 0.5 * (t.xx - t.zz);
  return std::max(0.5 * (t.xx + t.zz) + std::sqrt(d * d + t.xz * t.xz), t.yy);
}

Tensor evaluation_stress(const Constants& k, const Tensor& t) {
  const double p = -trace(t) / 3.0;
  const double pe = std::max(p, k.p_min);
  const double shift = pe - p;
  const double cap = -1e-3 * pe;
  if (shift == 0.0 && largest_principal(t) <= cap) return t;
  Principal pr = principal(t);
  pr.a = std::min(pr.a - shift, cap);
  pr.b = std::min(pr.b - shift, cap);
  pr.y = std::min(pr.y - shift, cap);
  return from_principal(pr);
}

// x^e, by multiplication or roots for the exponents parameter sets often use (1, ½, ¼, integers
// up to 8), else std::pow.
double power(double x, double e) {
  if (e == 1.0) return x;
  if (e == 0.5) return std::sqrt(x);
  if (e == 0.25) return std::sqrt(std::sqrt(x));
  if (e >= 2.0 && e <= 8.0 && e == std::floor(e)) {
    double r = x;
    for (int k = 1; k < static_cast<int>(e); ++k) r *= x;
    return r;
  }
  return std::pow(x, e);
}

// tr(A³) of a tensor with y principal: the in-plane block's plus yy³.
double trace_cube(const Tensor& a) {
  return a.xx * a.xx * a.xx + a.zz * a.zz * a.zz + 3.0 * a.xz * a.xz * (a.xx + a.zz) +
         a.yy * a.yy * a.yy;
}

PointState advanced(const Constants& k, const PointState& y, const Change& c, double w) {
  PointState z = y;
  z.stress = y.stress + w * c.stress;
  z.e = y.e + w * c.e;
  z.delta = y.delta + w * c.delta;
  if (k.igs) { // ‖δ‖ ≤ R (Niemunis & Herle 1997: ρ = ‖δ‖/R ≤ 1)
    const double dl = norm(z.delta);
    if (dl > k.R) z.delta = (k.R / dl) * z.delta;
  }
  return z;
}

// A granular point carries no tension: principal stresses above zero are set to zero.
bool cut_tension(Tensor& t) {
  if (largest_principal(t) <= 0.0) return false;
  Principal pr = principal(t);
  pr.a = std::min(pr.a, 0.0);
  pr.b = std::min(pr.b, 0.0);
  pr.y = std::min(pr.y, 0.0);
  t = from_principal(pr);
  return true;
}

} // namespace

Change rate(const Constants& k, const PointState& y, const Tensor& d) {
  const Tensor T = evaluation_stress(k, y.stress);
  const double tr = trace(T); // < 0
  // T̂ = T / tr T, T̂* = T̂ − 1/3 (von Wolffersdorff 1996)
  const Tensor Th = (1.0 / tr) * T;
  const Tensor Ts = Th - isotropic(1.0 / 3.0);
  const double ThTh = dot(Th, Th);
  const double ts2 = dot(Ts, Ts);
  // tan ψ = √3 ‖T̂*‖, cos 3θ = −√6 tr(T̂*³) / (T̂*:T̂*)^(3/2) (von Wolffersdorff 1996)
  const double tanpsi = std::sqrt(3.0 * ts2);
  double c3t = 1.0;
  if (ts2 > 1e-24)
    c3t = std::clamp(-std::sqrt(6.0) * trace_cube(Ts) / (ts2 * std::sqrt(ts2)), -1.0, 1.0);
  // F = √(tan²ψ/8 + (2 − tan²ψ)/(2 + √2 tanψ cos 3θ)) − tanψ/(2√2): the Matsuoka–Nakai limit
  // surface (von Wolffersdorff 1996)
  const double den = std::max(2.0 + std::sqrt(2.0) * tanpsi * c3t, 1e-12);
  const double F = std::sqrt(std::max(tanpsi * tanpsi / 8.0 + (2.0 - tanpsi * tanpsi) / den, 0.0)) -
                   tanpsi / (2.0 * std::sqrt(2.0));
  // limit void ratios e_i, e_c, e_d at 3p = −tr T (Bauer 1996)
  const double x = -tr / k.h_s;
  const double xn = power(x, k.n);
  const double bf = std::exp(-xn);
  const double ei = k.e_i0 * bf, ec = k.e_c0 * bf, ed = k.e_d0 * bf;
  // f_b = (h_s/n) (e_i0/e_c0)^β (1 + e_i)/e_i (3p/h_s)^(1−n) / [3 + a² − a√3 ((e_i0 − e_d0)/
  // (e_c0 − e_d0))^α]: isotropic compression of the loosest state follows e_i (von Wolffersdorff
  // 1996; Herle & Gudehus 1999)
  const double fb = k.fb0 * (1.0 + ei) / ei * (x / xn);
  // the factors read e within [e_d, e_i], the model's admissible range
  const double ef = std::clamp(y.e, ed, ei);
  const double fe = power(ec / ef, k.beta);                // f_e = (e_c/e)^β
  const double fd = power((ef - ed) / (ec - ed), k.alpha); // f_d = ((e − e_d)/(e_c − e_d))^α
  // L = f_b f_e / (T̂:T̂) (F² I + a² T̂⊗T̂), N = f_d f_b f_e a F / (T̂:T̂) (T̂ + T̂*)
  // (von Wolffersdorff 1996)
  const double c = fb * fe / ThTh;
  const double cF2 = c * F * F, ca2 = c * k.a * k.a;
  auto L = [&](const Tensor& X) { return cF2 * X + (ca2 * dot(Th, X)) * Th; };
  const Tensor N = (c * fd * k.a * F) * (Th + Ts);

  Change out;
  out.e = (1.0 + y.e) * trace(d); // ė = (1 + e) tr D
  if (!k.igs) {
    out.stress = L(d) + norm(d) * N; // T̊ = L:D + N‖D‖
    return out;
  }
  // intergranular strain (Niemunis & Herle 1997): ρ = ‖δ‖/R, δ̂ = δ/‖δ‖,
  // M = [ρ^χ m_T + (1 − ρ^χ) m_R] L + ρ^χ (1 − m_T) L:δ̂⊗δ̂ + ρ^χ N⊗δ̂   for δ̂:D > 0,
  // M = [ρ^χ m_T + (1 − ρ^χ) m_R] L + ρ^χ (m_R − m_T) L:δ̂⊗δ̂            for δ̂:D ≤ 0;
  // δ̊ = (I − δ̂⊗δ̂ ρ^β_r):D for δ̂:D > 0, else D
  const double dl = norm(y.delta);
  const double rho = std::min(dl / k.R, 1.0);
  const Tensor dh = dl > 0.0 ? (1.0 / dl) * y.delta : Tensor{};
  const double hd = dot(dh, d);
  const double rc = power(rho, k.chi);
  const Tensor Ld = L(d);
  const double mix = rc * k.m_T + (1.0 - rc) * k.m_R;
  if (hd > 0.0) {
    out.stress = mix * Ld + (rc * (1.0 - k.m_T) * hd) * L(dh) + (rc * hd) * N;
    out.delta = d - (power(rho, k.beta_r) * hd) * dh;
  } else {
    out.stress = mix * Ld + (rc * (k.m_R - k.m_T) * hd) * L(dh);
    out.delta = d;
  }
  return out;
}

Report integrate(const Constants& k, PointState& y, const Tensor& deps, Schedule* schedule) {
  Report rep;
  const double dn = norm(deps);
  if (schedule) schedule->count = 0;
  if (!(dn > 0.0)) return rep;
  // smallest sub-step, a fraction of the increment (ρ^β_r is steep at δ = 0: the first sub-steps
  // from a zero intergranular strain are short)
  constexpr double h_min = 1e-6;
  double h = y.substep > 0.0 ? std::min(1.0, y.substep / dn) : 1.0;
  h = std::max(h, h_min);
  double t = 0.0;
  bool failed = false;
  while (t < 1.0) {
    const double hs = std::min(h, 1.0 - t);
    const Tensor d = hs * deps;
    // modified Euler (Sloan 1987): Euler predictor, second rate at its end, their mean; the
    // local error estimate ½‖ΔT₂ − ΔT₁‖ relative to ‖T‖ (Sloan, Abbo & Sheng 2001)
    const Change c1 = rate(k, y, d);
    const PointState y1 = advanced(k, y, c1, 1.0);
    const Change c2 = rate(k, y1, d);
    Change mean;
    mean.stress = 0.5 * (c1.stress + c2.stress);
    mean.e = 0.5 * (c1.e + c2.e);
    mean.delta = 0.5 * (c1.delta + c2.delta);
    PointState y2 = advanced(k, y, mean, 1.0);
    const double scale = std::max(norm(y2.stress), std::sqrt(3.0) * k.p_min);
    double err = 0.5 * norm(c2.stress - c1.stress) / scale;
    if (k.igs) err = std::max(err, 0.5 * norm(c2.delta - c1.delta) / k.R);
    if (!std::isfinite(err)) err = std::numeric_limits<double>::infinity();
    if (err > k.tolerance && hs > h_min) { // refused: retry smaller
      ++rep.rejected;
      failed = true;
      h = std::max(hs * std::max(0.9 * std::sqrt(k.tolerance / err), 0.1), h_min);
      continue;
    }
    if (err > k.tolerance) rep.forced = true;
    if (cut_tension(y2.stress)) rep.tension_cut = true;
    y = y2;
    t += hs;
    ++rep.substeps;
    if (schedule && schedule->count < Schedule::kMax) schedule->fraction[schedule->count++] = hs;
    // next size: 0.9 √(STOL/err), at most doubled, not grown after a refusal
    double q = err > 0.0 ? 0.9 * std::sqrt(k.tolerance / err) : 2.0;
    q = std::clamp(q, 0.1, failed ? 1.0 : 2.0);
    failed = false;
    h = std::max(hs * q, h_min);
  }
  if (schedule && rep.substeps > Schedule::kMax) schedule->count = -1; // too long to replay
  y.substep = h * dn;
  return rep;
}

void replay(const Constants& k, PointState& y, const Tensor& deps, const Schedule& schedule) {
  for (int s = 0; s < schedule.count; ++s) {
    const Tensor d = schedule.fraction[s] * deps;
    const Change c1 = rate(k, y, d);
    const PointState y1 = advanced(k, y, c1, 1.0);
    const Change c2 = rate(k, y1, d);
    Change mean;
    mean.stress = 0.5 * (c1.stress + c2.stress);
    mean.e = 0.5 * (c1.e + c2.e);
    mean.delta = 0.5 * (c1.delta + c2.delta);
    const double substep = y.substep;
    y = advanced(k, y, mean, 1.0);
    y.substep = substep;
    cut_tension(y.stress);
  }
}

} // namespace hypoplastic

void Hypoplastic::Parameters::fields(scene::ParamVisitor& v) {
  using scene::Field;
  using scene::Scale;
  v.number({"critical_friction_angle", "φ_c", "°",
            "hypoplastic: critical-state friction angle (von Wolffersdorff 1996; Herle & Gudehus "
            "1999: the angle of repose of the dry sand)",
            Scale::none, Field::Value::degrees},
           critical_friction_angle, scene::in_range(10.0, 60.0));
  v.number({"granular_hardness", "h_s", "Pa",
            "hypoplastic: granular hardness of Bauer's compression law e = e_0 exp(−(3p/h_s)^n) "
            "(Bauer 1996; von Wolffersdorff 1996)"},
           granular_hardness, scene::positive());
  v.number({"compression_exponent", "n", "",
            "hypoplastic: exponent n of Bauer's compression law (Bauer 1996)"},
           compression_exponent, scene::in_range(0.01, 1.0, true));
  v.number({"densest_void_ratio", "e_d0", "",
            "hypoplastic: minimum (densest) void ratio at zero mean stress (von Wolffersdorff "
            "1996)"},
           densest_void_ratio, scene::positive());
  v.number({"critical_void_ratio", "e_c0", "",
            "hypoplastic: critical-state void ratio at zero mean stress (von Wolffersdorff 1996)"},
           critical_void_ratio, scene::positive());
  v.number({"loosest_void_ratio", "e_i0", "",
            "hypoplastic: maximum (loosest, isotropically compressed) void ratio at zero mean "
            "stress (von Wolffersdorff 1996)"},
           loosest_void_ratio, scene::positive());
  v.number({"density_peak_exponent", "α", "",
            "hypoplastic: exponent α of the density factor f_d, the peak friction of dense sand "
            "(von Wolffersdorff 1996; Herle & Gudehus 1999)"},
           density_peak_exponent, scene::in_range(0.0, 2.0));
  v.number({"density_stiffness_exponent", "β", "",
            "hypoplastic: exponent β of the density factor f_e, the stiffness of dense sand "
            "(von Wolffersdorff 1996; Herle & Gudehus 1999)"},
           density_stiffness_exponent, scene::in_range(0.0, 5.0));
  v.flag({"intergranular_strain", "IGS", "",
          "hypoplastic: the intergranular strain of Niemunis & Herle (1997), a strain memory that "
          "stiffens small cycles and reversals; false: the plain von Wolffersdorff model"},
         intergranular_strain);
  v.number({"igs_radius", "R", "",
            "hypoplastic: size R of the intergranular strain's elastic range in strain space "
            "(Niemunis & Herle 1997)"},
           igs_radius, scene::in_range(1e-7, 1e-2));
  v.number({"igs_reversal_factor", "m_R", "",
            "hypoplastic: stiffness factor m_R after a 180° strain reversal (Niemunis & Herle "
            "1997)"},
           igs_reversal_factor, scene::in_range(1.0, 100.0));
  v.number({"igs_transverse_factor", "m_T", "",
            "hypoplastic: stiffness factor m_T after a 90° change of strain direction (Niemunis & "
            "Herle 1997); ≤ igs_reversal_factor"},
           igs_transverse_factor, scene::in_range(1.0, 100.0));
  v.number({"igs_beta_r", "β_r", "",
            "hypoplastic: evolution exponent β_r of the intergranular strain (Niemunis & Herle "
            "1997)"},
           igs_beta_r, scene::in_range(0.01, 10.0));
  v.number({"igs_chi", "χ", "",
            "hypoplastic: interpolation exponent χ of the stiffness between m_R L and the "
            "hypoplastic one (Niemunis & Herle 1997)"},
           igs_chi, scene::in_range(0.1, 50.0));
  v.number({"initial_void_ratio", "e_0", "",
            "hypoplastic: void ratio of a point when the initial stresses place it (uniform, or "
            "with initial_void_ratio_at_zero_stress the value at p = 0)"},
           initial_void_ratio, scene::positive());
  v.flag({"initial_void_ratio_at_zero_stress", "e_0 at p = 0", "",
          "hypoplastic: true: a point placed at mean stress p gets initial_void_ratio × "
          "exp(−(3p/h_s)^n), the same relative density at every depth (Bauer 1996)"},
         initial_void_ratio_at_zero_stress);
  v.number({"minimum_mean_stress", "p_min", "Pa",
            "hypoplastic: the rate law is evaluated at a mean stress of at least this (the model "
            "has no stiffness at zero stress); also where the reference modulus stops falling"},
           minimum_mean_stress, scene::positive());
  v.number({"substep_tolerance", "STOL", "",
            "hypoplastic: relative local error a sub-step of the stress integration may have "
            "(modified Euler with error control: Sloan, Abbo & Sheng 2001)"},
           substep_tolerance, scene::in_range(1e-8, 0.1, true));
}

void Hypoplastic::Parameters::check(scene::ParamCheck& c) const {
  if (!(densest_void_ratio < critical_void_ratio))
    c.error("densest_void_ratio", "the densest void ratio e_d0 must be below the critical one "
                                  "e_c0 (critical_void_ratio)");
  if (!(critical_void_ratio < loosest_void_ratio))
    c.error("critical_void_ratio", "the critical void ratio e_c0 must be below the loosest one "
                                   "e_i0 (loosest_void_ratio)");
  if (densest_void_ratio < critical_void_ratio && critical_void_ratio < loosest_void_ratio) {
    // f_b's denominator 3 + a² − a√3 ((e_i0 − e_d0)/(e_c0 − e_d0))^α must be positive (von
    // Wolffersdorff 1996): otherwise isotropic compression has no stiffness
    const double sp = std::sin(critical_friction_angle);
    const double a = std::sqrt(3.0) * (3.0 - sp) / (2.0 * std::sqrt(2.0) * sp);
    const double r =
        (loosest_void_ratio - densest_void_ratio) / (critical_void_ratio - densest_void_ratio);
    if (!(3.0 + a * a - a * std::sqrt(3.0) * std::pow(r, density_peak_exponent) > 0.0))
      c.error("density_peak_exponent",
              "with these void ratios and critical_friction_angle the isotropic stiffness "
              "factor f_b is not positive: 3 + a² − √3 a ((e_i0 − e_d0)/(e_c0 − e_d0))^α ≤ 0 "
              "(von Wolffersdorff 1996); lower density_peak_exponent");
  }
  if (intergranular_strain && igs_transverse_factor > igs_reversal_factor)
    c.error("igs_transverse_factor",
            "the transverse factor m_T must not exceed the reversal factor m_R "
            "(igs_reversal_factor; Niemunis & Herle 1997)");
  if (!(initial_void_ratio < loosest_void_ratio))
    c.error("initial_void_ratio", "the initial void ratio must be below the loosest one e_i0 "
                                  "(loosest_void_ratio): no state is looser");
  else if (initial_void_ratio_at_zero_stress && !(initial_void_ratio > densest_void_ratio))
    c.error("initial_void_ratio", "the initial void ratio at zero stress must be above the "
                                  "densest one e_d0 (densest_void_ratio)");
}

namespace {

// The block's values against its keys' rules (Parameters::fields), for a block built in code.
class RuleCheck final : public scene::ParamVisitor {
public:
  void number(const scene::Field& f, double& v, scene::Rule r) override {
    const double x = f.value == scene::Field::Value::degrees ? v / kRadPerDeg : v;
    bool ok = true;
    switch (r.kind) {
    case scene::Rule::Kind::any:
      break;
    case scene::Rule::Kind::positive:
      ok = x > 0.0;
      break;
    case scene::Rule::Kind::non_negative:
      ok = x >= 0.0;
      break;
    case scene::Rule::Kind::range:
      ok = x >= r.lo && (r.open_hi ? x < r.hi : x <= r.hi);
      break;
    }
    if (!ok)
      throw std::invalid_argument("hypoplastic: " + std::string(f.key) + " = " + std::to_string(x) +
                                  " is outside its range");
  }
  void integer(const scene::Field&, int&, int, int) override {}
  void flag(const scene::Field&, bool&) override {}
  void text(const scene::Field&, std::string&) override {}
};

class ThrowingCheck final : public scene::ParamCheck {
public:
  void error(std::string_view key, const std::string& message) override {
    throw std::invalid_argument("hypoplastic: " + std::string(key) + ": " + message);
  }
};

} // namespace

scene::ModelEntry Hypoplastic::entry() {
  return {keyword,
          "hypoplastic sand (von Wolffersdorff 1996) with the intergranular strain of Niemunis & "
          "Herle (1997): stiffness and strength follow stress and void ratio, compacts under "
          "cyclic shear",
          {scene::ParamBlock(Parameters{})}};
}

Hypoplastic Hypoplastic::from(const scene::ModelChoice& choice) {
  return Hypoplastic(choice.get<Parameters>());
}

Hypoplastic::Hypoplastic(const Parameters& p) {
  {
    Parameters q = p;
    RuleCheck rules;
    q.fields(rules);
    ThrowingCheck check;
    p.check(check);
  }

  const double s = std::sin(p.critical_friction_angle);
  k.a = std::sqrt(3.0) * (3.0 - s) / (2.0 * std::sqrt(2.0) * s); // von Wolffersdorff (1996)
  k.h_s = p.granular_hardness;
  k.n = p.compression_exponent;
  k.e_d0 = p.densest_void_ratio;
  k.e_c0 = p.critical_void_ratio;
  k.e_i0 = p.loosest_void_ratio;
  k.alpha = p.density_peak_exponent;
  k.beta = p.density_stiffness_exponent;
  // f_b's constant part (von Wolffersdorff 1996; Herle & Gudehus 1999)
  k.fb0 = k.h_s / k.n * std::pow(k.e_i0 / k.e_c0, k.beta) /
          (3.0 + k.a * k.a -
           k.a * std::sqrt(3.0) * std::pow((k.e_i0 - k.e_d0) / (k.e_c0 - k.e_d0), k.alpha));
  k.igs = p.intergranular_strain;
  k.R = p.igs_radius;
  k.m_R = p.igs_reversal_factor;
  k.m_T = p.igs_transverse_factor;
  k.beta_r = p.igs_beta_r;
  k.chi = p.igs_chi;
  k.p_min = p.minimum_mean_stress;
  k.tolerance = p.substep_tolerance;
  e_init = p.initial_void_ratio;
  e_init_at_zero_stress = p.initial_void_ratio_at_zero_stress;

  // the reference elasticity: m_R L at an isotropic state (T̂ = 1/3, F = 1, T̂:T̂ = 1/3):
  // L = 3 f_s (I + a²/9 1⊗1), so 2G = 3 f_s and λ = f_s a²/3 (von Wolffersdorff 1996)
  const double pr = kReferenceStress;
  const double x = 3.0 * pr / k.h_s;
  const double bf = hypoplastic::bauer_factor(k, pr);
  const double ei = k.e_i0 * bf, ec = k.e_c0 * bf, ed = k.e_d0 * bf;
  const double e = std::clamp(initial_void_ratio(pr), ed, ei);
  const double fs = k.fb0 * (1.0 + ei) / ei * std::pow(x, 1.0 - k.n) * std::pow(ec / e, k.beta);
  const double m = k.igs ? k.m_R : 1.0;
  const double G = 1.5 * m * fs, lam = m * fs * k.a * k.a / 3.0;
  el.hooke.young = G * (3.0 * lam + 2.0 * G) / (lam + G);
  el.hooke.poisson = lam / (2.0 * (lam + G));
  el.modulus.exponent = 1.0 - k.n; // f_b ∝ (3p/h_s)^(1−n)
  el.modulus.reference_stress = pr;
  el.modulus.min_stress = k.p_min;
}

hypoplastic::PointState Hypoplastic::point(const PointStress& s, const Internal& i) const {
  hypoplastic::PointState y;
  y.stress = {s.stress[0], s.stress[1], s.stress[2], s.syy};
  y.e = i.e > 0.0 ? i.e : initial_void_ratio(-hypoplastic::trace(y.stress) / 3.0);
  y.delta = i.delta;
  y.substep = i.substep;
  return y;
}

void Hypoplastic::store(const hypoplastic::PointState& y, PointStress& s, Internal& i) {
  s.stress = {y.stress.xx, y.stress.zz, y.stress.xz};
  s.syy = y.stress.yy;
  i.e = y.e;
  i.delta = y.delta;
  i.substep = y.substep;
}

Return Hypoplastic::update(const PointStress& c0, const Internal& i0, const Voigt& deps,
                           PointStress& s, Internal& i, VoigtMatrix* tangent,
                           bool /*predictor*/) const {
  s.stiffness = c0.stiffness;
  const hypoplastic::PointState y0 = point(c0, i0);
  hypoplastic::PointState y = y0;
  hypoplastic::Schedule schedule;
  hypoplastic::integrate(k, y, {deps[0], deps[1], 0.5 * deps[2], 0.0},
                         tangent ? &schedule : nullptr);
  store(y, s, i);
  if (tangent) {
    // central differences of the update along the same sub-steps (a refused or accepted
    // sub-step must not differ between the perturbed integrations)
    auto stress_at = [&](const Voigt& d) {
      hypoplastic::PointState z = y0;
      const hypoplastic::Tensor dt{d[0], d[1], 0.5 * d[2], 0.0};
      if (schedule.count >= 0) {
        hypoplastic::replay(k, z, dt, schedule);
      } else {
        hypoplastic::integrate(k, z, dt);
      }
      return Voigt{{z.stress.xx, z.stress.zz, z.stress.xz}};
    };
    if (schedule.count == 0) schedule = hypoplastic::Schedule::single();
    *tangent = numerical_tangent(stress_at, deps, 1e-6, 1e-4);
  }
  return Return::Elastic;
}

} // namespace demfem::continuum::constitutive
