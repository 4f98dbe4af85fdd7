// Probes and loads without a test elsewhere: base shaking as a body force, wall thrust against the
// pressure profile, the surface profile and the loci of tagged particles.
#include <gtest/gtest.h>

#include "../scratch.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "demfem/app/vocabulary.hpp"
#include "demfem/dem/engine.hpp"
#include "demfem/dem/io.hpp"
#include "demfem/dem/run.hpp"
#include "demfem/output/csv.hpp"
#include "demfem/scene/load.hpp"

using namespace demfem;

namespace {

constexpr double kPi = 3.14159265358979323846;

// Header (first non-comment line) and the last row of a probe CSV.
struct Csv {
  std::vector<std::string> header;
  std::vector<double> last;
};

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) out.push_back(cell);
  return out;
}

Csv read_csv(const std::filesystem::path& f) {
  std::ifstream in(f);
  std::string line;
  Csv c;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (c.header.empty()) {
      c.header = split(line);
      continue;
    }
    c.last.clear();
    for (const auto& s : split(line)) c.last.push_back(std::stod(s));
  }
  return c;
}

double column(const Csv& c, const std::string& name) {
  for (std::size_t k = 0; k < c.header.size(); ++k)
    if (c.header[k] == name) return c.last.at(k);
  ADD_FAILURE() << "no column " << name;
  return std::nan("");
}

// "p<id>" (built with +=: GCC 12 warns falsely on "p" + std::to_string(…) under -O3).
std::string pid(std::uint32_t id) {
  std::string s = "p";
  s += std::to_string(id);
  return s;
}

} // namespace

// A free particle under base shaking (no gravity, no contacts) from rest: body force
// m·A·sin(2πft) gives a = A sin(2πft), so
//   v(t) = ∫₀ᵗ A sin(2πfs) ds = A (1 − cos 2πft)/(2πf),
//   x(t) = ∫₀ᵗ v ds = A t/(2πf) − A sin(2πft)/(2πf)²   (d/dt of the second term: −A
//   cos(2πft)/(2πf)).
// Symplectic Euler sums a(t_n)Δt from the left: |v_n − v(t_n)| ≤ ½Δt|a(t_n) − a(0)| + O(Δt²) ≤ AΔt;
// x_n = Σ v_k Δt, whose first-order error cancels against that of v: |x_n − x(t_n)| ≤ AΔt·t_n
// is a loose bound. A wrong sign, factor 2π or phase gives errors of order A/(2πf)² ≫ these.
TEST(DemLoads, BaseShakingBodyForceOnAFreeParticle) {
  const double A = 2.0, f = 3.0;
  for (const char dir : {'x', 'z'}) {
    dem::EngineConfig c;
    c.gravity = 0.0;
    c.shaking = true;
    c.shaking_direction = dir;
    c.shaking_acceleration = scene::TimeFunction::sine(A, f);
    dem::Engine e(c);
    e.add_particle(0.3, 0.7, 0.05);
    const double dt = 1.0e-4;
    e.set_dt(dt);
    double max_dv = 0.0, max_dx = 0.0;
    const double w = 2.0 * kPi * f;
    double sum_a2_dt2 = 0.0;
    while (e.time() < 1.1) {
      const double an = A * std::sin(w * e.time());
      sum_a2_dt2 += an * an * dt * dt;
      e.step();
      const double t = e.time();
      const double v = A * (1.0 - std::cos(w * t)) / w;
      const double x = A * t / w - A * std::sin(w * t) / (w * w);
      const auto& p = e.particles();
      const double vs = dir == 'x' ? p.vx[0] : p.vz[0];
      const double xs = dir == 'x' ? p.x[0] - 0.3 : p.z[0] - 0.7;
      const double vo = dir == 'x' ? p.vz[0] : p.vx[0]; // the other direction stays at rest
      ASSERT_EQ(vo, 0.0);
      max_dv = std::max(max_dv, std::abs(vs - v));
      max_dx = std::max(max_dx, std::abs(xs - x) / std::max(t, 1e-300));
    }
    EXPECT_LT(max_dv, A * dt) << dir;
    EXPECT_LT(max_dx, A * dt) << dir;
    // Energy bookkeeping: the body force's work is counted over each step's displacement,
    // W = Σ m a_n v_{n+1} Δt, while ½m v_{n+1}² − ½m v_n² = m a_n Δt (v_n + v_{n+1})/2, so from
    // rest W − KE = ½ m Σ a_n² Δt² exactly (symplectic Euler's O(Δt) kinetic-energy lag).
    const auto b = e.energy();
    const double m = e.particles().mass[0];
    EXPECT_NEAR(b.external_work - b.kinetic, 0.5 * m * sum_a2_dt2, 1e-9 * b.kinetic) << dir;
    EXPECT_NEAR(b.external_work, b.kinetic, 0.02 * b.kinetic) << dir;
  }
}

// On the settled box (settle_box.toml without its footing, frictionless side walls): the wall
// thrust on the left wall equals the integral of its pressure profile, Σ p_k h t (both sum the
// normal contact forces on the wall; frictionless: no shear part); the surface profile lies within
// one particle diameter of the bed top from the disks' area at a random-packing fraction, and
// equals the highest particle tops of the final state; the loci follow the tagged particles.
TEST(DemProbes, ThrustPressureSurfaceLociOnSettledBed) {
  const auto file = scene::load_scene_file(DEMFEM_SOURCE_DIR "/cases/verification/settle_box.toml",
                                           demfem::app::vocabulary());
  auto sc = file.base;
  const int bins = 12;
  scene::Probe pp;
  pp.kind = scene::ProbeKind::PressureProfile;
  pp.target = "left";
  pp.bins = bins;
  sc.probes.push_back(pp);
  scene::Probe wt;
  wt.kind = scene::ProbeKind::WallThrust;
  wt.target = "left";
  sc.probes.push_back(wt);
  scene::Probe lp;
  lp.kind = scene::ProbeKind::Loci;
  lp.points = {{0.1, 0.05}, {0.9, 0.4}};
  sc.probes.push_back(lp);
  sc.output.vtk = false;
  sc.structures
      .clear(); // no footing: a flat bed top (the footing makes the bed heave at the walls)
  // The scene drops a square lattice straight down, which stacks the disks in vertical columns
  // (no thrust on the walls, tops at the column heights). Random initial velocities (±0.5 m/s,
  // fixed seed) make a random bed instead.
  std::mt19937_64 g(11);
  for (auto& q : sc.soil.dem->particles) {
    q[3] = static_cast<double>(g() >> 11) * 0x1.0p-53 - 0.5;
    q[4] = static_cast<double>(g() >> 11) * 0x1.0p-53 - 0.5;
  }
  dem::RunOptions o;
  o.out_dir = demfem::test::scratch("settled");
  const auto s = dem::run(sc, o);
  ASSERT_TRUE(s.ok) << s.message;
  const auto dir = o.out_dir / "dem";

  // Thrust = ∫ p dz · t over the wall height 1.2 m (bins of h = 0.1 m).
  const auto walls = read_csv(dir / "walls.csv");
  const auto pres = read_csv(dir / "pressure_left.csv");
  ASSERT_EQ(pres.last.size(), static_cast<std::size_t>(bins) + 1);
  const double h = 1.2 / bins, t = sc.soil.dem->thickness;
  double integral = 0.0;
  for (int k = 1; k <= bins; ++k) integral += pres.last[static_cast<std::size_t>(k)] * h * t;
  const double thrust = column(walls, "left.thrust [N]");
  EXPECT_GT(thrust, 10.0);                      // the bed pushes on the wall
  EXPECT_NEAR(thrust, integral, 1e-5 * thrust); // contact forces are stored as float
  // The pressure acts only below the bed top.
  for (int k = 5; k <= bins; ++k) EXPECT_EQ(pres.last[static_cast<std::size_t>(k)], 0.0) << k;

  // Bed top from the disks' area A = Σπr² over the width W = 1 m at packing fraction φ = 0.82
  // (random packing of polydisperse disks, 0.80–0.84): H = A/(φ W).
  double area = 0.0, rmax = 0.0;
  for (const auto& q : sc.soil.dem->particles) {
    area += kPi * q[2] * q[2];
    rmax = std::max(rmax, q[2]);
  }
  const double H = area / 0.82;
  const auto surf = read_csv(dir / "surface.csv");
  ASSERT_EQ(surf.last.size(), 11u);
  const auto ck = dem::io::read_checkpoint(dir / "final.ckpt");
  const auto& P = ck.particles;
  for (std::size_t b = 1; b <= 10; ++b) {
    EXPECT_NEAR(surf.last[b], H, 2.0 * rmax) << "bin " << b;
    double top = -1e300;
    for (std::size_t i = 0; i < P.size(); ++i) {
      const auto bin = static_cast<std::size_t>(P.x[i] / 0.1);
      if (bin + 1 == b) top = std::max(top, P.z[i] + P.radius[i]);
    }
    EXPECT_NEAR(surf.last[b], top, 1e-8) << "bin " << b;
  }

  // Loci: the particles nearest to the points at the start, tagged, traced to the end.
  const auto loci = read_csv(dir / "loci.csv");
  ASSERT_EQ(loci.header.size(), 5u);
  std::size_t tagged = 0;
  for (std::size_t i = 0; i < P.size(); ++i) {
    if (!(P.flags[i] & dem::kFlagTagged)) continue;
    ++tagged;
    const std::string id = pid(P.id[i]);
    EXPECT_NEAR(column(loci, id + ".x [m]"), P.x[i], 1e-8);
    EXPECT_NEAR(column(loci, id + ".z [m]"), P.z[i], 1e-8);
  }
  EXPECT_EQ(tagged, 2u);
  for (std::size_t k = 0; k < lp.points.size(); ++k) {
    std::size_t best = 0;
    double bd = 1e300;
    for (std::size_t i = 0; i < sc.soil.dem->particles.size(); ++i) {
      const auto& q = sc.soil.dem->particles[i];
      const double d = std::hypot(q[0] - lp.points[k].x, q[1] - lp.points[k].z);
      if (d < bd) {
        bd = d;
        best = i;
      }
    }
    EXPECT_EQ(loci.header[1 + 2 * k], pid(static_cast<std::uint32_t>(best)) + ".x [m]");
  }
}

// [[probe]] interval: each probe samples at its own interval (0: output.probe_interval), and at
// the end of the run; the energy watch keeps output.probe_interval.
TEST(DemProbes, EachProbeSamplesAtItsOwnInterval) {
  const auto file = scene::load_scene_file(DEMFEM_SOURCE_DIR "/cases/verification/settle_box.toml",
                                           demfem::app::vocabulary());
  auto sc = file.base;
  sc.info.duration = 0.2;
  sc.output.vtk = false;
  sc.output.probe_interval = 0.01;
  for (auto& p : sc.probes) {
    if (p.kind == scene::ProbeKind::Energy) p.interval = 0.05;
    if (p.kind == scene::ProbeKind::Coordination) p.interval = 0.04;
  }
  dem::RunOptions o;
  o.out_dir = demfem::test::scratch("intervals");
  const auto s = dem::run(sc, o);
  ASSERT_TRUE(s.ok) << s.message;
  auto times = [&](const char* f) {
    const auto t = output::read_csv(o.out_dir / "dem" / f).column("time");
    std::vector<double> r;
    for (double v : t) r.push_back(std::round(v * 1e6) / 1e6); // within a step of the grid
    return r;
  };
  auto grid = [](double dt, int n) {
    std::vector<double> r;
    for (int k = 0; k <= n; ++k) r.push_back(std::round(k * dt * 1e6) / 1e6);
    return r;
  };
  const double dt = s.dt;
  auto near = [&](const std::vector<double>& got, const std::vector<double>& want, const char* f) {
    ASSERT_EQ(got.size(), want.size()) << f;
    for (std::size_t k = 0; k < got.size(); ++k) EXPECT_NEAR(got[k], want[k], dt) << f << " " << k;
  };
  near(times("energy.csv"), grid(0.05, 4), "energy.csv");
  near(times("coordination.csv"), grid(0.04, 5), "coordination.csv");
  near(times("surface.csv"), grid(0.01, 20), "surface.csv");
  near(times("structures.csv"), grid(0.01, 20), "structures.csv");
}
