// The two models of a comparison side by side (model_differences.hpp). Every statement about a
// solver below mirrors what its code does; the source is named beside each.
#include "demfem/compare/model_differences.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>
#include <numbers>
#include <sstream>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "constitutive/k0.hpp"
#include "constitutive/registry.hpp"
#include "constitutive/soil.hpp"
#include "demfem/dem/contact/registry.hpp"
#include "demfem/output/contract.hpp"
#include "demfem/scene/params.hpp"
#include "demfem/scene/write_file.hpp"

namespace fs = std::filesystem;
namespace cst = demfem::continuum::constitutive;
using nlohmann::json;

namespace demfem::compare {

namespace {

constexpr double kDeg = 180.0 / std::numbers::pi;

std::string g3(double v) {
  return fmt::format("{:.3g}", v);
}
std::string g4(double v) {
  return fmt::format("{:.4g}", v);
}
// Pa shown as MPa or kPa.
std::string pa(double v) {
  if (std::abs(v) >= 1e6) return fmt::format("{:.4g} MPa", v / 1e6);
  if (std::abs(v) >= 1e3) return fmt::format("{:.4g} kPa", v / 1e3);
  return fmt::format("{:.4g} Pa", v);
}
std::string deg(double rad) {
  return fmt::format("{:.1f}°", rad * kDeg);
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

bool parse_file(const fs::path& p, json& j) {
  if (!fs::is_regular_file(p)) return false;
  try {
    j = json::parse(read_text(p));
    return j.is_object();
  } catch (const std::exception&) {
    return false;
  }
}

double num_or(const json& j, const char* key, double fallback = 0.0) {
  const auto it = j.find(key);
  return it != j.end() && it->is_number() ? it->get<double>() : fallback;
}

double area(const scene::Polygon& p) {
  return p.size() < 3 ? 0.0 : std::abs(scene::signed_area(p));
}

bool given(const scene::ContinuumSoil& c, const char* key) {
  return std::find(c.given.begin(), c.given.end(), key) != c.given.end();
}
const std::string* provenance(const scene::ContinuumSoil& c, const std::string& key) {
  for (const auto& [k, v] : c.provenance)
    if (k == key) return &v;
  return nullptr;
}
bool calibrated(const scene::ContinuumSoil& c, const char* key) {
  const auto* p = provenance(c, key);
  return p && p->rfind("dem calibration", 0) == 0;
}

// The keys of a model as "K_n = 1e+06 N/m, K_s = …" (its parameter blocks, scene/params.hpp).
std::string model_keys(const scene::ModelChoice& m) {
  std::vector<std::string> parts;
  for (const auto& t : scene::describe(m)) parts.push_back(t.text());
  return fmt::format("{}", fmt::join(parts, ", "));
}

// The DEM contact law with the parameters it reads (dem/contact/), and rolling resistance.
std::string contact_law(const scene::DemSoil& d) {
  const auto law = dem::contact::law_of(d);
  std::string s = fmt::format("disks, contact law {}: {}, μ_s {} / μ_D {}", law.keyword,
                              model_keys(law), g3(d.mu_static), g3(d.mu_dynamic));
  const auto rolling = dem::contact::rolling_of(d);
  if (rolling.written())
    s += fmt::format("; rolling resistance {}: {}", rolling.keyword, model_keys(rolling));
  return s;
}

// E as the report states it: "30 MPa", or "30 MPa × (p/1.08 MPa)^0.25" for a stress-dependent
// modulus (continuum/constitutive/elastic.hpp).
std::string modulus_text(const scene::ContinuumSoil& c) {
  const auto& el = cst::elastic_block(c);
  if (!el.stress_dependent()) return pa(el.young);
  return fmt::format("{} × (p/{})^{} at the in-plane mean stress p", pa(el.young),
                     pa(el.modulus_reference_stress), g3(el.modulus_exponent));
}

// The continuum soil's model is `keyword` (continuum/constitutive/registry.hpp)?
bool soil_is(const scene::ContinuumSoil& c, const char* keyword) {
  return cst::soil_model(c).keyword == keyword;
}
bool mohr_coulomb(const scene::ContinuumSoil& c) {
  return soil_is(c, cst::MohrCoulomb::keyword);
}

// Soil model of the continuum (continuum/constitutive/: elastic, Mohr–Coulomb, or another
// registered model, told by its summary and its keys).
std::string continuum_model(const scene::ContinuumSoil& c) {
  const bool cal = calibrated(c, "young") || calibrated(c, "friction_angle");
  const auto& el = cst::elastic_block(c);
  const auto& st = cst::strength_block(c);
  if (soil_is(c, cst::Elastic::keyword))
    return fmt::format("linear elastic, E = {}, ν = {}{}; never yields", modulus_text(c),
                       g3(el.poisson), cal ? " (calibrated)" : "");
  if (!mohr_coulomb(c)) {
    const auto& choice = cst::soil_model(c);
    const auto slot = cst::model_slot(); // (find points into it)
    const auto* entry = slot.find(choice.keyword);
    std::string keys;
    for (const auto& p : scene::describe(choice)) keys += (keys.empty() ? "" : ", ") + p.text();
    return fmt::format("{}: {}{}", entry ? entry->summary : choice.keyword, keys,
                       cal ? " (calibrated from DEM element tests)" : "");
  }
  return fmt::format(
      "Mohr–Coulomb, perfectly plastic, non-associated: E = {}, ν = {}, φ = {}, c = {}, "
      "ψ = {}{}{}{}",
      modulus_text(c), g3(el.poisson), deg(st.friction_angle), pa(st.cohesion),
      deg(st.dilation_angle),
      !std::isnan(st.dilation_cutoff) && st.dilation_angle > 0.0
          ? fmt::format(" up to a plastic dilation of {} (then ψ = 0)", g3(st.dilation_cutoff))
          : std::string(st.dilation_angle > 0.0 ? " without limit" : ""),
      st.tension_cutoff > 0.0 ? ", tension cut-off " + pa(st.tension_cutoff) : "",
      cal ? " (calibrated from DEM element tests)" : "");
}

// Largest |a(t)| over the run (sampled).
double peak(const scene::TimeFunction& f, double duration) {
  if (f.kind == scene::TimeFunction::Kind::Sine) return std::abs(f.amplitude);
  double m = 0.0;
  const int n = 4000;
  for (int i = 0; i <= n; ++i) m = std::max(m, std::abs(f(duration * i / n)));
  return m;
}

bool zero_function(const scene::TimeFunction& f) {
  return f.kind == scene::TimeFunction::Kind::Constant && f.value == 0.0;
}

struct Box {
  double x0 = 0, x1 = 0, z0 = 0, z1 = 0;
};
Box box_of(const scene::Scene& s, bool with_structures) {
  std::vector<scene::Vec2> pts(s.domain.begin(), s.domain.end());
  if (with_structures)
    for (const auto& st : s.structures) pts.insert(pts.end(), st.outline.begin(), st.outline.end());
  const auto b = scene::bounds(pts);
  return {b.x0, b.x1, b.z0, b.z1};
}

// The DEM friction of a boundary with its own μ or the soil's (dem/src/engine.cpp new_boundary:
// μ_D defaults to min(μ_s, the soil's μ_D)).
std::string boundary_friction(const std::optional<double>& ms, const std::optional<double>& md,
                              const scene::DemSoil& d, double* mu_s_out = nullptr,
                              double* mu_d_out = nullptr) {
  if (ms || md) {
    const double s = ms.value_or(d.mu_static);
    const double dd = md.value_or(std::min(s, d.mu_dynamic));
    if (mu_s_out) *mu_s_out = s;
    if (mu_d_out) *mu_d_out = dd;
    return fmt::format("μ_s {} / μ_D {} (its own)", g3(s), g3(dd));
  }
  if (mu_s_out) *mu_s_out = d.mu_static;
  if (mu_d_out) *mu_d_out = d.mu_dynamic;
  return fmt::format("μ_s {} / μ_D {} (the particles' μ)", g3(d.mu_static), g3(d.mu_dynamic));
}

} // namespace

double mean_diameter(const scene::DemSoil& d) {
  if (!d.particles.empty()) {
    double s = 0.0;
    for (const auto& q : d.particles) s += q[2];
    return 2.0 * s / static_cast<double>(d.particles.size());
  }
  switch (d.radius.kind) {
  case scene::RadiusDistribution::Kind::Uniform:
  case scene::RadiusDistribution::Kind::Equal:
    return d.radius.min + d.radius.max; // 2 × the number mean (min + max)/2
  case scene::RadiusDistribution::Kind::Table: {
    double s = 0.0, w = 0.0;
    for (const auto& [r, f] : d.radius.table) {
      s += r * f;
      w += f;
    }
    return w > 0.0 ? 2.0 * s / w : 0.0;
  }
  }
  return 0.0;
}

// ---- run_<solver>.json
// ------------------------------------------------------------------------------

fs::path solver_run_file(const fs::path& run_dir, const std::string& solver) {
  return run_dir / ("run_" + solver + ".json");
}

void write_solver_run(const fs::path& run_dir, const SolverRun& r) {
  json j;
  j["solver"] = r.solver;
  j["ok"] = r.ok;
  j["message"] = r.message;
  if (!r.note.empty()) j["note"] = r.note;
  j["solver_seconds"] = r.solver_seconds;
  j["total_seconds"] = r.total_seconds;
  j["steps"] = r.steps;
  j["dt_s"] = r.dt;
  j["simulated_time_s"] = r.simulated_time;
  j["threads"] = r.threads;
  if (r.solver == "dem") j["particles"] = r.particles;
  if (r.solver == "continuum") {
    j["dofs"] = r.dofs;
    j["cells"] = r.cells;
    j["refinement"] = r.refinement;
    j["degree"] = r.degree;
    j["integrator"] = r.integrator;
    j["substeps"] = r.substeps;
    j["h_min_m"] = r.h_min;
    j["h_max_m"] = r.h_max;
    j["seated"] = r.seated;
  }
  std::string when = r.finished_utc;
  if (when.empty()) {
    const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
    std::tm tm{};
    gmtime_r(&now, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S UTC", &tm);
    when = buf;
  }
  j["finished_utc"] = when;
  fs::create_directories(run_dir);
  scene::write_file_atomic(solver_run_file(run_dir, r.solver), j.dump(2) + "\n");
}

SolverRun read_solver_run(const fs::path& run_dir, const std::string& solver) {
  SolverRun r;
  json j;
  if (!parse_file(solver_run_file(run_dir, solver), j)) return r;
  try {
    r.present = true;
    r.solver = j.value("solver", std::string());
    r.ok = j.value("ok", false);
    r.message = j.value("message", std::string());
    r.note = j.value("note", std::string());
    r.solver_seconds = num_or(j, "solver_seconds");
    r.total_seconds = num_or(j, "total_seconds");
    r.steps = j.value("steps", 0LL);
    r.dt = num_or(j, "dt_s");
    r.simulated_time = num_or(j, "simulated_time_s");
    r.threads = j.value("threads", 0);
    r.particles = j.value("particles", std::size_t{0});
    r.dofs = j.value("dofs", std::size_t{0});
    r.cells = j.value("cells", std::size_t{0});
    r.refinement = j.value("refinement", -1);
    r.degree = j.value("degree", -1);
    r.integrator = j.value("integrator", std::string());
    r.substeps = j.value("substeps", 0LL);
    r.h_min = num_or(j, "h_min_m");
    r.h_max = num_or(j, "h_max_m");
    if (j.contains("seated"))
      r.seated = j.at("seated").get<std::vector<std::pair<std::string, double>>>();
    r.finished_utc = j.value("finished_utc", std::string());
  } catch (const std::exception&) {
    r.present = false; // malformed: treated as not recorded
  }
  return r;
}

ModelFacts read_model_facts(const fs::path& run_dir) {
  ModelFacts f;
  f.dem = read_solver_run(run_dir, "dem");
  f.continuum = read_solver_run(run_dir, "continuum");
  json p;
  if (parse_file(run_dir / output::dir::dem / output::file::packing, p)) {
    f.packing = true;
    f.packing_porosity = num_or(p, "porosity");
    for (const auto& [k, v] : p.items())
      if (k.rfind("seated_", 0) == 0 && v.is_object())
        f.dem_seat_dz.emplace_back(k.substr(7), num_or(v, "dz_m"));
  }
  json c;
  if (parse_file(run_dir / "calibration" / "calibration.json", c)) {
    try {
      f.calibration = true;
      f.calibration_key = c.value("key", std::string());
      f.cal_wall_seconds = num_or(c, "wall_seconds");
      const auto& b = c.at("bed");
      f.cal_surface = num_or(b, "surface_mass_matched_m");
      f.cal_surface_top_mean = num_or(b, "surface_top_mean_m");
      f.cal_bulk_density = num_or(b, "bulk_density_kg_m3");
      f.cal_porosity = num_or(b, "porosity");
      f.cal_k0 = num_or(b, "k0");
      f.cal_soil_mass = num_or(b, "soil_mass_kg");
      f.cal_continuum_mass = num_or(b, "continuum_mass_kg");
      if (b.contains("structure_seat_dz_m"))
        f.cal_seat_dz =
            b.at("structure_seat_dz_m").get<std::vector<std::pair<std::string, double>>>();
      if (c.contains("cyclic")) {
        f.cal_cyclic_sigma = num_or(c["cyclic"], "sigma_c_pa");
        for (const auto& l : c["cyclic"].value("loops", json::array()))
          f.cal_cyclic.push_back({num_or(l, "gamma"), num_or(l, "g_pa"), num_or(l, "xi")});
      }
      if (c.contains("envelope")) {
        f.cal_phi_fit = num_or(c["envelope"], "phi_deg");
        f.cal_cohesion_fit = num_or(c["envelope"], "cohesion_pa");
        f.cal_phi_cv = num_or(c["envelope"], "phi_cv_deg");
        f.cal_psi = num_or(c["envelope"], "psi_deg");
      }
      if (c.contains("affine")) {
        f.cal_affine_e = num_or(c["affine"], "e_inplane_pa");
        f.cal_affine_g = num_or(c["affine"], "g_pa");
      }
      if (c.contains("continuum")) {
        f.cal_young_source = c["continuum"].value("young_source", std::string());
        f.cal_young_small = num_or(c["continuum"], "young_small");
        f.cal_young_e50 = num_or(c["continuum"], "young_e50");
      }
      if (c.contains("specimen")) {
        f.cal_particles = c["specimen"].value("particles", 0);
        f.cal_specimens = c["specimen"].value("count", 1);
      }
      if (c.contains("envelope") && c["envelope"].contains("per_specimen"))
        for (const auto& ps : c["envelope"]["per_specimen"])
          f.cal_specimen_fits.emplace_back(num_or(ps, "phi_deg"), num_or(ps, "cohesion_pa"));
    } catch (const std::exception&) {
      f.calibration = false;
    }
  }
  return f;
}

// ---- what differs ------------------------------------------------------------------------------

namespace {

// What every row of model_differences reads: the scene, the run's facts, both soils, the
// continuum's options, and the domain's box without and with the structures.
struct DiffContext {
  const scene::Scene& s;
  const ModelFacts& f;
  const scene::DemSoil& d;
  const scene::ContinuumSoil& c;
  const scene::ContinuumOptions& co;
  bool mc; // the continuum is Mohr–Coulomb
  double g;
  Box dom, mesh;
  double tol; // a length below which two positions are the same
};

// The soil models: the DEM's contact law against the continuum's constitutive model.
void soil_model(const DiffContext& x, std::vector<DiffRow>& rows) {
  const auto& [s, f, d, c, co, mc, g, dom, mesh, tol] = x;
  DiffRow r{"soil model (constitutive behaviour)", contact_law(d), continuum_model(c), "", false};
  if (mc)
    r.consequence = fmt::format(
        "The granular bed's stiffness grows with confinement and falls with strain amplitude, "
        "and it compacts under shaking; the continuum's E {} and does not fall with strain, "
        "and it changes volume only elastically or by dilating at ψ ≥ 0 when it yields (up "
        "to its dilatancy cut-off; where it is pulled to the yield surface's apex, zero "
        "stress for a cohesionless soil, without limit) — it cannot densify.",
        cst::elastic_block(c).stress_dependent()
            ? "follows the initial confinement as p^" + g3(cst::elastic_block(c).modulus_exponent)
            : "is the same at every depth");
  else if (soil_is(c, cst::Hypoplastic::keyword))
    r.consequence =
        "Both can compact: the continuum's hypoplastic soil densifies under cyclic shear (its void "
        "ratio falls towards e_d) with a stiffness that follows the mean stress and, through the "
        "intergranular strain, the strain's recent path. A difference in settlement is then a "
        "difference between the two models of the same sand, not a capacity only the DEM has.";
  else if (soil_is(c, cst::Elastic::keyword))
    r.consequence = "The continuum never yields or slides: every permanent deformation and all "
                    "sliding at failure are DEM-only.";
  if (calibrated(c, "young") || calibrated(c, "friction_angle"))
    r.consequence += " Its parameters are the DEM element tests' (Parameters below), so the two "
                     "agree at the calibration's stress and strain levels, not everywhere.";
  rows.push_back(r);
}

// The soil's surface, density and mass in each model.
void surface_and_mass(const DiffContext& x, std::vector<DiffRow>& rows) {
  const auto& [s, f, d, c, co, mc, g, dom, mesh, tol] = x;
  // (listed particles are not a deposited bed: no porosity)
  const double n = f.calibration                      ? f.cal_porosity
                   : f.packing && d.particles.empty() ? f.packing_porosity
                                                      : -1.0;
  std::string dem = fmt::format("{} of {} disks, ρ_s = {} kg/m³",
                                d.particles.empty() ? "deposited bed" : "listed particles", d.count,
                                g4(d.density));
  if (n >= 0.0)
    dem += fmt::format(", porosity {:.4f} → bulk density {} kg/m³", n, g4(d.density * (1.0 - n)));
  if (f.calibration)
    dem +=
        fmt::format("; surface: mean column top {} m; mass {} kg per m thickness; the "
                    "calibration's mass-matched surface {} m{}",
                    g4(f.cal_surface_top_mean), g4(f.cal_soil_mass), g4(f.cal_surface),
                    std::abs(f.cal_surface - dom.z1) < tol ? " (capped at the domain's top)" : "");
  // The continuum soil: the domain below the surface without the structures' cells
  // (continuum/run/run.cpp; a structure's part inside the domain's bounding box).
  const double top = c.surface.value_or(dom.z1);
  double soil = area(clip(s.domain, 0.0, 1.0, top));
  for (const auto& st : s.structures) {
    auto q = clip(st.outline, 0.0, 1.0, std::min(top, dom.z1));
    q = clip(clip(clip(q, 0.0, -1.0, -dom.z0), 1.0, 0.0, dom.x1), -1.0, 0.0, -dom.x0);
    soil -= area(q);
  }
  const double mass = c.density * d.thickness * std::max(0.0, soil);
  std::string cont = fmt::format("{}: z ≤ {} m, ρ = {} kg/m³; mass {} kg per m thickness",
                                 c.surface ? "domain polygon below soil.continuum.surface"
                                           : "the whole domain polygon",
                                 g4(top), g4(c.density), g4(mass));
  bool matched = false;
  std::string why;
  if (f.calibration && f.cal_soil_mass > 0.0 && f.cal_bulk_density > 0.0) {
    // Matched: the same density and, in the continuum's actual soil (domain below the surface
    // without the structures), the DEM's soil mass within 1 %.
    const double ratio = mass / f.cal_soil_mass;
    const bool same_density = std::abs(c.density - f.cal_bulk_density) <= 1e-3 * f.cal_bulk_density;
    matched = same_density && std::abs(ratio - 1.0) <= 0.01;
    why = matched ? fmt::format("Same density, and the same soil mass to within 1 % "
                                "(continuum/DEM {:.4f}): the static loads (weight, thrust at "
                                "rest) start from the same soil.",
                                ratio)
                  : fmt::format("Continuum soil mass {:.3f} × the DEM's (surface {} m against "
                                "the bed's mass-matched {} m, density {} against {} kg/m³): "
                                "the at-rest loads differ accordingly.",
                                ratio, g4(top), g4(f.cal_surface), g4(c.density),
                                g4(f.cal_bulk_density));
  } else {
    why = "No calibration in this run: the DEM bed's surface and density were not measured, so "
          "mass and height are not matched (soil.continuum.calibrate = \"dem\" matches them).";
  }
  rows.push_back({"soil surface, density and mass", dem, cont, why, matched});
}

// The initial stress: the deposited bed's own against the continuum's geostatic K0.
void initial_stress(const DiffContext& x, std::vector<DiffRow>& rows) {
  const auto& [s, f, d, c, co, mc, g, dom, mesh, tol] = x;
  const double k0 = cst::soil_k0(c);
  const std::string src = calibrated(c, "k0") ? "calibrated: the DEM bed's"
                          : given(c, "k0")    ? "stated in the scene"
                          : c.k0 >= 0.0       ? "set"
                                              : "Jaky 1 − sin φ (no k0 given)";
  std::string dem = !d.particles.empty() ? "the listed particles' initial state (no deposition)"
                    : d.packing.target_porosity
                        ? "the deposited bed's own stresses (deposition under gravity "
                          "at raised friction, then the scene's friction, settled)"
                        : "the deposited bed's own stresses (deposition under gravity)";
  if (f.calibration)
    dem += fmt::format("; K0 = σ_xx/σ_zz = {:.3f} (Love–Weber stress, away from walls)", f.cal_k0);
  const std::string cont =
      fmt::format("geostatic: σ_zz = −ρ g depth, σ_xx = K0 σ_zz with K0 = {:.3f} ({}), then "
                  "an equilibrium correction",
                  k0, src);
  const bool matched = f.calibration && std::abs(k0 - f.cal_k0) <= 5e-4;
  rows.push_back({"initial stress", dem, cont,
                  matched ? "Same lateral stress ratio at rest: static thrusts comparable."
                  : f.calibration
                      ? fmt::format("K0 {:.3f} against the bed's {:.3f}: static lateral "
                                    "stresses differ by that ratio.",
                                    k0, f.cal_k0)
                      : "The bed's K0 was not measured (no calibration): the static lateral "
                        "stresses need not agree.",
                  matched});
}

// The continuum's box sides (continuum/fem/fem.hpp Problem: left/right rollers, bottom fixed,
// top free; box conditions skip structure dofs), each with the DEM walls that lie on it.
struct BoxSide {
  const char* name;
  const char* continuum;
  bool (*on)(const scene::Wall&, const Box&, double);
};
const BoxSide kBoxSides[] = {
    {"base", "fixed: u = 0 (fully rough, no sliding or lift-off)",
     [](const scene::Wall& w, const Box& b, double t) {
       return std::all_of(w.points.begin(), w.points.end(),
                          [&](const scene::Vec2& q) { return std::abs(q.z - b.z0) < t; });
     }},
    {"left side", "roller: u_x = 0, frictionless, no separation",
     [](const scene::Wall& w, const Box& b, double t) {
       return std::all_of(w.points.begin(), w.points.end(),
                          [&](const scene::Vec2& q) { return std::abs(q.x - b.x0) < t; });
     }},
    {"right side", "roller: u_x = 0, frictionless, no separation",
     [](const scene::Wall& w, const Box& b, double t) {
       return std::all_of(w.points.begin(), w.points.end(),
                          [&](const scene::Vec2& q) { return std::abs(q.x - b.x1) < t; });
     }},
};

// One side of the box: the DEM's walls on it (marked in `used`) against the continuum's condition.
void box_side(const DiffContext& x, const BoxSide& side, std::vector<bool>& used,
              std::vector<DiffRow>& rows) {
  const auto& [s, f, d, c, co, mc, g, dom, mesh, tol] = x;
  const bool right = std::string(side.name) == "right side";
  const bool left = std::string(side.name) == "left side";
  // A structure at the mesh's edge takes that side's dofs (box conditions skip them).
  const scene::Structure* edge = nullptr;
  for (const auto& st : s.structures) {
    const auto b = scene::bounds(st.outline);
    if ((right && std::abs(b.x1 - mesh.x1) < tol && b.x0 >= dom.x1 - tol) ||
        (left && std::abs(b.x0 - mesh.x0) < tol && b.x1 <= dom.x0 + tol))
      edge = &st;
  }
  std::string dem;
  double mu = 0.0, mu_d = 0.0;
  bool any = false;
  for (std::size_t k = 0; k < s.walls.size(); ++k)
    if (side.on(s.walls[k], dom, tol)) {
      used[k] = true;
      any = true;
      dem += fmt::format(
          "{}frictional wall '{}': {}{}", dem.empty() ? "" : "; ", s.walls[k].name,
          boundary_friction(s.walls[k].mu_static, s.walls[k].mu_dynamic, d, &mu, &mu_d),
          s.walls[k].opens_at ? fmt::format(", removed at t = {} s", g3(*s.walls[k].opens_at))
                              : "");
    }
  if (!any && edge) return; // the structure row covers it
  if (!any) dem = "no wall";
  std::string cont =
      edge ? fmt::format("structure '{}' (see structure faces)", edge->name) : side.continuum;
  std::string why;
  bool matched = false;
  // continuum.interface = "coulomb" (continuum/run/run.cpp): the wall is a zero-thickness
  // Coulomb contact plane with the DEM's μ (continuum/README.md)
  const bool coulomb = co.interface == "coulomb" && any && !edge;
  if (coulomb) {
    cont = fmt::format("Coulomb contact plane (continuum.interface = \"coulomb\"): zero "
                       "thickness, μ_s {} / μ_D {}, slides and separates",
                       g3(mu), g3(mu_d));
    why = "Matched: the same wall friction; the soil slides on the wall at μ_D once μ_s is "
          "exceeded and leaves it when pulled, as the DEM particles do.";
    matched = true;
  } else if (!any && !edge) {
    why = "The DEM soil has no wall on this side; the continuum's is held there.";
  } else if (std::string(side.name) == "base") {
    why = "The DEM bed can slide on its base and lift off it; the continuum cannot.";
    if (s.load.shaking && s.load.shaking->direction == 'x' && any) {
      // Rigid block on a Coulomb base: it starts sliding when |a| > μ_s g and keeps sliding
      // while |a| > μ_D g (Newmark 1965 sliding block).
      const double a = peak(s.load.shaking->acceleration, s.info.duration);
      why += fmt::format(" Peak shaking {} m/s² against μ_s g = {} and μ_D g = {} m/s²: {}.", g3(a),
                         g3(mu * g), g3(mu_d * g),
                         a > mu * g     ? "the DEM bed can slide on its base"
                         : a > mu_d * g ? "the DEM bed cannot start sliding on its base"
                                        : "no sliding on the base");
    }
  } else {
    matched = any && mu == 0.0 && !edge;
    why = matched ? "Both frictionless (the DEM wall can still separate from the soil)."
          : edge  ? "See structure faces."
                  : "Shear stress along this side: carried by the DEM wall's friction, zero "
                    "on the continuum's roller.";
  }
  rows.push_back({std::string("boundary: ") + side.name, dem, cont, why, matched});
}

// The boundaries: the continuum's box against the DEM's [[wall]]s, side by side, then the DEM
// walls on no side of the box.
void boundaries(const DiffContext& x, std::vector<DiffRow>& rows) {
  const auto& s = x.s;
  const auto& d = x.d;
  std::vector<bool> used(s.walls.size(), false);
  for (const auto& side : kBoxSides) box_side(x, side, used, rows);
  std::string other;
  for (std::size_t k = 0; k < s.walls.size(); ++k)
    if (!used[k])
      other += fmt::format("{}'{}' ({})", other.empty() ? "" : "; ", s.walls[k].name,
                           boundary_friction(s.walls[k].mu_static, s.walls[k].mu_dynamic, d));
  if (!other.empty())
    rows.push_back({"boundary: other walls", "frictional walls " + other,
                    "no counterpart: the soil's edge there is the domain polygon's "
                    "(stair-stepped, free)",
                    "The DEM soil leans on these walls; the continuum's does not.", false});
}

// The structure faces (continuum/run/run.cpp: tied rigid bodies, or the thin frictional layer)
void structure_faces(const DiffContext& x, std::vector<DiffRow>& rows) {
  const auto& [s, f, d, c, co, mc, g, dom, mesh, tol] = x;
  if (s.structures.empty()) return;
  std::string dem;
  for (const auto& st : s.structures)
    dem += fmt::format("{}'{}': {}", dem.empty() ? "" : "; ", st.name,
                       boundary_friction(st.mu_static, st.mu_dynamic, d));
  dem = "rigid bodies with frictional contacts that slide and open: " + dem;
  std::string cont, why;
  bool matched = false;
  const double h = f.continuum.h_min > 0.0 ? f.continuum.h_min : 0.0;
  if (co.interface == "coulomb") {
    // continuum/run/run.cpp: structures with every DoF fixed are unmeshed Coulomb contact
    // bodies; moving structures too unless continuum.structure_interface = "tied"
    std::string at_rest, moving;
    for (const auto& st : s.structures) {
      const bool fixed = (st.dof_x == scene::DofMode::Fixed && st.dof_z == scene::DofMode::Fixed &&
                          st.dof_rotation == scene::DofMode::Fixed) ||
                         co.structure_interface == "contact";
      std::string& list = fixed ? at_rest : moving;
      list += fmt::format("{}'{}'", list.empty() ? "" : ", ", st.name);
    }
    if (!at_rest.empty())
      cont = fmt::format("{}: zero-thickness Coulomb contact with the DEM's μ (not meshed; "
                         "continuum.interface = \"coulomb\"), slides and separates",
                         at_rest);
    if (!moving.empty())
      cont += fmt::format("{}{}: rigid bodies tied to the soil and seated (the soil carries "
                          "their weight, as the DEM bed does; continuum.structure_interface = "
                          "\"tied\"; \"contact\" makes them seated Coulomb contact bodies)",
                          cont.empty() ? "" : "; ", moving);
    matched = moving.empty();
    why = matched ? "Matched: zero-thickness contact with the same μ_s/μ_D, sliding and "
                    "separation."
                  : "The moving structures' faces are still bonded to the soil; the DEM's "
                    "slide and open at μ.";
  } else if (co.interface == "frictional") {
    const double mu = std::tan(co.interface_friction_angle);
    cont = fmt::format(
        "rigid bodies; the soil cells touching them form a Mohr–Coulomb layer one cell thick{} "
        "with δ = {} (tan δ = {:.3f}; layer φ_l = asin(tan δ)), c = 0, ψ = 0",
        h > 0.0 ? fmt::format(" (≈ {} m)", g3(h)) : std::string(), deg(co.interface_friction_angle),
        mu);
    why = fmt::format("A layer, not a zero-thickness contact: its thickness changes with the "
                      "mesh, it cannot open, and its one δ stands for the DEM's μ_s/μ_D "
                      "(tan δ {:.3f} against μ_D {}).",
                      mu, g3(d.mu_dynamic));
  } else {
    cont = "rigid bodies tied to the soil (continuum.interface = \"tied\"): no slip, no "
           "separation — an infinitely rough, bonded face";
    why = "The continuum's soil cannot slide along or separate from a structure; the DEM's "
          "does at μ. Wall friction and active wedges differ accordingly.";
  }
  rows.push_back({"boundary: structure faces", dem, cont, why, matched});
}

// Damping (dem/src/engine.cpp: C, D global damping; contact law; continuum/run/run.cpp)
void damping(const DiffContext& x, std::vector<DiffRow>& rows) {
  const auto& [s, f, d, c, co, mc, g, dom, mesh, tol] = x;
  std::string dem = "Coulomb sliding at contacts (μ_D) at every amplitude";
  const auto law = dem::contact::law_of(d);
  const auto slot = dem::contact::law_slot();
  if (const auto* e = slot.find(law.keyword))
    dem += fmt::format("; contact law {} ({}; dem/contact/): {}", law.keyword, e->summary,
                       model_keys(law));
  dem +=
      d.damping_c > 0.0 || d.damping_d > 0.0
          ? fmt::format("; global damping C = {} /s, D = {} /s", g3(d.damping_c), g3(d.damping_d))
          : "; no global damping (soil.dem.damping_c = damping_d = 0)";
  if (!f.cal_cyclic.empty()) {
    const auto& a = f.cal_cyclic.front();
    const auto& b = f.cal_cyclic.back();
    dem += fmt::format("; measured (cyclic biaxial): ξ = {:.1f} % at γ = {:.2g} … {:.1f} % at "
                       "γ = {:.2g}",
                       100 * a.xi, a.gamma, 100 * b.xi, b.gamma);
  }
  std::string cont;
  const bool viscous = co.rayleigh_alpha > 0.0 || co.rayleigh_beta > 0.0;
  // calibrate = "dem" sets α, β from the DEM's small-strain ξ0 (compare::apply_calibration)
  const std::string* rayleigh = provenance(c, "continuum.rayleigh");
  cont = viscous ? fmt::format("Rayleigh α = {} /s, β = {} s{}", g3(co.rayleigh_alpha),
                               g3(co.rayleigh_beta),
                               rayleigh ? " (calibrated — " + *rayleigh + ")" : std::string())
                 : "no Rayleigh damping (α = β = 0)";
  if (co.local_damping > 0.0 && co.integrator == "explicit")
    cont += fmt::format("; local damping α_L = {}", g3(co.local_damping));
  if (co.absorbing) cont += "; Lysmer dashpots on the unconstrained boundary components";
  cont += mc ? "; plastic dissipation once Mohr–Coulomb yields" : "; elastic: no plastic work";
  std::string why;
  if (!viscous && co.local_damping <= 0.0)
    why = mc ? "Below yield the continuum dissipates nothing; the DEM dissipates by sliding at "
               "every amplitude."
             : "The continuum dissipates nothing at all.";
  else if (viscous)
    why = "Both dissipate, by different mechanisms: the continuum's Rayleigh damping is "
          "viscous (frequency-dependent, the same at every amplitude), the DEM's friction "
          "grows with the strain amplitude.";
  else
    why = "Both dissipate, by different mechanisms (local non-viscous against frictional).";
  if (!f.cal_cyclic.empty() && !rayleigh)
    why += " The calibration's ξ(γ) is measured but not used by the continuum.";
  rows.push_back({"damping", dem, cont, why, false});
}

// The excitation (dem/src/engine.cpp integrate: m·a on particles only; continuum: ρ·a on soil)
void excitation(const DiffContext& x, std::vector<DiffRow>& rows) {
  const auto& [s, f, d, c, co, mc, g, dom, mesh, tol] = x;
  std::string both = "gravity g = " + g3(g) + " m/s²";
  std::string dem = both, cont = both;
  if (s.load.shaking) {
    const auto& sh = *s.load.shaking;
    dem += fmt::format("; body force m·a(t) on every particle, a_{} = {} m/s²; walls and "
                       "structures are not shaken",
                       sh.direction, sh.acceleration.describe());
    cont += fmt::format("; body force ρ·a(t) on the soil cells, the same a_{}(t), in the frame "
                        "of the fixed base; structures are not shaken",
                        sh.direction);
  } else {
    dem += "; no shaking";
    cont += "; no shaking";
  }
  bool loads = false;
  for (const auto& st : s.structures)
    if (!zero_function(st.force_x) || !zero_function(st.force_z) || !zero_function(st.moment))
      loads = true;
  if (loads) {
    dem += "; structure loads at their load points";
    cont += "; structure loads as body forces with the same resultant and moment";
  }
  rows.push_back({"excitation", dem, cont,
                  "The same input: differences in response are the models', not the loading's.",
                  true});
}

// Friction changes during the run (set-friction events).
void friction_changes(const DiffContext& x, std::vector<DiffRow>& rows) {
  const auto& [s, f, d, c, co, mc, g, dom, mesh, tol] = x;
  for (const auto& ev : s.events) {
    if (ev.action != scene::EventAction::SetFriction) continue;
    const bool same = ev.mu_static == d.mu_static && ev.mu_dynamic == d.mu_dynamic;
    rows.push_back(
        {fmt::format("friction change at t = {} s", g3(ev.time)),
         fmt::format("group '{}' gets μ_s {} / μ_D {}{}", ev.group, g3(ev.mu_static),
                     g3(ev.mu_dynamic), same ? " (the soil's own values: no change)" : ""),
         "no counterpart: φ and the interfaces keep their values",
         same ? "None: the event repeats the friction the bed was deposited and calibrated with."
              : "The DEM shakes with another friction than the one its packing (and the "
                "continuum's calibration) was made with.",
         same});
  }
}

// Each structure's placement (packing seat vs continuum offsets and seating stage)
void placements(const DiffContext& x, std::vector<DiffRow>& rows) {
  const auto& [s, f, d, c, co, mc, g, dom, mesh, tol] = x;
  for (const auto& st : s.structures) {
    double dem_dz = 0.0;
    bool dem_known = f.packing || f.calibration;
    for (const auto& [n, dz] : f.packing ? f.dem_seat_dz : f.cal_seat_dz)
      if (n == st.name) dem_dz = dz;
    double cont_dz = 0.0;
    for (const auto& [n, dz] : c.structure_offsets)
      if (n == st.name) cont_dz = dz;
    std::string dem =
        !dem_known ? "as the packing left it (packing.json not found)"
        : dem_dz != 0.0
            ? fmt::format("seated by the packing: {} m {} its stated base, where the bed carries "
                          "its weight",
                          g3(std::abs(dem_dz)), dem_dz < 0.0 ? "below" : "above")
            : "where the scene puts it";
    std::string cont = cont_dz != 0.0
                           ? fmt::format("placed at the DEM's seat ({} m {})",
                                         g3(std::abs(cont_dz)), cont_dz < 0.0 ? "below" : "above")
                           : "where the scene puts it";
    double settled = 0.0;
    for (const auto& [n, settle] : f.continuum.seated)
      if (n == st.name) {
        settled = settle;
        cont += fmt::format("; seated under its weight before t = 0 (settled {} m)", g3(settle));
      }
    // The continuum's seating settles the structure further from the DEM's seat by its elastic
    // settlement under the weight; below 1 mm the two start at the same height.
    const bool same_seat = dem_known && std::abs(dem_dz - cont_dz) <= 1e-9;
    const bool matched = same_seat && std::abs(settled) <= 1e-3;
    rows.push_back({fmt::format("placement of '{}'", st.name), dem, cont,
                    matched     ? "Same starting height in both models."
                    : same_seat ? fmt::format("The continuum starts {} m lower than the DEM: its "
                                              "seating adds the settlement under the weight to the "
                                              "DEM's seat.",
                                              g3(settled))
                                : "The structure starts at a different height in the two models.",
                    matched});
  }
}

// Time integration.
void time_integration(const DiffContext& x, std::vector<DiffRow>& rows) {
  const auto& [s, f, d, c, co, mc, g, dom, mesh, tol] = x;
  std::string dem = "explicit symplectic Euler";
  if (f.dem.present)
    dem += fmt::format(", Δt = {} s ({}), {} steps", g3(f.dem.dt),
                       d.dt > 0.0 ? "soil.dem.dt"
                                  : fmt::format("{} × the stable limit", g3(d.dt_safety)),
                       f.dem.steps);
  else
    dem += d.dt > 0.0 ? fmt::format(", Δt = {} s", g3(d.dt))
                      : fmt::format(", Δt = {} × the stable limit", g3(d.dt_safety));
  std::string cont;
  const std::string integ = f.continuum.present && !f.continuum.integrator.empty()
                                ? f.continuum.integrator
                                : co.integrator;
  if (integ == "explicit")
    cont = fmt::format("explicit central differences, lumped mass{}",
                       f.continuum.present
                           ? fmt::format(", Δt = {} s ({}), {} steps", g3(f.continuum.dt),
                                         co.dt > 0.0 ? "continuum.dt"
                                                     : fmt::format("{} × the critical step",
                                                                   g3(co.explicit_safety)),
                                         f.continuum.substeps)
                           : std::string());
  else
    cont = fmt::format("implicit Newmark β = {}, γ = {}, Newton{}", g3(co.newmark_beta),
                       g3(co.newmark_gamma),
                       f.continuum.present ? fmt::format(", Δt = {} s, {} steps",
                                                         g3(f.continuum.dt), f.continuum.steps)
                                           : std::string());
  rows.push_back({"time integration", dem, cont,
                  "Each solver is stable at its own step; their convergence is measured by "
                  "'demfem study error-vs-time' on scenes with closed forms.",
                  false});
}

// Resolution.
void resolution(const DiffContext& x, std::vector<DiffRow>& rows) {
  const auto& [s, f, d, c, co, mc, g, dom, mesh, tol] = x;
  const double dm = mean_diameter(d);
  const double H = (f.calibration ? f.cal_surface : c.surface.value_or(dom.z1)) - dom.z0;
  std::string dem = fmt::format("{} disks, mean diameter {} m ({:.0f} across the soil's {} m "
                                "height)",
                                d.count, g3(dm), dm > 0.0 ? H / dm : 0.0, g3(H));
  std::string cont;
  const int deg_ = f.continuum.degree > 0 ? f.continuum.degree : co.degree;
  const int ref = f.continuum.refinement >= 0 ? f.continuum.refinement : co.refinement;
  cont = fmt::format("Q{} elements, refinement {}", deg_, ref);
  if (f.continuum.present && f.continuum.h_max > 0.0)
    cont += fmt::format(
        ": cells {}{} m ({:.0f} over the height), {} cells, {} dofs", g3(f.continuum.h_min),
        f.continuum.h_max > f.continuum.h_min * (1 + 1e-9) ? "–" + g3(f.continuum.h_max)
                                                           : std::string(),
        H / f.continuum.h_max, f.continuum.cells, f.continuum.dofs);
  std::string why = "The DEM resolves grains and force chains; the continuum smooths over its "
                    "cells.";
  if (f.kernel_width > 0.0)
    why += fmt::format(" DEM fields are coarse-grained with a kernel of support radius {} m "
                       "({:.1f} mean diameters) before they are compared.",
                       g3(f.kernel_width), dm > 0.0 ? f.kernel_width / dm : 0.0);
  rows.push_back({"resolution", dem, cont, why, false});
}
} // namespace

std::vector<DiffRow> model_differences(const scene::Scene& s, const ModelFacts& f) {
  std::vector<DiffRow> rows;
  if (!s.soil.dem || !s.soil.continuum) return rows;
  const auto& c = *s.soil.continuum;
  const Box mesh = box_of(s, true);
  const DiffContext x{.s = s,
                      .f = f,
                      .d = *s.soil.dem,
                      .c = c,
                      .co = s.continuum,
                      .mc = mohr_coulomb(c),
                      .g = s.load.gravity,
                      .dom = box_of(s, false),
                      .mesh = mesh,
                      .tol = 1e-6 * std::max(1.0, std::max(mesh.x1 - mesh.x0, mesh.z1 - mesh.z0))};
  // one writer per aspect, in the report's order
  using Aspect = void (*)(const DiffContext&, std::vector<DiffRow>&);
  for (const Aspect aspect :
       {soil_model, surface_and_mass, initial_stress, boundaries, structure_faces, damping,
        excitation, friction_changes, placements, time_integration, resolution})
    aspect(x, rows);
  return rows;
}

// ---- parameters --------------------------------------------------------------------------------

std::vector<ParamRow> model_parameters(const scene::Scene& s, const ModelFacts& f) {
  std::vector<ParamRow> rows;
  const std::string file =
      s.source_file.empty() ? "the scene" : fs::path(s.source_file).filename().string();
  const std::string stated = "scene (" + file + ", stated or its default)";
  if (s.soil.dem) {
    const auto& d = *s.soil.dem;
    auto add = [&](const std::string& k, const std::string& v) {
      rows.push_back({"DEM", k, v, stated});
    };
    add("soil.dem.count", std::to_string(d.count));
    std::string rad;
    switch (d.radius.kind) {
    case scene::RadiusDistribution::Kind::Uniform:
      rad = fmt::format("uniform {}–{} m", g3(d.radius.min), g3(d.radius.max));
      break;
    case scene::RadiusDistribution::Kind::Equal:
      rad = fmt::format("equal {} m", g3(d.radius.min));
      break;
    case scene::RadiusDistribution::Kind::Table:
      rad = fmt::format("table of {} radii", d.radius.table.size());
      break;
    }
    add("soil.dem.radius", rad);
    add("soil.dem.density", g4(d.density) + " kg/m³ (grains)");
    add("soil.dem.thickness", g3(d.thickness) + " m");
    const auto law = dem::contact::law_of(d);
    add("soil.dem.contact", law.keyword);
    for (const auto& t : scene::describe(law)) add("soil.dem." + t.key, t.value);
    add("soil.dem.mu_static / mu_dynamic", g3(d.mu_static) + " / " + g3(d.mu_dynamic));
    if (const auto rolling = dem::contact::rolling_of(d); rolling.written()) {
      add("soil.dem.rolling", rolling.keyword);
      for (const auto& t : scene::describe(rolling)) add("soil.dem." + t.key, t.value);
    }
    add("soil.dem.damping_c / damping_d", g3(d.damping_c) + " / " + g3(d.damping_d) + " 1/s");
    add("soil.dem.dt", d.dt > 0.0
                           ? g3(d.dt) + " s"
                           : fmt::format("automatic: {} × the stable limit{}", g3(d.dt_safety),
                                         f.dem.present ? " = " + g3(f.dem.dt) + " s" : ""));
    add("soil.dem.packing",
        fmt::format("{} placement, deposition damping {}, {}",
                    scene::keyword(scene::kPlacementNames, d.packing.placement),
                    g3(d.packing.damping),
                    d.packing.target_porosity
                        ? fmt::format("target porosity {:.4f}", *d.packing.target_porosity)
                        : "no density target"));
    if (f.packing && d.particles.empty())
      rows.push_back({"DEM", "porosity of the deposited bed",
                      fmt::format("{:.4f}", f.packing_porosity), "measured: dem/packing.json"});
  }
  for (const auto& w : s.walls)
    if ((w.mu_static || w.mu_dynamic) && s.soil.dem)
      rows.push_back({"DEM", "wall." + w.name + ".mu",
                      boundary_friction(w.mu_static, w.mu_dynamic, *s.soil.dem), stated});
  for (const auto& st : s.structures)
    if ((st.mu_static || st.mu_dynamic) && s.soil.dem)
      rows.push_back({"DEM", "structure." + st.name + ".mu",
                      boundary_friction(st.mu_static, st.mu_dynamic, *s.soil.dem), stated});
  if (s.soil.continuum) {
    const auto& c = *s.soil.continuum;
    auto add = [&](const char* key, const std::string& v) {
      std::string prov;
      if (const auto* p = provenance(c, key))
        prov = (calibrated(c, key) ? "calibrated from the DEM — " : "") + *p;
      else if (given(c, key))
        prov = "stated in the scene";
      else
        prov = "default";
      rows.push_back({"continuum", std::string("soil.continuum.") + key, v, prov});
    };
    rows.push_back(
        {"continuum", "soil.continuum.model", cst::soil_model(c).keyword, "scene (" + file + ")"});
    const auto& el = cst::elastic_block(c);
    const auto& st = cst::strength_block(c);
    if (cst::soil_model(c).chosen_uses(cst::Elastic::Parameters::kName)) {
      add("young", pa(el.young));
      if (el.modulus_exponent != 0.0) {
        add("modulus_exponent", g3(el.modulus_exponent));
        if (!std::isnan(el.modulus_reference_stress))
          add("modulus_reference_stress", pa(el.modulus_reference_stress));
      }
      add("poisson", fmt::format("{:.3f}", el.poisson));
    }
    if (mohr_coulomb(c)) {
      add("friction_angle", deg(st.friction_angle));
      add("cohesion", pa(st.cohesion));
      add("dilation_angle", deg(st.dilation_angle));
      if (!std::isnan(st.dilation_cutoff)) add("dilation_cutoff", g3(st.dilation_cutoff));
    } else if (!soil_is(c, cst::Elastic::keyword)) { // another model: the keys of its blocks
      for (const auto& p : scene::describe(cst::soil_model(c)))
        if (p.key != "young" && p.key != "poisson" && p.key.rfind("modulus_", 0) != 0)
          add(p.key.c_str(), p.value);
    }
    add("density", g4(c.density) + " kg/m³ (bulk)");
    add("k0", c.k0 >= 0.0 ? fmt::format("{:.3f}", c.k0)
                          : fmt::format("{:.3f} (Jaky 1 − sin φ)", cst::soil_k0(c)));
    add("surface", c.surface ? g4(*c.surface) + " m" : std::string("(none: the domain's top)"));
    for (const auto& [name, dz] : c.structure_offsets) {
      const std::string key = "structure." + name + ".base";
      const auto* p = provenance(c, key);
      rows.push_back({"continuum", key, fmt::format("{:+.3g} m", dz),
                      p ? "calibrated from the DEM — " + *p : "calibration"});
    }
    const auto& co = s.continuum;
    const std::string cs = "scene [continuum] (stated or its default)";
    const int ref = f.continuum.refinement >= 0 ? f.continuum.refinement : co.refinement;
    const int dg = f.continuum.degree > 0 ? f.continuum.degree : co.degree;
    rows.push_back(
        {"continuum", "continuum.refinement / degree", fmt::format("{} / {}", ref, dg),
         ref != co.refinement || dg != co.degree ? "command line (--refinement/--degree)" : cs});
    rows.push_back({"continuum", "continuum.integrator", co.integrator, cs});
    rows.push_back({"continuum", "continuum.dt",
                    co.dt > 0.0 ? g3(co.dt) + " s"
                                : "automatic" + (f.continuum.present && f.continuum.dt > 0.0
                                                     ? " = " + g3(f.continuum.dt) + " s"
                                                     : std::string()),
                    cs});
    rows.push_back({"continuum", "continuum.interface",
                    co.interface == "frictional"
                        ? fmt::format("frictional, δ = {}", deg(co.interface_friction_angle))
                        : co.interface,
                    cs});
    const std::string* rayleigh = provenance(c, "continuum.rayleigh");
    rows.push_back({"continuum", "continuum.rayleigh_alpha / rayleigh_beta",
                    g3(co.rayleigh_alpha) + " 1/s / " + g3(co.rayleigh_beta) + " s",
                    rayleigh             ? "calibrated from the DEM — " + *rayleigh
                    : co.rayleigh_stated ? "stated in the scene"
                                         : cs});
    if (co.integrator == "explicit")
      rows.push_back({"continuum", "continuum.local_damping", g3(co.local_damping), cs});
    rows.push_back({"continuum", "continuum.bbar", co.bbar ? "on" : "off", cs});
    rows.push_back({"continuum", "continuum.seat_structures",
                    co.seat_structures ? (*co.seat_structures ? "true" : "false")
                                       : "absent (embedded fixed-z structures)",
                    cs});
  }
  return rows;
}

} // namespace demfem::compare
