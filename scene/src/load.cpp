#include "demfem/scene/load.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <string_view>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <toml++/toml.h>

#include "demfem/scene/names.hpp"
#include "demfem/scene/particles_file.hpp"
#include "demfem/scene/probe_spec.hpp"
#include "demfem/scene/reader.hpp"
#include "validate_internal.hpp"

namespace demfem::scene {

std::string Diagnostic::format() const {
  std::string where = file;
  if (line > 0) where += fmt::format(":{}:{}", line, column);
  const char* what = warning ? "warning" : "error";
  if (key.empty()) return fmt::format("{}: {}: {}", where, what, message);
  return fmt::format("{}: {}: {}: {}", where, what, key, message);
}

namespace {
std::string join_diagnostics(const std::vector<Diagnostic>& d) {
  std::string s;
  for (const auto& x : d) {
    if (!s.empty()) s += '\n';
    s += x.format();
  }
  return s;
}
} // namespace

SceneError::SceneError(std::vector<Diagnostic> diagnostics)
    : std::runtime_error(join_diagnostics(diagnostics)), diagnostics_(std::move(diagnostics)) {}

std::vector<std::string> SceneFile::variant_names() const {
  std::vector<std::string> names;
  for (const auto& v : variants) names.push_back(v.variant);
  return names;
}

const Scene& SceneFile::select(const std::string& variant) const {
  if (variant.empty()) return base;
  for (const auto& v : variants)
    if (v.variant == variant) return v;
  const auto names = variant_names();
  throw SceneError({Diagnostic{
      path, 0, 0, "variant",
      names.empty() ? fmt::format("no variant '{}': the file defines no [[variant]]", variant)
                    : fmt::format("no variant '{}'; valid: {}", variant, fmt::join(names, ", "))}});
}

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// ---- time functions ----------------------------------------------------------------------------
std::optional<TimeFunction> read_time_function(Reader& parent, std::string_view key);

TimeFunction time_function_from_table(Reader& r) {
  static const std::vector<std::string> kTypes = {"constant", "ramp",  "sine",
                                                  "t-sine",   "table", "sum"};
  TimeFunction f;
  const std::string type = r.string("type", "");
  if (type.empty()) {
    r.error_here(fmt::format("a time function needs 'type'; valid: {}", fmt::join(kTypes, ", ")));
    return f;
  }
  std::vector<std::string> valid{"type"};
  if (type == "constant") {
    f = TimeFunction::constant(r.required_number("value"));
    valid.push_back("value");
  } else if (type == "ramp") {
    f = TimeFunction::ramp(r.required_number("rate"), r.number("offset", 0.0),
                           r.non_negative("start", 0.0));
    f.stop = r.non_negative("stop", 0.0);
    valid.insert(valid.end(), {"rate", "offset", "start", "stop"});
  } else if (type == "sine") {
    f = TimeFunction::sine(r.required_number("amplitude"), r.positive("frequency", 1.0, true),
                           r.number("phase", 0.0), r.non_negative("start", 0.0));
    f.stop = r.non_negative("stop", 0.0);
    valid.insert(valid.end(), {"amplitude", "frequency", "phase", "start", "stop"});
  } else if (type == "t-sine") {
    const double a = r.required_number("amplitude");
    double omega = 0.0;
    if (r.has("omega") == r.has("frequency"))
      r.error_here("t-sine needs exactly one of 'omega' [rad/s] or 'frequency' [Hz]");
    if (r.has("omega")) omega = r.positive("omega", 1.0);
    if (r.has("frequency")) omega = 2.0 * std::numbers::pi * r.positive("frequency", 1.0);
    f = TimeFunction::t_sine(a, omega);
    valid.insert(valid.end(), {"amplitude", "omega", "frequency"});
  } else if (type == "table") {
    const auto pts = r.points("points", 1);
    std::vector<std::pair<double, double>> tab;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      if (i > 0 && !(pts[i].x > pts[i - 1].x)) {
        r.error("points", fmt::format("times must increase strictly; point {} has t = {} after {}",
                                      i, pts[i].x, pts[i - 1].x));
        break;
      }
      tab.emplace_back(pts[i].x, pts[i].z);
    }
    if (!r.has("points")) r.error_here("table needs 'points' = [[t, value], …]");
    f = TimeFunction::piecewise(std::move(tab));
    valid.push_back("points");
  } else if (type == "sum") {
    const toml::node* n = r.node("terms");
    std::vector<TimeFunction> terms;
    if (!n || !n->is_array()) {
      r.error_here("sum needs 'terms' = [ {type = …}, … ]");
    } else {
      const auto& arr = *n->as_array();
      for (std::size_t i = 0; i < arr.size(); ++i) {
        const auto* t = arr[i].as_table();
        if (!t) {
          r.error_at(arr[i].source(), fmt::format("{}.terms[{}]", r.path(), i),
                     "each term must be a time function table {type = …}");
          continue;
        }
        Reader sub(*t, fmt::format("{}.terms[{}]", r.path(), i), r.file(), r.diags(), t->source());
        terms.push_back(time_function_from_table(sub));
      }
    }
    f = TimeFunction::sum(std::move(terms));
    valid.push_back("terms");
  } else {
    r.error("type",
            fmt::format("unknown time function '{}'; valid: {}", type, fmt::join(kTypes, ", ")));
    return f;
  }
  r.finish(valid);
  return f;
}

std::optional<TimeFunction> read_time_function(Reader& parent, std::string_view key) {
  const toml::node* n = parent.node(key);
  if (!n) return std::nullopt;
  if (n->is_number()) {
    const double v = n->value<double>().value_or(0.0);
    if (!std::isfinite(v)) {
      parent.error(key, "must be a finite number");
      return std::nullopt;
    }
    return TimeFunction::constant(v);
  }
  if (const auto* t = n->as_table()) {
    Reader r(*t, parent.key_path(key), parent.file(), parent.diags(), t->source());
    return time_function_from_table(r);
  }
  parent.error(key, fmt::format("expected a number or a time function table {{type = …}}, got {}",
                                Reader::type_name(*n)));
  return std::nullopt;
}

// ---- sections ----------------------------------------------------------------------------------
template <typename Enum, std::size_t N>
Enum read_enum(Reader& r, std::string_view key, const std::array<const char*, N>& names, Enum def) {
  if (auto i = r.keyword(key, names)) return static_cast<Enum>(*i);
  return def;
}

RadiusDistribution read_radius(Reader& parent) {
  RadiusDistribution d;
  const toml::node* n = parent.node("radius");
  if (!n) {
    parent.error_here("missing required key 'radius' ({uniform = [min, max]}, {equal = r} or "
                      "{table = [[r, weight], …]})");
    return d;
  }
  const auto* t = n->as_table();
  if (!t || t->size() != 1) {
    parent.error("radius", "expected exactly one of {uniform = [min, max]}, {equal = r}, "
                           "{table = [[r, weight], …]}");
    return d;
  }
  Reader r(*t, parent.key_path("radius"), parent.file(), parent.diags(), t->source());
  if (r.has("uniform")) {
    const auto pts = r.node("uniform");
    const auto* a = pts->as_array();
    if (!a || a->size() != 2 || !(*a)[0].is_number() || !(*a)[1].is_number()) {
      r.error("uniform", "expected [min, max] radii in metres");
      return d;
    }
    d.kind = RadiusDistribution::Kind::Uniform;
    d.min = (*a)[0].value<double>().value_or(0);
    d.max = (*a)[1].value<double>().value_or(0);
    if (!(d.min > 0.0) || !(d.max >= d.min) || !std::isfinite(d.max))
      r.error("uniform",
              fmt::format("radii must satisfy 0 < min ≤ max, got [{}, {}]", d.min, d.max));
  } else if (r.has("equal")) {
    d.kind = RadiusDistribution::Kind::Equal;
    d.min = d.max = r.positive("equal", 1.0);
  } else if (r.has("table")) {
    d.kind = RadiusDistribution::Kind::Table;
    for (const auto& p : r.points("table", 1)) {
      if (!(p.x > 0.0) || !(p.z >= 0.0))
        r.error("table", fmt::format("each entry [radius, weight] needs radius > 0 and weight ≥ 0, "
                                     "got [{}, {}]",
                                     p.x, p.z));
      d.table.emplace_back(p.x, p.z);
    }
    if (!d.table.empty()) {
      d.min = d.max = d.table.front().first;
      for (const auto& [rad, w] : d.table) {
        d.min = std::min(d.min, rad);
        d.max = std::max(d.max, rad);
      }
    }
  }
  r.finish({"uniform", "equal", "table"});
  return d;
}

DemSoil read_dem_soil(Reader& r, const Vocabulary& vocabulary) {
  DemSoil s;
  s.count = r.integer("count", 0, 1, 100'000'000);
  if (!r.has("count") && !r.has("particles_file"))
    r.error_here("missing required key 'count' (number of particles)");
  s.radius = read_radius(r);
  s.density = r.positive("density", s.density);
  s.thickness = r.positive("thickness", s.thickness);
  s.mu_static = r.non_negative("mu_static", s.mu_static);
  s.mu_dynamic = r.non_negative("mu_dynamic", s.mu_dynamic);
  if (s.mu_dynamic > s.mu_static)
    r.error("mu_dynamic", fmt::format("dynamic friction {} exceeds static friction {}; need "
                                      "mu_dynamic ≤ mu_static",
                                      s.mu_dynamic, s.mu_static));
  std::vector<std::string> slot_keys; // the models' keys (params.hpp), for finish()
  for (const auto& slot : vocabulary.dem) s.models.push_back(read_model(r, slot, slot_keys));
  s.damping_c = r.non_negative("damping_c", s.damping_c);
  s.damping_d = r.non_negative("damping_d", s.damping_d);
  s.dt = r.non_negative("dt", s.dt);
  s.dt_safety = r.in_range("dt_safety", s.dt_safety, 1e-6, 1.0);
  s.max_overlap = r.in_range("max_overlap", s.max_overlap, 1e-6, 2.0);
  s.energy_warning = r.non_negative("energy_warning", s.energy_warning);
  s.energy_limit = r.non_negative("energy_limit", s.energy_limit);
  s.fill = r.polygon("fill", false);
  if (const auto* pt = r.table("packing")) {
    Reader p(*pt, r.key_path("packing"), r.file(), r.diags(), pt->source());
    s.packing.ke_ratio = p.positive("ke_ratio", s.packing.ke_ratio);
    s.packing.max_time = p.positive("max_time", s.packing.max_time);
    s.packing.damping = p.non_negative("damping", s.packing.damping);
    s.packing.cache = p.string("cache", s.packing.cache);
    s.packing.placement = read_enum(p, "placement", kPlacementNames, s.packing.placement);
    if (const toml::node* tn = p.node("target")) {
      if (const auto* str = tn->as_string()) {
        if (str->get() != "none")
          p.error("target", fmt::format("expected \"none\" or a table {{ porosity = n }} / "
                                        "{{ void_ratio = e }}, got \"{}\"",
                                        str->get()));
      } else if (const auto* tt = tn->as_table()) {
        Reader t(*tt, p.key_path("target"), p.file(), p.diags(), tt->source());
        if (t.has("porosity") == t.has("void_ratio")) {
          t.error_here("give exactly one of porosity (0 < n < 1) or void_ratio (e > 0)");
        } else if (t.has("porosity")) {
          s.packing.target_porosity = t.in_range("porosity", 0.2, 0.01, 0.9);
        } else {
          const double e = t.positive("void_ratio", 0.25);
          s.packing.target_porosity = e / (1.0 + e); // n = e / (1 + e)
          s.packing.target_as_void_ratio = true;
        }
        s.packing.target_tolerance = t.in_range("tolerance", s.packing.target_tolerance, 1e-4, 0.1);
        t.finish({"porosity", "void_ratio", "tolerance"});
      } else {
        p.error("target", "expected \"none\" or a table { porosity = n } / { void_ratio = e }");
      }
    }
    p.finish({"ke_ratio", "max_time", "damping", "cache", "target", "placement"});
  }
  if (const toml::node* n = r.node("particles")) {
    const auto* a = n->as_array();
    if (!a) r.error("particles", "expected a list [[x, z, r], …] or [[x, z, r, vx, vz, omega], …]");
    for (std::size_t i = 0; a && i < a->size(); ++i) {
      const auto* e = (*a)[i].as_array();
      std::array<double, 6> q{};
      bool ok = e && (e->size() == 3 || e->size() == 6);
      for (std::size_t k = 0; ok && k < e->size(); ++k) {
        if (!(*e)[k].is_number())
          ok = false;
        else
          q[k] = (*e)[k].value<double>().value_or(0.0);
      }
      if (ok && !(q[2] > 0.0)) ok = false;
      if (!ok)
        r.error_at((*a)[i].source(), fmt::format("{}[{}]", r.key_path("particles"), i),
                   "expected [x, z, r] or [x, z, r, vx, vz, omega] with r > 0");
      else
        s.particles.push_back(q);
    }
    if (a && static_cast<std::size_t>(s.count) != a->size())
      r.error("particles",
              fmt::format("count = {} but {} particles are listed", s.count, a->size()));
  }
  if (const auto pf = r.opt_string("particles_file")) {
    if (r.has("particles"))
      r.error("particles_file", "give either 'particles' (inline list) or 'particles_file', not "
                                "both");
    std::filesystem::path path(*pf);
    if (path.is_relative()) path = std::filesystem::path(r.file()).parent_path() / path;
    std::error_code ec;
    if (pf->empty() || !std::filesystem::is_regular_file(path, ec)) {
      r.error("particles_file",
              fmt::format("cannot open particle file '{}' (resolved relative to the scene "
                          "file's directory: '{}'); give an existing .csv or .npy file",
                          *pf, path.string()));
    } else {
      s.particles_file = std::filesystem::absolute(path, ec).lexically_normal().string();
      const std::size_t before = r.diags().size();
      s.particles = read_particles_file(path, r.key_path("particles_file"), r.diags());
      if (const std::size_t n = r.diags().size() - before; n > 0) {
        // where the scene names the file, before the file's own problems
        r.error("particles_file", fmt::format("the particle file '{}' is refused ({} problem(s) "
                                              "in it, listed next)",
                                              *pf, n));
        std::rotate(r.diags().begin() + static_cast<std::ptrdiff_t>(before),
                    std::prev(r.diags().end()), r.diags().end());
      }
      if (r.has("count") && !s.particles.empty() &&
          static_cast<std::size_t>(s.count) != s.particles.size())
        r.error("count", fmt::format("count = {} but {} holds {} particles; give count = {} or "
                                     "leave count out",
                                     s.count, *pf, s.particles.size(), s.particles.size()));
      if (!r.has("count")) s.count = static_cast<int>(s.particles.size());
    }
  }
  if (const auto pm = r.opt_string("particle_mass")) {
    if (*pm == "sphere")
      s.sphere_mass = true;
    else if (*pm != "disk")
      r.error("particle_mass",
              fmt::format("unknown mass convention '{}'; valid: disk, sphere", *pm));
  }
  std::vector<std::string> valid{
      "count",        "radius",    "density", "thickness", "mu_static",      "mu_dynamic",
      "damping_c",    "damping_d", "dt",      "dt_safety", "max_overlap",    "energy_warning",
      "energy_limit", "fill",      "packing", "particles", "particles_file", "particle_mass"};
  valid.insert(valid.begin() + 6, slot_keys.begin(), slot_keys.end()); // after the friction
  r.finish(valid);
  return s;
}

// The value of a number key of a choice's blocks; NaN when no block has it or it is unset.
double number_of(const ModelChoice& choice, std::string_view key) {
  class Get final : public ParamVisitor {
  public:
    explicit Get(std::string_view k) : wanted(k) {}
    std::string_view wanted;
    double value = std::numeric_limits<double>::quiet_NaN();
    void number(const Field& f, double& v, Rule) override {
      if (f.key == wanted) value = v;
    }
    void integer(const Field&, int&, int, int) override {}
    void flag(const Field&, bool&) override {}
    void text(const Field&, std::string&) override {}
  } get(key);
  for (const auto& b : choice.blocks) b.visit(get);
  return get.value;
}

ContinuumSoil read_continuum_soil(Reader& r, const Vocabulary& vocabulary) {
  ContinuumSoil s;
  // the constitutive model and its keys (young, poisson, friction_angle, …), which its parameter
  // blocks own (continuum/constitutive/)
  std::vector<std::string> valid;
  for (const ModelSlot& slot : vocabulary.continuum) s.models.push_back(read_model(r, slot, valid));
  s.density = r.positive("density", s.density);
  s.k0 = r.number("k0", s.k0);
  s.surface = r.opt_number("surface");
  if (const auto cal = r.opt_string("calibrate")) {
    if (*cal == "dem")
      s.calibrate_dem = true;
    else if (*cal != "none")
      r.error("calibrate", fmt::format("unknown calibration '{}'; valid: \"dem\" (parameters from "
                                       "`demfem calibrate`) or \"none\"",
                                       *cal));
  }
  // E = young (p/p_ref)^n needs p_ref; a calibrated soil gets both from the calibration
  for (const auto& m : s.models) {
    const double n = number_of(m, "modulus_exponent");
    if (!std::isnan(n) && n != 0.0 && std::isnan(number_of(m, "modulus_reference_stress")) &&
        !s.calibrate_dem)
      r.error("modulus_exponent",
              "a stress-dependent modulus (modulus_exponent > 0) needs modulus_reference_stress "
              "[Pa], the mean stress at which `young` holds (or calibrate = \"dem\")");
  }
  for (const std::string& k : valid)
    if (r.has(k)) s.given.push_back(k);
  for (const char* k : {"density", "k0", "surface"})
    if (r.has(k)) s.given.emplace_back(k);
  // Written by the resolved dump (where each calibrated value came from); informational.
  if (const auto* pv = r.table("provenance"))
    for (auto&& [k, v] : *pv)
      s.provenance.emplace_back(std::string(k.str()), v.value<std::string>().value_or(""));
  for (const char* k : {"density", "k0", "surface", "calibrate", "provenance"})
    valid.emplace_back(k);
  r.finish(valid);
  return s;
}

ContinuumOptions read_continuum_options(Reader& r) {
  ContinuumOptions o;
  o.refinement = r.integer("refinement", o.refinement, 0, 12);
  o.degree = r.integer("degree", o.degree, 1, 4);
  o.mesh_size_near = r.non_negative("mesh_size_near", o.mesh_size_near);
  o.mesh_grading = r.in_range("mesh_grading", o.mesh_grading, 1.0, 3.0);
  o.bbar = r.boolean("bbar", o.bbar);
  o.dt = r.non_negative("dt", o.dt);
  if (const toml::node* n = r.node("dt")) { // kept for the explicit step check (validate.hpp)
    o.dt_line = static_cast<int>(n->source().begin.line);
    o.dt_column = static_cast<int>(n->source().begin.column);
  }
  o.newmark_beta = r.in_range("newmark_beta", o.newmark_beta, 0.0, 0.5);
  o.newmark_gamma = r.in_range("newmark_gamma", o.newmark_gamma, 0.0, 1.0);
  o.rayleigh_alpha = r.non_negative("rayleigh_alpha", o.rayleigh_alpha);
  o.rayleigh_beta = r.non_negative("rayleigh_beta", o.rayleigh_beta);
  o.rayleigh_stated = r.has("rayleigh_alpha") || r.has("rayleigh_beta");
  o.absorbing = r.boolean("absorbing", o.absorbing);
  o.linear_solver = r.string("linear_solver", o.linear_solver);
  if (o.linear_solver != "cg-amg" && o.linear_solver != "gmres-amg" && o.linear_solver != "direct")
    r.error("linear_solver",
            fmt::format("unknown solver '{}'; valid: cg-amg, gmres-amg, direct", o.linear_solver));
  o.interface = r.string("interface", o.interface);
  if (o.interface != "tied" && o.interface != "frictional" && o.interface != "coulomb")
    r.error("interface",
            fmt::format("unknown interface '{}'; valid: tied, frictional, coulomb", o.interface));
  o.structure_interface = r.string("structure_interface", o.structure_interface);
  if (o.structure_interface != "contact" && o.structure_interface != "tied")
    r.error("structure_interface",
            fmt::format("unknown structure_interface '{}'; valid: contact, tied",
                        o.structure_interface));
  o.interface_friction_angle =
      r.in_range("interface_friction_angle", o.interface_friction_angle / kDeg, 0.0, 89.0) * kDeg;
  o.load_steps = r.integer("load_steps", o.load_steps, 1, 100000);
  o.newton_tolerance = r.positive("newton_tolerance", o.newton_tolerance);
  o.newton_max_iterations = r.integer("newton_max_iterations", o.newton_max_iterations, 1, 1000);
  o.max_displacement = r.non_negative("max_displacement", o.max_displacement);
  o.integrator = r.string("integrator", o.integrator);
  if (o.integrator != "implicit" && o.integrator != "explicit")
    r.error("integrator",
            fmt::format("unknown integrator '{}'; valid: implicit, explicit", o.integrator));
  if (o.interface == "coulomb" && o.integrator != "explicit")
    r.error("interface", fmt::format("interface = \"coulomb\" (zero-thickness Coulomb contact "
                                     "with the walls and fixed structures) needs integrator = "
                                     "\"explicit\", got \"{}\"; valid with \"{}\": tied, "
                                     "frictional",
                                     o.integrator, o.integrator));
  o.explicit_safety = r.in_range("explicit_safety", o.explicit_safety, 0.01, 1.0);
  o.local_damping = r.in_range("local_damping", o.local_damping, 0.0, 1.0);
  if (r.has("seat_structures")) o.seat_structures = r.boolean("seat_structures", true);
  r.finish({"integrator",
            "explicit_safety",
            "local_damping",
            "refinement",
            "degree",
            "mesh_size_near",
            "mesh_grading",
            "bbar",
            "dt",
            "newmark_beta",
            "newmark_gamma",
            "rayleigh_alpha",
            "rayleigh_beta",
            "absorbing",
            "linear_solver",
            "interface",
            "structure_interface",
            "interface_friction_angle",
            "load_steps",
            "newton_tolerance",
            "newton_max_iterations",
            "max_displacement",
            "seat_structures"});
  return o;
}

std::optional<double> friction_opt(Reader& r, std::string_view key) {
  const auto v = r.opt_number(key);
  if (v && *v < 0.0) r.error(key, fmt::format("friction must be ≥ 0, got {}", *v));
  return v;
}

Wall read_wall(Reader& r) {
  Wall w;
  w.name = r.string("name", "");
  if (w.name.empty()) r.error_here("every [[wall]] needs a 'name'");
  if (const auto why = part_name_problem(w.name)) r.error("name", *why);
  w.points = r.points("points", 2);
  if (!r.has("points")) r.error_here("missing required key 'points' (a polyline [[x, z], …])");
  w.mu_static = friction_opt(r, "mu_static");
  w.mu_dynamic = friction_opt(r, "mu_dynamic");
  if (r.has("opens_at")) w.opens_at = r.non_negative("opens_at", 0.0);
  w.record = r.boolean("record", w.record);
  r.finish({"name", "points", "mu_static", "mu_dynamic", "opens_at", "record"});
  return w;
}

Structure read_structure(Reader& r, const DemSoil* dem) {
  Structure s;
  s.name = r.string("name", "");
  if (s.name.empty()) r.error_here("every [[structure]] needs a 'name'");
  if (const auto why = part_name_problem(s.name)) r.error("name", *why);
  s.kind = read_enum(r, "kind", kStructureKindNames, s.kind);
  const std::string shape = r.string("shape", "rectangle");
  std::vector<std::string> valid{"name", "kind", "shape"};
  if (shape == "rectangle") {
    s.width = r.positive("width", 1.0, true);
    s.height = r.positive("height", 1.0, true);
    s.base_centre = r.point("base").value_or(Vec2{});
    if (!r.has("base")) r.error_here("rectangle needs 'base' = [x, z], the centre of its base");
    const double hw = 0.5 * s.width;
    const auto b = s.base_centre;
    s.outline = {
        {b.x - hw, b.z}, {b.x + hw, b.z}, {b.x + hw, b.z + s.height}, {b.x - hw, b.z + s.height}};
    valid.insert(valid.end(), {"width", "height", "base"});
  } else if (shape == "segment") {
    // A thin wall: a rectangle of the given thickness behind the segment's right-hand side.
    const auto a = r.point("from");
    const auto b = r.point("to");
    const double th = r.positive("thickness", 0.1);
    if (!a || !b) {
      r.error_here("segment needs 'from' = [x, z] and 'to' = [x, z]");
    } else {
      const double dx = b->x - a->x, dz = b->z - a->z, len = std::hypot(dx, dz);
      if (!(len > 0.0)) {
        r.error("to", "segment has zero length");
      } else {
        const double nx = dz / len * th, nz = -dx / len * th; // right-hand normal
        s.outline = {*a, {a->x + nx, a->z + nz}, {b->x + nx, b->z + nz}, *b};
        if (signed_area(s.outline) < 0) std::reverse(s.outline.begin(), s.outline.end());
        s.width = th;
        s.height = len;
        s.base_centre = {0.5 * (a->x + a->x + nx), 0.5 * (a->z + a->z + nz)};
      }
    }
    valid.insert(valid.end(), {"from", "to", "thickness"});
  } else if (shape == "polygon") {
    s.outline = r.polygon("polygon", true);
    if (!s.outline.empty()) {
      double xmin = s.outline[0].x, xmax = xmin, zmin = s.outline[0].z, zmax = zmin;
      for (const auto& p : s.outline) {
        xmin = std::min(xmin, p.x);
        xmax = std::max(xmax, p.x);
        zmin = std::min(zmin, p.z);
        zmax = std::max(zmax, p.z);
      }
      s.width = xmax - xmin;
      s.height = zmax - zmin;
      s.base_centre = {0.5 * (xmin + xmax), zmin};
    }
    valid.push_back("polygon");
  } else {
    r.error("shape", fmt::format("unknown shape '{}'; valid: rectangle, segment, polygon", shape));
  }
  s.density = r.positive("density", s.density);
  s.mass = r.non_negative("mass", s.mass);
  s.inertia = r.non_negative("inertia", s.inertia);
  s.pivot = r.point("pivot").value_or(s.base_centre);
  s.dof_x = read_enum(r, "dof_x", kDofModeNames, s.dof_x);
  s.dof_z = read_enum(r, "dof_z", kDofModeNames, s.dof_z);
  s.dof_rotation = read_enum(r, "dof_rotation", kDofModeNames, s.dof_rotation);
  auto tf = [&](std::string_view key, TimeFunction& into) {
    if (auto f = read_time_function(r, key)) into = *f;
  };
  tf("motion_x", s.motion_x);
  tf("motion_z", s.motion_z);
  tf("motion_rotation", s.motion_rotation);
  tf("force_x", s.force_x);
  tf("force_z", s.force_z);
  tf("moment", s.moment);
  s.load_point = r.point("load_point").value_or(Vec2{s.base_centre.x, s.base_centre.z + s.height});
  s.dead_weight = r.boolean("dead_weight", s.dead_weight);
  s.mu_static = friction_opt(r, "mu_static");
  s.mu_dynamic = friction_opt(r, "mu_dynamic");
  if (const toml::node* n = r.node("record")) {
    static const std::vector<std::string> kRecord = {"thrust", "pressure-profile", "motion"};
    if (const auto* a = n->as_array()) {
      for (const auto& e : *a) {
        const auto v = e.value<std::string>();
        if (!v || std::find(kRecord.begin(), kRecord.end(), *v) == kRecord.end())
          r.error_at(e.source(), r.key_path("record"),
                     fmt::format("unknown record '{}'; valid: {}", v.value_or("?"),
                                 fmt::join(kRecord, ", ")));
        else
          s.record.push_back(*v);
      }
    } else {
      r.error("record", "expected a list of strings");
    }
  }
  (void)dem;
  valid.insert(valid.end(),
               {"density", "mass", "inertia", "pivot", "dof_x", "dof_z", "dof_rotation", "motion_x",
                "motion_z", "motion_rotation", "force_x", "force_z", "moment", "load_point",
                "dead_weight", "mu_static", "mu_dynamic", "record"});
  r.finish(valid);
  return s;
}

Load read_load(Reader& r) {
  Load l;
  l.gravity = r.non_negative("gravity", l.gravity);
  if (const auto* st = r.table("shaking")) {
    Reader s(*st, r.key_path("shaking"), r.file(), r.diags(), st->source());
    Shaking sh;
    const std::string dir = s.string("direction", "x");
    if (dir != "x" && dir != "z")
      s.error("direction", fmt::format("must be \"x\" or \"z\", got \"{}\"", dir));
    sh.direction = dir == "z" ? 'z' : 'x';
    // body force m·A·sin(2πft) (paper §6)
    sh.acceleration =
        TimeFunction::sine(s.number("amplitude", 0.0), s.positive("frequency", 1.0, true),
                           s.number("phase", 0.0), s.non_negative("start", 0.0));
    sh.acceleration.stop = s.non_negative("stop", 0.0);
    if (!s.has("amplitude")) s.error_here("shaking needs 'amplitude' [m/s²] (1 gal = 0.01 m/s²)");
    s.finish({"direction", "amplitude", "frequency", "phase", "start", "stop"});
    l.shaking = sh;
  }
  r.finish({"gravity", "shaking"});
  return l;
}

// A [[probe]]: the keys its kind takes (probe_spec.hpp); a key it does not take is refused.
Probe read_probe(Reader& r) {
  Probe p;
  if (const toml::node* n = r.node("kind"); n && n->value<std::string>() == "structure") {
    r.error("kind", "there is no probe kind 'structure': structures.csv records every structure "
                    "(settlement, rotation, moment, soil forces) at output.probe_interval in both "
                    "solvers; delete this [[probe]] (for a wall's thrust: kind = \"wall-thrust\")");
    for (const char* k : {"target", "interval", "bins", "points"}) r.mark_used(k);
    return p;
  }
  p.kind = read_enum(r, "kind", kProbeKindNames, p.kind);
  if (!r.has("kind"))
    r.error_here(
        fmt::format("every [[probe]] needs 'kind'; valid: {}", fmt::join(kProbeKindNames, ", ")));
  const ProbeSpec& spec = probe_spec(p.kind);
  std::vector<std::string> keys{"kind", "interval"};
  p.interval = r.non_negative("interval", 0.0);
  if (spec.target) {
    p.target = r.string("target", "");
    keys.emplace_back("target");
  }
  if (spec.bins) {
    p.bins = r.integer("bins", p.bins, 1, 100000);
    keys.emplace_back("bins");
  }
  if (spec.points) {
    p.points = r.points("points", 0);
    keys.emplace_back("points");
  }
  for (const char* k : {"target", "bins", "points"})
    if (r.has(k) && std::find(keys.begin(), keys.end(), k) == keys.end()) {
      r.error(k, fmt::format("{} {} probe takes no '{}' (it would have no effect); its keys: {}",
                             p.kind == ProbeKind::Energy ? "an" : "a",
                             keyword(kProbeKindNames, p.kind), k, fmt::join(keys, ", ")));
      r.mark_used(k);
    }
  r.finish(keys);
  return p;
}

Scene resolve(const toml::table& root, const std::string& file, const Vocabulary& vocabulary,
              std::vector<Diagnostic>& diags) {
  const std::size_t diags_before = diags.size();
  Scene sc;
  sc.source_file = file;
  Reader top(root, "", file, diags, root.source());
  top.mark_used("variant");

  if (const auto* t = top.table("scene")) {
    Reader r(*t, "scene", file, diags, t->source());
    sc.info.name = r.string("name", "");
    if (sc.info.name.empty())
      r.error_here("missing required key 'name'");
    else if (const auto why = name_problem(sc.info.name))
      r.error("name", *why);
    sc.info.description = r.string("description", "");
    sc.info.duration = r.positive("duration", sc.info.duration, true);
    sc.info.seed = static_cast<unsigned long>(r.integer("seed", 1, 0, 2147483647));
    if (const toml::node* n = r.node("solvers")) {
      sc.info.solvers.clear();
      const auto* a = n->as_array();
      if (!a || a->empty())
        r.error("solvers", "expected a non-empty list: [\"dem\"], [\"continuum\"] or both");
      else
        for (const auto& e : *a) {
          const auto v = e.value<std::string>();
          if (v == "dem")
            sc.info.solvers.push_back(Solver::Dem);
          else if (v == "continuum")
            sc.info.solvers.push_back(Solver::Continuum);
          else
            r.error_at(e.source(), "scene.solvers",
                       fmt::format("unknown solver '{}'; valid: dem, continuum", v.value_or("?")));
        }
    }
    r.finish({"name", "description", "duration", "seed", "solvers"});
  } else {
    top.error_here("missing required table [scene] (name, duration, solvers)");
  }

  if (const auto* t = top.table("domain")) {
    Reader r(*t, "domain", file, diags, t->source());
    sc.domain = r.polygon("polygon", true);
    r.finish({"polygon"});
  } else {
    top.error_here("missing required table [domain] with 'polygon' = [[x, z], …]");
  }

  if (const auto* t = top.table("soil")) {
    Reader r(*t, "soil", file, diags, t->source());
    if (const auto* d = r.table("dem")) {
      Reader rd(*d, "soil.dem", file, diags, d->source());
      sc.soil.dem = read_dem_soil(rd, vocabulary);
    }
    if (const auto* c = r.table("continuum")) {
      Reader rc(*c, "soil.continuum", file, diags, c->source());
      sc.soil.continuum = read_continuum_soil(rc, vocabulary);
    }
    r.finish({"dem", "continuum"});
  }
  if (sc.uses(Solver::Dem) && !sc.soil.dem)
    top.error_here("scene.solvers lists \"dem\" but there is no [soil.dem] table");
  if (sc.uses(Solver::Continuum) && !sc.soil.continuum)
    top.error_here("scene.solvers lists \"continuum\" but there is no [soil.continuum] table");
  if (sc.soil.dem && sc.soil.dem->fill.empty()) sc.soil.dem->fill = sc.domain;

  if (const auto* t = top.table("continuum")) {
    Reader r(*t, "continuum", file, diags, t->source());
    sc.continuum = read_continuum_options(r);
  }

  auto each = [&](std::string_view key, auto&& fn) {
    if (const auto* a = top.array_of_tables(key)) {
      for (std::size_t i = 0; i < a->size(); ++i) {
        const auto& tbl = *(*a)[i].as_table();
        const auto nm = tbl["name"].value<std::string>();
        Reader r(tbl,
                 nm ? fmt::format("{}[{}]", key, printable(*nm)) : fmt::format("{}[{}]", key, i),
                 file, diags, tbl.source());
        fn(r);
      }
    }
  };
  each("wall", [&](Reader& r) { sc.walls.push_back(read_wall(r)); });
  each("structure", [&](Reader& r) {
    sc.structures.push_back(read_structure(r, sc.soil.dem ? &*sc.soil.dem : nullptr));
  });
  each("group", [&](Reader& r) {
    Group g;
    g.name = r.string("name", "");
    if (g.name.empty()) r.error_here("every [[group]] needs a 'name'");
    g.region = r.polygon("region", true);
    r.finish({"name", "region"});
    sc.groups.push_back(std::move(g));
  });
  each("event", [&](Reader& r) {
    Event e;
    e.time = r.non_negative("time", 0.0);
    if (!r.has("time")) r.error_here("every [[event]] needs 'time' [s]");
    e.action = read_enum(r, "action", kEventActionNames, e.action);
    e.group = r.string("group", "");
    e.wall = r.string("wall", "");
    e.mu_static = r.non_negative("mu_static", 0.0);
    e.mu_dynamic = r.non_negative("mu_dynamic", 0.0);
    if (e.mu_dynamic > e.mu_static)
      r.error("mu_dynamic", "dynamic friction must not exceed static friction");
    r.finish({"time", "action", "group", "wall", "mu_static", "mu_dynamic"});
    sc.events.push_back(std::move(e));
  });
  each("probe", [&](Reader& r) { sc.probes.push_back(read_probe(r)); });
  // record = ["pressure-profile"] on a structure: its pressure-profile probe (default bins), unless
  // a [[probe]] already profiles it.
  for (const auto& st : sc.structures) {
    if (std::find(st.record.begin(), st.record.end(), "pressure-profile") == st.record.end())
      continue;
    const bool probed = std::any_of(sc.probes.begin(), sc.probes.end(), [&](const Probe& p) {
      return p.kind == ProbeKind::PressureProfile && p.target == st.name;
    });
    if (!probed) {
      Probe p;
      p.kind = ProbeKind::PressureProfile;
      p.target = st.name;
      sc.probes.push_back(std::move(p));
    }
  }

  if (const auto* t = top.table("load")) {
    Reader r(*t, "load", file, diags, t->source());
    sc.load = read_load(r);
  }
  if (const auto* t = top.table("output")) {
    Reader r(*t, "output", file, diags, t->source());
    sc.output.interval = r.positive("interval", sc.output.interval);
    sc.output.probe_interval = r.positive("probe_interval", sc.output.probe_interval);
    sc.output.vtk = r.boolean("vtk", sc.output.vtk);
    sc.output.vtk_compression =
        read_enum(r, "vtk_compression", kVtkCompressionNames, sc.output.vtk_compression);
    sc.output.force_chains = r.boolean("force_chains", sc.output.force_chains);
    sc.output.figures = r.boolean("figures", sc.output.figures);
    sc.output.checkpoint_interval =
        r.non_negative("checkpoint_interval", sc.output.checkpoint_interval);
    if (const toml::node* n = r.node("series")) { // snapshot series times [s]
      const auto* a = n->as_array();
      bool ok = a != nullptr;
      for (std::size_t i = 0; ok && i < a->size(); ++i) {
        const auto v = (*a)[i].value<double>();
        ok = (*a)[i].is_number() && v && std::isfinite(*v) && *v >= 0.0 &&
             (sc.output.series.empty() || *v > sc.output.series.back());
        if (ok) sc.output.series.push_back(*v);
      }
      if (!ok) r.error("series", "expected a list of increasing times ≥ 0 [s], e.g. [1, 5, 9]");
    }
    r.finish({"interval", "probe_interval", "vtk", "vtk_compression", "force_chains", "figures",
              "checkpoint_interval", "series"});
  }

  // Cross references, located at the key that names the missing thing.
  auto at = [&](std::string_view array, std::size_t i, std::string_view key) {
    const toml::node* n = root[array][i][key].node();
    if (!n) n = root[array][i].node();
    return n ? n->source() : root.source();
  };
  std::set<std::string> names;
  for (std::size_t i = 0; i < sc.walls.size(); ++i)
    if (!names.insert(sc.walls[i].name).second)
      top.error_at(at("wall", i, "name"), fmt::format("wall[{}].name", sc.walls[i].name),
                   fmt::format("duplicate wall/structure name '{}'", sc.walls[i].name));
  for (std::size_t i = 0; i < sc.structures.size(); ++i)
    if (!names.insert(sc.structures[i].name).second)
      top.error_at(at("structure", i, "name"),
                   fmt::format("structure[{}].name", sc.structures[i].name),
                   fmt::format("duplicate wall/structure name '{}'", sc.structures[i].name));
  for (std::size_t i = 0; i < sc.events.size(); ++i) {
    const auto& e = sc.events[i];
    if (e.action == EventAction::SetFriction && !sc.group(e.group))
      top.error_at(at("event", i, "group"), fmt::format("event[{}].group", i),
                   fmt::format("event at t = {} names group '{}', which no [[group]] defines",
                               e.time, e.group));
    if (e.action == EventAction::OpenWall && !sc.wall(e.wall))
      top.error_at(at("event", i, "wall"), fmt::format("event[{}].wall", i),
                   fmt::format("event at t = {} names wall '{}', which no [[wall]] defines", e.time,
                               e.wall));
  }
  for (std::size_t i = 0; i < sc.probes.size(); ++i) {
    const auto& p = sc.probes[i];
    const char* kind = keyword(kProbeKindNames, p.kind);
    if (probe_spec(p.kind).target && !sc.structure(p.target) && !sc.wall(p.target))
      top.error_at(
          at("probe", i, "target"), fmt::format("probe[{}].target", i),
          fmt::format("probe '{}' needs 'target' naming a structure or wall; '{}' is neither", kind,
                      p.target));
    // One probe of a kind per target: each writes its own file. The wall-thrust probes write one
    // file (walls.csv) at one interval.
    for (std::size_t j = 0; j < i; ++j) {
      const auto& q = sc.probes[j];
      if (q.kind != p.kind) continue;
      if (p.kind == ProbeKind::WallThrust) {
        if (q.interval != p.interval)
          top.error_at(at("probe", i, "interval"), fmt::format("probe[{}].interval", i),
                       fmt::format("the wall-thrust probes write one file, walls.csv, at one "
                                   "interval: probe[{}] gives {} s, this one {} s",
                                   j, q.interval, p.interval));
        if (q.target != p.target) continue;
      } else if (q.target != p.target) {
        continue;
      }
      top.error_at(at("probe", i, "kind"), fmt::format("probe[{}].kind", i),
                   fmt::format("a second '{}' probe{} (probe[{}] is one): give one", kind,
                               p.target.empty() ? std::string() : fmt::format(" on '{}'", p.target),
                               j));
      break;
    }
  }

  top.finish({"scene", "domain", "soil", "continuum", "wall", "structure", "group", "event",
              "probe", "load", "output", "variant"});
  // Semantic checks on a scene that read cleanly: what it asks must be possible.
  if (diags.size() == diags_before) detail::validate_semantics(sc, root, file, vocabulary, diags);
  return sc;
}

// ---- variants ----------------------------------------------------------------------------------
std::vector<std::string> split_dotted(const std::string& s) {
  std::vector<std::string> parts;
  std::string cur;
  for (char c : s) {
    if (c == '.') {
      parts.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  parts.push_back(cur);
  return parts;
}

// Applies one dotted override, moving `value` into place (a move keeps its source position, a
// copy would lose it); returns an error message or "".
std::string apply_override(toml::table& root, const std::string& dotted, toml::node&& value) {
  const auto parts = split_dotted(dotted);
  toml::node* cur = &root;
  std::string walked;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const auto& p = parts[i];
    const bool last = i + 1 == parts.size();
    if (p.empty()) return "empty path segment";
    toml::node* next = nullptr;
    if (auto* t = cur->as_table()) {
      next = t->get(p);
      if (last) {
        // With calibrate = "dem" the calibrated keys exist implicitly (their values come from
        // `demfem calibrate`): a variant may state one.
        static constexpr std::array<std::string_view, 11> kCalibrated{"young",
                                                                      "poisson",
                                                                      "friction_angle",
                                                                      "cohesion",
                                                                      "dilation_angle",
                                                                      "dilation_cutoff",
                                                                      "modulus_exponent",
                                                                      "modulus_reference_stress",
                                                                      "density",
                                                                      "k0",
                                                                      "surface"};
        const bool calibrated =
            walked == "soil.continuum" && (*t)["calibrate"].value<std::string>() == "dem" &&
            std::find(kCalibrated.begin(), kCalibrated.end(), p) != kCalibrated.end();
        if (!next && !calibrated)
          return fmt::format("the base scene has no key '{}' under '{}' to override; add it to the "
                             "base scene (with its default) so each variant states what it changes",
                             p, walked.empty() ? "(top level)" : walked);
        t->insert_or_assign(p, std::move(value));
        return "";
      }
    } else if (auto* a = cur->as_array()) {
      // Array element by index or by the element's 'name'.
      std::size_t idx = a->size();
      if (std::all_of(p.begin(), p.end(), [](char c) { return c >= '0' && c <= '9'; })) {
        // Digits only: an index. Too many digits for any array is simply out of range (no
        // std::stoul, whose exception text would reach the user).
        idx = p.size() <= 9 ? static_cast<std::size_t>(std::stoul(p)) : a->size();
      } else {
        for (std::size_t k = 0; k < a->size(); ++k)
          if (const auto* et = (*a)[k].as_table(); et && (*et)["name"].value<std::string>() == p)
            idx = k;
      }
      if (idx >= a->size()) {
        std::vector<std::string> names;
        for (std::size_t k = 0; k < a->size(); ++k)
          if (const auto* et = (*a)[k].as_table())
            if (const auto nm = (*et)["name"].value<std::string>()) names.push_back(*nm);
        const std::string shown = p.size() > 24 ? p.substr(0, 21) + "…" : p;
        if (a->empty()) return fmt::format("'{}' has no element '{}': it is empty", walked, shown);
        return fmt::format(
            "'{}' has no element '{}'; valid: an index 0–{}{}{}", walked, shown, a->size() - 1,
            names.empty() ? "" : " or a name: ", fmt::format("{}", fmt::join(names, ", ")));
      }
      if (last) {
        a->replace(a->begin() + static_cast<std::ptrdiff_t>(idx), std::move(value));
        return "";
      }
      next = a->get(idx);
    }
    if (!next)
      return fmt::format("the base scene has no '{}' under '{}' to override", p,
                         walked.empty() ? "(top level)" : walked);
    walked += (walked.empty() ? "" : ".") + p;
    cur = next;
  }
  return "";
}

toml::table parse_toml(std::string_view text, const std::string& source_name) {
  try {
    return toml::parse(text, source_name);
  } catch (const toml::parse_error& e) {
    Diagnostic d;
    d.file = source_name;
    d.line = static_cast<int>(e.source().begin.line);
    d.column = static_cast<int>(e.source().begin.column);
    d.message = fmt::format("TOML syntax: {}", e.description());
    throw SceneError({d});
  }
}

void dedupe(std::vector<Diagnostic>& diags) {
  std::vector<Diagnostic> out;
  std::set<std::string> seen;
  for (auto& d : diags)
    if (seen.insert(d.format()).second) out.push_back(std::move(d));
  diags = std::move(out);
}

} // namespace

bool Scene::uses(Solver s) const {
  return std::find(info.solvers.begin(), info.solvers.end(), s) != info.solvers.end();
}
const Structure* Scene::structure(const std::string& n) const {
  for (const auto& s : structures)
    if (s.name == n) return &s;
  return nullptr;
}
const Wall* Scene::wall(const std::string& n) const {
  for (const auto& w : walls)
    if (w.name == n) return &w;
  return nullptr;
}
const Group* Scene::group(const std::string& n) const {
  for (const auto& g : groups)
    if (g.name == n) return &g;
  return nullptr;
}

SceneFile parse_scene(std::string_view text, const std::string& source_name,
                      const Vocabulary& vocabulary) {
  const toml::table root = parse_toml(text, source_name);

  std::vector<Diagnostic> diags;
  SceneFile out;
  out.path = source_name;
  out.base = resolve(root, source_name, vocabulary, diags);

  if (const toml::node* vn = root.get("variant")) {
    const auto* arr = vn->as_array();
    if (!arr || !vn->is_array_of_tables()) {
      diags.push_back({source_name, static_cast<int>(vn->source().begin.line),
                       static_cast<int>(vn->source().begin.column), "variant",
                       "expected [[variant]] tables with 'name' and 'set'"});
    } else {
      std::set<std::string> seen;
      for (std::size_t i = 0; i < arr->size(); ++i) {
        const auto& vt = *(*arr)[i].as_table();
        const int vline = static_cast<int>(vt.source().begin.line);
        const int vcol = static_cast<int>(vt.source().begin.column);
        const auto name = vt["name"].value<std::string>();
        const std::string label = name ? printable(*name) : fmt::format("#{}", i + 1);
        if (!name || name->empty()) {
          diags.push_back({source_name, vline, vcol, fmt::format("variant[{}]", i),
                           "every [[variant]] needs a non-empty 'name'"});
          continue;
        }
        if (const auto why = name_problem(*name)) { // it names a run directory: a name, no path
          const auto& src = vt.get("name")->source();
          diags.push_back({source_name, static_cast<int>(src.begin.line),
                           static_cast<int>(src.begin.column), fmt::format("variant[{}].name", i),
                           *why});
          continue;
        }
        if (!seen.insert(*name).second)
          diags.push_back({source_name, vline, vcol, fmt::format("variant[{}]", *name),
                           "duplicate variant name"});
        for (auto&& [k, v] : vt) {
          if (k != "name" && k != "set" && k != "description")
            diags.push_back({source_name, static_cast<int>(k.source().begin.line),
                             static_cast<int>(k.source().begin.column),
                             fmt::format("variant[{}].{}", label, k.str()),
                             "unknown key; valid keys here: name, description, set"});
        }
        // A fresh parse per variant keeps every node's source position (toml++ copies drop it).
        toml::table copy = parse_toml(text, source_name);
        toml::table* set =
            (*copy.get_as<toml::array>("variant"))[i].as_table()->get_as<toml::table>("set");
        if (!set && vt.contains("set")) {
          const auto& sn = *vt.get("set");
          diags.push_back({source_name, static_cast<int>(sn.source().begin.line),
                           static_cast<int>(sn.source().begin.column),
                           fmt::format("variant[{}].set", label),
                           "expected a table of overrides { \"dotted.key\" = value, … }"});
          continue;
        }
        if (set) {
          // `"a.b" = v` is one quoted dotted key; `a.b = v` nests tables: accept both.
          std::function<void(toml::table&, const std::string&)> apply =
              [&](toml::table& t, const std::string& prefix) {
                for (auto&& [k, v] : t) {
                  const std::string path =
                      prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
                  if (v.is_table() && !v.as_table()->is_inline()) {
                    apply(*v.as_table(), path);
                    continue;
                  }
                  const std::string err = apply_override(copy, path, std::move(v));
                  if (!err.empty())
                    diags.push_back({source_name, static_cast<int>(k.source().begin.line),
                                     static_cast<int>(k.source().begin.column),
                                     fmt::format("variant[{}].set.{}", label, path), err});
                }
              };
          apply(*set, "");
        }
        copy.erase("variant");
        Scene s = resolve(copy, source_name, vocabulary, diags);
        s.variant = *name;
        s.variant_description = vt["description"].value_or(std::string());
        out.variants.push_back(std::move(s));
      }
    }
  }
  dedupe(diags);
  const auto warn = std::stable_partition(diags.begin(), diags.end(),
                                          [](const Diagnostic& d) { return !d.warning; });
  out.warnings.assign(std::make_move_iterator(warn), std::make_move_iterator(diags.end()));
  diags.erase(warn, diags.end());
  if (!diags.empty()) throw SceneError(std::move(diags));
  return out;
}

SceneFile load_scene_file(const std::filesystem::path& path, const Vocabulary& vocabulary) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw SceneError(
        {Diagnostic{path.string(), 0, 0, "", "cannot open the scene file (does it exist?)"}});
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_scene(ss.str(), path.string(), vocabulary);
}

} // namespace demfem::scene
