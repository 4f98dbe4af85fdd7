#include "calibrate_element.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <stdexcept>

#include <fmt/format.h>

namespace demfem::calibrate::calib {

namespace {

struct Rect {
  double x0, z0, x1, z1;
};

// A rigid, frictionless platen (smooth platens: the usual DEM biaxial boundary, so the specimen
// deforms homogeneously up to localisation).
scene::Structure platen(const std::string& name, Rect r, double mass) {
  scene::Structure s;
  s.name = name;
  s.kind = scene::StructureKind::Wall;
  s.outline = {{r.x0, r.z0}, {r.x1, r.z0}, {r.x1, r.z1}, {r.x0, r.z1}}; // counter-clockwise
  s.pivot = {0.5 * (r.x0 + r.x1), 0.5 * (r.z0 + r.z1)};
  s.base_centre = s.pivot;
  s.load_point = s.pivot;
  s.mass = mass;
  s.inertia = mass * ((r.x1 - r.x0) * (r.x1 - r.x0) + (r.z1 - r.z0) * (r.z1 - r.z0)) / 12.0;
  s.dead_weight = false;
  s.mu_static = 0.0;
  s.mu_dynamic = 0.0;
  s.dof_x = s.dof_z = s.dof_rotation = scene::DofMode::Fixed;
  return s;
}

// The specimen between four platens: inner surfaces at left/right/bottom/top.
struct Cell {
  std::unique_ptr<dem::Engine> e;
  int L = 0, R = 1, B = 2, T = 3;
  double xl0 = 0.0, xr0 = 0.0, zb0 = 0.0, zt0 = 0.0; // inner surfaces when built
  double thickness = 1.0;
  [[nodiscard]] const dem::StructureState& st(int k) const { return e->structures()[k]; }
  [[nodiscard]] double left() const { return xl0 + st(L).ux; }
  [[nodiscard]] double right() const { return xr0 + st(R).ux; }
  [[nodiscard]] double bottom() const { return zb0 + st(B).uz; }
  [[nodiscard]] double top() const { return zt0 + st(T).uz; }
  [[nodiscard]] double width() const { return right() - left(); }
  [[nodiscard]] double height() const { return top() - bottom(); }
};

// Builds the cell around the box [xl, xr] × [zb, zt]. Lateral platens are twice the specimen's
// height long and the top/bottom ones twice its width, so corners stay closed as they move.
Cell make_cell(const dem::EngineConfig& config, const dem::Particles& p,
               const std::vector<std::byte>& history, double xl, double xr, double zb, double zt,
               double thickness) {
  Cell c;
  c.e = std::make_unique<dem::Engine>(config);
  double mass = 0.0, rmax = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    c.e->add_particle(p.x[i], p.z[i], p.radius[i], p.vx[i], p.vz[i], p.omega[i]);
    mass += p.mass[i];
    rmax = std::max(rmax, p.radius[i]);
  }
  // Platen mass: 2 % of the specimen (≈ 20 grains for 1,000): light enough to follow dilation,
  // heavy enough that its spring-mass period on the contact springs spans many time steps.
  const double mw = 0.02 * mass;
  const double tk = 4.0 * rmax, w = xr - xl, h = zt - zb;
  c.xl0 = xl;
  c.xr0 = xr;
  c.zb0 = zb;
  c.zt0 = zt;
  c.thickness = thickness;
  c.e->add_structure(platen("left", {xl - tk, zb - 0.5 * h, xl, zt + 0.5 * h}, mw));
  c.e->add_structure(platen("right", {xr, zb - 0.5 * h, xr + tk, zt + 0.5 * h}, mw));
  c.e->add_structure(platen("bottom", {xl - 0.5 * w, zb - tk, xr + 0.5 * w, zb}, mw));
  c.e->add_structure(platen("top", {xl - 0.5 * w, zt, xr + 0.5 * w, zt + tk}, mw));
  if (!history.empty()) c.e->load_contact_history(history);
  c.e->set_dt(c.e->auto_dt());
  return c;
}

// Stress-controlled lateral platens: constant inward force σ·h·t (updated by the caller).
void hold_lateral(Cell& c, double sigma) {
  auto& S = c.e->structures();
  const double f = sigma * c.height() * c.thickness;
  S[c.L].spec.dof_x = scene::DofMode::Free;
  S[c.L].spec.force_x = scene::TimeFunction::constant(f);
  S[c.R].spec.dof_x = scene::DofMode::Free;
  S[c.R].spec.force_x = scene::TimeFunction::constant(-f);
}

void hold_axial(Cell& c, double sigma) {
  auto& S = c.e->structures();
  const double f = sigma * c.width() * c.thickness;
  S[c.B].spec.dof_z = scene::DofMode::Free;
  S[c.B].spec.force_z = scene::TimeFunction::constant(f);
  S[c.T].spec.dof_z = scene::DofMode::Free;
  S[c.T].spec.force_z = scene::TimeFunction::constant(-f);
}

// Runs n steps and returns the platen stresses averaged over them (compression positive):
// soil_f* is the force of the particles on a platen.
struct Stresses {
  double left = 0.0, right = 0.0, bottom = 0.0, top = 0.0;
  [[nodiscard]] double axial() const { return 0.5 * (bottom + top); }
  [[nodiscard]] double lateral() const { return 0.5 * (left + right); }
};
Stresses advance(Cell& c, int n) {
  Stresses s;
  for (int k = 0; k < n; ++k) {
    c.e->step();
    if (c.e->failed()) break;
    const double h = c.height() * c.thickness, w = c.width() * c.thickness;
    s.left += -c.st(c.L).soil_fx / h;
    s.right += c.st(c.R).soil_fx / h;
    s.bottom += -c.st(c.B).soil_fz / w;
    s.top += c.st(c.T).soil_fz / w;
  }
  const double inv = 1.0 / std::max(n, 1);
  s.left *= inv;
  s.right *= inv;
  s.bottom *= inv;
  s.top *= inv;
  return s;
}

struct Box {
  double xl, xr, zb, zt;
};
Box bounds(const dem::Particles& p) {
  Box b{1e300, -1e300, 1e300, -1e300};
  for (std::size_t i = 0; i < p.size(); ++i) {
    b.xl = std::min(b.xl, p.x[i] - p.radius[i]);
    b.xr = std::max(b.xr, p.x[i] + p.radius[i]);
    b.zb = std::min(b.zb, p.z[i] - p.radius[i]);
    b.zt = std::max(b.zt, p.z[i] + p.radius[i]);
  }
  return b;
}

// P-wave travel time across the specimen with the affine modulus as an upper bound of the
// stiffness: the time scale for quasi-static checks.
double wave_time(const Specimen& sp, double size) {
  double solid = 0.0, mass = 0.0, rsum = 0.0;
  for (std::size_t i = 0; i < sp.particles.size(); ++i) {
    solid += std::numbers::pi * sp.particles.radius[i] * sp.particles.radius[i];
    mass += sp.particles.mass[i];
    rsum += sp.particles.radius[i];
  }
  const double r_mean = rsum / static_cast<double>(std::max<std::size_t>(sp.particles.size(), 1));
  const Box b = bounds(sp.particles);
  const double area = (b.xr - b.xl) * (b.zt - b.zb);
  const double rho = mass / (area * sp.thickness);
  const double kn = dem::contact::reference_stiffness(sp.config.law, r_mean).kn;
  const double modulus = std::max(kn, 1.0) / sp.thickness; // ≥ the 2D modulus
  (void)solid;
  return size / std::sqrt(modulus / rho);
}

dem::Particles by_id(const dem::Particles& p);

struct Consolidated {
  dem::Particles particles;
  std::vector<std::byte> history;
  Box box; // platen inner surfaces
  double time = 0.0;
  long long steps = 0;
  std::string failure;
};

// Isotropic consolidation to σ_c: all four platens under constant force σ_c·L·t, with global
// damping (ratio 0.1 of critical for the mean grain on one normal spring, as pack.cpp's
// deposition damping) to bring the assembly to rest; ends when every platen stress is within
// 1 % of σ_c over 10 consecutive averaging windows and the grains are at rest.
Consolidated consolidate(const Specimen& sp, double sigma_c, const ElementSettings& st) {
  dem::EngineConfig cfg = sp.config;
  double m_mean = 0.0;
  for (double m : sp.particles.mass) m_mean += m;
  m_mean /= static_cast<double>(std::max<std::size_t>(sp.particles.size(), 1));
  double r_mean = 0.0;
  for (double r : sp.particles.radius) r_mean += r;
  r_mean /= static_cast<double>(std::max<std::size_t>(sp.particles.size(), 1));
  const double kn = dem::contact::reference_stiffness(cfg.law, r_mean).kn; // the law's K_n
  const double damp = 2.0 * 0.1 * std::sqrt(kn / m_mean); // C = 2ζ√(k/m) (SDOF oscillator)
  cfg.damping_c += damp;
  cfg.damping_d += damp;
  const Box b0 = bounds(sp.particles);
  Cell c = make_cell(cfg, sp.particles, {}, b0.xl, b0.xr, b0.zb, b0.zt, sp.thickness);
  const double tw = wave_time(sp, std::max(b0.xr - b0.xl, b0.zt - b0.zb));
  const double t_max = std::max(400.0 * tw, 2000.0 * c.e->dt() * st.control_steps);
  int good = 0;
  Consolidated out;
  while (c.e->time() < t_max) {
    hold_lateral(c, sigma_c);
    hold_axial(c, sigma_c);
    const Stresses s = advance(c, st.control_steps);
    if (c.e->failed()) {
      out.failure = c.e->failure();
      break;
    }
    const double err = std::max({std::abs(s.left - sigma_c), std::abs(s.right - sigma_c),
                                 std::abs(s.bottom - sigma_c), std::abs(s.top - sigma_c)}) /
                       sigma_c;
    const auto en = c.e->energy();
    // at rest: kinetic energy below 1e-6 of the work σ_c·A·t of the confinement per unit strain
    const double ke_ref = 1e-6 * sigma_c * c.width() * c.height() * c.thickness;
    good = (err < 0.01 && en.kinetic + en.rotational < ke_ref) ? good + 1 : 0;
    if (st.progress) st.progress("consolidation", std::min(1.0, c.e->time() / t_max));
    if (good >= 10) break;
  }
  out.particles = by_id(c.e->particles());
  out.history = c.e->save_contact_history(false);
  out.box = {c.left(), c.right(), c.bottom(), c.top()};
  out.time = c.e->time();
  out.steps = c.e->stats().steps;
  return out;
}

// The particles in stable-id order (the engine reorders them; contact history is keyed by id,
// and a new engine numbers particles in the order they are added).
dem::Particles by_id(const dem::Particles& p) {
  std::vector<std::size_t> order(p.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](auto a, auto b) { return p.id[a] < p.id[b]; });
  dem::Particles q;
  for (auto i : order) {
    q.x.push_back(p.x[i]);
    q.z.push_back(p.z[i]);
    q.radius.push_back(p.radius[i]);
    q.mass.push_back(p.mass[i]);
    q.vx.push_back(0.0);
    q.vz.push_back(0.0);
    q.omega.push_back(0.0);
    q.id.push_back(p.id[i]);
  }
  return q;
}

double solid_area(const dem::Particles& p) {
  double a = 0.0;
  for (double r : p.radius) a += std::numbers::pi * r * r; // disks
  return a;
}

} // namespace

BiaxialResult biaxial(const Specimen& sp, double sigma_c, const ElementSettings& st) {
  BiaxialResult res;
  res.sigma_c = sigma_c;
  const Consolidated k = consolidate(sp, sigma_c, st);
  res.consolidation_time = k.time;
  res.steps = k.steps;
  if (!k.failure.empty()) {
    res.failure = k.failure;
    return res;
  }
  Cell c = make_cell(sp.config, k.particles, k.history, k.box.xl, k.box.xr, k.box.zb, k.box.zt,
                     sp.thickness);
  const double w0 = c.width(), h0 = c.height();
  res.porosity = 1.0 - solid_area(k.particles) / (w0 * h0);
  // Quasi-static strain rate from the inertial number I = ε̇ d √(ρ_s/σ) (GDR MiDi, Eur. Phys.
  // J. E 14 (2004) 341; I < 1e-3 is the quasi-static regime).
  const double rate = st.inertial_number / (sp.d_mean * std::sqrt(sp.config.density / sigma_c));
  res.strain_rate = rate;
  auto& S = c.e->structures();
  // Top and bottom platens approach at ε̇ h0 / 2 each (engineering strain on h0). The velocity
  // grows linearly over t_r = 5 wave transit times: a sudden start would load the specimen with
  // the impedance stress ρ c v before it equilibrates.
  const double t_r = 5.0 * wave_time(sp, h0);
  const double t_end = st.max_axial_strain / rate + 0.5 * t_r;
  const double v = 0.5 * rate * h0;
  std::vector<std::pair<double, double>> path;
  for (int m = 0; m <= 20; ++m) {
    const double t = t_r * m / 20.0;
    path.emplace_back(t, v * t * t / (2.0 * t_r)); // u = v t²/(2 t_r) while accelerating
  }
  path.emplace_back(t_end + 1.0, v * (t_end + 1.0 - 0.5 * t_r)); // then u = v (t − t_r/2)
  auto down = path;
  for (auto& q : down) q.second = -q.second;
  S[c.T].spec.dof_z = scene::DofMode::Prescribed;
  S[c.T].spec.motion_z = scene::TimeFunction::piecewise(down);
  S[c.B].spec.dof_z = scene::DofMode::Prescribed;
  S[c.B].spec.motion_z = scene::TimeFunction::piecewise(path);
  while (c.e->time() < t_end) {
    hold_lateral(c, sigma_c);
    const Stresses s = advance(c, st.control_steps);
    if (c.e->failed()) {
      res.failure = c.e->failure();
      break;
    }
    Sample q;
    q.time = c.e->time();
    q.e_axial = (h0 - c.height()) / h0;
    q.e_lateral = (w0 - c.width()) / w0;
    q.s_axial = s.axial();
    q.s_lateral = s.lateral();
    res.samples.push_back(q);
    if (st.progress) st.progress("biaxial", c.e->time() / t_end);
  }
  res.steps += c.e->stats().steps;
  return res;
}

std::vector<CyclicLoop> cyclic(const Specimen& sp, double sigma_c,
                               const std::vector<double>& axial_amplitudes,
                               const ElementSettings& st) {
  std::vector<CyclicLoop> loops;
  const Consolidated k = consolidate(sp, sigma_c, st);
  if (!k.failure.empty()) return loops;
  Cell c = make_cell(sp.config, k.particles, k.history, k.box.xl, k.box.xr, k.box.zb, k.box.zt,
                     sp.thickness);
  const double w0 = c.width(), h0 = c.height();
  const double rate = st.inertial_number / (sp.d_mean * std::sqrt(sp.config.density / sigma_c));
  const double tw = wave_time(sp, std::max(w0, h0));
  auto& S = c.e->structures();
  S[c.T].spec.dof_z = scene::DofMode::Prescribed;
  S[c.B].spec.dof_z = scene::DofMode::Prescribed;
  double done = 0.0;
  double total = 0.0;
  std::vector<double> periods;
  for (double a : axial_amplitudes) {
    // Quasi-static: peak strain rate 2πa/T ≤ ε̇ (as the biaxial test) and T ≥ 40 wave times.
    periods.push_back(std::max(2.0 * std::numbers::pi * a / rate, 40.0 * tw));
    total += 2.0 * periods.back();
  }
  for (std::size_t n = 0; n < axial_amplitudes.size(); ++n) {
    const double a = axial_amplitudes[n], T = periods[n];
    const double t0 = c.e->time();
    // ε_zz(t) = a sin(2π(t − t0)/T): each platen moves by ∓ a h0/2 sin(…)
    S[c.T].spec.motion_z = scene::TimeFunction::sine(-0.5 * a * h0, 1.0 / T, 0.0, t0);
    S[c.T].spec.motion_z.stop = t0 + 2.0 * T;
    S[c.B].spec.motion_z = scene::TimeFunction::sine(0.5 * a * h0, 1.0 / T, 0.0, t0);
    S[c.B].spec.motion_z.stop = t0 + 2.0 * T;
    CyclicLoop loop;
    while (c.e->time() < t0 + 2.0 * T) {
      hold_lateral(c, sigma_c);
      const Stresses s = advance(c, st.control_steps);
      if (c.e->failed()) return loops;
      if (c.e->time() >= t0 + T) {
        Sample q;
        q.time = c.e->time() - t0 - T;
        q.e_axial = (h0 - c.height()) / h0;
        q.e_lateral = (w0 - c.width()) / w0;
        q.s_axial = s.axial();
        q.s_lateral = s.lateral();
        loop.samples.push_back(q);
      }
      if (st.progress) st.progress("cyclic", (done + c.e->time() - t0) / total);
    }
    done += 2.0 * T;
    // Last cycle (τ = (σ_zz − σ_xx)/2, γ = ε_zz − ε_xx): both fitted by least squares with
    // a + b sin ωt + c cos ωt, which rejects the stick-slip noise of the platen forces. Secant
    // modulus G = τ_a/γ_a; for the fitted ellipse W_D = π τ_a γ_a sin δ and W_S = ½ τ_a γ_a, so
    // ξ = W_D/(4π W_S) = ½ sin δ, δ the phase lead of τ over γ (Kramer 1996, §5.4 and eq. 6.3).
    const auto& L = loop.samples;
    if (L.size() >= 8) {
      const double w = 2.0 * std::numbers::pi / T;
      auto harmonic = [&](auto value, double& amp, double& phase) {
        double m[3][4] = {};
        for (const auto& q : L) {
          const double f[3] = {1.0, std::sin(w * q.time), std::cos(w * q.time)};
          const double y = value(q);
          for (int r = 0; r < 3; ++r) {
            for (int k2 = 0; k2 < 3; ++k2) m[r][k2] += f[r] * f[k2];
            m[r][3] += f[r] * y;
          }
        }
        for (int r = 0; r < 3; ++r) // Gauss–Jordan on the 3×3 normal equations
          for (int r2 = 0; r2 < 3; ++r2) {
            if (r2 == r || m[r][r] == 0.0) continue;
            const double f = m[r2][r] / m[r][r];
            for (int k2 = 0; k2 < 4; ++k2) m[r2][k2] -= f * m[r][k2];
          }
        const double b = m[1][3] / m[1][1], cc = m[2][3] / m[2][2];
        amp = std::hypot(b, cc);
        phase = std::atan2(cc, b);
      };
      double ga = 0.0, gp = 0.0, ta = 0.0, tp = 0.0, aa = 0.0, ap = 0.0, la = 0.0, lp = 0.0;
      harmonic([](const Sample& q) { return q.e_axial - q.e_lateral; }, ga, gp);
      harmonic([](const Sample& q) { return 0.5 * (q.s_axial - q.s_lateral); }, ta, tp);
      harmonic([](const Sample& q) { return q.e_axial; }, aa, ap);
      harmonic([](const Sample& q) { return q.e_lateral; }, la, lp);
      loop.gamma_amplitude = ga;
      loop.g_secant = ga > 0.0 ? ta / ga : 0.0;
      loop.damping = 0.5 * std::sin(tp - gp);
      // In-plane Poisson's ratio of the cycle: ν' = −ε_xx/ε_zz under constant lateral stress
      // (2D elasticity), from the part of ε_xx's first harmonic in phase with ε_zz's.
      loop.nu_inplane = aa > 0.0 ? -la * std::cos(lp - ap) / aa : 0.0;
    }
    loops.push_back(std::move(loop));
  }
  return loops;
}

BedStress bed_stress(const dem::Engine& e, const StressWindow& w, double thickness,
                     const std::vector<StressWindow>& exclude) {
  BedStress out;
  std::vector<dem::ContactView> cv;
  e.contacts(cv);
  const auto& p = e.particles();
  auto inside = [](const StressWindow& r, double x, double z) {
    return x >= r.x0 && x <= r.x1 && z >= r.z0 && z <= r.z1;
  };
  for (const auto& c : cv) {
    if (c.j < 0 || !(c.fn > 0.0)) continue;
    if (!inside(w, c.cx, c.cz)) continue;
    bool skip = false;
    for (const auto& x : exclude) skip = skip || inside(x, c.cx, c.cz);
    if (skip) continue;
    const auto i = c.i;
    const auto j = static_cast<std::size_t>(c.j);
    const double lx = p.x[i] - p.x[j], lz = p.z[i] - p.z[j]; // branch vector j → i
    const double d = std::hypot(lx, lz);
    const double nx = lx / d, nz = lz / d, tx = -nz, tz = nx; // contact_laws.hpp convention
    const double fx = c.fn * nx + c.fs * tx, fz = c.fn * nz + c.fs * tz; // force on i
    out.sxx += fx * lx; // Love–Weber: σ_ij = (1/V) Σ_c f_i l_j
    out.szz += fz * lz;
    out.sxz += 0.5 * (fx * lz + fz * lx);
    ++out.contacts;
  }
  double area = (w.x1 - w.x0) * (w.z1 - w.z0);
  for (const auto& x : exclude) {
    const double ox = std::max(0.0, std::min(w.x1, x.x1) - std::max(w.x0, x.x0));
    const double oz = std::max(0.0, std::min(w.z1, x.z1) - std::max(w.z0, x.z0));
    area -= ox * oz;
  }
  const double v = std::max(area, 1e-300) * thickness;
  out.sxx /= v;
  out.szz /= v;
  out.sxz /= v;
  return out;
}

} // namespace demfem::calibrate::calib
