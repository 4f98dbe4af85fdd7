// Writes a resolved Scene back as TOML with every default explicit.
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <numbers>
#include <regex>
#include <sstream>

#include <toml++/toml.h>

#include "demfem/scene/load.hpp"
#include "demfem/scene/probe_spec.hpp"
#include "demfem/scene/reader.hpp"

namespace demfem::scene {

namespace {

constexpr double kToDeg = 180.0 / std::numbers::pi;
// Degrees for the file, rounded to 1e-9° so 30° does not come back as 29.999999999999996.
double deg(double rad) {
  return std::round(rad * kToDeg * 1e9) / 1e9;
}

toml::array pts(const std::vector<Vec2>& p) {
  toml::array a;
  for (const auto& v : p) a.push_back(toml::array{v.x, v.z});
  return a;
}
toml::array pt(Vec2 v) {
  return toml::array{v.x, v.z};
}

toml::table tf(const TimeFunction& f) {
  using K = TimeFunction::Kind;
  switch (f.kind) {
  case K::Constant:
    return toml::table{{"type", "constant"}, {"value", f.value}};
  case K::Ramp: {
    toml::table t{{"type", "ramp"}, {"rate", f.rate}, {"offset", f.offset}, {"start", f.start}};
    if (f.stop > f.start) t.insert("stop", f.stop);
    return t;
  }
  case K::Sine: {
    toml::table t{{"type", "sine"},
                  {"amplitude", f.amplitude},
                  {"frequency", f.frequency},
                  {"phase", f.phase},
                  {"start", f.start}};
    if (f.stop > f.start) t.insert("stop", f.stop);
    return t;
  }
  case K::TSine:
    return toml::table{{"type", "t-sine"}, {"amplitude", f.amplitude}, {"omega", f.omega}};
  case K::Table: {
    toml::array a;
    for (const auto& [t, v] : f.table) a.push_back(toml::array{t, v});
    return toml::table{{"type", "table"}, {"points", a}};
  }
  case K::Sum: {
    toml::array a;
    for (const auto& t : f.terms) a.push_back(tf(t));
    return toml::table{{"type", "sum"}, {"terms", a}};
  }
  }
  return {};
}

template <typename T> toml::table inline_table(T&& t) {
  toml::table out = std::forward<T>(t);
  out.is_inline(true);
  return out;
}

// toml++ as packaged prints doubles with max_digits10 (5.6 → 5.5999999999999996); rewrite each
// long number in its shortest form that reads back to the same double.
std::string shortest_floats(const std::string& text) {
  static const std::regex kLong(R"(-?\d+\.\d{12,}(e[+-]?\d+)?)");
  std::string out;
  auto begin = std::sregex_iterator(text.begin(), text.end(), kLong);
  std::size_t last = 0;
  for (auto it = begin; it != std::sregex_iterator(); ++it) {
    const auto& m = *it;
    out.append(text, last, static_cast<std::size_t>(m.position()) - last);
    const double v = std::strtod(m.str().c_str(), nullptr);
    char buf[64];
    auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, v);
    std::string s(buf, ec == std::errc{} ? ptr : buf);
    if (s.find_first_of(".eE") == std::string::npos) s += ".0"; // keep it a TOML float
    out += s;
    last = static_cast<std::size_t>(m.position() + m.length());
  }
  out.append(text, last, std::string::npos);
  return out;
}

} // namespace

std::string to_toml(const Scene& s) {
  toml::table root;
  toml::array solvers;
  for (auto v : s.info.solvers) solvers.push_back(v == Solver::Dem ? "dem" : "continuum");
  root.insert("scene", toml::table{{"name", s.info.name},
                                   {"description", s.info.description},
                                   {"solvers", solvers},
                                   {"duration", s.info.duration},
                                   {"seed", static_cast<int64_t>(s.info.seed)}});
  root.insert("domain", toml::table{{"polygon", pts(s.domain)}});

  toml::table soil;
  if (const auto& d = s.soil.dem) {
    toml::table radius;
    switch (d->radius.kind) {
    case RadiusDistribution::Kind::Uniform:
      radius.insert("uniform", toml::array{d->radius.min, d->radius.max});
      break;
    case RadiusDistribution::Kind::Equal:
      radius.insert("equal", d->radius.min);
      break;
    case RadiusDistribution::Kind::Table: {
      toml::array a;
      for (const auto& [r, w] : d->radius.table) a.push_back(toml::array{r, w});
      radius.insert("table", a);
      break;
    }
    }
    soil.insert(
        "dem",
        toml::table{{"count", d->count},
                    {"radius", inline_table(radius)},
                    {"density", d->density},
                    {"thickness", d->thickness},
                    {"mu_static", d->mu_static},
                    {"mu_dynamic", d->mu_dynamic},
                    {"damping_c", d->damping_c},
                    {"damping_d", d->damping_d},
                    {"dt", d->dt},
                    {"dt_safety", d->dt_safety},
                    {"max_overlap", d->max_overlap},
                    {"energy_warning", d->energy_warning},
                    {"energy_limit", d->energy_limit},
                    {"fill", pts(d->fill)},
                    {"packing",
                     toml::table{{"ke_ratio", d->packing.ke_ratio},
                                 {"max_time", d->packing.max_time},
                                 {"damping", d->packing.damping},
                                 {"cache", d->packing.cache},
                                 {"placement", keyword(kPlacementNames, d->packing.placement)}}}});
    if (d->packing.target_porosity) { //: as the file gave it (porosity or void ratio)
      const double n = *d->packing.target_porosity;
      toml::table t;
      if (d->packing.target_as_void_ratio)
        t.insert("void_ratio", n / (1.0 - n)); // e = n / (1 − n)
      else
        t.insert("porosity", n);
      t.insert("tolerance", d->packing.target_tolerance);
      soil.get_as<toml::table>("dem")->get_as<toml::table>("packing")->insert("target", t);
    } else {
      soil.get_as<toml::table>("dem")->get_as<toml::table>("packing")->insert("target", "none");
    }
    if (d->sphere_mass) soil.get_as<toml::table>("dem")->insert("particle_mass", "sphere");
    for (const auto& m : d->models) write_model(m, *soil.get_as<toml::table>("dem"));
    if (!d->particles_file.empty()) {
      soil.get_as<toml::table>("dem")->insert("particles_file", d->particles_file);
    } else if (!d->particles.empty()) {
      toml::array list;
      for (const auto& q : d->particles)
        list.push_back(toml::array{q[0], q[1], q[2], q[3], q[4], q[5]});
      soil.get_as<toml::table>("dem")->insert("particles", list);
    }
  }
  if (const auto& c = s.soil.continuum) {
    soil.insert("continuum", toml::table{{"density", c->density}, {"k0", c->k0}});
    // the constitutive model and its keys, through its parameter blocks
    for (const auto& m : c->models) write_model(m, *soil.get_as<toml::table>("continuum"));
    if (c->surface) soil.get_as<toml::table>("continuum")->insert("surface", *c->surface);
    if (c->calibrate_dem) soil.get_as<toml::table>("continuum")->insert("calibrate", "dem");
    if (!c->provenance.empty()) { // where each value came from
      toml::table prov;
      for (const auto& [k, v] : c->provenance) prov.insert_or_assign(k, v);
      soil.get_as<toml::table>("continuum")->insert("provenance", prov);
    }
  }
  if (!soil.empty()) root.insert("soil", soil);

  if (s.uses(Solver::Continuum)) {
    const auto& o = s.continuum;
    root.insert("continuum",
                toml::table{{"refinement", o.refinement},
                            {"degree", o.degree},
                            {"bbar", o.bbar},
                            {"dt", o.dt},
                            {"newmark_beta", o.newmark_beta},
                            {"newmark_gamma", o.newmark_gamma},
                            {"rayleigh_alpha", o.rayleigh_alpha},
                            {"rayleigh_beta", o.rayleigh_beta},
                            {"absorbing", o.absorbing},
                            {"linear_solver", o.linear_solver},
                            {"interface", o.interface},
                            {"structure_interface", o.structure_interface},
                            {"interface_friction_angle", deg(o.interface_friction_angle)},
                            {"load_steps", o.load_steps},
                            {"newton_tolerance", o.newton_tolerance},
                            {"newton_max_iterations", o.newton_max_iterations},
                            {"max_displacement", o.max_displacement},
                            {"integrator", o.integrator},
                            {"explicit_safety", o.explicit_safety},
                            {"local_damping", o.local_damping}});
    if (o.seat_structures)
      root.get_as<toml::table>("continuum")->insert("seat_structures", *o.seat_structures);
    if (o.mesh_size_near > 0.0) { // written only when set: uniform grids resolve as before
      root.get_as<toml::table>("continuum")->insert("mesh_size_near", o.mesh_size_near);
      root.get_as<toml::table>("continuum")->insert("mesh_grading", o.mesh_grading);
    }
  }

  if (!s.walls.empty()) {
    toml::array a;
    for (const auto& w : s.walls) {
      toml::table t{{"name", w.name}, {"points", pts(w.points)}, {"record", w.record}};
      if (w.mu_static) t.insert("mu_static", *w.mu_static);
      if (w.mu_dynamic) t.insert("mu_dynamic", *w.mu_dynamic);
      if (w.opens_at) t.insert("opens_at", *w.opens_at);
      a.push_back(t);
    }
    root.insert("wall", a);
  }
  if (!s.structures.empty()) {
    toml::array a;
    for (const auto& st : s.structures) {
      toml::array rec;
      for (const auto& r : st.record) rec.push_back(r);
      toml::table t{{"name", st.name},
                    {"kind", keyword(kStructureKindNames, st.kind)},
                    {"shape", "polygon"},
                    {"polygon", pts(st.outline)},
                    {"density", st.density},
                    {"mass", st.mass},
                    {"inertia", st.inertia},
                    {"pivot", pt(st.pivot)},
                    {"dof_x", keyword(kDofModeNames, st.dof_x)},
                    {"dof_z", keyword(kDofModeNames, st.dof_z)},
                    {"dof_rotation", keyword(kDofModeNames, st.dof_rotation)},
                    {"motion_x", inline_table(tf(st.motion_x))},
                    {"motion_z", inline_table(tf(st.motion_z))},
                    {"motion_rotation", inline_table(tf(st.motion_rotation))},
                    {"force_x", inline_table(tf(st.force_x))},
                    {"force_z", inline_table(tf(st.force_z))},
                    {"moment", inline_table(tf(st.moment))},
                    {"load_point", pt(st.load_point)},
                    {"dead_weight", st.dead_weight},
                    {"record", rec}};
      if (st.mu_static) t.insert("mu_static", *st.mu_static);
      if (st.mu_dynamic) t.insert("mu_dynamic", *st.mu_dynamic);
      a.push_back(t);
    }
    root.insert("structure", a);
  }
  if (!s.groups.empty()) {
    toml::array a;
    for (const auto& g : s.groups)
      a.push_back(toml::table{{"name", g.name}, {"region", pts(g.region)}});
    root.insert("group", a);
  }
  if (!s.events.empty()) {
    toml::array a;
    for (const auto& e : s.events) {
      toml::table t{{"time", e.time}, {"action", keyword(kEventActionNames, e.action)}};
      if (e.action == EventAction::SetFriction) {
        t.insert("group", e.group);
        t.insert("mu_static", e.mu_static);
        t.insert("mu_dynamic", e.mu_dynamic);
      } else {
        t.insert("wall", e.wall);
      }
      a.push_back(t);
    }
    root.insert("event", a);
  }
  if (!s.probes.empty()) {
    toml::array a;
    for (const auto& p : s.probes) { // the keys its kind takes (probe_spec.hpp)
      toml::table t{{"kind", keyword(kProbeKindNames, p.kind)}, {"interval", p.interval}};
      const ProbeSpec& spec = probe_spec(p.kind);
      if (spec.target) t.insert("target", p.target);
      if (spec.bins) t.insert("bins", p.bins);
      if (spec.points) t.insert("points", pts(p.points));
      a.push_back(t);
    }
    root.insert("probe", a);
  }
  toml::table load{{"gravity", s.load.gravity}};
  if (const auto& sh = s.load.shaking) {
    toml::table t{{"direction", std::string(1, sh->direction)},
                  {"amplitude", sh->acceleration.amplitude},
                  {"frequency", sh->acceleration.frequency},
                  {"phase", sh->acceleration.phase},
                  {"start", sh->acceleration.start}};
    if (sh->acceleration.stop > sh->acceleration.start) t.insert("stop", sh->acceleration.stop);
    load.insert("shaking", inline_table(t));
  }
  root.insert("load", load);
  root.insert("output", toml::table{{"interval", s.output.interval},
                                    {"probe_interval", s.output.probe_interval},
                                    {"vtk", s.output.vtk},
                                    {"force_chains", s.output.force_chains},
                                    {"figures", s.output.figures},
                                    {"checkpoint_interval", s.output.checkpoint_interval}});
  if (s.output.vtk_compression != VtkCompression::Lz4) // the default is left out
    root.get_as<toml::table>("output")->insert(
        "vtk_compression",
        std::string(kVtkCompressionNames[static_cast<std::size_t>(s.output.vtk_compression)]));
  if (!s.output.series.empty()) {
    toml::array a;
    for (double t : s.output.series) a.push_back(t);
    root.get_as<toml::table>("output")->insert("series", a);
  }
  std::ostringstream os;
  os << "# resolved scene: " << s.label() << " (from " << s.source_file << ")\n";
  os << root << "\n";
  return shortest_floats(os.str());
}

} // namespace demfem::scene
