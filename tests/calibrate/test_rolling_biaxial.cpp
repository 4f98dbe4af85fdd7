// The macroscopic friction angle of the calibration's DEM biaxial test (calibrate/src/
// calibrate_element.cpp) against the rolling friction μ_r (dem/contact/rolling_spring.hpp): one
// specimen of the retaining wall's soil (1,000 disks, deposited once, without rolling resistance,
// as `demfem calibrate` deposits its first specimen), sheared at two confinements with μ_r = 0,
// 0.05 and 0.1. Disks without rolling resistance roll instead of sliding and saturate at a low φ;
// rolling resistance raises it (Estrada, Taboada & Radjai, PRE 78 (2008) 021301). The numbers are
// recorded in cases/README.md ("Rolling resistance and the biaxial friction angle"). Minutes on
// 2 cores: a `long` test.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <numbers>
#include <string>
#include <vector>

#include "../../calibrate/src/calibrate_element.hpp"
#include "../scratch.hpp"
#include "demfem/app/vocabulary.hpp"
#include "demfem/calibrate/calibrate.hpp"
#include "demfem/dem/pack.hpp"
#include "demfem/scene/load.hpp"

using namespace demfem;
namespace calib = demfem::calibrate::calib;

namespace {

double deg(double rad) {
  return rad * 180.0 / std::numbers::pi;
}

// The wall's scene with `extra` keys added to its [soil.dem].
scene::Scene wall_scene(const std::string& extra) {
  const auto path = std::filesystem::path(DEMFEM_SOURCE_DIR) / "cases" / "retaining_wall.toml";
  std::ifstream in(path);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto at = text.find("[soil.dem]\n");
  text.insert(at + 11, extra);
  return scene::parse_scene(text, path.string(), app::vocabulary()).base;
}

struct Peak {
  double phi_peak = 0.0, phi_cv = 0.0, s = 0.0, t = 0.0, porosity = 0.0;
};

// As calibrate.cpp's evaluate(): the peak of the 1 %-running-mean mobilised ratio
// sin φ = (σ1 − σ3)/(σ1 + σ3), φ_cv its mean over the last quarter of the strain.
Peak evaluate(const calib::BiaxialResult& r, double max_strain) {
  Peak p;
  p.porosity = r.porosity;
  const auto& q = r.samples;
  const std::size_t n = q.size(), win = std::max<std::size_t>(1, n / 15); // 1 % of 15 %
  double best = -1.0, cv = 0.0;
  int ncv = 0;
  for (std::size_t i = 0; i + win <= n; ++i) {
    double ratio = 0.0, s = 0.0;
    for (std::size_t k = i; k < i + win; ++k) {
      ratio += (q[k].s_axial - q[k].s_lateral) / (q[k].s_axial + q[k].s_lateral);
      s += 0.5 * (q[k].s_axial + q[k].s_lateral);
    }
    ratio /= static_cast<double>(win);
    s /= static_cast<double>(win);
    if (ratio > best) {
      best = ratio;
      p.s = s;
      p.t = s * ratio; // t = s sin φ_mobilised at the peak
    }
  }
  for (const auto& x : q)
    if (x.e_axial >= 0.75 * max_strain) {
      cv += (x.s_axial - x.s_lateral) / (x.s_axial + x.s_lateral);
      ++ncv;
    }
  p.phi_peak = deg(std::asin(std::clamp(best, 0.0, 1.0)));
  p.phi_cv = deg(std::asin(std::clamp(cv / std::max(ncv, 1), 0.0, 1.0)));
  return p;
}

} // namespace

// Three specimens (the calibration's seeds: the scene's, + 1,000,003 k), each deposited once and
// sheared at the four confinements of the wall's calibration (σ_c = ρ_b g z at z = H/10, H/4, H/2
// and H of its bed: 12, 30, 61 and 122 kPa) per μ_r. The mean φ_peak of the twelve tests must rise
// by more than 0.5° per step of μ_r, and φ of the Mohr–Coulomb envelope through the twelve peaks
// (t = s sin φ + c cos φ, least squares, as calibrate.cpp fits it) from μ_r = 0 to 0.1: equal
// values mean the rolling sub-model has no effect.
TEST(CalibrateLong, RollingResistanceRaisesTheBiaxialFrictionAngle) {
  const auto cache = test::scratch_dir("packings");
  const scene::Scene wall = wall_scene("");
  std::vector<dem::Particles> packings;
  for (int k = 0; k < 3; ++k)
    packings.push_back(
        dem::pack_or_load(calibrate::specimen_scene(wall, 1000, cache, k), cache).particles);
  calib::ElementSettings es; // the calibration's: I = 1e-3, to 15 % axial strain
  const std::vector<double> sigmas = {12.2e3, 30.4e3, 60.8e3, 121.6e3};
  std::vector<double> envelope, mean_peak;
  for (const double mu_r : {0.0, 0.05, 0.1}) {
    // K_r = K_s (3e6 N/m): k_r = K_s R*², the shear spring's stiffness on the rolling arc R*θ
    const std::string rolling =
        mu_r > 0.0 ? "rolling = \"elastic-plastic\"\nrolling_stiffness = 3.0e6\nmu_rolling = " +
                         std::to_string(mu_r) + "\n"
                   : "";
    calib::Specimen sp;
    sp.config = dem::make_config(wall_scene(rolling));
    sp.config.gravity = 0.0;
    sp.config.shaking = false;
    sp.thickness = wall.soil.dem->thickness;
    std::vector<double> xs, ys;
    double peak = 0.0, cv = 0.0, porosity = 0.0;
    for (const auto& packed : packings) {
      sp.particles = packed; // the same packings for every μ_r
      sp.d_mean = 0.0;
      for (const double r : sp.particles.radius) sp.d_mean += 2.0 * r;
      sp.d_mean /= static_cast<double>(sp.particles.size());
      for (const double sigma : sigmas) {
        const auto r = calib::biaxial(sp, sigma, es);
        ASSERT_TRUE(r.failure.empty()) << r.failure;
        const Peak p = evaluate(r, es.max_axial_strain);
        std::printf("mu_r = %.2f, sigma_c = %5.1f kPa: porosity %.4f, phi_peak %.1f deg, phi_cv "
                    "%.1f deg\n",
                    mu_r, sigma / 1e3, p.porosity, p.phi_peak, p.phi_cv);
        xs.push_back(p.s);
        ys.push_back(p.t);
        peak += p.phi_peak / 12.0;
        cv += p.phi_cv / 12.0;
        porosity += p.porosity / 12.0;
      }
    }
    // least squares t = a + b s: sin φ = b, c = a / cos φ
    double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
    for (std::size_t i = 0; i < xs.size(); ++i) {
      sx += xs[i];
      sy += ys[i];
      sxx += xs[i] * xs[i];
      sxy += xs[i] * ys[i];
    }
    const double n = static_cast<double>(xs.size());
    const double b = (n * sxy - sx * sy) / (n * sxx - sx * sx), a = (sy - b * sx) / n;
    const double phi = deg(std::asin(std::clamp(b, 0.0, 1.0)));
    std::printf("mu_r = %.2f: envelope phi %.1f deg, c %.2f kPa; mean phi_peak %.1f deg, mean "
                "phi_cv %.1f deg, mean porosity %.4f\n",
                mu_r, phi, a / std::cos(std::asin(b)) / 1e3, peak, cv, porosity);
    envelope.push_back(phi);
    mean_peak.push_back(peak);
  }
  EXPECT_GT(mean_peak[1], mean_peak[0] + 0.5);
  EXPECT_GT(mean_peak[2], mean_peak[1] + 0.5);
  EXPECT_GT(envelope[2], envelope[0]);
}
