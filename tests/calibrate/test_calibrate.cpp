// `demfem calibrate`: DEM element tests on a tiny specimen of a tiny bed.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "../scratch.hpp"
#include <nlohmann/json.hpp>

#include "../../compare/src/report_sections.hpp"
#include "constitutive/soil.hpp"
#include "demfem/app/vocabulary.hpp"
#include "demfem/calibrate/calibrate.hpp"
#include "demfem/compare/model_differences.hpp"
#include "demfem/scene/load.hpp"
#include <fmt/format.h>

namespace fs = std::filesystem;
namespace cst = demfem::continuum::constitutive;
using namespace demfem;

namespace {

// A 1.2 m wide box of 300 disks (r 15–25 mm, ≈ 0.4 m deep), μ_s = μ_D = 0.5: "μ = 0.5 disks".
// K_n = 1e6 N/m keeps δ/r ≈ 2 % at the base and at the largest confinement.
std::string tiny_scene(const fs::path& cache, const std::string& continuum_extra = "") {
  return R"(
[scene]
name = "tiny-calibration"
duration = 1.0
solvers = ["dem", "continuum"]
seed = 7
[domain]
polygon = [[0, 0], [1.2, 0], [1.2, 0.8], [0, 0.8]]
[soil.dem]
count = 300
radius = { uniform = [0.015, 0.025] }
density = 2650
contact = "cundall-rebound"
kn = 1.0e6
ks = 3.0e5
mu_static = 0.5
mu_dynamic = 0.5
rebound = 0.1
[soil.dem.packing]
damping = 0.05
max_time = 10.0
cache = ")" +
         cache.string() +
         R"("
[soil.continuum]
calibrate = "dem"
)" + continuum_extra +
         R"(
[[wall]]
name = "base"
points = [[0, 0], [1.2, 0]]
[[wall]]
name = "left"
points = [[0, 0.8], [0, 0]]
[[wall]]
name = "right"
points = [[1.2, 0], [1.2, 0.8]]
[load]
gravity = 9.81
)";
}

calibrate::CalibrateOptions tiny_options(const fs::path& dir) {
  calibrate::CalibrateOptions o;
  o.out_dir = dir;
  o.cache_dir = dir / "cache";
  o.particles = 200;
  o.specimens = 1; // one realisation keeps these tests short; PoolsSpecimens… tests several
  o.depth_fractions = {0.5, 1.0};
  o.cyclic_amplitudes = {3e-4, 3e-3};
  o.figures = false;
  return o;
}

} // namespace

// One tiny calibration, checked against closed forms and literature bands:
//  * φ_peak of μ = 0.5 disks: 12°–32°. Steady-state strength of disk packings without rolling
//    resistance at μ = 0.5 is sin φ ≈ 0.25–0.3 (φ ≈ 15–18°; Estrada, Taboada & Radjai, PRE 78
//    (2008) 021301); dense packings peak a few degrees higher. The band is wide because a
//    200-disk specimen is noisy.
//  * Stiffness: the small-strain shear modulus G0 (which gives the calibrated E) lies between
//    0.1 and 1.2 times the affine (Voigt) estimate. Affine is an upper bound of the elastic
//    modulus of the contact network at the deposited Z (the consolidated specimen may have a few
//    more contacts, hence 1.2); non-affine relaxation of disordered packings lowers it by up to
//    an order of magnitude near isostaticity (e.g. Somfai et al., PRE 72 (2005) 021301).
//  * K0 in (0.3, 1.5); the mass-matched surface holds the DEM's soil mass within 1 %.
//  * Cached second call: identical values, from the cache.
TEST(Calibrate, TinySpecimenGivesPlausibleParametersAndIsCached) {
  const fs::path dir = demfem::test::scratch_dir("calibrate");
  const auto file = scene::parse_scene(tiny_scene(dir / "cache"), (dir / "tiny.toml").string(),
                                       demfem::app::vocabulary());
  const auto& s = file.base;
  const auto o = tiny_options(dir);

  const auto c = calibrate::load_or_calibrate(s, o);
  EXPECT_FALSE(c.from_cache);
  ASSERT_EQ(c.tests.size(), 2u);
  for (const auto& t : c.tests) {
    EXPECT_TRUE(t.failure.empty()) << t.failure;
    EXPECT_GT(t.phi_peak, 12.0);
    EXPECT_LT(t.phi_peak, 32.0);
    EXPECT_GT(t.e50, 0.0);
    EXPECT_LE(t.phi_cv, t.phi_peak + 1e-9);
  }
  EXPECT_GT(c.young, 0.0);
  EXPECT_GT(c.poisson, 0.0);
  EXPECT_LT(c.poisson, 0.5);
  EXPECT_GT(c.friction_angle_deg, 12.0);
  EXPECT_LT(c.friction_angle_deg, 32.0);
  EXPECT_GE(c.dilation_angle_deg, 0.0);
  EXPECT_LE(c.dilation_angle_deg, c.friction_angle_deg);
  EXPECT_GT(c.k0, 0.3);
  EXPECT_LT(c.k0, 1.5);
  EXPECT_GT(c.bulk_density, 0.7 * 2650);
  EXPECT_LT(c.bulk_density, 0.95 * 2650);
  EXPECT_NEAR(c.continuum_mass, c.soil_mass, 0.01 * c.soil_mass);
  EXPECT_GT(c.surface, 0.3);
  EXPECT_LT(c.surface, 0.5);
  ASSERT_EQ(c.cyclic.size(), 2u);
  // The calibrated stiffness against the affine estimate: 0.1 ≤ G0/G_affine ≤ 1.2.
  EXPECT_GT(c.cyclic[0].g, 0.1 * c.affine_g) << c.cyclic[0].g << " vs " << c.affine_g;
  EXPECT_LT(c.cyclic[0].g, 1.2 * c.affine_g) << c.cyclic[0].g << " vs " << c.affine_g;
  EXPECT_DOUBLE_EQ(c.young, 2.0 * c.cyclic[0].g * (1.0 + c.poisson)); // E0 = 2 G0 (1 + ν)
  EXPECT_GT(c.young_e50, 0.0);
  // Damping grows with the amplitude and stays below the rigid–plastic loop's 2/π
  // (W_D = 4 τ_y γ_a, W_S = ½ τ_y γ_a; Kramer 1996, eq. 6.3).
  EXPECT_GE(c.cyclic[0].xi, -0.01);
  EXPECT_GT(c.cyclic[1].xi, c.cyclic[0].xi);
  EXPECT_LT(c.cyclic[1].xi, 2.0 / M_PI);
  EXPECT_LT(c.cyclic[1].g, c.cyclic[0].g); // modulus reduction
  // The cycles' in-plane Poisson's ratio ν' = −ε_xx/ε_zz (lateral stress held): the specimen
  // bulges as it is compressed (ν' > 0); at small strain it stays below the incompressible
  // ν' = 1 (2D), at large amplitude it may dilate beyond (measured 1.17 at γ = 6.5e-3 here).
  for (const auto& l : c.cyclic) EXPECT_GT(l.nu, 0.0) << l.gamma;
  EXPECT_LT(c.cyclic[0].nu, 1.0);
  // ν is the smallest cycle's, as G0 (one elastic state); the biaxial tests' ν is kept beside it.
  EXPECT_DOUBLE_EQ(c.poisson, c.cyclic[0].nu / (1.0 + c.cyclic[0].nu));
  EXPECT_TRUE(std::isfinite(c.poisson_e50));
  EXPECT_NE(c.poisson, c.poisson_e50);
  EXPECT_NE(c.poisson_source.find("cyclic"), std::string::npos) << c.poisson_source;
  // The smallest amplitude again at σ_c(H/10): the bed of linear-contact disks is softer at the
  // lower confinement, so the continuum's modulus follows E ∝ p^n, n = ln(G0/G0_s)/ln(σ/σ_s),
  // with p_ref the mid-depth confinement E0 comes from.
  ASSERT_EQ(c.cyclic_shallow.size(), 1u);
  EXPECT_NEAR(c.cyclic_shallow_sigma, 0.1 / 0.5 * c.cyclic_sigma, 1e-9 * c.cyclic_sigma);
  EXPECT_LT(c.cyclic_shallow[0].g, c.cyclic[0].g);
  EXPECT_NEAR(c.modulus_exponent,
              std::log(c.cyclic[0].g / c.cyclic_shallow[0].g) /
                  std::log(c.cyclic_sigma / c.cyclic_shallow_sigma),
              1e-12);
  EXPECT_GT(c.modulus_exponent, 0.0);
  EXPECT_LT(c.modulus_exponent, 1.0);
  EXPECT_DOUBLE_EQ(c.modulus_reference_stress, c.cyclic_sigma);

  const auto t0 = std::chrono::steady_clock::now();
  const auto d = calibrate::load_or_calibrate(s, o);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_TRUE(d.from_cache);
  (void)seconds; // no timed assertion (COMMON rules); from_cache is what makes it fast
  EXPECT_EQ(d.key, c.key);
  EXPECT_DOUBLE_EQ(d.young, c.young);
  EXPECT_DOUBLE_EQ(d.friction_angle_deg, c.friction_angle_deg);
  EXPECT_DOUBLE_EQ(d.k0, c.k0);
  EXPECT_DOUBLE_EQ(d.surface, c.surface);
  EXPECT_EQ(d.tests[0].ea, c.tests[0].ea);
  ASSERT_EQ(d.cyclic.size(), c.cyclic.size());
  EXPECT_DOUBLE_EQ(d.cyclic[0].nu, c.cyclic[0].nu); // the cache keeps ν' of the cycles
  EXPECT_DOUBLE_EQ(d.modulus_exponent, c.modulus_exponent);
  EXPECT_DOUBLE_EQ(d.modulus_reference_stress, c.modulus_reference_stress);
  ASSERT_EQ(d.cyclic_shallow.size(), 1u);
  EXPECT_DOUBLE_EQ(d.cyclic_shallow[0].g, c.cyclic_shallow[0].g);

  // Outputs: JSON, the TOML block (parses as a scene fragment), figures off here.
  const auto files = calibrate::write_calibration(c, dir / "out", false);
  EXPECT_TRUE(fs::exists(dir / "out" / "calibration.json"));
  std::ifstream tin(dir / "out" / "calibration.toml");
  const std::string block((std::istreambuf_iterator<char>(tin)), std::istreambuf_iterator<char>());
  EXPECT_NE(block.find("[soil.continuum]"), std::string::npos);
  EXPECT_NE(block.find("young = "), std::string::npos);
  EXPECT_NE(block.find("modulus_exponent = "), std::string::npos);
  EXPECT_NE(block.find("modulus_reference_stress = "), std::string::npos);

  // calibrate = "dem": the calibrated values fill what the scene does not state; stated ones win.
  const auto stated = scene::parse_scene(tiny_scene(dir / "cache", "young = 5.0e6\nk0 = 0.5\n"),
                                         "tiny2.toml", demfem::app::vocabulary());
  scene::Scene r = stated.base;
  ASSERT_TRUE(r.soil.continuum->calibrate_dem);
  const auto lines = calibrate::apply_calibration(r, d);
  EXPECT_EQ(lines.size(), 12u); // 11 parameters and the damping
  const auto& el = cst::elastic_block(*r.soil.continuum);
  EXPECT_DOUBLE_EQ(el.young, 5.0e6);
  EXPECT_DOUBLE_EQ(el.modulus_exponent, d.modulus_exponent);
  EXPECT_DOUBLE_EQ(el.modulus_reference_stress, d.modulus_reference_stress);
  // Dilatancy cut-off: the mean of the tests' dilation (densest point to the end), which a
  // dilating specimen has (ψ > 0 above), cached and passed to the continuum.
  {
    double mean = 0.0;
    for (const auto& t : c.tests) {
      EXPECT_GT(t.dilation, 0.0);
      double ev_max = 0.0;
      for (std::size_t i = 0; i < t.ea.size(); ++i) ev_max = std::max(ev_max, t.ea[i] + t.el[i]);
      // the samples are thinned for the file: the same to their resolution
      EXPECT_NEAR(t.dilation, ev_max - (t.ea.back() + t.el.back()), 1e-3);
      mean += t.dilation / static_cast<double>(c.tests.size());
    }
    EXPECT_NEAR(c.dilation_cutoff, mean, 1e-12);
    EXPECT_DOUBLE_EQ(d.dilation_cutoff, c.dilation_cutoff);
    EXPECT_DOUBLE_EQ(cst::strength_block(*r.soil.continuum).dilation_cutoff, c.dilation_cutoff);
    EXPECT_NE(block.find("dilation_cutoff = "), std::string::npos);
  }
  // Damping: Rayleigh α, β giving the smallest-amplitude cyclic ξ0 at the layer's first shear
  // mode f1 = V_s/4H (recomputed here from the resolved continuum), ξ(ω) = α/2ω + βω/2.
  {
    ASSERT_FALSE(d.cyclic.empty());
    const auto& sc = *r.soil.continuum;
    double zmin = *sc.surface;
    for (const auto& q : r.domain) zmin = std::min(zmin, q.z);
    const double vs = std::sqrt(el.young / (2.0 * (1.0 + el.poisson)) / sc.density);
    const double w1 = 2.0 * M_PI * vs / (4.0 * (*sc.surface - zmin));
    double xi0 = d.cyclic.front().xi, g0 = d.cyclic.front().gamma;
    for (const auto& p : d.cyclic)
      if (p.gamma < g0) g0 = p.gamma, xi0 = p.xi;
    const double a = r.continuum.rayleigh_alpha, b = r.continuum.rayleigh_beta;
    EXPECT_GT(a, 0.0);
    EXPECT_GT(b, 0.0);
    EXPECT_NEAR(a / (2.0 * w1) + b * w1 / 2.0, xi0, 1e-9 * xi0);
    // explicit integrator (issue 10): mass-proportional only, ξ0 at the excitation frequency
    // (none here: f1), no β (it would cut the stable step)
    scene::Scene ex = stated.base;
    ex.continuum.integrator = "explicit";
    (void)calibrate::apply_calibration(ex, d);
    EXPECT_EQ(ex.continuum.rayleigh_beta, 0.0);
    EXPECT_NEAR(ex.continuum.rayleigh_alpha / (2.0 * w1), xi0, 1e-9 * xi0);
    // stated Rayleigh coefficients win
    scene::Scene kept = stated.base;
    kept.continuum.rayleigh_stated = true;
    (void)calibrate::apply_calibration(kept, d);
    EXPECT_EQ(kept.continuum.rayleigh_alpha, 0.0);
    EXPECT_EQ(kept.continuum.rayleigh_beta, 0.0);
  }
  EXPECT_DOUBLE_EQ(r.soil.continuum->k0, 0.5);
  EXPECT_DOUBLE_EQ(cst::elastic_block(*r.soil.continuum).poisson, d.poisson);
  EXPECT_NEAR(cst::strength_block(*r.soil.continuum).friction_angle,
              d.friction_angle_deg * M_PI / 180.0, 1e-12);
  EXPECT_DOUBLE_EQ(r.soil.continuum->density, d.bulk_density);
  ASSERT_TRUE(r.soil.continuum->surface.has_value());
  EXPECT_DOUBLE_EQ(*r.soil.continuum->surface, d.surface);
  // The resolved dump shows calibrate and the provenance of every value, and reads back.
  const std::string dumped = scene::to_toml(r);
  EXPECT_NE(dumped.find("calibrate = 'dem'"), std::string::npos) << dumped;
  EXPECT_NE(dumped.find("provenance"), std::string::npos);
  EXPECT_NE(dumped.find("stated in the scene"), std::string::npos);
  const auto back = scene::parse_scene(dumped, "dumped.toml", demfem::app::vocabulary());
  EXPECT_DOUBLE_EQ(cst::elastic_block(*back.base.soil.continuum).poisson, d.poisson);
}

// Deterministic: the same inputs computed twice (no cache) give bit-identical results.
TEST(Calibrate, IsDeterministic) {
  const fs::path dir = demfem::test::scratch("calibrate_det");
  auto o = tiny_options(dir);
  o.cyclic = false;
  o.depth_fractions = {1.0};
  o.max_axial_strain = 0.05;
  const auto file =
      scene::parse_scene(tiny_scene(dir / "cache"), "tiny.toml", demfem::app::vocabulary());
  const auto a = calibrate::calibrate(file.base, o);
  const auto b = calibrate::calibrate(file.base, o);
#include "constitutive/soil.hpp"
#include "demfem/app/vocabulary.hpp"
  EXPECT_EQ(a.key, b.key);
  EXPECT_EQ(a.tests[0].sa, b.tests[0].sa);
  EXPECT_EQ(a.tests[0].el, b.tests[0].el);
  EXPECT_EQ(a.k0, b.k0);
  EXPECT_EQ(a.young, b.young);
}

// Several specimens: each is another realisation (its own seed, porosity and peaks), every one
// is tested at every confinement, and the continuum's values are fitted to all of them:
//  * the first specimen is the one-specimen calibration's (same seed, same bits);
//  * φ, c: the least-squares line t = c cos φ + s sin φ through all peaks, recomputed here;
//  * each specimen's own fit is reported (the spread), E50' and ν' are means at mid-depth.
TEST(Calibrate, PoolsSpecimensAndReportsTheirSpread) {
  const fs::path dir = demfem::test::scratch("calibrate_pool");
  auto o = tiny_options(dir);
  o.cyclic = false;
  o.max_axial_strain = 0.05;
  const auto file =
      scene::parse_scene(tiny_scene(dir / "cache"), "tiny.toml", demfem::app::vocabulary());
  const auto one = calibrate::calibrate(file.base, o);
#include "constitutive/soil.hpp"
#include "demfem/app/vocabulary.hpp"
  o.specimens = 2;
  const auto two = calibrate::calibrate(file.base, o);
  EXPECT_NE(one.key, two.key);
  ASSERT_EQ(one.tests.size(), 2u);
  ASSERT_EQ(two.tests.size(), 4u); // by confinement, then by specimen
  EXPECT_EQ(two.specimens, 2);
  ASSERT_EQ(two.specimen_seeds.size(), 2u);
  EXPECT_EQ(two.specimen_seeds[0], file.base.info.seed);
  EXPECT_NE(two.specimen_seeds[1], two.specimen_seeds[0]);
  for (std::size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(two.tests[k].specimen, static_cast<int>(k % 2));
    EXPECT_EQ(two.tests[k].sigma_c, one.tests[k / 2].sigma_c);
  }
  EXPECT_EQ(two.tests[0].sa, one.tests[0].sa); // specimen 1 is the one-specimen calibration's
  EXPECT_EQ(two.tests[2].sa, one.tests[1].sa);
  EXPECT_NE(two.tests[1].porosity, two.tests[0].porosity); // another realisation
  EXPECT_NE(two.tests[1].t_peak, two.tests[0].t_peak);
  // the pooled envelope: least squares over the four peaks
  double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (const auto& t : two.tests) {
    ASSERT_TRUE(t.failure.empty()) << t.failure;
    n += 1;
    sx += t.s_peak;
    sy += t.t_peak;
    sxx += t.s_peak * t.s_peak;
    sxy += t.s_peak * t.t_peak;
  }
  const double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx), icpt = (sy - slope * sx) / n;
  EXPECT_NEAR(two.phi_fit, std::asin(slope) * 180.0 / M_PI, 1e-9);
  EXPECT_NEAR(two.cohesion_fit, icpt / std::cos(std::asin(slope)), 1e-6 * std::abs(icpt) + 1e-9);
  // each specimen's own fit; the first is the one-specimen calibration's
  ASSERT_EQ(two.specimen_fits.size(), 2u);
  EXPECT_NEAR(two.specimen_fits[0].first, one.phi_fit, 1e-12);
  EXPECT_NEAR(two.specimen_fits[0].second, one.cohesion_fit, 1e-9);
  EXPECT_NE(two.specimen_fits[1].first, two.specimen_fits[0].first);
  // E, ν without the cyclic test: E50', ν' at mid-depth (σ_c at H/2), mean over the specimens
  const double e50 = 0.5 * (two.tests[0].e50 + two.tests[1].e50);
  const double nup =
      0.5 * (std::max(0.0, two.tests[0].nu_inplane) + std::max(0.0, two.tests[1].nu_inplane));
  EXPECT_NEAR(two.poisson, std::min(0.49, nup / (1.0 + nup)), 1e-12);
  EXPECT_NEAR(two.young, e50 * (1.0 - two.poisson * two.poisson), 1e-9 * e50);
  // the spread is written where a user reads it: the TOML block and the JSON
  const std::string block = calibrate::continuum_block(two);
  EXPECT_NE(block.find("each specimen's peaks alone"), std::string::npos) << block;
  const auto files = calibrate::write_calibration(two, dir / "out", false);
  std::ifstream jin(dir / "out" / "calibration.json");
  const auto j = nlohmann::json::parse(jin);
  EXPECT_EQ(j.at("specimen").at("count"), 2);
  EXPECT_EQ(j.at("envelope").at("per_specimen").size(), 2u);
  const auto back = calibrate::read_calibration(dir / "out" / "calibration.json");
  EXPECT_EQ(back.specimen_fits, two.specimen_fits);
  EXPECT_EQ(back.tests[3].specimen, 1);
  // and the comparison report of a run directory holding it says so
  const fs::path run = dir / "run";
  fs::create_directories(run / "calibration");
  fs::copy_file(dir / "out" / "calibration.json", run / "calibration" / "calibration.json",
                fs::copy_options::overwrite_existing);
  const auto facts = compare::read_model_facts(run);
  EXPECT_EQ(facts.cal_specimens, 2);
  EXPECT_EQ(facts.cal_specimen_fits, two.specimen_fits);
  const std::string html = compare::detail::parameters_section(
      run, {compare::ParamRow{"continuum", "friction_angle", "x", "calibrated"}}, facts, nullptr);
  EXPECT_NE(html.find("2 specimen(s) of 200 disks"), std::string::npos) << html;
  EXPECT_NE(html.find(fmt::format("{:.1f}° / {:.3g} kPa", two.specimen_fits[1].first,
                                  two.specimen_fits[1].second / 1e3)),
            std::string::npos)
      << html;
}

// The cyclic test runs on every specimen too: G0, ξ and ν' of the continuum are the means per
// amplitude; each specimen's cycles are kept (the spread), its first is the one-specimen
// calibration's, and ν and E0 come from the pooled smallest cycle.
TEST(Calibrate, PoolsTheCyclicTestsOfTheSpecimens) {
  const fs::path dir = demfem::test::scratch("calibrate_pool_cyclic");
  auto o = tiny_options(dir);
  o.depth_fractions = {0.5};
  o.cyclic_amplitudes = {3e-4};
  const auto file =
      scene::parse_scene(tiny_scene(dir / "cache"), "tiny.toml", demfem::app::vocabulary());
  const auto one = calibrate::calibrate(file.base, o);
#include "constitutive/soil.hpp"
#include "demfem/app/vocabulary.hpp"
  o.specimens = 2;
  const auto two = calibrate::calibrate(file.base, o);
  ASSERT_EQ(one.cyclic_per_specimen.size(), 1u);
  ASSERT_EQ(two.cyclic_per_specimen.size(), 2u);
  ASSERT_EQ(two.cyclic.size(), 1u);
  const auto& a = two.cyclic_per_specimen[0][0];
  const auto& b = two.cyclic_per_specimen[1][0];
  EXPECT_EQ(a.g, one.cyclic[0].g); // specimen 1 is the one-specimen calibration's
  EXPECT_EQ(a.nu, one.cyclic[0].nu);
  EXPECT_NE(b.g, a.g); // another realisation
  EXPECT_DOUBLE_EQ(two.cyclic[0].g, 0.5 * (a.g + b.g));
  EXPECT_DOUBLE_EQ(two.cyclic[0].xi, 0.5 * (a.xi + b.xi));
  EXPECT_DOUBLE_EQ(two.cyclic[0].nu, 0.5 * (a.nu + b.nu));
  EXPECT_DOUBLE_EQ(two.poisson, two.cyclic[0].nu / (1.0 + two.cyclic[0].nu));
  EXPECT_DOUBLE_EQ(two.young, 2.0 * two.cyclic[0].g * (1.0 + two.poisson));
  EXPECT_NE(two.young_source.find("mean of 2 specimen(s)"), std::string::npos) << two.young_source;
  EXPECT_NE(calibrate::continuum_block(two).find("each specimen's smallest cycle"),
            std::string::npos);
  // the JSON keeps each specimen's cycles
  (void)calibrate::write_calibration(two, dir / "out", false);
  const auto back = calibrate::read_calibration(dir / "out" / "calibration.json");
  ASSERT_EQ(back.cyclic_per_specimen.size(), 2u);
  EXPECT_DOUBLE_EQ(back.cyclic_per_specimen[1][0].g, b.g);
  EXPECT_DOUBLE_EQ(back.cyclic_per_specimen[1][0].nu, b.nu);
}

TEST(Calibrate, SceneKeyRejectsUnknownCalibration) {
  const std::string text = "[scene]\nname = \"x\"\nduration = 1\nsolvers = [\"continuum\"]\n"
                           "[domain]\npolygon = [[0, 0], [1, 0], [1, 1], [0, 1]]\n"
                           "[soil.continuum]\ncalibrate = \"lab\"\n";
  try {
    (void)scene::parse_scene(text, "x.toml", demfem::app::vocabulary());
    ADD_FAILURE() << "calibrate = \"lab\" was accepted";
  } catch (const scene::SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown calibration 'lab'"), std::string::npos)
        << e.what();
  }
  std::string ok = text;
  ok.replace(ok.find("\"lab\""), 5, "\"dem\"");
  EXPECT_TRUE(scene::parse_scene(ok, "x.toml", demfem::app::vocabulary())
                  .base.soil.continuum->calibrate_dem);
}
