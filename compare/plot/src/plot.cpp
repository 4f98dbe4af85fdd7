#include "demfem/compare/plot.hpp"
#include "demfem/compare/gnuplot_run.hpp"
#include "demfem/compare/out_file.hpp"
#include "demfem/compare/raster.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <thread>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace fs = std::filesystem;

namespace demfem::compare {

namespace {
// gnuplot string literal: single quotes, doubled inside.
std::string quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}
// A title: single-quoted as above, or double-quoted with "\n" escapes when it has line breaks
// (a single-quoted gnuplot string cannot hold one).
std::string quote_title(const std::string& s) {
  if (s.find('\n') == std::string::npos) return quote(s);
  std::string out = "\"";
  for (char c : s)
    out += c == '\n'               ? std::string("\\n")
           : c == '"' || c == '\\' ? std::string("\\") + c
                                   : std::string(1, c);
  return out + "\"";
}
bool run_gnuplot(const fs::path& script, std::string* error) {
  const auto r = detail::run_gnuplot_scripts({script}, 1);
  if (r[0].empty()) return true;
  if (error) *error = r[0];
  return false;
}
// A PNG ends with its IEND chunk, an SVG with </svg>: gnuplot exits 0 over a figure a full disk
// or a file size limit cut short.
bool image_whole(const fs::path& f) {
  std::ifstream in(f, std::ios::binary);
  if (!in) return false;
  in.seekg(0, std::ios::end);
  const auto size = static_cast<long long>(in.tellg());
  const long long tail = std::min<long long>(size, 64);
  std::string t(static_cast<std::size_t>(tail), '\0');
  in.seekg(size - tail);
  in.read(t.data(), tail);
  if (!in) return false;
  if (f.extension() == ".svg") return t.find("</svg>") != std::string::npos;
  return size >= 12 &&
         t.compare(t.size() - 12, 12, std::string("\0\0\0\0IEND\xae\x42\x60\x82", 12)) == 0;
}
bool run_or_queue(const fs::path& png, const fs::path& script, std::string* error,
                  PlotQueue* queue) {
  if (!queue) {
    if (!run_gnuplot(script, error)) return false;
    fs::path svg = png;
    svg.replace_extension(".svg");
    for (const auto& f : {png, svg}) {
      std::error_code ec;
      if ((f == svg && !fs::exists(f, ec)) || image_whole(f)) continue;
      fs::remove(png, ec); // no figure rather than a cut one
      fs::remove(svg, ec);
      if (error)
        *error = fmt::format("cannot write {}: the figure is missing or cut short (a full disk or "
                             "a file size limit?)",
                             f.string());
      return false;
    }
    return true;
  }
  queue->pngs.push_back(png);
  queue->scripts.push_back(script);
  return true;
}
} // namespace

bool plot(const PlotSpec& spec, const fs::path& png, std::string* error, PlotQueue* queue) {
  std::size_t finite = 0;
  for (const auto& se : spec.series)
    for (std::size_t i = 0; i < std::min(se.x.size(), se.y.size()); ++i)
      finite += std::isfinite(se.x[i]) && std::isfinite(se.y[i]);
  if (finite == 0) {
    if (error) *error = "no finite data to plot";
    return false;
  }
  fs::create_directories(png.parent_path().empty() ? fs::path(".") : png.parent_path());
  fs::path stem = png;
  stem.replace_extension();
  const fs::path dat = stem.string() + ".dat";
  const fs::path gp = stem.string() + ".gp";
  {
    OutFile d(dat);
    d.precision(10);
    for (std::size_t s = 0; s < spec.series.size(); ++s) {
      d << "# " << spec.series[s].label << "\n";
      const auto& se = spec.series[s];
      for (std::size_t i = 0; i < std::min(se.x.size(), se.y.size()); ++i)
        if (std::isfinite(se.x[i]) && std::isfinite(se.y[i]))
          d << se.x[i] << " " << se.y[i] << "\n";
      d << "\n\n"; // gnuplot data block separator (index s)
    }
    d.close();
  }
  OutFile g(gp);
  std::string body;
  body +=
      fmt::format("set title {} noenhanced\nset xlabel {} noenhanced\nset ylabel {} noenhanced\n",
                  quote_title(spec.title), quote(spec.xlabel), quote(spec.ylabel));
  body += "set grid lc rgb '#dddddd'\nset key outside right top noenhanced\n";
  if (spec.equal_axes) body += "set size ratio -1\n";
  if (spec.log_x) body += "set logscale x\nset format x '%.0e'\n";
  if (spec.log_y) body += "set logscale y\nset format y '%.0e'\n";
  std::string clauses;
  for (std::size_t s = 0; s < spec.series.size(); ++s) {
    const auto& se = spec.series[s];
    if (!clauses.empty()) clauses += ", \\\n     ";
    clauses += fmt::format("{} index {} using 1:2 with {} title {} {}",
                           quote(dat.filename().string()), s, se.style, quote(se.label), se.extra);
  }
  if (clauses.empty()) clauses = "NaN notitle";
  body += "plot " + clauses + "\n";
  fs::path svg = png;
  svg.replace_extension(".svg");
  g << "# demfem figure; re-plot with: gnuplot " << gp.filename().string() << "\n";
  g << "cd " << quote(fs::absolute(dat).parent_path().string()) << "\n";
  g << fmt::format(
      "set terminal pngcairo size {},{} enhanced font 'DejaVu Sans,11'\nset output {}\n",
      spec.width, spec.height, quote(fs::absolute(png).string()));
  g << body;
  g << fmt::format(
      "set terminal svg size {},{} dynamic enhanced font 'DejaVu Sans,11'\nset output {}\n",
      spec.width, spec.height, quote(fs::absolute(svg).string()));
  g << "replot\nset output\n";
  g.close();
  return run_or_queue(png, gp, error, queue);
}

bool plot_particles(const dem::Particles& p, const std::vector<dem::ContactView>& contacts,
                    const std::vector<dem::BoundaryView>& boundaries, const SnapshotSpec& spec,
                    const fs::path& png, std::string* error, PlotQueue* queue) {
  fs::create_directories(png.parent_path().empty() ? fs::path(".") : png.parent_path());
  fs::path stem = png;
  stem.replace_extension();
  const fs::path ppng = stem.string() + ".particles.png";
  const fs::path cdat = stem.string() + ".chains.dat";
  const fs::path bdat = stem.string() + ".walls.dat";
  const fs::path gp = stem.string() + ".gp";

  double xmin = 1e300, xmax = -1e300, zmin = 1e300, zmax = -1e300, vmax = 0.0;
  std::vector<detail::RasterDisk> disks; // drawn as one image below (raster.hpp)
  disks.reserve(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!p.flags.empty() && (p.flags[i] & dem::kFlagRemoved)) continue;
    const double v = std::hypot(p.vx[i], p.vz[i]);
    vmax = std::max(vmax, v);
    xmin = std::min(xmin, p.x[i] - p.radius[i]);
    xmax = std::max(xmax, p.x[i] + p.radius[i]);
    zmin = std::min(zmin, p.z[i] - p.radius[i]);
    zmax = std::max(zmax, p.z[i] + p.radius[i]);
    disks.push_back({p.x[i], p.z[i], p.radius[i], p.vx[i], p.vz[i], v});
  }
  const double pxmin = xmin, pxmax = xmax, pzmin = zmin, pzmax = zmax; // the particles' extent
  double fmax = 0.0;
  for (const auto& c : contacts) fmax = std::max(fmax, std::abs(c.fn));
  // Force chains in 4 width classes by |fn|/max (gnuplot's vectors take no variable width);
  // blocks 0–3 compression, 4–7 tension.
  constexpr int kClasses = 4;
  std::vector<bool> has_block(2 * kClasses, false);
  const bool chains = spec.force_chains && !spec.velocity_arrows; // what the script draws
  std::string title = spec.title;
  if (chains) {
    // The pairs (a wall contact draws no chain), at most max_chain_lines of them: the strongest.
    std::vector<std::size_t> pairs;
    std::vector<double> magnitude;
    for (std::size_t k = 0; k < contacts.size(); ++k)
      if (contacts[k].j >= 0) {
        pairs.push_back(k);
        magnitude.push_back(std::abs(contacts[k].fn));
      }
    const auto drawn = detail::strongest(magnitude, spec.max_chain_lines);
    if (drawn.size() < pairs.size())
      title +=
          fmt::format(" (chains: the strongest {} of {} contacts)", drawn.size(), pairs.size());
    OutFile d(cdat);
    d.precision(8);
    for (int block = 0; block < 2 * kClasses; ++block) {
      const bool tension = block >= kClasses;
      const int cls = block % kClasses;
      d << "# " << (tension ? "tension" : "compression") << " class " << cls << "\n";
      for (const std::size_t q : drawn) {
        const auto& c = contacts[pairs[q]];
        if (c.tensile != tension || fmax <= 0.0) continue;
        const int k = std::min(kClasses - 1, static_cast<int>(kClasses * std::abs(c.fn) / fmax));
        if (k != cls) continue;
        const auto j = static_cast<std::size_t>(c.j);
        d << p.x[c.i] << " " << p.z[c.i] << " " << p.x[j] - p.x[c.i] << " " << p.z[j] - p.z[c.i]
          << "\n";
        has_block[block] = true;
      }
      if (!has_block[block]) d << "NaN NaN NaN NaN\n";
      d << "\n\n";
    }
    d.close();
  } else { // a velocity field draws no chains: no file (nor one left from an earlier run)
    std::error_code ec;
    fs::remove(cdat, ec);
  }
  {
    OutFile d(bdat);
    d.precision(8);
    for (const auto& b : boundaries) {
      if (b.open) continue;
      for (std::size_t k = 0; k < b.x.size(); ++k) {
        d << b.x[k] << " " << b.z[k] << "\n";
        xmin = std::min(xmin, b.x[k]);
        xmax = std::max(xmax, b.x[k]);
        zmin = std::min(zmin, b.z[k]);
        zmax = std::max(zmax, b.z[k]);
      }
      if (b.closed && !b.x.empty()) d << b.x[0] << " " << b.z[0] << "\n";
      d << "\n";
    }
    d << "NaN NaN\n";
    d.close();
  }
  if (!(xmax > xmin)) xmin = 0, xmax = 1;
  const fs::path vdat = stem.string() + ".velocity.dat";
  if (spec.velocity_arrows) { // cell means, as the strips draw them (raster.hpp); the longest
                              // arrow 0.9 cells
    const double cell = std::max(pxmax - pxmin, pzmax - pzmin) / 48.0;
    const auto v = detail::cell_mean_velocity(disks, pxmin, pxmax, pzmin, pzmax, cell);
    OutFile d(vdat);
    d << detail::cell_arrows(v, pxmin, pzmin, v.vmax > 0.0 ? 0.9 * cell / v.vmax : 0.0);
    d.close();
  }
  if (!(zmax > zmin)) zmin = 0, zmax = 1;
  const double aspect = (zmax - zmin) / (xmax - xmin);
  const int w = 1200;
  const int h = std::clamp(static_cast<int>(w * aspect) + 80, 300, 1600);
  fs::path svg = png;
  svg.replace_extension(".svg");

  OutFile g(gp);
  g << "# demfem particle snapshot; re-plot with: gnuplot " << gp.filename().string() << "\n";
  g << "cd " << quote(fs::absolute(ppng).parent_path().string()) << "\n";
  g << fmt::format(
      "set terminal pngcairo size {},{} enhanced font 'DejaVu Sans,11'\nset output {}\n", w, h,
      quote(fs::absolute(png).string()));
  g << fmt::format(
      "set title {} noenhanced\nset size ratio -1\nset xrange [{}:{}]\nset yrange [{}:{}]\n",
      quote(title), xmin, xmax, zmin, zmax);
  g << "set xlabel 'x [m]'\nset ylabel 'z [m]'\nset cblabel 'speed [m/s]'\n";
  g << "set palette defined " << detail::kPaletteGnuplot << "\n";
  g << fmt::format("set cbrange [0:{}]\n", vmax > 0 ? vmax : 1.0);
  g << "set key off\n";
  // The particles: one image of filled disks, ≈ 1,000 pixels along the longer side (about the plot
  // area), coloured by speed (raster.hpp); drawing each disk `with circles` (translucent, `fill
  // solid 0.85`) was ≈ 0.1 s of the figure's 0.25 s at 3,400 disks.
  {
    const detail::Raster grid = detail::raster_grid(pxmin, pxmax, pzmin, pzmax, 1000.0);
    std::error_code ec;
    fs::remove(stem.string() + ".particles.dat", ec); // the disks' table of earlier versions
    if (disks.empty() || grid.w <= 0) {               // no particle left in the model: no layer
      fs::remove(ppng, ec);
    } else {
      OutFile d(ppng);
      d << detail::raster_png(grid, disks, vmax, nullptr);
      d.close();
      g << detail::raster_pixmap(grid, ppng.filename().string(), 1);
    }
  }
  std::string cl = "NaN with lines lc palette frac 0"; // keeps the colour box
  for (int block = 0; chains && block < 2 * kClasses; ++block) {
    if (!has_block[block]) continue;
    const bool tension = block >= kClasses;
    const double lw = 0.4 + spec.chain_width_max * ((block % kClasses) + 1) / kClasses;
    cl += fmt::format(
        ", \\\n  {} index {} using 1:2:3:4 with vectors nohead lw {:.2f} {} lc rgb '{}'",
        quote(cdat.filename().string()), block, lw, tension ? "dt 2" : "",
        tension ? "#7b3294" : "#222222");
  }
  if (spec.velocity_arrows)
    cl += fmt::format(", \\\n  {} using 1:2:3:4 with vectors head filled size screen 0.006,20 "
                      "lw 1 lc rgb '#111111'",
                      quote(vdat.filename().string()));
  cl += fmt::format(", \\\n  {} using 1:2 with lines lw 3 lc rgb '#000000'",
                    quote(bdat.filename().string()));
  g << "plot " << cl << "\n";
  // No SVG twin: with one circle per particle and one line per contact it is 5× the PNG (6–7 MB
  // for the 3,400-disk wall) and costs 40 % of the figure's time; the script draws one on demand.
  g << "set output\n";
  g << fmt::format("# SVG: set terminal svg size {},{} dynamic enhanced font 'DejaVu Sans,11'; "
                   "set output {}; replot\n",
                   w, h, quote(fs::absolute(svg).string()));
  g.close();
  return run_or_queue(png, gp, error, queue);
}

std::vector<std::string> draw_queued(const PlotQueue& queue, unsigned processes) {
  const std::size_t n = queue.scripts.size();
  if (processes == 0) processes = std::max(1u, std::thread::hardware_concurrency());
  // Contiguous groups of about equal count, one process each.
  const std::size_t groups = std::min<std::size_t>(processes, n);
  std::vector<std::vector<fs::path>> jobs(groups);
  for (std::size_t g = 0; g < groups; ++g)
    for (std::size_t k = n * g / groups; k < n * (g + 1) / groups; ++k)
      jobs[g].push_back(queue.scripts[k]);
  const auto job_err = detail::run_gnuplot_jobs(jobs, processes);
  std::vector<std::string> err(n);
  for (std::size_t g = 0; g < groups; ++g) {
    if (job_err[g].empty()) continue;
    // gnuplot stops at a failing script: run the group's scripts again one by one.
    const auto one = detail::run_gnuplot_scripts(jobs[g], processes);
    for (std::size_t k = 0; k < jobs[g].size(); ++k) err[n * g / groups + k] = one[k];
    // A group that failed although each of its scripts draws alone means the grouping itself is
    // broken (as with relative script names until the twenty-fourth session): every figure is then
    // drawn twice, silently. Say so.
    if (std::all_of(one.begin(), one.end(), [](const std::string& e) { return e.empty(); }))
      spdlog::warn("gnuplot: {} scripts from {} failed when run in one process but each drew "
                   "alone: they were drawn one process each (slower)",
                   jobs[g].size(), jobs[g].front().string());
  }
  return err;
}

std::vector<double> running_mean(const std::vector<double>& y, std::size_t window) {
  std::vector<double> out(y.size(), 0.0);
  if (y.empty()) return out;
  window = std::max<std::size_t>(1, window);
  const std::size_t half = window / 2;
  // prefix sums: mean over [i − half, i + half] clipped to the series
  std::vector<double> pre(y.size() + 1, 0.0);
  for (std::size_t i = 0; i < y.size(); ++i) pre[i + 1] = pre[i] + y[i];
  for (std::size_t i = 0; i < y.size(); ++i) {
    const std::size_t a = i >= half ? i - half : 0;
    const std::size_t b = std::min(y.size(), i + half + 1);
    out[i] = (pre[b] - pre[a]) / static_cast<double>(b - a);
  }
  return out;
}

namespace detail {

std::vector<std::string> run_gnuplot_scripts(const std::vector<fs::path>& scripts,
                                             unsigned parallel) {
  std::vector<std::vector<fs::path>> jobs;
  jobs.reserve(scripts.size());
  for (const auto& s : scripts) jobs.push_back({s});
  return run_gnuplot_jobs(jobs, parallel);
}

namespace {
// gnuplot's environment: ours, with
// - glibc's malloc asked for transparent huge pages (GLIBC_TUNABLES glibc.malloc.hugetlb=1, added
//   to what the variable holds unless it sets hugetlb itself). A 2,800 × 1,192 strip allocates
//   its canvas, the decoded panel images and the PNG encoder's rows afresh: 13,000 page faults
//   with 4 KiB pages, 2,700–3,700 with huge pages, and 7–22 % less gnuplot CPU time per figure on
//   a virtual machine (bench/RESULTS.md, twenty-first session). Where the kernel offers no huge
//   pages the setting does nothing; other C libraries ignore the variable.
// - the PNG encoder module (png_preload.cpp) added to LD_PRELOAD, when it is where the build put
//   it and DEMFEM_PNG_PRELOAD is not 0: the same pixels, ≈ 30 % less gnuplot time per strip.
std::vector<std::string> gnuplot_environment() {
  std::string preload;
#ifdef DEMFEM_PNG_PRELOAD
  {
    const char* off = std::getenv("DEMFEM_PNG_PRELOAD");
    std::error_code ec;
    const std::string path = DEMFEM_PNG_PRELOAD;
    if (!(off && std::string(off) == "0") && path.find_first_of(" :") == std::string::npos &&
        fs::is_regular_file(path, ec)) // (LD_PRELOAD splits at spaces and colons)
      preload = path;
  }
#endif
  std::vector<std::string> e;
  bool have = false, have_preload = false;
  for (char** v = environ; v && *v; ++v) {
    std::string s(*v);
    if (s.rfind("GLIBC_TUNABLES=", 0) == 0) {
      have = true;
      if (s.find("glibc.malloc.hugetlb") == std::string::npos)
        s += (s.size() > std::strlen("GLIBC_TUNABLES=") ? ":" : "") +
             std::string("glibc.malloc.hugetlb=1");
    }
    if (!preload.empty() && s.rfind("LD_PRELOAD=", 0) == 0) {
      have_preload = true;
      s += (s.size() > std::strlen("LD_PRELOAD=") ? ":" : "") + preload;
    }
    e.push_back(std::move(s));
  }
  if (!have) e.emplace_back("GLIBC_TUNABLES=glibc.malloc.hugetlb=1");
  if (!preload.empty() && !have_preload) e.push_back("LD_PRELOAD=" + preload);
  return e;
}
} // namespace

std::vector<std::string> run_gnuplot_jobs(const std::vector<std::vector<fs::path>>& jobs,
                                          unsigned parallel) {
  if (parallel == 0) parallel = std::max(1u, std::thread::hardware_concurrency());
  std::vector<fs::path> scripts; // each job's first script: names its log and its errors
  for (const auto& j : jobs) scripts.push_back(j.empty() ? fs::path() : j.front());
  std::vector<std::string> err(scripts.size());
  std::vector<pid_t> pid(scripts.size(), -1);
  auto log_of = [&](std::size_t k) { return scripts[k].string() + ".log"; };
  auto finish = [&](std::size_t k, int status) {
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
      std::error_code ec;
      fs::remove(log_of(k), ec);
      return;
    }
    err[k] = WIFEXITED(status) ? fmt::format("gnuplot failed (exit {}) on {}; see {}",
                                             WEXITSTATUS(status), scripts[k].string(), log_of(k))
                               : fmt::format("gnuplot failed (signal {}) on {}; see {}",
                                             WTERMSIG(status), scripts[k].string(), log_of(k));
  };
  const std::vector<std::string> env = gnuplot_environment();
  std::vector<char*> envp;
  for (const auto& v : env) envp.push_back(const_cast<char*>(v.c_str()));
  envp.push_back(nullptr);
  // Started in order, waited for in order (the oldest first): only these children are reaped.
  std::vector<std::size_t> queue; // running scripts, oldest first
  std::size_t next = 0;
  while (next < scripts.size() || !queue.empty()) {
    while (next < scripts.size() && queue.size() < parallel) {
      const std::size_t k = next++;
      if (jobs[k].empty()) continue;
      posix_spawn_file_actions_t fa;
      posix_spawn_file_actions_init(&fa);
      posix_spawn_file_actions_addopen(&fa, 1, log_of(k).c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                       0644);
      posix_spawn_file_actions_adddup2(&fa, 1, 2);
      std::vector<std::string> args{"gnuplot"};
      for (std::size_t q = 0; q < jobs[k].size(); ++q) {
        if (q > 0) { // the next script starts from gnuplot's defaults
          args.emplace_back("-e");
          args.emplace_back("reset");
        }
        // Absolute: each script may `cd` to its own folder, and a relative name after it (a run
        // with a relative --out) would then not be found, failing the whole job into the
        // one-by-one rerun of draw_queued (every figure drawn twice over).
        args.push_back(fs::absolute(jobs[k][q]).string());
      }
      std::vector<char*> argv;
      for (auto& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      pid_t p = -1;
      const int rc = posix_spawnp(&p, "gnuplot", &fa, nullptr, argv.data(), envp.data());
      posix_spawn_file_actions_destroy(&fa);
      if (rc != 0) {
        err[k] = fmt::format("gnuplot failed to start on {} ({}); is gnuplot-nox installed?",
                             scripts[k].string(), std::strerror(rc));
        continue;
      }
      pid[k] = p;
      queue.push_back(k);
    }
    if (queue.empty()) continue;
    const std::size_t k = queue.front();
    int status = 0;
    pid_t w;
    do w = ::waitpid(pid[k], &status, 0);
    while (w < 0 && errno == EINTR);
    queue.erase(queue.begin());
    if (w < 0)
      err[k] = fmt::format("gnuplot on {}: lost ({})", scripts[k].string(), std::strerror(errno));
    else
      finish(k, status);
  }
  return err;
}

} // namespace detail

} // namespace demfem::compare
