#include "profiles.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <optional>

#include <fmt/format.h>

#include "demfem/compare/coarse_grain.hpp"
#include "demfem/compare/plot.hpp"
#include "demfem/compare/report.hpp"
#include "demfem/output/contract.hpp"
#include "demfem/scene/write_file.hpp"

namespace fs = std::filesystem;

namespace demfem::compare {

ProfileExtremes profile_extremes(const std::vector<double>& x, const std::vector<double>& v) {
  ProfileExtremes e;
  for (std::size_t k = 0; k < std::min(x.size(), v.size()); ++k) {
    if (!std::isfinite(v[k])) continue;
    if (v[k] > e.down) {
      e.down = v[k];
      e.x_down = x[k];
    }
    if (v[k] < e.up) {
      e.up = v[k];
      e.x_up = x[k];
    }
  }
  return e;
}

std::string subsidence_summary(double t_rest, double t_end, const ProfileExtremes& dem,
                               const ProfileExtremes& continuum) {
  const auto side = [](const ProfileExtremes& e) {
    const auto part = [](const char* verb, double v, double x) {
      return std::isfinite(x)
                 ? fmt::format("{} by at most {:.3g} mm (x = {:.4g} m)", verb, std::abs(v) * 1e3, x)
                 : fmt::format("nowhere {}", verb);
    };
    return part("settles", e.down, e.x_down) + " and " + part("rises", e.up, e.x_up);
  };
  return fmt::format("Surface from t = {:.3g} s to t = {:.3g} s: the DEM surface {}; the "
                     "continuum surface {}.",
                     t_rest, t_end, side(dem), side(continuum));
}

namespace detail {

std::pair<double, double> domain_x(const scene::Scene* scene) {
  if (!scene || scene->domain.empty()) return {0.0, 1.0};
  const auto b = scene::bounds(scene->domain);
  return {b.x0, b.x1};
}

void fail_on_write_error(const std::string& plot_error) {
  if (plot_error.starts_with("cannot write") || plot_error.starts_with("gnuplot failed ("))
    throw scene::WriteError(plot_error);
}

std::string safe_name(const std::string& s) {
  std::string o;
  for (char c : s)
    o += (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-') ? c : '_';
  while (!o.empty() && o.back() == '_') o.pop_back();
  return o;
}

namespace {

namespace dir = output::dir;
namespace file = output::file;

nlohmann::json finite_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

double mean_over(const std::vector<double>& t, const std::vector<double>& y, double a, double b) {
  double sum = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < std::min(t.size(), y.size()); ++i)
    if (t[i] >= a && t[i] <= b && std::isfinite(y[i])) {
      sum += y[i];
      ++n;
    }
  return n ? sum / n : NAN;
}

// The height of a structure's outline [m]; 1 when the scene has no structure of that name.
double structure_height(const scene::Scene* scene, const std::string& name) {
  double hw = 1.0;
  if (scene)
    for (const auto& s : scene->structures)
      if (s.name == name) {
        const auto b = scene::bounds(s.outline);
        hw = b.z1 > b.z0 ? b.z1 - b.z0 : 1.0;
      }
  return hw;
}

// ---- Read::PressureBins, Reduction::RestAndLateMean
// ----------------------------------------------

// Per target, per height bin: DEM at rest, DEM late mean, continuum at rest, continuum late mean
// [Pa] (NaN where a solver has no value), from both solvers' pressure_<target>.csv.
using PressureBins = std::map<std::string, std::map<int, std::array<double, 4>>>;

PressureBins pressure_bins(const fs::path& run_dir, const SplitOptions& so) {
  PressureBins prof;
  for (const auto solver : {dir::dem, dir::continuum}) {
    const fs::path d = run_dir / solver;
    if (!fs::is_directory(d)) continue;
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(d))
      if (e.path().extension() == ".csv" && e.path().filename().string().rfind("pressure_", 0) == 0)
        files.push_back(e.path());
    std::sort(files.begin(), files.end());
    const std::size_t o = solver == dir::dem ? 0 : 2;
    for (const auto& f : files) {
      const CsvTable t = read_csv(f);
      if (t.find(output::col::time.name) < 0) continue;
      const auto time = t.column(output::col::time.name);
      if (time.empty()) continue;
      // at rest: [load_start/2, load_start), or the first sample when the load starts at t ≈ 0
      const bool rest = so.load_start > 0.2;
      const double rest_a = rest ? 0.5 * so.load_start : 0.0;
      const double rest_b = rest ? so.load_start * (1 - 1e-9) - 1e-12 : time.front();
      for (const auto& name : t.columns) {
        std::string target;
        int bin = 0;
        if (!output::is_bin_heading(name, &target, &bin)) continue;
        const auto y = t.column(name);
        auto [it, fresh] = prof[target].try_emplace(bin);
        if (fresh) it->second.fill(NAN);
        it->second[o] = mean_over(time, y, rest_a, rest_b);
        it->second[o + 1] = mean_over(time, y, so.late_from, so.late_to);
      }
    }
  }
  return prof;
}

std::vector<ProfileResult> pressure_profiles(const Metric& row, const fs::path& run_dir,
                                             const fs::path& figdir, const SplitOptions& so,
                                             const scene::Scene* scene) {
  std::vector<ProfileResult> out;
  for (const auto& [target, bins] : pressure_bins(run_dir, so)) {
    const int n = bins.rbegin()->first + 1;
    const double hw = structure_height(scene, target);
    const char* names[4] = {"DEM at rest", "DEM, late mean", "continuum at rest",
                            "continuum, late mean"};
    const char* styles[4] = {"dt 2 lw 2 pt 6 lc rgb '#1f78b4'", "lw 2 pt 7 lc rgb '#1f78b4'",
                             "dt 2 lw 2 pt 4 lc rgb '#e31a1c'", "lw 2 pt 5 lc rgb '#e31a1c'"};
    std::vector<Series> ss(4);
    ProfileResult r{target, std::string(row.record), {}, {}, nlohmann::json::array()};
    for (int c = 0; c < 4; ++c)
      ss[static_cast<std::size_t>(c)] = {names[c], {}, {}, "linespoints", styles[c]};
    for (const auto& [k, v] : bins) {
      const double h = (k + 0.5) / n * hw; // bin centre above the wall's base
      for (std::size_t c = 0; c < 4; ++c) {
        ss[c].x.push_back(v[c] * row.scale.factor);
        ss[c].y.push_back(h);
      }
      r.values.push_back({{"height_m", h},
                          {"dem_rest_Pa", v[0]},
                          {"dem_late_Pa", v[1]},
                          {"continuum_rest_Pa", v[2]},
                          {"continuum_late_Pa", v[3]}});
    }
    PlotSpec spec;
    spec.title = fmt::format("{}: {}, at rest and late mean ({:.3g}–{:.3g} s)", target,
                             row.quantity, so.late_from, so.late_to);
    spec.xlabel = fmt::format("pressure [{}] (compression positive)", row.scale.unit);
    spec.ylabel = "height above the wall base [m]";
    spec.series = ss;
    spec.height = 500;
    const fs::path png = figdir / (safe_name(target) + "_" + std::string(row.key) + ".png");
    std::string err;
    if (plot(spec, png, &err)) r.figure = fs::relative(png, run_dir).string();
    fail_on_write_error(err);
    out.push_back(std::move(r));
  }
  return out;
}

// ---- Read::SurfaceBins, Reduction::EndMinusRest
// ---------------------------------------------------

// The DEM's surface settlement per bin followed as material, as the continuum's top nodes are:
// the particles that formed it at rest, from the particle snapshots nearest t_rest and t_end
// (each within 5 % of the span). Empty when those snapshots are missing or unreadable; the caller
// then takes the top of the bed per bin (surface.csv), which jumps by a grain whenever another
// particle becomes the highest.
std::vector<double> followed_dem_settlement(const fs::path& run_dir, double t_rest, double t_end,
                                            double x0, double x1, std::size_t bins) {
  const auto dps = read_pvd_entries(run_dir / dir::dem / file::particles_pvd);
  auto near = [&](double at) -> std::optional<std::size_t> {
    const std::size_t k = nearest_entry(dps, at);
    if (k < dps.size() && std::abs(dps[k].time - at) <= 0.05 * (t_end - t_rest)) return k;
    return std::nullopt;
  };
  const auto a = near(t_rest), b = near(t_end);
  if (!a || !b || *a == *b) return {};
  std::vector<double> zd;
  try {
    zd = dem_surface_settlement(read_particles_vtp(dps[*a].file), read_particles_vtp(dps[*b].file),
                                x0, x1, static_cast<int>(bins));
  } catch (const std::exception&) {
    return {};
  }
  if (zd.size() != bins ||
      std::none_of(zd.begin(), zd.end(), [](double v) { return std::isfinite(v); }))
    return {};
  return zd;
}

// Both solvers' subsidence per x bin between the load start and the end [m], down positive.
struct Subsidence {
  double rest = 0.0, end = 0.0; // [s]
  std::vector<double> x, dem, continuum;
  bool dem_followed = false; // the DEM's surface particles followed (else the top of the bed)
};

std::optional<Subsidence> subsidence(const Metric& row, const fs::path& run_dir,
                                     const SplitOptions& so, const scene::Scene* scene) {
  const fs::path sf = run_dir / dir::dem / row.source.file;
  const auto snaps = read_pvd_entries(run_dir / dir::continuum / file::continuum_pvd);
  if (!fs::exists(sf) || snaps.empty()) return std::nullopt;
  const CsvTable t = read_csv(sf);
  const auto time = t.column(output::col::time.name);
  const std::size_t nb = t.columns.size() > 1 ? t.columns.size() - 1 : 0;
  if (nb == 0 || time.empty()) return std::nullopt;
  const auto [x0, x1] = domain_x(scene);
  auto row_at = [&](double at) {
    std::size_t best = 0;
    for (std::size_t r = 0; r < time.size(); ++r)
      if (std::abs(time[r] - at) < std::abs(time[best] - at)) best = r;
    return best;
  };
  Subsidence s;
  s.rest = so.load_start;
  s.end = std::min(time.back(), snaps.back().time);
  const auto r0 = row_at(s.rest), r1 = row_at(s.end);
  std::vector<double> zc0, zc1;
  try {
    zc0 = continuum_surface(read_continuum_vtu(snaps[nearest_entry(snaps, s.rest)].file), x0, x1,
                            static_cast<int>(nb));
    zc1 = continuum_surface(read_continuum_vtu(snaps[nearest_entry(snaps, s.end)].file), x0, x1,
                            static_cast<int>(nb));
  } catch (const std::exception&) {
  }
  if (zc0.size() != nb || zc1.size() != nb) return std::nullopt;
  const std::vector<double> zd = followed_dem_settlement(run_dir, s.rest, s.end, x0, x1, nb);
  s.dem_followed = !zd.empty();
  for (std::size_t b = 0; b < nb; ++b) {
    s.x.push_back(x0 + (x1 - x0) * (static_cast<double>(b) + 0.5) / static_cast<double>(nb));
    s.dem.push_back(s.dem_followed ? zd[b] // subsidence: rest − end
                                   : t.rows[r0][b + 1] - t.rows[r1][b + 1]);
    s.continuum.push_back(zc0[b] - zc1[b]);
  }
  return s;
}

nlohmann::json subsidence_record(const Subsidence& s, const ProfileExtremes& de,
                                 const ProfileExtremes& ce, const std::string& note) {
  nlohmann::json js = nlohmann::json::array();
  for (std::size_t b = 0; b < s.x.size(); ++b)
    js.push_back({{"x_m", s.x[b]},
                  {"dem_m", finite_or_null(s.dem[b])},
                  {"continuum_m", finite_or_null(s.continuum[b])}});
  return {{"rest_s", s.rest},
          {"end_s", s.end},
          {"largest_dem_m", de.down},
          {"largest_continuum_m", ce.down},
          {"largest_dem_x_m", finite_or_null(de.x_down)},
          {"largest_continuum_x_m", finite_or_null(ce.x_down)},
          {"largest_rise_dem_m", -de.up},
          {"largest_rise_continuum_m", -ce.up},
          {"largest_rise_dem_x_m", finite_or_null(de.x_up)},
          {"largest_rise_continuum_x_m", finite_or_null(ce.x_up)},
          {"summary", note},
          {"dem_surface", s.dem_followed ? "surface particles followed" : "top of the bed"},
          {"bins", js}};
}

std::vector<ProfileResult> subsidence_profile(const Metric& row, const fs::path& run_dir,
                                              const fs::path& figdir, const SplitOptions& so,
                                              const scene::Scene* scene) {
  const auto s = subsidence(row, run_dir, so, scene);
  if (!s) return {};
  Series sd{"DEM", s->x, s->dem, "linespoints", "lw 2 pt 7 lc rgb '#1f78b4'"};
  Series sc{"continuum", s->x, s->continuum, "linespoints", "lw 2 pt 5 lc rgb '#e31a1c'"};
  // Both ways: a dilating continuum may rise more beside a footing than it settles.
  const auto de = profile_extremes(sd.x, sd.y), ce = profile_extremes(sc.x, sc.y);
  const double largest = std::max(std::max(de.down, -de.up), std::max(ce.down, -ce.up)); // [m]
  const bool mm = largest < 0.01;
  const double factor = row.scale.factor > 0.0 ? row.scale.factor : mm ? 1e3 : 1e2;
  const std::string_view unit = row.scale.factor > 0.0 ? row.scale.unit : mm ? "mm" : "cm";
  for (auto* x : {&sd, &sc})
    for (double& y : x->y) y *= factor;
  PlotSpec spec;
  spec.title = fmt::format("{}, t = {:.3g} s − t = {:.3g} s (down positive; DEM {:.3g} … {:.3g} "
                           "mm, continuum {:.3g} … {:.3g} mm)",
                           row.quantity, s->end, s->rest, de.up * 1e3, de.down * 1e3, ce.up * 1e3,
                           ce.down * 1e3);
  spec.xlabel = "x [m]";
  spec.ylabel = fmt::format("subsidence [{}] (down positive)", unit);
  spec.series = {sd, sc};
  spec.height = 450;
  ProfileResult r{"", std::string(row.record), {}, {}, {}};
  const fs::path png = figdir / (std::string(row.key) + ".png");
  std::string err;
  if (plot(spec, png, &err)) r.figure = fs::relative(png, run_dir).string();
  fail_on_write_error(err);
  r.note = subsidence_summary(s->rest, s->end, de, ce) +
           (s->dem_followed
                ? " DEM: the mean settlement of the particles that formed the surface at rest "
                  "(within one mean diameter of the top of their bin), followed to the end, as "
                  "the continuum's surface nodes are."
                : " DEM: the top of the bed in each bin (no particle snapshots at both times).");
  r.values = subsidence_record(*s, de, ce, r.note);
  return {r};
}

} // namespace

std::vector<ProfileResult> compare_profiles(const fs::path& run_dir, const fs::path& figdir,
                                            std::span<const Metric> table, const SplitOptions& so,
                                            const scene::Scene* scene) {
  std::vector<ProfileResult> out;
  for (const auto& row : table) {
    if (row.subject != Subject::Profile) continue;
    auto add = row.source.read == Read::PressureBins
                   ? pressure_profiles(row, run_dir, figdir, so, scene)
                   : subsidence_profile(row, run_dir, figdir, so, scene);
    for (auto& r : add) out.push_back(std::move(r));
  }
  return out;
}

} // namespace detail
} // namespace demfem::compare
