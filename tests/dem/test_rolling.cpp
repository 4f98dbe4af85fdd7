// Rolling resistance (dem/contact/rolling_spring.hpp), against closed forms: a disk on a floor
// under a torque below μ_r r f_n does not roll and rolls above it; a disk on a slope
// stays below the rolling friction's angle atan μ_r and rolls down at
// a = (2/3) g (sin θ − μ_r cos θ) above it; the elastic rolling spring's small oscillation has the
// period 2π√((I + m r²)/k_r); the engine keeps the rolling moment across checkpoints and
// reorders; the scene reads, writes and validates the keys.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <span>
#include <vector>

#include "demfem/app/vocabulary.hpp"
#include "demfem/dem/contact/registry.hpp"
#include "demfem/dem/engine.hpp"
#include "demfem/dem/stable_step.hpp"
#include "demfem/scene/load.hpp"

using namespace demfem;
using namespace demfem::dem;

namespace {

constexpr double kPi = 3.14159265358979323846;

EngineConfig rolling_config(double mu_r, double kr = 1.0e6, double mu_s = 0.8) {
  EngineConfig c;
  c.law = contact::make_law("cundall-rebound", {{"kn", 1.0e8}, {"ks", 3.0e7}}, "elastic-plastic",
                            {{"rolling_stiffness", kr}, {"mu_rolling", mu_r}});
  c.materials = {Material{mu_s, mu_s}};
  return c;
}

// 120 disks (r 2.5–4 cm) on a lattice of 9 cm in a 0.8 m wide box, to fall and settle, added in
// a scrambled order (k ↦ 37k mod 120), so that a reorder changes it.
void add_bed(Engine& e) {
  e.add_wall({{0.0, 2.0}, {0.0, 0.0}, {0.8, 0.0}, {0.8, 2.0}}, "box");
  for (int q = 0; q < 120; ++q) {
    const int k = (37 * q) % 120;
    e.add_particle(0.05 + 0.09 * (k % 8) + 0.003 * (k % 3), 0.05 + 0.09 * (k / 8),
                   0.025 + 0.005 * (k % 4));
  }
}

double disk_mass(const EngineConfig& c, double r) {
  return c.density * kPi * r * r * c.thickness;
}

struct Slope {
  double distance = 0.0; // travelled down the slope [m]
  double speed = 0.0;    // along the slope [m/s]
  double omega = 0.0;
};

// A disk of radius r released at rest on a line wall at angle θ, at its static overlap: its state
// at each of `times`.
std::vector<Slope> on_slope(const EngineConfig& c, double theta, std::vector<double> times) {
  Engine e(c);
  const double L = 3.0, r = 0.05;
  const double dx = std::cos(theta), dz = -std::sin(theta); // down the slope
  const double nx = std::sin(theta), nz = std::cos(theta);  // the slope's upward normal
  e.add_wall({{0.0, 0.0}, {L * dx, L * dz}}, "slope");
  const double m = disk_mass(c, r);
  const double d0 = r - m * c.gravity * std::cos(theta) / 1.0e8; // static normal overlap
  const double x0 = 0.2 * dx + d0 * nx, z0 = 0.2 * dz + d0 * nz;
  e.add_particle(x0, z0, r);
  e.set_dt(e.auto_dt());
  std::vector<Slope> out;
  for (const double t : times) {
    e.run_until(t, 1'000'000'000);
    const auto& p = e.particles();
    Slope s;
    s.distance = (p.x[0] - x0) * dx + (p.z[0] - z0) * dz;
    s.speed = p.vx[0] * dx + p.vz[0] * dz;
    s.omega = p.omega[0];
    out.push_back(s);
  }
  return out;
}

} // namespace

// Below atan μ_r the rolling moment holds the disk: released at rest it swings on the elastic
// rolling spring (overshooting it may slip a little at the start) and stays, within a
// millimetre, while at tan θ = 0.15 it rolls 40 mm in the same 0.5 s. Above, it rolls down at
// (2/3) g (sin θ − μ_r cos θ) (measured between 0.25 and 0.5 s, after the spring's loading),
// within 1 %; without rolling resistance at (2/3) g sin θ.
TEST(DemRolling, DiskOnASlopeRollsOnlyAboveTheRollingFrictionAngle) {
  const double mu_r = 0.1, g = 9.81;
  for (const double tan_theta : {0.05, 0.09}) { // below μ_r: stays
    const auto s = on_slope(rolling_config(mu_r), std::atan(tan_theta), {0.25, 0.5});
    std::printf("tan θ = %.2f: moved %.3g m, then %.3g m; speed %.3g m/s\n", tan_theta,
                s[0].distance, s[1].distance, s[1].speed);
    EXPECT_LT(std::abs(s[1].distance), 1e-3) << tan_theta;
    EXPECT_LT(std::abs(s[1].distance - s[0].distance), 2e-4) << tan_theta; // not rolling on
  }
  for (const double tan_theta : {0.15, 0.3}) { // above: rolls at the closed form
    const double theta = std::atan(tan_theta);
    const double a = 2.0 / 3.0 * g * (std::sin(theta) - mu_r * std::cos(theta));
    const auto s = on_slope(rolling_config(mu_r), theta, {0.25, 0.5});
    const double measured = (s[1].speed - s[0].speed) / 0.25;
    std::printf("tan θ = %.2f: acceleration %.5g m/s², closed form %.5g m/s², moved %.3g m\n",
                tan_theta, measured, a, s[1].distance);
    EXPECT_NEAR(measured, a, 0.01 * a) << tan_theta;
    EXPECT_NEAR(-s[1].omega * 0.05, s[1].speed, 0.01 * s[1].speed) << tan_theta; // no slip
  }
  // the same disk without rolling resistance rolls at a slope of 0.05
  EngineConfig free = rolling_config(mu_r);
  free.law = contact::make_law("cundall-rebound", {{"kn", 1.0e8}, {"ks", 3.0e7}});
  const double theta = std::atan(0.05), a = 2.0 / 3.0 * g * std::sin(theta);
  const auto s = on_slope(free, theta, {0.25, 0.5});
  EXPECT_NEAR((s[1].speed - s[0].speed) / 0.25, a, 0.01 * a);
}

// A disk resting on a floor, turned by a torque T (added to its spin as T Δt/I before each step,
// raised linearly over its first 0.1 s, three periods of the rolling spring, so that neither the
// spring nor the shear spring is set swinging): below the rolling moment's cap μ_r r f_n (f_n = m
// g, R* = r at a wall) it turns only by the spring's elastic rotation T/k_r and does not roll;
// above it rolls without slip at the angular acceleration (T − μ_r r m g)/(I + m r²) (moments about
// the contact point), within 1 %. Without rolling resistance the smaller torque rolls it at T/(I +
// m r²).
TEST(DemRolling, DiskOnAFloorRollsOnlyUnderATorqueAboveTheCap) {
  const double mu_r = 0.1, r = 0.05;
  auto turn = [&](const EngineConfig& c, double torque, double t_mid, double t_end) {
    Engine e(c);
    e.add_wall({{-2.0, 0.0}, {2.0, 0.0}}, "floor");
    const double m = disk_mass(c, r);
    e.add_particle(0.0, r - m * c.gravity / 1.0e8, r); // at its static overlap
    e.set_dt(e.auto_dt());
    double w_mid = 0.0;
    while (e.time() < t_end) {
      auto& p = e.particles();
      p.omega[0] += std::min(1.0, e.time() / 0.1) * torque * e.dt() * p.inv_inertia[0];
      e.step();
      if (w_mid == 0.0 && e.time() >= t_mid) w_mid = e.particles().omega[0];
    }
    const auto& p = e.particles();
    return std::array<double, 3>{p.x[0], w_mid, p.omega[0]}; // position, spin at t_mid, at t_end
  };
  const EngineConfig c = rolling_config(mu_r);
  const double m = disk_mass(c, r);
  const double cap = mu_r * r * m * c.gravity;        // μ_r R* f_n
  const double inertia = 0.5 * m * r * r + m * r * r; // I + m r² about the contact point
  const double kr = 1.0e6 * r * r;                    // k_r = K_r R*²
  for (const double f : {0.5, 0.9}) {                 // below the cap: the spring holds it at T/k_r
    const double theta = f * cap / kr, omega = std::sqrt(kr / inertia);
    const auto s = turn(c, f * cap, 0.25, 0.5);
    std::printf("T = %.2f cap: moved %.3g m (r T/k_r = %.3g m), spin %.3g rad/s\n", f, s[0],
                r * theta, s[2]);
    EXPECT_NEAR(s[0], -r * theta, 0.1 * r * theta) << f; // rolled by T/k_r to the left (T > 0)
    EXPECT_LT(std::abs(s[2]), 0.2 * theta * omega) << f; // the swing left by the ramp
  }
  for (const double f : {1.2, 2.0}) { // above: rolls at the closed form
    const auto s = turn(c, f * cap, 0.25, 0.5);
    const double alpha = (f - 1.0) * cap / inertia, measured = (s[2] - s[1]) / 0.25;
    std::printf("T = %.2f cap: angular acceleration %.5g rad/s², closed form %.5g rad/s²\n", f,
                measured, alpha);
    EXPECT_NEAR(measured, alpha, 0.01 * alpha) << f;
    EXPECT_LT(s[0], -0.5 * alpha * 0.0625 * r) << f; // rolled to the left (ω > 0)
  }
  EngineConfig free = c; // no rolling resistance: the smaller torque rolls the disk
  free.law = contact::make_law("cundall-rebound", {{"kn", 1.0e8}, {"ks", 3.0e7}});
  const auto s = turn(free, 0.5 * cap, 0.25, 0.5);
  EXPECT_NEAR((s[2] - s[1]) / 0.25, 0.5 * cap / inertia, 0.01 * 0.5 * cap / inertia);
}

// A disk rolling on a floor, its rolling spring below the cap: a small oscillation of period
// 2π√((I + m r²)/k_r), k_r = K_r r² (R* = r at a wall), for a disk 2π√(1.5 m/K_r), within 1 %,
// and no energy lost (the peak spin comes back to within 1 %).
TEST(DemRolling, ElasticRollingSpringOscillatesAtItsPeriod) {
  const double kr = 2.0e5, r = 0.05, omega0 = 0.2;
  EngineConfig c = rolling_config(10.0, kr); // μ_r large: the moment stays elastic
  Engine e(c);
  e.add_wall({{-1.0, 0.0}, {1.0, 0.0}}, "floor");
  const double m = disk_mass(c, r);
  e.add_particle(0.0, r - m * c.gravity / 1.0e8, r, -omega0 * r, 0.0, omega0); // rolling
  e.set_dt(e.auto_dt());
  const double period = 2.0 * kPi * std::sqrt(1.5 * m / kr);
  std::vector<double> crossings;
  double last = omega0, peak = 0.0;
  while (e.time() < 5.2 * period) {
    e.step();
    const double w = e.particles().omega[0];
    if ((last > 0.0) != (w > 0.0)) // linear interpolation of the zero crossing
      crossings.push_back(e.time() - e.dt() * w / (w - last));
    if (e.time() > 4.0 * period) peak = std::max(peak, std::abs(w));
    last = w;
  }
  ASSERT_GE(crossings.size(), 10u);
  const double measured = (crossings[9] - crossings[1]) / 4.0; // four whole periods
  std::printf("rolling period %.6g s, closed form %.6g s; peak spin %.5g of %.5g rad/s\n", measured,
              period, peak, omega0);
  EXPECT_NEAR(measured, period, 0.01 * period);
  EXPECT_NEAR(peak, omega0, 0.01 * omega0);
}

// The rolling moment is a couple of the relative rotation: none when the bodies turn together,
// against the relative rotation otherwise; and two disks rolling on each other in free flight
// keep their angular momentum (orbital and spin) to round-off.
TEST(DemRolling, MomentOpposesRelativeRotationAndConservesAngularMomentum) {
  const auto law = contact::make_law("cundall-rebound", {}, "elastic-plastic",
                                     {{"rolling_stiffness", 1e5}, {"mu_rolling", 0.5}});
  auto moment = [&](double wr) {
    ContactHistory h;
    std::vector<double> extra(1, 0.0);
    ContactInput in{1e-4, 0.0, 0.0, 1.0, 0.025, 0.5, 0.3, 1e-4, wr};
    return std::visit([&](const auto& m) { return m.evaluate(in, h, extra.data()); }, law).mr;
  };
  EXPECT_EQ(moment(0.0), 0.0);
  EXPECT_LT(moment(2.0), 0.0); // i turns counter-clockwise relative to j: a clockwise moment on i
  EXPECT_EQ(moment(-2.0), -moment(2.0));

  EngineConfig c = rolling_config(0.5, 1e5);
  c.gravity = 0.0;
  Engine e(c);
  const double r = 0.05;
  e.add_particle(-r + 1e-4, 0.0, r, 0.0, 0.01, 3.0);
  e.add_particle(r - 1e-4, 0.0, r, 0.0, -0.01, -1.0);
  e.set_dt(e.auto_dt());
  auto angular_momentum = [&] {
    const auto& p = e.particles();
    double l = 0.0;
    for (std::size_t i = 0; i < p.size(); ++i)
      l += p.mass[i] * (p.x[i] * p.vz[i] - p.z[i] * p.vx[i]) + p.omega[i] / p.inv_inertia[i];
    return l;
  };
  const double l0 = angular_momentum();
  double w0 = e.particles().omega[0];
  e.run_steps(2000);
  EXPECT_NEAR(angular_momentum(), l0, 1e-9 * std::abs(l0));
  EXPECT_LT(std::abs(e.particles().omega[0] - e.particles().omega[1]), std::abs(w0 + 1.0));
}

// The rolling moments are contact history: a run saved and restored midway (engine state), and
// one whose particles are renumbered (reorder, owner swaps), continue bit for bit.
TEST(DemRolling, MomentsSurviveCheckpointsAndReorders) {
  auto build = [] {
    EngineConfig c = rolling_config(0.05, 3.0e5, 0.5);
    c.reorder_every = 1;
    c.shaking = true;
    c.shaking_acceleration = scene::TimeFunction::sine(3.0, 5.0);
    auto e = std::make_unique<Engine>(c);
    add_bed(*e);
    e->set_dt(e->auto_dt());
    return e;
  };
  auto a = build();
  a->run_steps(3000);
  ASSERT_FALSE(a->failed()) << a->failure();
  EXPECT_EQ(a->history_width(), 1u);
  const auto state = a->save_state();
  const auto particles = a->particles();
  a->run_steps(2000);
  auto b = build();
  b->restore_state(particles, state);
  b->run_steps(2000);
  const auto& pa = a->particles();
  const auto& pb = b->particles();
  for (std::size_t i = 0; i < pa.size(); ++i) {
    ASSERT_EQ(pa.x[i], pb.x[i]) << i;
    ASSERT_EQ(pa.omega[i], pb.omega[i]) << i;
  }
  EXPECT_GT(a->stats().reorders, 5);
  EXPECT_EQ(a->energy().total(), b->energy().total());
}

// The rolling moment enters the energy budget: a bed shaken with rolling resistance closes its
// budget as well as without it.
TEST(DemRolling, EnergyBudgetCloses) {
  EngineConfig c = rolling_config(0.1, 3.0e5, 0.5);
  Engine e(c);
  add_bed(e);
  e.set_dt(e.auto_dt());
  const double e0 = e.energy().total();
  e.run_steps(20000);
  const auto b = e.energy();
  std::printf("rolling bed: gravity work %.4g J, friction %.4g J, closure %.3g\n", b.gravity_work,
              b.friction, (b.total() - e0) / b.gravity_work);
  EXPECT_LT(std::abs(b.total() - e0), 0.01 * b.gravity_work);
}

// The scene reads the rolling keys, writes them back only when rolling resistance is on (the
// resolved scene of a scene without it does not change), and the stable step counts the rolling
// spring's mode.
TEST(DemRolling, SceneKeysAndStableStep) {
  const std::string base = R"([scene]
name = "roll"
duration = 0.1
[domain]
polygon = [[-1, -1], [1, -1], [1, 1], [-1, 1]]
[soil.dem]
count = 2
radius = { equal = 0.05 }
particles = [[-0.06, 0, 0.05], [0.06, 0, 0.05]]
)";
  const auto& v = app::vocabulary();
  const auto off = scene::parse_scene(base, "roll.toml", v).base;
  EXPECT_EQ(scene::to_toml(off).find("rolling"), std::string::npos);
  const auto on = scene::parse_scene(base + "rolling = \"elastic-plastic\"\nmu_rolling = 0.2\n"
                                            "rolling_stiffness = 1.0e9\n",
                                     "roll.toml", v)
                      .base;
  const std::string text = scene::to_toml(on);
  EXPECT_NE(text.find("rolling = 'elastic-plastic'"), std::string::npos) << text;
  EXPECT_NE(text.find("mu_rolling = 0.2"), std::string::npos) << text;
  const std::string back = scene::to_toml(scene::parse_scene(text, "roll.toml", v).base);
  EXPECT_EQ(back.substr(back.find('\n')), text.substr(text.find('\n'))); // but the comment
  EXPECT_EQ(contact::rolling_name(make_config(on).law), "elastic-plastic");
  // K_r = 1e9 N/m: ω_r² = 2 K_r (r/2)²/(½ m r²) = K_r/m = 1e9/20.8, stiffer than the normal mode
  const auto with = scene_critical_step(on), without = scene_critical_step(off);
  ASSERT_TRUE(with && without);
  EXPECT_LT(with->dt, 0.5 * without->dt);
  EXPECT_NE(with->formula().find("rolling spring"), std::string::npos) << with->formula();
  try {
    (void)scene::parse_scene(base + "rolling = \"elastic-plastic\"\nmu_rolling = -1\n", "roll.toml",
                             v);
    FAIL() << "expected a SceneError";
  } catch (const scene::SceneError& e) {
    EXPECT_EQ(e.diagnostics().at(0).key, "soil.dem.mu_rolling");
  }
}

// A bed sloshing in its box (its neighbour list rebuilt every few dozen steps) run with a reorder
// at every rebuild and without reorders agrees to round-off.
TEST(DemRolling, ReorderDoesNotChangeTheRun) {
  auto run = [](int reorder_every) {
    EngineConfig c = rolling_config(0.05, 3.0e5, 0.5);
    c.reorder_every = reorder_every;
    c.shaking = true;
    c.shaking_acceleration = scene::TimeFunction::sine(12.0, 2.0);
    Engine e(c);
    add_bed(e);
    e.set_dt(e.auto_dt());
    e.run_steps(6000);
    return std::pair{e.particles(), e.stats()};
  };
  const auto [a, sa] = run(1);
  const auto [b, sb] = run(0);
  EXPECT_GT(sa.reorders, 3);
  EXPECT_EQ(sb.reorders, 0);
  double worst = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) { // the reordered run holds them in another order
    const auto k =
        static_cast<std::size_t>(std::find(b.id.begin(), b.id.end(), a.id[i]) - b.id.begin());
    worst = std::max(worst, std::abs(a.omega[i] - b.omega[k]));
    scale = std::max(scale, std::abs(a.omega[i]));
  }
  std::printf("reordered vs not (%lld reorders): largest spin difference %.3g of %.3g rad/s\n",
              sa.reorders, worst, scale);
  EXPECT_LT(worst, 1e-6 * scale);
}

// A pair's owner is its lower index: a contact history loaded into an engine that holds the
// particles in the opposite order swaps the owner and partner of every pair, and their rolling
// moment changes sign with the owner (RollingSpring::flip_owner). One step of a settling bed with
// rolling resistance from its saved contact history gives, particle by particle (by id), the
// spin change of the engine that saved it, to round-off.
TEST(DemRolling, HistoryOfSwappedPairsKeepsTheMoments) {
  EngineConfig c = rolling_config(0.05, 3.0e5, 0.5);
  c.reorder_every = 0;
  Engine a(c);
  add_bed(a);
  a.set_dt(a.auto_dt());
  a.run_steps(6000);
  ASSERT_FALSE(a.failed()) << a.failure();
  const Particles before = a.particles();
  const auto history = a.save_contact_history();
  Engine b(c); // the same bed, its particles added in the opposite order, with a's ids
  b.add_wall({{0.0, 2.0}, {0.0, 0.0}, {0.8, 0.0}, {0.8, 2.0}}, "box");
  const std::size_t n = before.size();
  for (std::size_t k = n; k-- > 0;)
    b.add_particle(before.x[k], before.z[k], before.radius[k], before.vx[k], before.vz[k],
                   before.omega[k]);
  for (std::size_t k = 0; k < n; ++k) b.particles().id[k] = before.id[n - 1 - k];
  b.load_contact_history(history);
  b.set_dt(a.dt());
  a.step();
  b.step();
  const auto& pa = a.particles();
  const auto& pb = b.particles();
  double worst = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(b.index_of(pa.id[i]));
    const double da = pa.omega[i] - before.omega[i], db = pb.omega[k] - before.omega[i];
    worst = std::max(worst, std::abs(da - db));
    scale = std::max(scale, std::abs(da));
  }
  std::printf("swapped owners: largest difference of the spin change %.3g of %.3g rad/s\n", worst,
              scale);
  EXPECT_GT(scale, 0.0);
  EXPECT_LT(worst, 1e-6 * scale);
}
