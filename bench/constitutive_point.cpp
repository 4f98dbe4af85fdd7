// Cost of one integration-point update through the constitutive seam (Material::update), per
// model: a point at a K0 stress (σzz = −50 kPa, σxx = σyy = −25 kPa) sheared cyclically
// (amplitude γa, `steps` increments per cycle, with a small normal-strain increment), each
// update committed before the next (as the explicit integrator does). Usage:
//   bench_constitutive_point [updates=2000000] [steps_per_cycle=4000] [amplitude=1e-3]
// Prints updates/s for Mohr–Coulomb and the hypoplastic model (with and without the
// intergranular strain), and for the hypoplastic model its sub-steps per update and the cost
// with the numerical tangent (implicit stages). Timed in processor time (std::clock), the best of
// three repeats, so that a busy machine slows it less. Results: bench/RESULTS.md.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>

#include "constitutive/registry.hpp"
#include "demfem/scene/params.hpp"

using namespace demfem::continuum::constitutive;

namespace {

State at_k0(const Material& m) {
  State s = m.initial_state();
  s.stress = {-2.5e4, -5e4, 0.0};
  s.syy = -2.5e4;
  m.set_stress(s);
  return s;
}

// The strain increment of update j: cyclic shear plus a tenth of it on the normal strains.
Voigt increment(long j, int steps, double amplitude) {
  const double dg = 4.0 * amplitude / steps;
  const long phase = (j + steps / 4) % steps; // start at γ = 0 going up
  const double s = phase < steps / 2 ? 1.0 : -1.0;
  return {{0.1 * s * dg, -0.1 * s * dg, s * dg}};
}

struct Timing {
  double per_second = 0.0;
  double checksum = 0.0;
};

Timing run(const Material& m, long updates, int steps, double amplitude, bool tangent) {
  Timing best;
  for (int rep = 0; rep < 3; ++rep) {
    State c = at_k0(m), s;
    VoigtMatrix t{};
    double sum = 0.0;
    const std::clock_t c0 = std::clock();
    for (long j = 0; j < updates; ++j) {
      m.update(c, increment(j, steps, amplitude), s, tangent ? &t : nullptr);
      c = s;
      sum += s.stress[2];
    }
    const double dt = double(std::clock() - c0) / CLOCKS_PER_SEC;
    if (updates / dt > best.per_second) best = {updates / dt, sum};
  }
  return best;
}

} // namespace

int main(int argc, char** argv) {
  const long updates = argc > 1 ? std::atol(argv[1]) : 2000000;
  const int steps = argc > 2 ? std::atoi(argv[2]) : 4000;
  const double amplitude = argc > 3 ? std::atof(argv[3]) : 1e-3;
  std::printf("%ld updates, %d per cycle, amplitude %g (increment |Δγ| = %.3g)\n", updates, steps,
              amplitude, 4.0 * amplitude / steps);

  // the models as a scene chooses them: the continuum slot's choice, Material::from
  const demfem::scene::ModelSlot slot = model_slot();
  demfem::scene::ModelChoice mc = demfem::scene::default_choice(slot); // mohr-coulomb
  mc.get<Elastic::Parameters>().young = 3e7;
  mc.get<Elastic::Parameters>().poisson = 0.3;
  mc.get<MohrCoulomb::Parameters>().friction_angle = 30.0 * kRadPerDeg;
  mc.get<MohrCoulomb::Parameters>().dilation_angle = 5.0 * kRadPerDeg;
  demfem::scene::ModelChoice hp = mc;
  demfem::scene::choose(hp, slot, Hypoplastic::keyword);
  hp.get<Hypoplastic::Parameters>().initial_void_ratio = 0.7;
  demfem::scene::ModelChoice hp_off = hp;
  hp_off.get<Hypoplastic::Parameters>().intergranular_strain = false;

  struct Case {
    const char* name;
    Material m;
  };
  const Case cases[] = {{"mohr-coulomb", Material::from(mc)},
                        {"hypoplastic (IGS)", Material::from(hp)},
                        {"hypoplastic (no IGS)", Material::from(hp_off)}};
  double mc_rate = 0.0;
  for (const Case& c : cases) {
    const Timing r = run(c.m, updates, steps, amplitude, false);
    if (mc_rate == 0.0) mc_rate = r.per_second;
    std::printf("%-22s %.3g updates/s  %.1f ns/update  (%.1f x Mohr–Coulomb's time)  [%g]\n",
                c.name, r.per_second, 1e9 / r.per_second, mc_rate / r.per_second, r.checksum);
  }
  // sub-steps per update of the hypoplastic model on the same path
  for (const demfem::scene::ModelChoice* p : {&hp, &hp_off}) {
    const Material m = Material::from(*p);
    const Hypoplastic& h = *m.get_if<Hypoplastic>();
    const State s0 = at_k0(m);
    hypoplastic::PointState y = h.point(s0, std::get<Hypoplastic::Internal>(s0.internal));
    long sub = 0, rejected = 0;
    const long n = std::min(updates, 200000L);
    for (long j = 0; j < n; ++j) {
      const Voigt d = increment(j, steps, amplitude);
      const hypoplastic::Report r = hypoplastic::integrate(h.k, y, {d[0], d[1], 0.5 * d[2], 0.0});
      sub += r.substeps;
      rejected += r.rejected;
    }
    std::printf("hypoplastic (%s): %.3f sub-steps and %.4f refusals per update\n",
                h.k.igs ? "IGS" : "no IGS", double(sub) / n, double(rejected) / n);
  }
  const long nt = std::max(updates / 20, 1L);
  const Timing t = run(cases[1].m, nt, steps, amplitude, true);
  std::printf("hypoplastic (IGS) with numerical tangent: %.3g updates/s  %.1f ns/update\n",
              t.per_second, 1e9 / t.per_second);
  return 0;
}
