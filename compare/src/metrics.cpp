#include "demfem/compare/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>
#include <set>

#include <fmt/format.h>

#include "demfem/compare/coarse_grain.hpp"
#include "demfem/compare/plot.hpp"
#include "demfem/compare/report.hpp"
#include "demfem/output/contract.hpp"
#include "profiles.hpp"

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

// The columns of one time series file: "<owner>.<q>" (or "<q>") without its unit → series.
using Columns = std::map<std::string, TimeSeries>;

Columns read_columns(const fs::path& path) {
  Columns out;
  if (!fs::exists(path)) return out;
  const CsvTable t = read_csv(path);
  const int tc = t.find(col::time.name);
  if (tc < 0) return out;
  const auto time = t.column(t.columns[static_cast<std::size_t>(tc)]);
  for (std::size_t c = 0; c < t.columns.size(); ++c) {
    if (static_cast<int>(c) == tc) continue;
    const auto br = t.columns[c].rfind(" [");
    out[t.columns[c].substr(0, br)] = {time, t.column(t.columns[c])};
  }
  return out;
}

// One solver's time series files under its folder, each read once when a row first asks.
class SolverFiles {
public:
  SolverFiles(fs::path dir, bool wanted) : dir_(std::move(dir)), wanted_(wanted) {}
  [[nodiscard]] bool wanted() const { return wanted_; }
  [[nodiscard]] const Columns& file(std::string_view name) {
    auto it = files_.find(name);
    if (it == files_.end())
      it = files_.emplace(std::string(name), wanted_ ? read_columns(dir_ / name) : Columns{}).first;
    return it->second;
  }
  // The series `key` of file `name`; null when not written (or this solver is not read).
  [[nodiscard]] const TimeSeries* find(std::string_view name, const std::string& key) {
    const auto& f = file(name);
    const auto it = f.find(key);
    return it == f.end() ? nullptr : &it->second;
  }

private:
  fs::path dir_;
  bool wanted_;
  std::map<std::string, Columns, std::less<>> files_;
};

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

MetricRow compare_metric(const MetricSeries& m, const SplitOptions& o, double report_threshold) {
  const double threshold = std::isfinite(m.def.threshold) ? m.def.threshold : report_threshold;
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
  std::string v(outcome_word(r));
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

std::string_view outcome_word(const MetricRow& r) {
  if (!r.comparable) return "n/a";
  if (r.def.role == Role::Check) return r.diverges ? "fails" : "holds";
  return r.diverges ? "diverge" : "agree";
}

namespace {
enum class Sides { Both, Dem, Continuum };

// The owners of the structure and wall columns in discovery order: walls (an owner with a
// thrust) and every owner of another column (walls among them).
struct OwnerLists {
  std::vector<std::string> walls, all;
  [[nodiscard]] bool is_wall(const std::string& o) const {
    return std::find(walls.begin(), walls.end(), o) != walls.end();
  }
};

OwnerLists owner_lists(SolverFiles& files) {
  std::set<std::string> keys; // both files' columns, in key order
  for (const auto f : {file::structures, file::walls})
    for (const auto& [k, s] : files.file(f)) keys.insert(k);
  OwnerLists r;
  for (const auto& k : keys) {
    std::string owner, q, unit;
    if (!split_column(k + " []", owner, q, unit)) continue;
    auto& list = q == col::thrust.name ? r.walls : r.all;
    if (std::find(list.begin(), list.end(), owner) == list.end()) list.push_back(owner);
  }
  return r;
}

// Whether a row of these owners applies to a wall (or another structure).
bool applies(Owners owners, bool wall) {
  switch (owners) {
  case Owners::Walls:
    return wall;
  case Owners::Structures:
    return true;
  case Owners::Bodies:
    return !wall;
  case Owners::PressureTargets:
  case Owners::Scene:
    return false;
  }
  return false;
}

// One row applied to one owner ("" for the scene), without its series.
MetricSeries instance(const Metric& row, const std::string& owner) {
  MetricSeries m;
  m.def.key = owner.empty() ? std::string(row.key) : owner + "." + std::string(row.key);
  m.def.owner = owner;
  m.def.quantity =
      owner.empty() ? std::string(row.quantity) : owner + " " + std::string(row.quantity);
  m.def.unit = row.unit;
  m.def.meaning = row.meaning;
  m.def.role = row.role;
  m.def.threshold = row.threshold;
  m.def.rank = row.rank;
  m.def.scale = row.scale;
  return m;
}

// The note of a series that is 0 in both solvers.
std::string zero_note(const Metric& row, const scene::Structure* s) {
  using scene::DofMode;
  const bool fixed = s && ((row.dof == Dof::Z && s->dof_z == DofMode::Fixed) ||
                           (row.dof == Dof::Rotation && s->dof_rotation == DofMode::Fixed) ||
                           (row.dof == Dof::X && s->dof_x == DofMode::Fixed));
  return fixed ? "0 in both: the scene fixes this degree of freedom" : "0 in both";
}

const scene::Structure* structure_named(const scene::Scene* scene, const std::string& name) {
  if (scene)
    for (const auto& s : scene->structures)
      if (s.name == name) return &s;
  return nullptr;
}

// A Read::Column row of one owner ("" for the scene): its series in each solver read, or nothing
// when a solver read does not write it.
std::optional<MetricSeries> read_column(const Metric& row, const std::string& owner,
                                        SolverFiles& dem, SolverFiles& cont) {
  const std::string key =
      owner.empty() ? std::string(row.source.column.name) : output::key(owner, row.source.column);
  const TimeSeries* d = dem.find(row.source.file, key);
  const TimeSeries* c = cont.find(row.source.file, key);
  if ((dem.wanted() && !d) || (cont.wanted() && !c)) return std::nullopt;
  MetricSeries m = instance(row, owner);
  m.def.dem_source = fmt::format("{}/{}: {}", dir::dem, row.source.file, key);
  m.def.continuum_source = fmt::format("{}/{}: {}", dir::continuum, row.source.file, key);
  if (d) m.dem = *d;
  if (c) m.continuum = *c;
  return m;
}

double finite_mean(const std::vector<double>& v) {
  double sum = 0.0;
  int n = 0;
  for (double x : v)
    if (std::isfinite(x)) {
      sum += x;
      ++n;
    }
  return n ? sum / n : NAN;
}

// A Read::SurfaceMean row: the DEM's surface-profile probe (highest particle top per x bin)
// against the continuum's top boundary moved by its displacement (the .vtu snapshots), each
// averaged over the bins. A continuum run alone bins its surface as the scene's surface-profile
// probe would. `last` receives the continuum's last snapshot when it was read.
std::optional<MetricSeries> read_surface_mean(const Metric& row, const fs::path& run_dir,
                                              const scene::Scene* scene, Sides sides,
                                              std::optional<ContinuumSnapshot>& last) {
  const bool want_dem = sides != Sides::Continuum, want_cont = sides != Sides::Dem;
  const fs::path sf = run_dir / dir::dem / row.source.file;
  std::size_t probe_bins = 0;
  if (scene)
    for (const auto& p : scene->probes)
      if (p.kind == scene::ProbeKind::SurfaceProfile) probe_bins = static_cast<std::size_t>(p.bins);
  if (!((want_dem && fs::exists(sf)) || (!want_dem && probe_bins > 0))) return std::nullopt;
  const CsvTable t = want_dem ? read_csv(sf) : CsvTable{};
  const auto time = want_dem ? t.column(col::time.name) : std::vector<double>{};
  const std::size_t nb = !want_dem ? probe_bins : t.columns.size() > 0 ? t.columns.size() - 1 : 0;
  const auto [x0, x1] = detail::domain_x(scene);
  const auto snaps = want_cont ? read_pvd_entries(run_dir / dir::continuum / file::continuum_pvd)
                               : std::vector<PvdEntry>{};
  if (nb == 0 || (want_cont && snaps.empty())) return std::nullopt;
  MetricSeries m = instance(row, "");
  m.def.dem_source =
      fmt::format("{}/{}: highest particle top in each of {} x bins, averaged over the bins",
                  dir::dem, row.source.file, nb);
  m.def.continuum_source = "continuum/*.vtu snapshots: top of the soil cells + vertical "
                           "displacement, averaged over the same bins";
  for (std::size_t r = 0; r < t.rows.size(); ++r) {
    const auto& row_r = t.rows[r];
    const std::size_t n = std::min(nb + 1, row_r.size());
    const double z = n > 1 ? finite_mean({row_r.begin() + 1, row_r.begin() + n}) : NAN;
    if (!std::isfinite(z)) continue;
    m.dem.t.push_back(time[r]);
    m.dem.y.push_back(z);
  }
  for (const auto& e : snaps) {
    try {
      auto snap = read_continuum_vtu(e.file);
      const double z = finite_mean(continuum_surface(snap, x0, x1, static_cast<int>(nb)));
      if (&e == &snaps.back()) last = std::move(snap);
      if (!std::isfinite(z)) continue;
      m.continuum.t.push_back(e.time);
      m.continuum.y.push_back(z);
    } catch (const std::exception&) {
      // an unreadable snapshot is skipped
    }
  }
  if ((want_dem && m.dem.t.empty()) || (want_cont && m.continuum.t.empty())) return std::nullopt;
  return m;
}

// The continuum's last snapshot against its small-strain kinematics: beyond about 10 % strain
// the neglected quadratic terms of the strain (ε²/2, 5 % of ε) and the fixed reference geometry
// make its displacements no soil's. A shaken cohesionless backfill reached ε_v = 7.9 at its top
// corners and a 0.8 m rise of its surface (cases/README.md, "The continuum beyond small
// strains").
void check_small_strain(const fs::path& run_dir, std::optional<ContinuumSnapshot>& last,
                        MetricSet& set) {
  const auto snaps = read_pvd_entries(run_dir / dir::continuum / file::continuum_pvd);
  if (snaps.empty()) return;
  try {
    if (!last) last = read_continuum_vtu(snaps.back().file);
    const auto r = continuum_strain_range(*last, kSmallStrainLimit);
    set.continuum_beyond_small_strain = r.share_beyond();
    if (r.area_beyond > 0.0)
      set.warnings.push_back(fmt::format(
          "The continuum leaves the small strains its kinematics assume: at t = {:.3g} s, "
          "{:.1f} % of the soil's area has a volumetric or plastic strain above {:.0f} % "
          "(largest volumetric strain {:.3g} at x = {:.3g} m, z = {:.3g} m; largest plastic "
          "strain {:.3g} at x = {:.3g} m, z = {:.3g} m). There its displacements (surface "
          "elevation, subsidence profile, settlements) are not those of a soil.",
          snaps.back().time, 100.0 * r.share_beyond(), 100.0 * kSmallStrainLimit, r.max_volumetric,
          r.vol_x, r.vol_z, r.max_plastic, r.plastic_x, r.plastic_z));
  } catch (const std::exception&) {
    // an unreadable snapshot: nothing to say about it
  }
}

// A structure whose DEM soil forces are 0 throughout while the continuum's are not: the particles
// never touch it (e.g. a packing that leaves a gap under it).
void warn_untouched(const std::string& b, SolverFiles& dem, SolverFiles& cont, MetricSet& set) {
  bool dem_zero = true, cont_zero = true, any = false;
  for (const auto& c : {col::force_x, col::force_z, col::moment}) {
    const std::string k = output::key(b, c);
    const TimeSeries* d = dem.find(file::structures, k);
    const TimeSeries* n = cont.find(file::structures, k);
    if (!d || !n) continue;
    any = true;
    dem_zero = dem_zero && all_zero(*d);
    cont_zero = cont_zero && all_zero(*n);
  }
  if (any && dem_zero && !cont_zero)
    set.warnings.push_back(fmt::format(
        "The DEM's soil force and moment on '{}' are 0 throughout the run: no particle touches "
        "it, so its DEM motion is that of a body loaded without soil and its comparison with "
        "the continuum (where the soil is tied to it) is not a comparison of two soil models.",
        b));
}

// The columns of one owner that are a metric of the table under another name, and the load's own
// history, where the solver writes them.
void add_other_names(const std::string& owner, bool wall, std::span<const Metric> table,
                     SolverFiles& files, MetricSet& set) {
  for (const auto& on : other_names()) {
    const std::string k = output::key(owner, on.column);
    const bool written = files.find(file::structures, k) || files.find(file::walls, k);
    const bool input = on.same_as.name.empty();
    const bool compared = std::any_of(table.begin(), table.end(), [&](const Metric& m) {
      return m.subject == Subject::Series && m.source.read == Read::Column &&
             applies(m.owners, wall) && m.source.column.name == on.same_as.name;
    });
    if (applies(on.owners, wall) && written && (input || compared))
      set.aliases.push_back({output::heading(owner, on.column),
                             input ? std::string("(input)") : output::key(owner, on.same_as),
                             std::string(on.why)});
  }
}

MetricSet collect(const fs::path& run_dir, const scene::Scene* scene, Sides sides,
                  std::span<const Metric> table) {
  MetricSet set;
  SolverFiles dem(run_dir / dir::dem, sides != Sides::Continuum);
  SolverFiles cont(run_dir / dir::continuum, sides != Sides::Dem);
  // A series, or a note where it is 0 in every solver read.
  auto add = [&](const Metric& row, std::optional<MetricSeries> m, const std::string& owner) {
    if (!m) return;
    if ((!dem.wanted() || all_zero(m->dem)) && (!cont.wanted() || all_zero(m->continuum))) {
      m->note = zero_note(row, structure_named(scene, owner));
      set.zero.push_back(std::move(*m));
    } else {
      set.series.push_back(std::move(*m));
    }
  };
  // Walls first (their own rows, then their motion), then the other structures.
  const OwnerLists owners = owner_lists(dem.wanted() ? dem : cont);
  std::vector<std::string> order = owners.walls;
  for (const auto& o : owners.all)
    if (!owners.is_wall(o)) order.push_back(o);
  for (const auto& o : order) {
    const bool wall = owners.is_wall(o);
    if (!wall && sides == Sides::Both) warn_untouched(o, dem, cont, set);
    for (const auto& row : table)
      if (row.subject == Subject::Series && row.source.read == Read::Column &&
          row.owners != Owners::Scene && applies(row.owners, wall))
        add(row, read_column(row, o, dem, cont), o);
    add_other_names(o, wall, table, dem.wanted() ? dem : cont, set);
  }
  // The scene's own series.
  std::optional<ContinuumSnapshot> last_snapshot;
  for (const auto& row : table) {
    if (row.subject != Subject::Series || row.owners != Owners::Scene) continue;
    if (row.source.read == Read::Column) add(row, read_column(row, "", dem, cont), "");
    if (row.source.read == Read::SurfaceMean)
      if (auto m = read_surface_mean(row, run_dir, scene, sides, last_snapshot))
        set.series.push_back(std::move(*m));
  }
  if (cont.wanted()) check_small_strain(run_dir, last_snapshot, set);
  // Key quantities first (Metric::rank), in table order within a rank.
  std::stable_sort(
      set.series.begin(), set.series.end(),
      [](const MetricSeries& a, const MetricSeries& b) { return a.def.rank < b.def.rank; });
  return set;
}
} // namespace

MetricSet collect_metrics(const fs::path& run_dir, const scene::Scene* scene,
                          std::span<const Metric> table) {
  return collect(run_dir, scene, Sides::Both, table);
}

MetricSet collect_solver_metrics(const fs::path& run_dir, const scene::Scene* scene,
                                 scene::Solver solver, std::span<const Metric> table) {
  return collect(run_dir, scene, solver == scene::Solver::Dem ? Sides::Dem : Sides::Continuum,
                 table);
}

} // namespace demfem::compare
