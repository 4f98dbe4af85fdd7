#include "demfem/compare/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>

#include <fmt/format.h>

#include "demfem/compare/coarse_grain.hpp"
#include "demfem/compare/plot.hpp"
#include "demfem/compare/report.hpp"
#include "demfem/output/contract.hpp"

namespace fs = std::filesystem;

namespace demfem::compare {
namespace {

namespace col = output::col;
namespace dir = output::dir;
namespace file = output::file;

// "wall.thrust [N]" → {"wall", "thrust", "N"}; false when the column is not "<name>.<q> [unit]".
bool split_column(const std::string& col, std::string& owner, std::string& q, std::string& unit) {
  const auto br = col.rfind(" [");
  const std::string base = br == std::string::npos ? col : col.substr(0, br);
  unit = br == std::string::npos ? std::string() : col.substr(br + 2, col.size() - br - 3);
  const auto dot = base.rfind('.');
  if (dot == std::string::npos) return false;
  owner = base.substr(0, dot);
  q = base.substr(dot + 1);
  return true;
}

struct Csv {
  std::map<std::string, TimeSeries> cols; // "<owner>.<q>" → series
};

// Every "<owner>.<q> [unit]" column of <dir>/<file>.
void read_into(const fs::path& path, Csv& out) {
  if (!fs::exists(path)) return;
  const CsvTable t = read_csv(path);
  const int tc = t.find(col::time.name);
  if (tc < 0) return;
  const auto time = t.column(t.columns[static_cast<std::size_t>(tc)]);
  for (std::size_t c = 0; c < t.columns.size(); ++c) {
    if (static_cast<int>(c) == tc) continue;
    std::string owner, q, unit;
    if (!split_column(t.columns[c], owner, q, unit)) continue;
    out.cols[owner + "." + q] = {time, t.column(t.columns[c])};
  }
}

bool all_zero(const TimeSeries& s) {
  for (double v : s.y)
    if (std::isfinite(v) && v != 0.0) return false;
  return true;
}

double mean_in(const TimeSeries& s, double a, double b, std::size_t* n_out = nullptr) {
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < std::min(s.t.size(), s.y.size()); ++i)
    if (s.t[i] >= a - 1e-12 && s.t[i] <= b + 1e-12 && std::isfinite(s.y[i])) {
      sum += s.y[i];
      ++n;
    }
  if (n_out) *n_out = n;
  return n ? sum / static_cast<double>(n) : NAN;
}

// One quantity of a structure, from "<owner>.<q>" columns of the two solvers.
struct StructQ {
  output::Column column; // its column (output/contract.hpp): name and unit
  const char* quantity;  // plain words after the owner's name
  const char* meaning;
};

// The registry: the structure and wall quantities both solvers write (structures.csv, walls.csv;
// the run-directory contract, output/contract.hpp). Each appears once.
constexpr StructQ kWallQ[] = {
    {col::thrust, "thrust",
     "normal soil force on the wall, F·n with n the wall chord's normal out of the soil: > 0 "
     "pressing, < 0 pulling (walls.csv)"},
    {col::reaction_z, "vertical soil force",
     "vertical soil force on the wall (wall friction for a vertical wall; walls.csv)"},
};
constexpr StructQ kBodyQ[] = {
    {col::settlement, "settlement", "downward displacement of the structure's pivot"},
    {col::rotation, "rotation", "rotation about the pivot, counter-clockwise positive"},
    {col::moment, "soil moment", "moment of the soil's forces about the pivot"},
    {col::displacement_x, "horizontal displacement", "horizontal displacement of the pivot"},
    {col::force_x, "horizontal soil force", "horizontal soil force on the structure"},
    {col::force_z, "vertical soil force", "vertical soil force on the structure"},
};

} // namespace

double Part::relative() const {
  if (!std::isfinite(dem) || !std::isfinite(continuum) || dem == 0.0) return NAN;
  return (continuum - dem) / std::abs(dem);
}

std::vector<double> moving_average(const std::vector<double>& t, const std::vector<double>& y,
                                   double window) {
  const std::size_t n = std::min(t.size(), y.size());
  std::vector<double> out(n, NAN);
  std::size_t a = 0, b = 0; // samples [a, b) inside the window
  double sum = 0.0;
  std::size_t cnt = 0;
  for (std::size_t i = 0; i < n; ++i) {
    while (b < n && t[b] <= t[i] + 0.5 * window + 1e-12) {
      if (std::isfinite(y[b])) {
        sum += y[b];
        ++cnt;
      }
      ++b;
    }
    while (a < b && t[a] < t[i] - 0.5 * window - 1e-12) {
      if (std::isfinite(y[a])) {
        sum -= y[a];
        --cnt;
      }
      ++a;
    }
    out[i] = cnt ? sum / static_cast<double>(cnt) : NAN;
  }
  return out;
}

Split split_series(const TimeSeries& s, const SplitOptions& o) {
  Split r;
  const std::size_t n = std::min(s.t.size(), s.y.size());
  if (n == 0) {
    r.static_value = r.mean_increment = r.amplitude = NAN;
    return r;
  }
  // Static value: the mean over the second half of the rest period, or the first sample(s) when
  // the load starts at t ≈ 0.
  std::size_t cnt = 0;
  if (o.load_start > 0.2) // [load_start/2, load_start): the load start itself excluded
    r.static_value = mean_in(s, 0.5 * o.load_start, o.load_start * (1.0 - 1e-9) - 1e-12, &cnt);
  if (cnt == 0) {
    // the sample nearest to the load start
    std::size_t best = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (std::abs(s.t[i] - o.load_start) < std::abs(s.t[best] - o.load_start)) best = i;
    r.static_value = s.y[best];
  }
  r.increment.resize(n);
  for (std::size_t i = 0; i < n; ++i) r.increment[i] = s.y[i] - r.static_value;
  r.mean = moving_average(s.t, r.increment, o.window);
  TimeSeries inc{s.t, r.increment};
  r.mean_increment = mean_in(inc, o.late_from, o.late_to);
  // Oscillation amplitude over the late window, only where the moving average has a full window.
  const double dt = n > 1 ? (s.t[n - 1] - s.t[0]) / static_cast<double>(n - 1) : 0.0;
  if (o.period > 0.0 && dt > o.period / 4.0) {
    r.amplitude = NAN; // sampled too coarsely to see the oscillation
    return r;
  }
  double sum2 = 0.0;
  std::size_t m = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (s.t[i] < o.late_from - 1e-12 || s.t[i] > o.late_to + 1e-12) continue;
    const double osc = r.increment[i] - r.mean[i];
    if (!std::isfinite(osc)) continue;
    sum2 += osc * osc;
    ++m;
  }
  r.amplitude = m ? std::sqrt(2.0 * sum2 / static_cast<double>(m)) : NAN; // sine: A = √2·RMS
  return r;
}

SplitOptions split_options(const scene::Scene* scene, double t_end) {
  SplitOptions o;
  double period = 0.0;
  if (scene && scene->load.shaking) {
    const auto& a = scene->load.shaking->acceleration;
    o.load_start = a.start;
    if (a.frequency > 0.0) period = 1.0 / a.frequency;
  } else if (scene) {
    for (const auto& s : scene->structures)
      for (const auto* f : {&s.force_x, &s.force_z, &s.moment}) {
        if (f->kind == scene::TimeFunction::Kind::TSine && f->omega > 0.0)
          period = std::max(period, 2.0 * std::numbers::pi / f->omega);
        if (f->kind == scene::TimeFunction::Kind::Sine && f->frequency > 0.0) {
          period = std::max(period, 1.0 / f->frequency);
          o.load_start = f->start;
        }
      }
  }
  o.period = period;
  // Whole loading periods, about one second long (one period when it is longer).
  o.window = period > 0.0 ? std::max(1.0, std::round(1.0 / period)) * period : 1.0;
  // Late window: whole loading periods inside the last third of the loading span, ending half a
  // moving-average window before the end (where the moving mean still has its full window).
  if (period > 0.0) {
    o.late_to = std::max(o.load_start, t_end - 0.5 * o.window);
    const double k = std::max(1.0, std::floor((o.late_to - o.load_start) / 3.0 / period));
    o.late_from = std::max(o.load_start, o.late_to - k * period);
  } else {
    o.late_to = t_end;
    o.late_from = t_end - (t_end - o.load_start) / 3.0;
  }
  return o;
}

double MetricRow::largest_response() const {
  double big = 0.0;
  for (double x : {increment.dem, increment.continuum, amplitude.dem, amplitude.continuum})
    if (std::isfinite(x)) big = std::max(big, std::abs(x));
  return big;
}

MetricRow compare_metric(const MetricSeries& m, const SplitOptions& o, double threshold) {
  MetricRow r;
  r.def = m.def;
  r.dem_split = split_series(m.dem, o);
  r.continuum_split = split_series(m.continuum, o);
  r.static_part = {r.dem_split.static_value, r.continuum_split.static_value};
  r.increment = {r.dem_split.mean_increment, r.continuum_split.mean_increment};
  r.amplitude = {r.dem_split.amplitude, r.continuum_split.amplitude};
  // First divergence on the increments, on the DEM's time base inside the common span.
  double scale = 0.0;
  for (double v : r.dem_split.increment)
    if (std::isfinite(v)) scale = std::max(scale, std::abs(v));
  double scale_mean = 0.0;
  for (double v : r.dem_split.mean)
    if (std::isfinite(v)) scale_mean = std::max(scale_mean, std::abs(v));
  if (!m.continuum.t.empty() && !m.dem.t.empty()) {
    const double t1 = std::min(m.dem.t.back(), m.continuum.t.back());
    for (std::size_t k = 0; k < m.dem.t.size(); ++k) {
      const double t = m.dem.t[k];
      if (t < o.load_start - 1e-12 || t > t1) continue;
      const double dc = interpolate(m.continuum.t, r.continuum_split.increment, t);
      if (r.first_divergence < 0 && scale > 0 &&
          std::abs(dc - r.dem_split.increment[k]) > threshold * scale)
        r.first_divergence = t;
      const double mc = interpolate(m.continuum.t, r.continuum_split.mean, t);
      if (r.first_divergence_mean < 0 && scale_mean > 0 && std::isfinite(r.dem_split.mean[k]) &&
          std::abs(mc - r.dem_split.mean[k]) > threshold * scale_mean)
        r.first_divergence_mean = t;
    }
  }
  // Verdict: the late mean increments (and the oscillation amplitudes where both are measured)
  // within ±threshold of the DEM's.
  const double ri = r.increment.relative();
  const double ra = r.amplitude.relative();
  const bool inc_ok = std::isfinite(ri) && std::abs(ri) <= threshold;
  const bool amp_known = std::isfinite(ra);
  const bool amp_ok = !amp_known || std::abs(ra) <= threshold;
  r.diverges = !(inc_ok && amp_ok);
  auto ratio = [](const Part& p) {
    return std::isfinite(p.dem) && p.dem != 0.0 ? fmt::format("{:.2f}×", p.continuum / p.dem)
                                                : std::string("n/a");
  };
  const bool dz = all_zero(m.dem), cz = all_zero(m.continuum);
  if (dz != cz) {
    r.comparable = false;
    r.diverges = false;
    r.verdict = fmt::format("not comparable: the {} series is 0 throughout (nothing measured)",
                            dz ? "DEM" : "continuum");
    return r;
  }
  std::string v = r.diverges ? "diverge" : "agree";
  v += fmt::format(": mean increment continuum/DEM {} ({:.3g} vs {:.3g} {})", ratio(r.increment),
                   r.increment.continuum, r.increment.dem, m.def.unit);
  if (amp_known)
    v += fmt::format("; oscillation amplitude {} ({:.3g} vs {:.3g})", ratio(r.amplitude),
                     r.amplitude.continuum, r.amplitude.dem);
  else
    v += "; oscillation amplitude not compared (sampled too coarsely or not measured)";
  v += fmt::format("; threshold ±{:.0f} %", 100 * threshold);
  if (!std::isfinite(ri)) v += " (DEM mean increment 0: no relative measure)";
  // Scale: responses that are a sliver of the static value (a footing's rocking against its
  // weight: ±0.2 % in the main job) diverge on their own scale; the reader should see both.
  // Forces, moments and pressures only: the static value of a position or an angle is a datum.
  const double st = std::abs(r.static_part.dem);
  const bool magnitude = m.def.unit != "m" && m.def.unit != "rad";
  if (magnitude && std::isfinite(st) && st > 0.0) {
    const double big = r.largest_response();
    if (big < kSmallResponseShare * st)
      v += fmt::format("; in both solvers the response is at most {:.2g} % of the static value "
                       "({:.4g} {})",
                       100.0 * big / st, r.static_part.dem, m.def.unit);
  }
  r.verdict = v;
  return r;
}

namespace {
enum class Sides { Both, Dem, Continuum };

MetricSet collect(const fs::path& run_dir, const scene::Scene* scene, Sides sides) {
  MetricSet set;
  const bool want_dem = sides != Sides::Continuum, want_cont = sides != Sides::Dem;
  Csv dem, cont;
  for (const auto f : {file::structures, file::walls}) {
    if (want_dem) read_into(run_dir / dir::dem / f, dem);
    if (want_cont) read_into(run_dir / dir::continuum / f, cont);
  }
  // Owners that have a thrust (walls): from the scene, else from the walls.csv columns.
  std::vector<std::string> walls, bodies;
  for (const auto& [k, s] : (want_dem ? dem : cont).cols) {
    std::string owner, q, unit;
    split_column(k + " []", owner, q, unit);
    auto& list = q == col::thrust.name ? walls : bodies;
    if (std::find(list.begin(), list.end(), owner) == list.end()) list.push_back(owner);
  }
  auto is_wall = [&](const std::string& o) {
    return std::find(walls.begin(), walls.end(), o) != walls.end();
  };
  auto structure = [&](const std::string& o) -> const scene::Structure* {
    if (!scene) return nullptr;
    for (const auto& s : scene->structures)
      if (s.name == o) return &s;
    return nullptr;
  };
  auto add = [&](const std::string& owner, const StructQ& sq, const std::string& dem_file,
                 const std::string& cont_file) {
    const std::string key = output::key(owner, sq.column);
    if ((want_dem && !dem.cols.count(key)) || (want_cont && !cont.cols.count(key))) return;
    MetricSeries m;
    m.def.key = key;
    m.def.quantity = owner + " " + sq.quantity;
    m.def.unit = sq.column.unit;
    m.def.dem_source = "dem/" + dem_file + ": " + key;
    m.def.continuum_source = "continuum/" + cont_file + ": " + key;
    m.def.meaning = sq.meaning;
    if (want_dem) m.dem = dem.cols.at(key);
    if (want_cont) m.continuum = cont.cols.at(key);
    if ((!want_dem || all_zero(m.dem)) && (!want_cont || all_zero(m.continuum))) {
      const auto* s = structure(owner);
      const std::string_view q = sq.column.name;
      if (s && ((q == col::settlement.name && s->dof_z == scene::DofMode::Fixed) ||
                (q == col::rotation.name && s->dof_rotation == scene::DofMode::Fixed) ||
                (q == col::displacement_x.name && s->dof_x == scene::DofMode::Fixed)))
        m.note = "0 in both: the scene fixes this degree of freedom";
      else
        m.note = "0 in both";
      set.zero.push_back(std::move(m));
      return;
    }
    set.series.push_back(std::move(m));
  };
  for (const auto& w : walls) {
    for (const auto& sq : kWallQ) add(w, sq, std::string(file::walls), std::string(file::walls));
    // The same physical quantities under other names (output/contract.hpp).
    set.aliases.push_back({output::heading(w, col::reaction_x), output::key(w, col::thrust),
                           "the horizontal soil force: equal to the thrust on a vertical wall"});
    set.aliases.push_back({output::heading(w, col::force_x), output::key(w, col::thrust),
                           "structures.csv's horizontal soil force: walls.csv's reaction_x"});
    set.aliases.push_back({output::heading(w, col::force_z), output::key(w, col::reaction_z),
                           "structures.csv's vertical soil force: walls.csv's reaction_z"});
    // A wall's motion (settlement, rotation, displacement) is compared when it can move.
    for (const auto& sq : kBodyQ) {
      const std::string_view q = sq.column.name;
      if (q == col::force_x.name || q == col::force_z.name) continue;
      add(w, sq, std::string(file::structures), std::string(file::structures));
    }
  }
  for (const auto& b : bodies) {
    if (is_wall(b)) continue;
    // A structure whose DEM soil forces are 0 throughout while the continuum's are not: the
    // particles never touch it (e.g. a packing that leaves a gap under it).
    bool dem_zero = true, cont_zero = true, any = false;
    for (const auto& c : {col::force_x, col::force_z, col::moment}) {
      const std::string k = output::key(b, c);
      if (sides == Sides::Both && dem.cols.count(k) && cont.cols.count(k)) {
        any = true;
        dem_zero = dem_zero && all_zero(dem.cols.at(k));
        cont_zero = cont_zero && all_zero(cont.cols.at(k));
      }
    }
    if (any && dem_zero && !cont_zero)
      set.warnings.push_back(fmt::format(
          "The DEM's soil force and moment on '{}' are 0 throughout the run: no particle touches "
          "it, so its DEM motion is that of a body loaded without soil and its comparison with "
          "the continuum (where the soil is tied to it) is not a comparison of two soil models.",
          b));
    for (const auto& sq : kBodyQ)
      add(b, sq, std::string(file::structures), std::string(file::structures));
    if ((want_dem ? dem : cont).cols.count(output::key(b, col::applied_moment)))
      set.aliases.push_back(
          {output::heading(b, col::applied_moment), "(input)",
           "the applied load's moment: the same history in both by construction"});
  }
  // The continuum's last snapshot, when the surface below has read it (the small-strain check).
  std::optional<ContinuumSnapshot> last_snapshot;
  // Surface elevation: the DEM's surface-profile probe (highest particle top per x bin) against
  // the continuum's top boundary moved by its displacement (from the .vtu snapshots).
  {
    const fs::path sf = run_dir / dir::dem / file::surface;
    // A continuum run alone bins its surface as the scene's surface-profile probe would.
    std::size_t probe_bins = 0;
    if (scene)
      for (const auto& p : scene->probes)
        if (p.kind == scene::ProbeKind::SurfaceProfile)
          probe_bins = static_cast<std::size_t>(p.bins);
    if ((want_dem && fs::exists(sf)) || (!want_dem && probe_bins > 0)) {
      const CsvTable t = want_dem ? read_csv(sf) : CsvTable{};
      const auto time = want_dem ? t.column(col::time.name) : std::vector<double>{};
      const std::size_t nb = !want_dem              ? probe_bins
                             : t.columns.size() > 0 ? t.columns.size() - 1
                                                    : 0;
      double x0 = 0.0, x1 = 1.0;
      if (scene && !scene->domain.empty()) {
        x0 = x1 = scene->domain[0].x;
        for (const auto& q : scene->domain) {
          x0 = std::min(x0, q.x);
          x1 = std::max(x1, q.x);
        }
      }
      const auto snaps = want_cont
                             ? read_pvd_entries(run_dir / dir::continuum / file::continuum_pvd)
                             : decltype(read_pvd_entries(run_dir)){};
      if (nb > 0 && (!want_cont || !snaps.empty())) {
        MetricSeries m;
        m.def.key = "surface.elevation";
        m.def.quantity = "surface elevation (mean over the width)";
        m.def.unit = "m";
        m.def.dem_source = fmt::format(
            "dem/surface.csv: highest particle top in each of {} x bins, averaged over the bins",
            nb);
        m.def.continuum_source =
            "continuum/*.vtu snapshots: top of the soil cells + vertical displacement, "
            "averaged over the same bins";
        m.def.meaning = "ground level; its increment is minus the surface subsidence";
        for (std::size_t r = 0; r < t.rows.size(); ++r) {
          double sum = 0.0;
          int n = 0;
          for (std::size_t b = 0; b < nb; ++b) {
            const double v = t.rows[r][b + 1];
            if (std::isfinite(v)) {
              sum += v;
              ++n;
            }
          }
          if (n == 0) continue;
          m.dem.t.push_back(time[r]);
          m.dem.y.push_back(sum / n);
        }
        for (const auto& e : snaps) {
          try {
            auto snap = read_continuum_vtu(e.file);
            const auto z = continuum_surface(snap, x0, x1, static_cast<int>(nb));
            if (&e == &snaps.back()) last_snapshot = std::move(snap);
            double sum = 0.0;
            int n = 0;
            for (double v : z)
              if (std::isfinite(v)) {
                sum += v;
                ++n;
              }
            if (n == 0) continue;
            m.continuum.t.push_back(e.time);
            m.continuum.y.push_back(sum / n);
          } catch (const std::exception&) {
            // an unreadable snapshot is skipped
          }
        }
        if ((!want_dem || !m.dem.t.empty()) && (!want_cont || !m.continuum.t.empty()))
          set.series.push_back(std::move(m));
      }
    }
  }
  // The continuum's last snapshot against its small-strain kinematics: beyond about 10 % strain
  // the neglected quadratic terms of the strain (ε²/2, 5 % of ε) and the fixed reference geometry
  // make its displacements no soil's. A shaken cohesionless backfill reached ε_v = 7.9 at its top
  // corners and a 0.8 m rise of its surface (cases/README.md, "The continuum beyond small
  // strains").
  if (want_cont) {
    const auto snaps = read_pvd_entries(run_dir / dir::continuum / file::continuum_pvd);
    if (!snaps.empty()) {
      try {
        if (!last_snapshot) last_snapshot = read_continuum_vtu(snaps.back().file);
        const auto r = continuum_strain_range(*last_snapshot, kSmallStrainLimit);
        set.continuum_beyond_small_strain = r.share_beyond();
        if (r.area_beyond > 0.0)
          set.warnings.push_back(fmt::format(
              "The continuum leaves the small strains its kinematics assume: at t = {:.3g} s, "
              "{:.1f} % of the soil's area has a volumetric or plastic strain above {:.0f} % "
              "(largest volumetric strain {:.3g} at x = {:.3g} m, z = {:.3g} m; largest plastic "
              "strain {:.3g} at x = {:.3g} m, z = {:.3g} m). There its displacements (surface "
              "elevation, subsidence profile, settlements) are not those of a soil.",
              snaps.back().time, 100.0 * r.share_beyond(), 100.0 * kSmallStrainLimit,
              r.max_volumetric, r.vol_x, r.vol_z, r.max_plastic, r.plastic_x, r.plastic_z));
      } catch (const std::exception&) {
        // an unreadable snapshot: nothing to say about it
      }
    }
  }
  // Key quantities first: thrust, settlement, rotation, surface, then the rest.
  auto rank = [](const MetricSeries& m) {
    const std::string& k = m.def.key;
    for (const auto& [key, r] : {std::pair<const char*, int>{".thrust", 0},
                                 {".settlement", 1},
                                 {".rotation", 2},
                                 {"surface.", 3},
                                 {".moment", 4}})
      if (k.find(key) != std::string::npos) return r;
    return 10;
  };
  std::stable_sort(set.series.begin(), set.series.end(),
                   [&](const MetricSeries& a, const MetricSeries& b) { return rank(a) < rank(b); });
  return set;
}
} // namespace

MetricSet collect_metrics(const fs::path& run_dir, const scene::Scene* scene) {
  return collect(run_dir, scene, Sides::Both);
}

MetricSet collect_solver_metrics(const fs::path& run_dir, const scene::Scene* scene,
                                 scene::Solver solver) {
  return collect(run_dir, scene, solver == scene::Solver::Dem ? Sides::Dem : Sides::Continuum);
}

} // namespace demfem::compare
