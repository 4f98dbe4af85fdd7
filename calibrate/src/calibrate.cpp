#include "demfem/calibrate/calibrate.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <numbers>
#include <numeric>
#include <tuple>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "calibrate_element.hpp"
#include "constitutive/soil.hpp"
#include "demfem/compare/plot.hpp"
#include "demfem/dem/engine.hpp"
#include "demfem/dem/key_hash.hpp"
#include "demfem/dem/pack.hpp"
#include "demfem/dem/stable_step.hpp"
#include "demfem/scene/load.hpp"
#include "demfem/scene/write_file.hpp"

namespace demfem::calibrate {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr int kCalibrationFormat = 10; // bump when the tests or their evaluation change
constexpr double kPi = std::numbers::pi;
double deg(double rad) {
  return rad * 180.0 / kPi;
}

using Fnv = dem::KeyHash; // the cache key (key_hash.hpp)

// A cyclic test's loop as the calibration keeps it.
CyclicPoint point_of(const calib::CyclicLoop& l) {
  return {l.gamma_amplitude, l.g_secant, l.damping, l.nu_inplane};
}

// Mean G of a list of cycles (the shallow confinement's smallest cycle over the specimens).
double mean_g(const std::vector<CyclicPoint>& v) {
  double g = 0.0;
  for (const auto& q : v) g += q.g / static_cast<double>(v.size());
  return g;
}

// The distinct confinements of the biaxial tests, in test order.
std::vector<double> confinements(const Calibration& c) {
  std::vector<double> v;
  for (const auto& t : c.tests)
    if (std::none_of(v.begin(), v.end(),
                     [&](double x) { return std::abs(x - t.sigma_c) <= 1e-9 * x; }))
      v.push_back(t.sigma_c);
  return v;
}

[[noreturn]] void scene_error(const scene::Scene& s, const std::string& key,
                              const std::string& msg) {
  scene::Diagnostic d;
  d.file = s.source_file;
  d.key = key;
  d.message = msg;
  throw scene::SceneError({d});
}

double area(const scene::Polygon& p) {
  double s = 0.0;
  for (std::size_t k = 0; k < p.size(); ++k) {
    const auto a = p[k], b = p[(k + 1) % p.size()];
    s += a.x * b.z - b.x * a.z; // shoelace
  }
  return 0.5 * std::abs(s);
}

// Area of the polygon below height z.
double area_below(const scene::Polygon& poly, double z) {
  return area(scene::clip(poly, 0.0, 1.0, z));
}

struct Fit {
  double slope = 0.0, intercept = 0.0;
  bool ok = false;
};
Fit linear_fit(const std::vector<double>& x, const std::vector<double>& y) {
  Fit f;
  const std::size_t n = x.size();
  if (n < 2) return f;
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < n; ++i) {
    sx += x[i];
    sy += y[i];
    sxx += x[i] * x[i];
    sxy += x[i] * y[i];
  }
  const double den = n * sxx - sx * sx;
  if (!(std::abs(den) > 0.0)) return f;
  f.slope = (n * sxy - sx * sy) / den; // least squares
  f.intercept = (sy - f.slope * sx) / n;
  f.ok = true;
  return f;
}

// Evaluates one biaxial test (samples compression positive).
BiaxialCurve evaluate(double depth, const calib::BiaxialResult& r, double max_strain) {
  BiaxialCurve c;
  c.depth = depth;
  c.sigma_c = r.sigma_c;
  c.porosity = r.porosity;
  c.strain_rate = r.strain_rate;
  c.failure = r.failure;
  const std::size_t n = r.samples.size();
  for (const auto& s : r.samples) {
    c.ea.push_back(s.e_axial);
    c.el.push_back(s.e_lateral);
    c.sa.push_back(s.s_axial);
    c.sl.push_back(s.s_lateral);
  }
  if (n >= 8) {
    std::vector<double> q(n), ratio(n);
    for (std::size_t i = 0; i < n; ++i) {
      q[i] = c.sa[i] - c.sl[i];
      ratio[i] = q[i] / (c.sa[i] + c.sl[i]); // sin φ_mobilised = (σ1 − σ3)/(σ1 + σ3)
    }
    // Stick-slip makes the platen stresses noisy: peaks are taken on running means over 1 %
    // axial strain.
    const auto win = static_cast<std::size_t>(
        std::max(1.0, 0.01 / std::max(max_strain, 1e-6) * static_cast<double>(n)));
    const auto qs = compare::running_mean(q, win), rs = compare::running_mean(ratio, win);
    std::size_t ip = 0, iq = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (rs[i] > rs[ip]) ip = i;
      if (qs[i] > qs[iq]) iq = i;
    }
    c.phi_peak = deg(std::asin(std::clamp(rs[ip], 0.0, 1.0)));
    const double smean = 0.5 * (c.sa[ip] + c.sl[ip]);
    c.s_peak = smean; // s = (σ1 + σ3)/2, t = s sin φ_mobilised at the (smoothed) peak
    c.t_peak = smean * rs[ip];
    c.strain_at_peak = c.ea[ip];
    // Residual / critical state: mean mobilised ratio over the last quarter.
    double sum = 0.0;
    std::size_t cnt = 0;
    std::vector<double> xe, ye;
    for (std::size_t i = 0; i < n; ++i)
      if (c.ea[i] >= 0.75 * max_strain) {
        sum += ratio[i];
        ++cnt;
        xe.push_back(c.ea[i]);
        ye.push_back(c.ea[i] + c.el[i]);
      }
    if (cnt) c.phi_cv = deg(std::asin(std::clamp(sum / static_cast<double>(cnt), 0.0, 1.0)));
    c.end_dilatancy = linear_fit(xe, ye).slope;
    // Dilation of the test: volumetric strain (compression positive) from its densest point to
    // its end. The continuum's dilatancy cut-off (ψ → 0 beyond it) is the mean over the tests.
    {
      double ev_max = 0.0;
      for (std::size_t i = 0; i < n; ++i) ev_max = std::max(ev_max, c.ea[i] + c.el[i]);
      c.dilation = std::max(0.0, ev_max - (c.ea[n - 1] + c.el[n - 1]));
    }
    // Dilatancy at the peak: sin ψ = −ε̇_v/(ε̇_1 − ε̇_3) = −s/(2 − s), s = dε_v/dε_1 over ±1 %
    // axial strain around the peak (Vermeer & de Borst, Heron 29 (1984), compression positive).
    std::vector<double> xp, yp;
    for (std::size_t i = 0; i < n; ++i)
      if (std::abs(c.ea[i] - c.ea[ip]) <= 0.01) {
        xp.push_back(c.ea[i]);
        yp.push_back(c.ea[i] + c.el[i]);
      }
    const Fit fp = linear_fit(xp, yp);
    if (fp.ok) c.psi = deg(std::asin(std::clamp(-fp.slope / (2.0 - fp.slope), -1.0, 1.0)));
    // Initial tangent: least squares of q over ε_a ≤ 0.1 % (at least the first 4 samples).
    std::vector<double> x0, y0;
    for (std::size_t i = 0; i < n; ++i)
      if (c.ea[i] <= 1e-3 || x0.size() < 4) {
        x0.push_back(c.ea[i]);
        y0.push_back(q[i]);
      }
    c.e_small = linear_fit(x0, y0).slope;
    // Secant at 50 % of the peak deviator (smoothed; q = 0 at ε = 0: isotropic start).
    for (std::size_t i = 0; i < n; ++i)
      if (qs[i] >= 0.5 * qs[iq] && c.ea[i] > 0.0) {
        c.e50 = qs[i] / c.ea[i];
        c.nu_inplane = -c.el[i] / c.ea[i];
        break;
      }
  }
  // at most ≈ 600 samples kept for the figures and the JSON
  const std::size_t stride = std::max<std::size_t>(1, n / 600);
  if (stride > 1) {
    auto thin = [&](std::vector<double>& v) {
      std::vector<double> o;
      for (std::size_t k = 0; k < v.size(); k += stride) o.push_back(v[k]);
      v = std::move(o);
    };
    thin(c.ea);
    thin(c.el);
    thin(c.sa);
    thin(c.sl);
  }
  return c;
}

json to_json(const Calibration& c) {
  json j;
  j["format"] = kCalibrationFormat;
  j["key"] = c.key;
  j["scene"] = c.scene_label;
  j["wall_seconds"] = c.wall_seconds;
  j["bed"] = {{"bottom_m", c.bed_bottom},
              {"height_m", c.bed_height},
              {"surface_mass_matched_m", c.surface},
              {"surface_top_mean_m", c.surface_top_mean},
              {"porosity", c.porosity},
              {"bulk_density_kg_m3", c.bulk_density},
              {"coordination", c.coordination},
              {"soil_mass_kg", c.soil_mass},
              {"continuum_mass_kg", c.continuum_mass},
              {"k0", c.k0},
              {"k0_profile", c.k0_profile},
              {"structure_seat_dz_m", c.seat_dz}};
  json tests = json::array();
  for (const auto& t : c.tests)
    tests.push_back({{"specimen", t.specimen},
                     {"depth_m", t.depth},
                     {"sigma_c_pa", t.sigma_c},
                     {"porosity", t.porosity},
                     {"strain_rate", t.strain_rate},
                     {"e_small_inplane_pa", t.e_small},
                     {"e50_inplane_pa", t.e50},
                     {"nu_inplane", t.nu_inplane},
                     {"phi_peak_deg", t.phi_peak},
                     {"phi_cv_deg", t.phi_cv},
                     {"psi_deg", t.psi},
                     {"s_peak_pa", t.s_peak},
                     {"t_peak_pa", t.t_peak},
                     {"strain_at_peak", t.strain_at_peak},
                     {"end_dilatancy", t.end_dilatancy},
                     {"dilation", t.dilation},
                     {"failure", t.failure},
                     {"e_axial", t.ea},
                     {"e_lateral", t.el},
                     {"s_axial_pa", t.sa},
                     {"s_lateral_pa", t.sl}});
  j["biaxial"] = tests;
  j["specimen"] = {{"particles", c.particles},
                   {"count", c.specimens},
                   {"seeds", c.specimen_seeds},
                   {"porosity_deposited", c.specimen_porosity}};
  json fits = json::array();
  for (const auto& [phi, coh] : c.specimen_fits)
    fits.push_back({{"phi_deg", phi}, {"cohesion_pa", coh}});
  j["envelope"] = {{"phi_deg", c.phi_fit},
                   {"cohesion_pa", c.cohesion_fit},
                   {"per_specimen", fits},
                   {"phi_cv_deg", c.phi_cv},
                   {"psi_deg", c.psi}};
  j["affine"] = {{"e_inplane_pa", c.affine_e}, {"g_pa", c.affine_g}};
  auto cycles = [](const std::vector<CyclicPoint>& v) { // the reader's `cycle` inverted
    json a = json::array();
    for (const auto& p : v)
      a.push_back({{"gamma", p.gamma},
                   {"g_pa", p.g},
                   {"xi", p.xi},
                   {"nu_inplane", std::isfinite(p.nu) ? json(p.nu) : json(nullptr)}});
    return a;
  };
  json per = json::array();
  for (const auto& sp : c.cyclic_per_specimen) per.push_back(cycles(sp));
  j["cyclic"] = {
      {"sigma_c_pa", c.cyclic_sigma}, {"loops", cycles(c.cyclic)}, {"per_specimen", per}};
  if (!c.cyclic_shallow.empty())
    j["cyclic"]["shallow"] = {{"sigma_c_pa", c.cyclic_shallow_sigma},
                              {"per_specimen", cycles(c.cyclic_shallow)}};
  j["continuum"] = {
      {"young", c.young},
      {"poisson", c.poisson},
      {"friction_angle_deg", c.friction_angle_deg},
      {"cohesion", c.cohesion},
      {"dilation_angle_deg", c.dilation_angle_deg},
      {"dilation_cutoff",
       std::isfinite(c.dilation_cutoff) ? json(c.dilation_cutoff) : json(nullptr)},
      {"density", c.bulk_density},
      {"k0", c.k0},
      {"surface", c.surface},
      {"young_source", c.young_source},
      {"young_small", c.young_small},
      {"young_e50", c.young_e50},
      {"poisson_source", c.poisson_source},
      {"poisson_e50", std::isfinite(c.poisson_e50) ? json(c.poisson_e50) : json(nullptr)},
      {"modulus_exponent", c.modulus_exponent},
      {"modulus_reference_stress", c.modulus_reference_stress}};
  return j;
}

Calibration from_json(const json& j) {
  Calibration c;
  c.key = j.at("key");
  c.scene_label = j.at("scene");
  c.wall_seconds = j.at("wall_seconds");
  const auto& b = j.at("bed");
  c.bed_bottom = b.at("bottom_m");
  c.bed_height = b.at("height_m");
  c.surface = b.at("surface_mass_matched_m");
  c.surface_top_mean = b.at("surface_top_mean_m");
  c.porosity = b.at("porosity");
  c.bulk_density = b.at("bulk_density_kg_m3");
  c.coordination = b.at("coordination");
  c.soil_mass = b.at("soil_mass_kg");
  c.continuum_mass = b.at("continuum_mass_kg");
  c.k0 = b.at("k0");
  c.k0_profile = b.at("k0_profile").get<std::vector<std::pair<double, double>>>();
  if (b.contains("structure_seat_dz_m"))
    c.seat_dz = b.at("structure_seat_dz_m").get<std::vector<std::pair<std::string, double>>>();
  for (const auto& t : j.at("biaxial")) {
    BiaxialCurve x;
    x.specimen = t.value("specimen", 0);
    x.depth = t.at("depth_m");
    x.sigma_c = t.at("sigma_c_pa");
    x.porosity = t.at("porosity");
    x.strain_rate = t.at("strain_rate");
    x.e_small = t.at("e_small_inplane_pa");
    x.e50 = t.at("e50_inplane_pa");
    x.nu_inplane = t.at("nu_inplane");
    x.phi_peak = t.at("phi_peak_deg");
    x.phi_cv = t.at("phi_cv_deg");
    x.psi = t.at("psi_deg");
    x.s_peak = t.at("s_peak_pa");
    x.t_peak = t.at("t_peak_pa");
    x.strain_at_peak = t.at("strain_at_peak");
    x.end_dilatancy = t.at("end_dilatancy");
    x.dilation = t.value("dilation", 0.0);
    x.failure = t.at("failure");
    x.ea = t.at("e_axial").get<std::vector<double>>();
    x.el = t.at("e_lateral").get<std::vector<double>>();
    x.sa = t.at("s_axial_pa").get<std::vector<double>>();
    x.sl = t.at("s_lateral_pa").get<std::vector<double>>();
    c.tests.push_back(std::move(x));
  }
  const auto& sp = j.at("specimen");
  c.particles = sp.at("particles");
  c.specimens = sp.value("count", 1);
  c.specimen_seeds = sp.value("seeds", std::vector<unsigned long>{});
  c.specimen_porosity = sp.at("porosity_deposited");
  const auto& e = j.at("envelope");
  c.phi_fit = e.at("phi_deg");
  c.cohesion_fit = e.at("cohesion_pa");
  if (e.contains("per_specimen"))
    for (const auto& f : e.at("per_specimen"))
      c.specimen_fits.emplace_back(f.at("phi_deg"), f.at("cohesion_pa"));
  c.phi_cv = e.at("phi_cv_deg");
  c.psi = e.at("psi_deg");
  c.affine_e = j.at("affine").at("e_inplane_pa");
  c.affine_g = j.at("affine").at("g_pa");
  c.cyclic_sigma = j.at("cyclic").at("sigma_c_pa");
  auto cycle = [](const json& p) {
    CyclicPoint q{p.at("gamma"), p.at("g_pa"), p.at("xi")};
    if (p.contains("nu_inplane") && p.at("nu_inplane").is_number()) q.nu = p.at("nu_inplane");
    return q;
  };
  for (const auto& p : j.at("cyclic").at("loops")) c.cyclic.push_back(cycle(p));
  if (j.at("cyclic").contains("per_specimen"))
    for (const auto& one : j.at("cyclic").at("per_specimen")) {
      c.cyclic_per_specimen.emplace_back();
      for (const auto& p : one) c.cyclic_per_specimen.back().push_back(cycle(p));
    }
  if (j.at("cyclic").contains("shallow")) {
    const auto& sh = j.at("cyclic").at("shallow");
    c.cyclic_shallow_sigma = sh.at("sigma_c_pa");
    for (const auto& p : sh.at("per_specimen")) c.cyclic_shallow.push_back(cycle(p));
  }
  const auto& k = j.at("continuum");
  c.young = k.at("young");
  c.poisson = k.at("poisson");
  c.friction_angle_deg = k.at("friction_angle_deg");
  c.cohesion = k.at("cohesion");
  c.dilation_angle_deg = k.at("dilation_angle_deg");
  if (k.contains("dilation_cutoff") && k.at("dilation_cutoff").is_number())
    c.dilation_cutoff = k.at("dilation_cutoff");
  c.young_source = k.at("young_source");
  c.young_small = k.at("young_small");
  c.young_e50 = k.at("young_e50");
  c.poisson_source = k.value("poisson_source", std::string());
  if (k.contains("poisson_e50") && k.at("poisson_e50").is_number())
    c.poisson_e50 = k.at("poisson_e50");
  c.modulus_exponent = k.value("modulus_exponent", 0.0);
  c.modulus_reference_stress = k.value("modulus_reference_stress", 0.0);
  return c;
}

fs::path cache_file(const scene::Scene& s, const CalibrateOptions& o) {
  return calibration_cache_dir(s, o) / ("calibration-" + calibration_key(s, o) + ".json");
}

} // namespace

namespace {
// The packing seed of specimen k: the scene's for the first, then one far from any seed a user
// would pick next (`--seed 42` after 41 must not reuse a specimen).
unsigned long specimen_seed(const scene::Scene& s, int k) {
  return s.info.seed + 1000003ul * static_cast<unsigned long>(k);
}
} // namespace

// The element-test specimen k: the scene's [soil.dem] in a box W × 1.5 W of `n` disks, deposited
// by the scene's packing procedure (its walls are the box's base and sides) with specimen_seed.
scene::Scene specimen_scene(const scene::Scene& s, int n, const fs::path& cache, int k) {
  scene::Scene sp = s;
  sp.info.seed = specimen_seed(s, k);
  auto& d = sp.soil.dem.value();
  d.count = n;
  d.particles.clear();
  d.particles_file.clear();
  const auto radii = dem::draw_radii(d.radius, n, sp.info.seed);
  double area = 0.0;
  for (double r : radii) area += kPi * r * r;
  const double box = area / 0.82; // settled at a packing fraction ≈ 0.82 (2D disks)
  const double w = std::sqrt(box / 1.5), h = 1.5 * w;
  sp.domain = {{0, 0}, {w, 0}, {w, h}, {0, h}};
  d.fill = sp.domain;
  d.packing.cache = cache.string();
  sp.walls.clear();
  scene::Wall base, left, right;
  base.name = "base";
  base.points = {{0, 0}, {w, 0}};
  left.name = "left";
  left.points = {{0, h}, {0, 0}};
  right.name = "right";
  right.points = {{w, 0}, {w, h}};
  sp.walls = {base, left, right};
  sp.structures.clear();
  sp.groups.clear();
  sp.events.clear();
  sp.probes.clear();
  sp.load.shaking.reset();
  sp.info.name = s.info.name + "-specimen";
  sp.variant.clear();
  return sp;
}

fs::path calibration_cache_dir(const scene::Scene& s, const CalibrateOptions& o) {
  if (!o.cache_dir.empty()) return o.cache_dir;
  if (s.soil.dem && !s.soil.dem->packing.cache.empty()) return s.soil.dem->packing.cache;
  return o.out_dir / "cache";
}

std::string calibration_key(const scene::Scene& s, const CalibrateOptions& o) {
  if (!s.soil.dem) return "none";
  Fnv f;
  const int fmt_version = kCalibrationFormat;
  f.bytes(&fmt_version, sizeof fmt_version);
  f.str(dem::packing_key(s)); // the bed: everything that shapes the deposited packing
  for (int k = 0; k < std::max(o.specimens, 1); ++k)
    f.str(dem::packing_key(specimen_scene(s, o.particles, {}, k)));
  f.bytes(&o.particles, sizeof o.particles);
  for (double v : o.depth_fractions) f.num(v);
  f.num(o.max_axial_strain);
  f.num(o.inertial_number);
  f.num(o.cyclic ? 1.0 : 0.0);
  if (o.cyclic)
    for (double v : o.cyclic_amplitudes) f.num(v);
  if (o.cyclic) f.num(o.cyclic_shallow_fraction);
  f.num(s.soil.dem->max_overlap);
  return fmt::format("{:016x}", f.h);
}

Calibration calibrate(const scene::Scene& scene, const CalibrateOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!scene.soil.dem)
    scene_error(scene, "soil.dem", "demfem calibrate needs a [soil.dem] table (the DEM soil)");
  const auto& d = *scene.soil.dem;
  if (!d.particles.empty())
    scene_error(scene, "soil.dem.particles",
                "demfem calibrate needs a packed soil (count and radius), not explicit particles");
  Calibration c;
  c.key = calibration_key(scene, o);
  c.scene_label = scene.label();
  c.particles = o.particles;
  const fs::path cache = calibration_cache_dir(scene, o);
  fs::create_directories(cache);
  auto report = [&](const std::string& stage, double frac) {
    if (!o.progress) return;
    scene::Progress p;
    p.stage = stage;
    p.time = frac;
    p.end_time = 1.0;
    p.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    o.progress(p);
  };

  // ---- the scene's deposited bed: density, surface, K0 -------------------------------------
  const auto bed = dem::pack_or_load(scene, o.out_dir.empty() ? cache : o.out_dir, o.progress);
  const auto& P = bed.particles;
  // Structures where the packing seated them (dem::PackResult::seat_dz); the continuum is moved
  // there too (apply_calibration), so both models hold the foundation at the same height.
  std::vector<scene::Structure> structures = scene.structures;
  for (std::size_t k = 0; k < structures.size() && k < bed.seat_dz.size(); ++k)
    if (bed.seat_dz[k] != 0.0) {
      structures[k] = scene::shifted(structures[k], bed.seat_dz[k]);
      c.seat_dz.emplace_back(structures[k].name, bed.seat_dz[k]);
    }
  const auto& fill = d.fill.empty() ? scene.domain : d.fill;
  double x0 = 1e300, x1 = -1e300, zb = 1e300, rmax = 0.0;
  for (const auto& q : fill) {
    x0 = std::min(x0, q.x);
    x1 = std::max(x1, q.x);
    zb = std::min(zb, q.z);
  }
  for (std::size_t i = 0; i < P.size(); ++i) {
    c.soil_mass += P.mass[i];
    rmax = std::max(rmax, P.radius[i]);
  }
  c.porosity = bed.measure.porosity;
  c.coordination = bed.measure.coordination;
  c.bulk_density = d.density * (1.0 - c.porosity); // ρ_b = ρ_s (1 − n)
  c.bed_bottom = zb;
  {
    // Mean of the column tops (columns 2 r_max wide), as measure_packing's surface columns.
    const double cw = 2.0 * rmax;
    const auto ncol = static_cast<std::size_t>(std::max(1.0, std::ceil((x1 - x0) / cw)));
    std::vector<double> tops(ncol, -1e300);
    for (std::size_t i = 0; i < P.size(); ++i) {
      const auto k = static_cast<std::size_t>(
          std::clamp((P.x[i] - x0) / cw, 0.0, static_cast<double>(ncol - 1)));
      tops[k] = std::max(tops[k], P.z[i] + P.radius[i]);
    }
    // columns over a structure hold the soil below it, not the surface
    for (const auto& st : structures) {
      double sx0 = 1e300, sx1 = -1e300;
      for (const auto& q : st.outline) {
        sx0 = std::min(sx0, q.x);
        sx1 = std::max(sx1, q.x);
      }
      for (std::size_t k = 0; k < ncol; ++k)
        if (x0 + (k + 1) * cw > sx0 && x0 + k * cw < sx1) tops[k] = -1e300;
    }
    std::erase_if(tops, [](double t) { return t < -1e299; });
    c.surface_top_mean = tops.empty() ? zb
                                      : std::accumulate(tops.begin(), tops.end(), 0.0) /
                                            static_cast<double>(tops.size());
  }
  // Mass-matched surface: the height z_s at which (fill area below z_s − structures) ρ_b t
  // equals the DEM soil mass (bisection).
  {
    const double target = c.soil_mass / (c.bulk_density * d.thickness);
    // Structures displace soil only where they stand inside the fill (clipped to its bounding
    // box): a retaining wall beside the fill holds none of it.
    const auto fb = scene::bounds(fill);
    std::vector<scene::Polygon> inside;
    for (const auto& st : structures) {
      auto p = scene::clip(st.outline, -1.0, 0.0, -fb.x0); // x ≥ x0
      p = scene::clip(p, 1.0, 0.0, fb.x1);                 // x ≤ x1
      p = scene::clip(p, 0.0, -1.0, -fb.z0);               // z ≥ z0
      if (p.size() >= 3) inside.push_back(std::move(p));
    }
    auto soil_area = [&](double z) {
      double a = area_below(fill, z);
      for (const auto& p : inside) a -= area_below(p, z);
      return a;
    };
    double ztop = zb;
    for (const auto& q : fill) ztop = std::max(ztop, q.z);
    double lo = zb, hi = ztop;
    if (soil_area(hi) <= target) {
      lo = hi; // the bed fills the polygon: the continuum soil is all of it
    } else {
      for (int it = 0; it < 80; ++it) {
        const double mid = 0.5 * (lo + hi);
        (soil_area(mid) < target ? lo : hi) = mid;
      }
    }
    c.surface = 0.5 * (lo + hi);
    c.continuum_mass = c.bulk_density * d.thickness * soil_area(c.surface);
  }
  c.bed_height = c.surface - c.bed_bottom;
  {
    // K0: Love–Weber stress of the bed at rest under gravity, with the scene's walls and its
    // structures held fixed (as during deposition), away from walls and structures.
    dem::EngineConfig cfg = dem::make_config(scene);
    cfg.shaking = false;
    dem::Engine e(cfg);
    for (std::size_t i = 0; i < P.size(); ++i) e.add_particle(P.x[i], P.z[i], P.radius[i]);
    for (const auto& w : scene.walls) e.add_wall(w);
    std::vector<calib::StressWindow> exclude;
    const double margin = 10.0 * rmax; // 5 diameters around each structure
    for (auto st : structures) {
      st.dof_x = st.dof_z = st.dof_rotation = scene::DofMode::Fixed;
      st.force_x = st.force_z = st.moment = scene::TimeFunction{};
      e.add_structure(st);
      calib::StressWindow b{1e300, -1e300, 1e300, -1e300};
      for (const auto& q : st.outline) {
        b.x0 = std::min(b.x0, q.x - margin);
        b.x1 = std::max(b.x1, q.x + margin);
        b.z0 = std::min(b.z0, q.z - margin);
        b.z1 = std::max(b.z1, q.z + margin);
      }
      exclude.push_back(b);
    }
    if (!bed.contact_history.empty()) e.load_contact_history(bed.contact_history);
    dem::set_scene_dt(e, d.dt > 0.0 ? d.dt : e.auto_dt());
    e.run_steps(200);
    const double W = x1 - x0, H = c.bed_height;
    const calib::StressWindow win{x0 + 0.1 * W, x1 - 0.1 * W, zb + 4.0 * rmax,
                                  c.surface - 6.0 * rmax};
    const auto s = calib::bed_stress(e, win, d.thickness, exclude);
    c.k0 = s.szz > 0.0 ? s.sxx / s.szz : 0.0;
    for (int band = 0; band < 4; ++band) {
      const double za = zb + 4.0 * rmax + band * (H - 10.0 * rmax) / 4.0;
      const double zc = za + (H - 10.0 * rmax) / 4.0;
      const auto sb =
          calib::bed_stress(e, {x0 + 0.1 * W, x1 - 0.1 * W, za, zc}, d.thickness, exclude);
      if (sb.szz > 0.0) c.k0_profile.emplace_back(c.surface - 0.5 * (za + zc), sb.sxx / sb.szz);
    }
  }
  report("calibrate: bed", 0.05);

  // ---- the specimens -----------------------------------------------------------------------
  const int nspec = std::max(o.specimens, 1);
  c.specimens = nspec;
  std::vector<calib::Specimen> specimens;
  for (int k = 0; k < nspec; ++k) {
    const scene::Scene sps = specimen_scene(scene, o.particles, cache, k);
    const auto spec = dem::pack_or_load(sps, cache, o.progress);
    c.specimen_porosity += spec.measure.porosity / nspec;
    c.specimen_seeds.push_back(sps.info.seed);
    calib::Specimen S;
    S.config = dem::make_config(sps);
    S.config.gravity = 0.0; // element test: no body force
    S.config.shaking = false;
    S.particles = spec.particles;
    S.thickness = d.thickness;
    for (double r : S.particles.radius) S.d_mean += 2.0 * r;
    S.d_mean /= static_cast<double>(std::max<std::size_t>(S.particles.size(), 1));
    specimens.push_back(std::move(S));
  }
  const double g = scene.load.gravity;
  calib::ElementSettings es;
  es.inertial_number = o.inertial_number;
  es.max_axial_strain = o.max_axial_strain;
  const std::size_t nbiax = o.depth_fractions.size() * specimens.size();
  const bool shallow = o.cyclic && !o.cyclic_amplitudes.empty() && o.cyclic_shallow_fraction > 0.0;
  const std::size_t ntest = nbiax + (o.cyclic ? specimens.size() : 0) * (shallow ? 2 : 1);
  // Progress of element test number `done` (of ntest): specimen k at confinement sigma.
  auto test_progress = [&](double sigma, std::size_t k, std::size_t done) {
    return [&report, sigma, k, done, nspec = specimens.size(), ntest](const std::string& stage,
                                                                      double f) {
      report(fmt::format("calibrate: {} σ_c = {:.4g} kPa, specimen {}/{}", stage, sigma / 1e3,
                         k + 1, nspec),
             0.05 + 0.95 * (static_cast<double>(done) + f) / static_cast<double>(ntest));
    };
  };
  for (std::size_t q = 0; q < o.depth_fractions.size(); ++q)
    for (std::size_t k = 0; k < specimens.size(); ++k) {
      const double z = o.depth_fractions[q] * c.bed_height;
      const double sigma = c.bulk_density * g * z; // geostatic vertical stress σ_v = ρ_b g z
      const std::size_t done = q * specimens.size() + k;
      es.progress = test_progress(sigma, k, done);
      const auto r = calib::biaxial(specimens[k], sigma, es);
      c.tests.push_back(evaluate(z, r, o.max_axial_strain));
      c.tests.back().specimen = static_cast<int>(k);
      spdlog::info("{}: biaxial σ_c = {:.4g} kPa, specimen {}: φ_peak {:.1f}°, φ_cv {:.1f}°, ψ "
                   "{:.1f}°, E50' {:.3g} MPa{}",
                   scene.label(), sigma / 1e3, k + 1, c.tests.back().phi_peak,
                   c.tests.back().phi_cv, c.tests.back().psi, c.tests.back().e50 / 1e6,
                   r.failure.empty() ? "" : " — FAILED: " + r.failure);
    }
  // Mohr–Coulomb envelope through the peaks: t = s sin φ + c cos φ, over all tests (the
  // calibration) and over each specimen's alone (its spread).
  auto envelope = [&](int only) {
    std::vector<double> xs, ys;
    for (const auto& t : c.tests) {
      if (!t.failure.empty() || t.ea.empty() || (only >= 0 && t.specimen != only)) continue;
      xs.push_back(t.s_peak);
      ys.push_back(t.t_peak);
    }
    std::pair<double, double> r{0.0, 0.0};
    const Fit f = linear_fit(xs, ys);
    if (f.ok && f.slope > 0.0 && f.slope < 1.0) {
      const double phi = std::asin(f.slope);
      r = {deg(phi), f.intercept / std::cos(phi)};
    } else if (!xs.empty()) { // one test: cohesionless through its peak
      r = {deg(std::asin(std::clamp(ys[0] / xs[0], 0.0, 1.0))), 0.0};
    }
    return r;
  };
  std::tie(c.phi_fit, c.cohesion_fit) = envelope(-1);
  if (nspec > 1)
    for (int k = 0; k < nspec; ++k) c.specimen_fits.push_back(envelope(k));
  {
    double cv = 0.0, ps = 0.0;
    int n = 0;
    for (const auto& t : c.tests) {
      if (!t.failure.empty() || t.ea.empty()) continue;
      cv += t.phi_cv;
      ps += t.psi;
      ++n;
    }
    if (n > 0) {
      c.phi_cv = cv / n;
      c.psi = ps / n;
    }
  }
  // Affine (Voigt) estimate of the in-plane moduli for an isotropic 2D contact network with Z
  // contacts per particle and solid fraction φ_s: λ = κ(k_n − k_s)/8, G = κ(k_n + k_s)/8,
  // κ = 2 Z φ_s/(π t) (branch length 2r̄; e.g. Kruyt & Rothenburg, IJSS 41 (2004) 5763);
  // E' = 4G(λ + G)/(λ + 2G).
  {
    const double kap = 2.0 * c.coordination * (1.0 - c.porosity) / (kPi * d.thickness);
    const auto k = dem::contact::reference_stiffness(dem::contact::make_law(d),
                                                     0.5 * (d.radius.min + d.radius.max));
    const double lam = kap * (k.kn - k.ks) / 8.0, G = kap * (k.kn + k.ks) / 8.0;
    c.affine_g = G;
    c.affine_e = 4.0 * G * (lam + G) / (lam + 2.0 * G);
  }
  // The continuum's E and ν: the confinement nearest to mid-depth, secant at 50 % of the peak
  // (the usual Mohr–Coulomb stiffness, e.g. PLAXIS's E50), mean over the specimens, converted to
  // plane strain.
  {
    std::size_t best = 0;
    for (std::size_t k = 0; k < c.tests.size(); ++k)
      if (std::abs(c.tests[k].depth - 0.5 * c.bed_height) <
          std::abs(c.tests[best].depth - 0.5 * c.bed_height))
        best = k;
    if (!c.tests.empty()) {
      const double depth = c.tests[best].depth;
      double e50 = 0.0, nup = 0.0;
      int n = 0;
      for (const auto& t : c.tests)
        if (t.depth == depth && t.failure.empty() && t.e50 > 0.0) {
          e50 += t.e50;
          nup += std::max(0.0, t.nu_inplane);
          ++n;
        }
      if (n > 0) {
        e50 /= n;
        nup /= n;
      }
      c.poisson = std::min(0.49, nup / (1.0 + nup)); // ν = ν'/(1 + ν')
      c.young = e50 * (1.0 - c.poisson * c.poisson); // E = E'(1 − ν²)
      c.young_source = fmt::format("secant at 50 % of the peak deviator, biaxial tests at σ_c = "
                                   "{:.4g} kPa (z = {:.3g} m), mean of {} specimen(s)",
                                   c.tests[best].sigma_c / 1e3, depth, n);
      c.poisson_source = fmt::format("ν'/(1 + ν'), ν' = −ε_xx/ε_zz at 50 % of the peak, biaxial "
                                     "tests at σ_c = {:.4g} kPa, mean of {} specimen(s)",
                                     c.tests[best].sigma_c / 1e3, n);
    }
    c.friction_angle_deg = std::clamp(c.phi_fit, 1.0, 60.0);
    c.cohesion = std::max(0.0, c.cohesion_fit);
    c.dilation_angle_deg = std::clamp(c.psi, 0.0, c.friction_angle_deg);
    double dil = 0.0;
    int nd = 0;
    for (const auto& t : c.tests)
      if (t.failure.empty() && !t.ea.empty()) {
        dil += t.dilation;
        ++nd;
      }
    if (nd > 0) c.dilation_cutoff = dil / nd;
  }
  // ---- cyclic ------------------------------------------------------------------------------
  if (o.cyclic && !o.cyclic_amplitudes.empty()) {
    const double sigma = c.bulk_density * g * 0.5 * c.bed_height;
    c.cyclic_sigma = sigma;
    // Every specimen, as the biaxial tests: G0, ξ and ν of one realisation scatter (G0 ± 7 %
    // over four wall beds); the continuum takes the means per amplitude.
    for (std::size_t k = 0; k < specimens.size(); ++k) {
      es.progress = test_progress(sigma, k, nbiax + k);
      auto& mine = c.cyclic_per_specimen.emplace_back();
      for (const auto& l : calib::cyclic(specimens[k], sigma, o.cyclic_amplitudes, es))
        mine.push_back(point_of(l));
    }
    // Means over the specimens, amplitude by amplitude, as far as every specimen got.
    std::size_t na = o.cyclic_amplitudes.size();
    for (const auto& sp : c.cyclic_per_specimen) na = std::min(na, sp.size());
    for (std::size_t a = 0; a < na; ++a) {
      CyclicPoint m{0.0, 0.0, 0.0, 0.0};
      for (const auto& sp : c.cyclic_per_specimen) {
        m.gamma += sp[a].gamma;
        m.g += sp[a].g;
        m.xi += sp[a].xi;
        m.nu += sp[a].nu;
      }
      const double n = static_cast<double>(c.cyclic_per_specimen.size());
      c.cyclic.push_back({m.gamma / n, m.g / n, m.xi / n, m.nu / n});
    }
    // The smallest amplitude again near the top of the bed: the modulus's stress exponent. A
    // bed of linear-contact disks stiffens with confinement (more and firmer contacts): G0 of
    // the foundation bed's specimens was 18 / 24 / 29 / 32 MPa at 108 / 216 / 540 / 1080 kPa,
    // and the DEM foundation there rocked 1.8× as far as the uniform-E continuum, its sides
    // (0–5 m deep) 2.4× (cases/README.md, "A modulus that follows the confinement").
    if (shallow) {
      const double ss = c.bulk_density * g * o.cyclic_shallow_fraction * c.bed_height;
      c.cyclic_shallow_sigma = ss;
      for (std::size_t k = 0; k < specimens.size(); ++k) {
        es.progress = test_progress(ss, k, nbiax + specimens.size() + k);
        const auto l = calib::cyclic(specimens[k], ss, {o.cyclic_amplitudes.front()}, es);
        if (!l.empty()) c.cyclic_shallow.push_back(point_of(l.front()));
      }
      const double g_shallow = mean_g(c.cyclic_shallow);
      if (!c.cyclic.empty() && c.cyclic.front().g > 0.0 && g_shallow > 0.0 && sigma > ss) {
        // G0 = G0_ref (σ/σ_ref)^n through the two confinements (Janbu 1963), n within [0, 1]
        c.modulus_exponent =
            std::clamp(std::log(c.cyclic.front().g / g_shallow) / std::log(sigma / ss), 0.0, 1.0);
        c.modulus_reference_stress = sigma;
        spdlog::info(
            "{}: G0 {:.4g} MPa at σ_c = {:.4g} kPa, {:.4g} MPa at {:.4g} kPa: E ∝ p^{:.3f}",
            scene.label(), g_shallow / 1e6, ss / 1e3, c.cyclic.front().g / 1e6, sigma / 1e3,
            c.modulus_exponent);
        // A shallow cycle that dissipates is not small-strain elastic: the pile's equal-radius
        // bed (case-6) slips along its lattice at σ_c(H/10), ξ 0.19–0.31 against ≤ 0.007 at
        // σ_c(H/2), and G0 falls 7.5× (n clamped to 1). Said, not corrected.
        double xi_shallow = 0.0;
        for (const auto& q : c.cyclic_shallow) xi_shallow += q.xi;
        xi_shallow /= static_cast<double>(std::max<std::size_t>(c.cyclic_shallow.size(), 1));
        std::vector<std::string> why;
        if (xi_shallow > 0.1) why.push_back(fmt::format("dissipate (mean ξ = {:.3f})", xi_shallow));
        if (c.modulus_exponent >= 1.0) why.push_back("give n at its bound, 1");
        if (!why.empty())
          spdlog::warn("{}: the shallow cycles at σ_c = {:.4g} kPa {}: the bed is not elastic "
                       "there, and E ∝ p^n overstates how fast its stiffness falls towards the "
                       "surface",
                       scene.label(), ss / 1e3, fmt::join(why, " and "));
      }
    }
    // Small-strain Young's modulus of the continuum: E0 = 2 G0 (1 + ν) (isotropic elasticity;
    // the in-plane shear modulus is the same in 2D and in plane strain).
    if (!c.cyclic.empty() && c.cyclic.front().g > 0.0) {
      // ν from the same small-strain cycle as G0, so that E0 and ν describe one elastic state:
      // the biaxial tests' ν' at 50 % of the peak is mostly plastic flow and varies ± 20 % between
      // beds (0.24–0.36 over four wall beds), one specimen's cycle ± 4 % (0.29–0.31;
      // cases/README.md).
      const double nup = c.cyclic.front().nu;
      if (std::isfinite(nup) && nup > 0.0) {
        c.poisson_e50 = c.poisson;
        c.poisson = std::min(0.49, nup / (1.0 + nup)); // ν = ν'/(1 + ν') (plane strain)
        c.poisson_source =
            fmt::format("ν'/(1 + ν'), ν' = −ε_xx/ε_zz of the cyclic biaxial tests at "
                        "σ_c = {:.4g} kPa, γ = {:.2g}, mean of {} specimen(s) "
                        "(the biaxial tests at 50 % of the peak: {:.3f})",
                        c.cyclic_sigma / 1e3, c.cyclic.front().gamma, c.cyclic_per_specimen.size(),
                        c.poisson_e50);
      }
      c.young_small = 2.0 * c.cyclic.front().g * (1.0 + c.poisson);
      // The continuum's elastic part stands for the soil before yield, and the scenes load it
      // cyclically (shaking, rocking): the cyclic small-strain modulus, not the monotonic E50
      // (which is mostly plastic contraction at 1–2 % strain), is the matching stiffness.
      c.young_e50 = c.young;
      c.young = c.young_small;
      c.young_source = fmt::format(
          "small-strain E0 = 2 G0 (1 + ν), G0 of the cyclic biaxial tests at σ_c = {:.4g} kPa, "
          "γ = {:.2g}, mean of {} specimen(s) (E50 = {:.4g} Pa)",
          c.cyclic_sigma / 1e3, c.cyclic.front().gamma, c.cyclic_per_specimen.size(), c.young_e50);
    }
  }
  c.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  try { // the cache is an optimisation: a failed write costs a recomputation, not the run
    const fs::path cf = cache_file(scene, o);
    std::error_code ec;
    if (cf.has_parent_path()) fs::create_directories(cf.parent_path(), ec);
    scene::write_file_atomic(cf, to_json(c).dump(1) + "\n");
  } catch (const scene::WriteError& e) {
    spdlog::warn("calibration cache not written: {}", e.what());
  }
  return c;
}

Calibration load_or_calibrate(const scene::Scene& scene, const CalibrateOptions& o) {
  const fs::path f = cache_file(scene, o);
  if (fs::exists(f)) {
    try {
      std::ifstream in(f);
      Calibration c = from_json(json::parse(in));
      c.from_cache = true;
      c.scene_label = scene.label();
      return c;
    } catch (const std::exception& e) {
      spdlog::warn("calibration cache {} unreadable ({}); calibrating again", f.string(), e.what());
    }
  }
  return calibrate(scene, o);
}

std::string specimen_fits_text(const std::vector<std::pair<double, double>>& fits) {
  std::string per;
  for (const auto& [phi, coh] : fits)
    per += fmt::format("{}{:.1f}° / {:.3g} kPa", per.empty() ? "" : ", ", phi, coh / 1e3);
  return per;
}

std::string continuum_block(const Calibration& c) {
  std::string s;
  s += fmt::format("# Calibrated by `demfem calibrate` ({}; key {}): DEM element tests on {} "
                   "{}-disk specimen(s)\n# made by the scene's packing procedure, and its "
                   "deposited bed. Paste into the scene, or set\n# calibrate = \"dem\" to take "
                   "these values from the cache.\n",
                   c.scene_label, c.key, c.specimens, c.particles);
  s += "[soil.continuum]\nmodel = \"mohr-coulomb\"\n";
  s += fmt::format("young = {:.4g}   # [Pa] plane strain: {}\n", c.young, c.young_source);
  if (c.young_e50 > 0.0)
    s += fmt::format("#   monotonic: E50 = E50'(1 − ν²) = {:.4g} Pa (secant at 50 % of the peak "
                     "deviator, σ_c at mid-depth)\n",
                     c.young_e50);
  if (c.cyclic_per_specimen.size() > 1) { // the realisation spread of the small-strain values
    std::string g0, nu;
    for (const auto& one : c.cyclic_per_specimen)
      if (!one.empty()) {
        g0 += fmt::format("{}{:.3g}", g0.empty() ? "" : ", ", one.front().g / 1e6);
        nu += fmt::format("{}{:.3f}", nu.empty() ? "" : ", ", one.front().nu);
      }
    s += fmt::format("#   each specimen's smallest cycle: G0 = {} MPa, ν' = {}\n", g0, nu);
  }
  if (c.modulus_exponent > 0.0 && c.modulus_reference_stress > 0.0) {
    const double g_shallow = mean_g(c.cyclic_shallow);
    s += fmt::format("modulus_exponent = {:.3f}   # E ∝ p^n: G0 = {:.3g} MPa at σ_c = {:.4g} kPa, "
                     "{:.3g} MPa at {:.4g} kPa (cyclic, smallest amplitude)\n",
                     c.modulus_exponent, g_shallow / 1e6, c.cyclic_shallow_sigma / 1e3,
                     c.cyclic.empty() ? 0.0 : c.cyclic.front().g / 1e6,
                     c.modulus_reference_stress / 1e3);
    s +=
        fmt::format("modulus_reference_stress = {:.6g}   # [Pa] the mean stress `young` holds at\n",
                    c.modulus_reference_stress);
  }
  s += fmt::format("poisson = {:.3f}   # {}\n", c.poisson, c.poisson_source);
  std::string sig;
  for (const double v : confinements(c))
    sig += fmt::format("{}{:.4g}", sig.empty() ? "" : ", ", v / 1e3);
  s += fmt::format("friction_angle = {:.2f}   # [deg] Mohr–Coulomb fit of the biaxial peaks at "
                   "σ_c = {} kPa, {} specimen(s) (φ_cv = {:.1f}°)\n",
                   c.friction_angle_deg, sig, c.specimens, c.phi_cv);
  s += fmt::format("cohesion = {:.4g}   # [Pa] the fit's intercept c = {:.4g} Pa, ≥ 0\n",
                   c.cohesion, c.cohesion_fit);
  if (c.specimen_fits.size() > 1)
    s += fmt::format("#   each specimen's peaks alone: φ / c = {}\n",
                     specimen_fits_text(c.specimen_fits));
  s += fmt::format("dilation_angle = {:.2f}   # [deg] mean ψ at the peaks, sin ψ = −ε̇_v/γ̇ "
                   "(clamped to [0, φ])\n",
                   c.dilation_angle_deg);
  if (std::isfinite(c.dilation_cutoff))
    s += fmt::format("dilation_cutoff = {:.4f}   # plastic dilation after which ψ = 0: the "
                     "biaxial tests' volumetric strain\n#   from their densest point to the end "
                     "({:.0f} % axial strain), mean of the tests\n",
                     c.dilation_cutoff, 100.0 * (c.tests.empty() ? 0.0 : c.tests[0].ea.back()));
  s += fmt::format("density = {:.5g}   # [kg/m³] ρ_s (1 − n), porosity n = {:.4f} of the "
                   "deposited bed\n",
                   c.bulk_density, c.porosity);
  s += fmt::format("k0 = {:.3f}   # σ_xx/σ_zz of the deposited bed (Love–Weber stress)\n", c.k0);
  s += fmt::format("surface = {:.4g}   # [m] holds the DEM bed's soil mass at this density, "
                   "capped at the fill's top\n#   (mean column top {:.4g} m; masses: DEM {:.5g} "
                   "kg, continuum {:.5g} kg per m thickness)\n",
                   c.surface, c.surface_top_mean, c.soil_mass, c.continuum_mass);
  return s;
}

Calibration read_calibration(const fs::path& json_file) {
  std::ifstream in(json_file);
  if (!in) throw std::runtime_error("cannot read " + json_file.string());
  Calibration c = from_json(json::parse(in));
  c.from_cache = true;
  return c;
}

CalibrationFiles write_calibration(const Calibration& c, const fs::path& dir, bool figures) {
  CalibrationFiles out;
  fs::create_directories(dir);
  scene::write_file_atomic(dir / "calibration.json", to_json(c).dump(1) + "\n");
  out.written.push_back(dir / "calibration.json");
  scene::write_file_atomic(dir / "calibration.toml", continuum_block(c));
  out.written.push_back(dir / "calibration.toml");
  if (!figures) return out;
  const fs::path fd = dir / "figures";
  fs::create_directories(fd);
  auto emit = [&](const compare::PlotSpec& p, const std::string& name) {
    std::string err;
    if (plot(p, fd / (name + ".png"), &err))
      out.written.push_back(fd / (name + ".png"));
    else
      out.problems.push_back(err);
  };
  const std::string by_specimen =
      c.specimens > 1 ? fmt::format(" ({} specimens: solid, dashed, dotted, …)", c.specimens) : "";
  compare::PlotSpec ss{"Biaxial compression: deviator stress" + by_specimen,
                       "axial strain ε_zz [%]",
                       "σ_zz − σ_xx [kPa]",
                       {},
                       false,
                       1000,
                       600};
  compare::PlotSpec vs{"Biaxial compression: volumetric strain (compression positive)" +
                           by_specimen,
                       "axial strain ε_zz [%]",
                       "ε_v = ε_zz + ε_xx [%]",
                       {},
                       false,
                       1000,
                       600};
  compare::PlotSpec env{fmt::format("Failure envelope: φ = {:.1f}°, c = {:.3g} kPa (peaks)",
                                    c.phi_fit, c.cohesion_fit / 1e3),
                        "s = (σ1 + σ3)/2 [kPa]",
                        "t = (σ1 − σ3)/2 [kPa]",
                        {},
                        false,
                        1000,
                        600};
  compare::Series pk{"peaks", {}, {}, "points", "pt 7 ps 1.5"};
  double smax = 0.0;
  const auto sig = confinements(c);
  for (const auto& t : c.tests) {
    // one colour per confinement, one dash pattern per specimen; the legend names a confinement
    // once
    const auto q = static_cast<std::size_t>(
        std::find_if(sig.begin(), sig.end(),
                     [&](double v) { return std::abs(v - t.sigma_c) <= 1e-9 * v; }) -
        sig.begin());
    compare::Series a{t.specimen == 0 ? fmt::format("σ_c = {:.4g} kPa", t.sigma_c / 1e3)
                                      : std::string(),
                      {},
                      {},
                      "lines",
                      fmt::format("lc {} dt {}", q + 1, t.specimen + 1)};
    compare::Series b = a;
    for (std::size_t i = 0; i < t.ea.size(); ++i) {
      a.x.push_back(100.0 * t.ea[i]);
      a.y.push_back((t.sa[i] - t.sl[i]) / 1e3);
      b.x.push_back(100.0 * t.ea[i]);
      b.y.push_back(100.0 * (t.ea[i] + t.el[i]));
    }
    ss.series.push_back(a);
    vs.series.push_back(b);
    pk.x.push_back(t.s_peak / 1e3);
    pk.y.push_back(t.t_peak / 1e3);
    smax = std::max(smax, t.s_peak / 1e3);
  }
  const double sp = std::sin(c.phi_fit * kPi / 180.0), cp = std::cos(c.phi_fit * kPi / 180.0);
  compare::Series fit{"fit t = s sin φ + c cos φ",
                      {0.0, 1.1 * smax},
                      {c.cohesion_fit * cp / 1e3, (1.1 * smax * sp + c.cohesion_fit * cp / 1e3)},
                      "lines",
                      "dt 2"};
  env.series = {pk, fit};
  for (std::size_t k = 0; k < c.specimen_fits.size(); ++k) { // the realisation spread
    const double sk = std::sin(c.specimen_fits[k].first * kPi / 180.0);
    const double ck = c.specimen_fits[k].second * std::cos(c.specimen_fits[k].first * kPi / 180.0);
    env.series.push_back({k == 0 ? "each specimen's peaks alone" : "",
                          {0.0, 1.1 * smax},
                          {ck / 1e3, 1.1 * smax * sk + ck / 1e3},
                          "lines",
                          "lc rgb '#999999' dt 3"});
  }
  emit(ss, "stress_strain");
  emit(vs, "volumetric_strain");
  emit(env, "failure_envelope");
  if (!c.cyclic.empty() && c.cyclic.front().g > 0.0) {
    compare::PlotSpec gg{fmt::format("Cyclic biaxial at σ_c = {:.4g} kPa: G/G0 (G0 = {:.3g} MPa)",
                                     c.cyclic_sigma / 1e3, c.cyclic.front().g / 1e6),
                         "log10 shear strain amplitude γ",
                         "G/G0",
                         {},
                         false,
                         1000,
                         600};
    compare::PlotSpec xi{"Cyclic biaxial: damping ratio",
                         "log10 shear strain amplitude γ",
                         "ξ [%]",
                         {},
                         false,
                         1000,
                         600};
    compare::Series a{"DEM", {}, {}, "linespoints", "pt 7"}, b = a;
    for (const auto& p : c.cyclic) {
      if (!(p.gamma > 0.0)) continue;
      a.x.push_back(std::log10(p.gamma));
      a.y.push_back(p.g / c.cyclic.front().g);
      b.x.push_back(std::log10(p.gamma));
      b.y.push_back(100.0 * p.xi);
    }
    gg.series = {a};
    xi.series = {b};
    emit(gg, "modulus_reduction");
    emit(xi, "damping");
  }
  return out;
}

namespace {
// The frequency [Hz] that drives a scene: its shaking's, else the first sine (or t·sin ωt) load on
// a structure; 0 when neither.
double excitation_frequency(const scene::Scene& sc) {
  auto freq = [](const scene::TimeFunction& f) {
    using K = scene::TimeFunction::Kind;
    if (f.kind == K::Sine) return f.frequency;
    if (f.kind == K::TSine) return f.omega / (2.0 * kPi);
    return 0.0;
  };
  if (sc.load.shaking)
    if (const double f = freq(sc.load.shaking->acceleration); f > 0.0) return f;
  for (const auto& st : sc.structures)
    for (const auto* f : {&st.force_x, &st.force_z, &st.moment})
      if (const double v = freq(*f); v > 0.0) return v;
  return 0.0;
}
} // namespace

std::vector<std::string> apply_calibration(scene::Scene& scene, const Calibration& c) {
  std::vector<std::string> lines;
  if (!scene.soil.continuum) return lines;
  auto& s = *scene.soil.continuum;
  auto& el = continuum::constitutive::elastic_block(s);  // young, poisson, modulus_*
  auto& mc = continuum::constitutive::strength_block(s); // friction_angle, cohesion, …
  const std::string src = fmt::format("dem calibration {}", c.key);
  auto set = [&](const char* key, double& slot, double value, const std::string& shown,
                 const std::string& how) {
    const bool given = std::find(s.given.begin(), s.given.end(), key) != s.given.end();
    std::string note;
    if (given) {
      note = fmt::format("stated in the scene (the calibration gives {})", shown);
    } else {
      slot = value;
      note = fmt::format("{}: {}", src, how);
    }
    s.provenance.emplace_back(key, note);
    lines.push_back(fmt::format("{} = {}: {}", key, given ? "(scene)" : shown, note));
  };
  set("young", el.young, c.young, fmt::format("{:.4g} Pa", c.young), c.young_source);
  set("poisson", el.poisson, c.poisson, fmt::format("{:.3f}", c.poisson), c.poisson_source);
  set("friction_angle", mc.friction_angle, c.friction_angle_deg * kPi / 180.0,
      fmt::format("{:.2f}°", c.friction_angle_deg), "Mohr–Coulomb fit of the biaxial peaks");
  set("cohesion", mc.cohesion, c.cohesion, fmt::format("{:.4g} Pa", c.cohesion),
      "intercept of the fit, ≥ 0");
  set("dilation_angle", mc.dilation_angle, c.dilation_angle_deg * kPi / 180.0,
      fmt::format("{:.2f}°", c.dilation_angle_deg), "mean dilatancy angle at the peaks");
  set("density", s.density, c.bulk_density, fmt::format("{:.5g} kg/m³", c.bulk_density),
      fmt::format("ρ_s (1 − n) of the deposited bed, n = {:.4f}", c.porosity));
  set("k0", s.k0, c.k0, fmt::format("{:.3f}", c.k0), "σ_xx/σ_zz of the deposited bed");
  double surf = s.surface.value_or(0.0);
  set("surface", surf, c.surface, fmt::format("{:.4g} m", c.surface),
      c.soil_mass > 0.0 && std::abs(c.continuum_mass / c.soil_mass - 1.0) > 0.005
          ? fmt::format("the fill's top: the continuum there holds {:.3f} × the DEM bed's soil "
                        "mass at that density",
                        c.continuum_mass / c.soil_mass)
          : std::string("height holding the DEM bed's soil mass at that density"));
  s.surface = surf;
  if (std::isfinite(c.dilation_cutoff))
    set("dilation_cutoff", mc.dilation_cutoff, c.dilation_cutoff,
        fmt::format("{:.4f}", c.dilation_cutoff),
        "dilatancy cut-off: mean dilation of the biaxial tests, densest point to the end "
        "(ψ → 0 beyond it)");
  if (c.modulus_exponent > 0.0 && c.modulus_reference_stress > 0.0) {
    set("modulus_exponent", el.modulus_exponent, c.modulus_exponent,
        fmt::format("{:.3f}", c.modulus_exponent),
        fmt::format("E ∝ p^n through G0 of the cyclic tests at σ_c = {:.4g} and {:.4g} kPa",
                    c.cyclic_shallow_sigma / 1e3, c.modulus_reference_stress / 1e3));
    set("modulus_reference_stress", el.modulus_reference_stress, c.modulus_reference_stress,
        fmt::format("{:.4g} Pa", c.modulus_reference_stress),
        "the confinement of the cyclic test E0 comes from");
  }
  if (mc.dilation_angle > mc.friction_angle) mc.dilation_angle = mc.friction_angle;
  // Damping: Rayleigh damping giving the DEM's small-strain damping ratio ξ0 (the cyclic test's
  // smallest amplitude; larger strains dissipate by plasticity in the continuum) at the layer's
  // first shear mode and at the excitation frequency (implicit), or mass-proportional at the
  // excitation frequency only (explicit).
  if (!c.cyclic.empty() && !scene.continuum.rayleigh_stated) {
    const auto p0 =
        *std::min_element(c.cyclic.begin(), c.cyclic.end(),
                          [](const auto& a, const auto& b) { return a.gamma < b.gamma; });
    double zmin = s.surface.value_or(0.0);
    for (const auto& q : scene.domain) zmin = std::min(zmin, q.z);
    const double h = s.surface.value_or(0.0) - zmin;
    const double gmod = el.young / (2.0 * (1.0 + el.poisson)); // G = E / 2(1 + ν)
    // f1 = V_s / 4H: first shear mode of a uniform layer on a rigid base (Kramer 1996, eq. 7.41)
    const double f1 = h > 0.0 && s.density > 0.0 ? std::sqrt(gmod / s.density) / (4.0 * h) : 0.0;
    double fe = excitation_frequency(scene);
    if (!(fe > 0.0)) fe = f1;
    if (f1 > 0.0 && p0.xi > 0.0) {
      const double w1 = 2.0 * kPi * f1, w2 = 2.0 * kPi * fe;
      std::string note;
      if (scene.continuum.integrator == "explicit") {
        // Explicit central differences: no stiffness-proportional part (β cuts the stable step
        // by √(1 + ξ²) − ξ, ξ = βω_max/2: 2–5× on the paper scenes). Mass-proportional
        // only, ξ(ω) = α/2ω equal to ξ0 at the excitation frequency (Chopra, Dynamics of Structures
        // §11.4).
        scene.continuum.rayleigh_alpha = 2.0 * p0.xi * w2;
        scene.continuum.rayleigh_beta = 0.0;
        note = fmt::format("{}: ξ0 = {:.4f} (cyclic test at γ = {:.2g}) at {} {:.3g} Hz, mass-"
                           "proportional only (explicit integrator; ξ = {:.4f} at f1 = V_s/4H = "
                           "{:.3g} Hz)",
                           src, p0.xi, p0.gamma, fe == f1 ? "f1 = V_s/4H =" : "the excitation's",
                           fe, p0.xi * w2 / w1, f1);
      } else {
        // ξ(ω) = α/2ω + βω/2 equal to ξ0 at ω1 and ω2 (Chopra, Dynamics of Structures, eq. 11.4.9)
        scene.continuum.rayleigh_alpha = 2.0 * p0.xi * w1 * w2 / (w1 + w2);
        scene.continuum.rayleigh_beta = 2.0 * p0.xi / (w1 + w2);
        note = fmt::format("{}: ξ0 = {:.4f} (cyclic test at γ = {:.2g}) at f1 = V_s/4H = {:.3g} Hz "
                           "and {} {:.3g} Hz",
                           src, p0.xi, p0.gamma, f1, fe == f1 ? "again" : "the excitation's", fe);
      }
      s.provenance.emplace_back("continuum.rayleigh", note);
      lines.push_back(fmt::format("continuum.rayleigh_alpha = {:.4g} 1/s, rayleigh_beta = {:.4g} "
                                  "s: {}",
                                  scene.continuum.rayleigh_alpha, scene.continuum.rayleigh_beta,
                                  note));
    }
  }
  // Structures at the height where the DEM packing seated them (always: geometry is not a
  // continuum parameter a scene can state against it). The DEM run seats them itself.
  s.structure_offsets = c.seat_dz;
  for (const auto& [name, dz] : c.seat_dz)
    for (const auto& st : scene.structures)
      if (st.name == name) {
        const std::string note =
            fmt::format("{}: {:.3g} m {} the scene's base, where the DEM packing seated it", src,
                        std::abs(dz), dz < 0.0 ? "below" : "above");
        s.provenance.emplace_back("structure." + name + ".base", note);
        lines.push_back(
            fmt::format("structure.{}.base z = {:.4g} m: {}", name, st.base_centre.z + dz, note));
      }
  // A model that reads neither the elastic nor the Mohr–Coulomb block (the hypoplastic soil) gets
  // density, K0, surface and damping from the DEM, but not its own constants: say so.
  namespace cst = continuum::constitutive;
  if (const auto* m = s.model("model"); m && !m->chosen_uses(cst::Elastic::Parameters::kName) &&
                                        !m->chosen_uses(cst::MohrCoulomb::Parameters::kName)) {
    const std::string note = "its constants are not calibrated from the DEM element tests; they "
                             "keep the scene's values (or the defaults)";
    s.provenance.emplace_back("model", m->keyword + ": " + note);
    lines.push_back(fmt::format("model = {}: {}", m->keyword, note));
    spdlog::warn("soil.continuum.model = {}: calibrate = \"dem\" gives density, k0, surface and "
                 "damping; {}",
                 m->keyword, note);
  }
  return lines;
}

} // namespace demfem::calibrate
