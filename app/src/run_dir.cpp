#include "run_dir.hpp"

#include <algorithm>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include "command.hpp"
#include "demfem/dem/key_hash.hpp"
#include "demfem/dem/pack.hpp"
#include "demfem/scene/load.hpp"
#include "demfem/scene/write_file.hpp"
#include "demfem/studies/error_study.hpp"
#include "log.hpp"

namespace fs = std::filesystem;

namespace demfem::app {

namespace {

const std::vector<std::string> kDemOutputs = {"dem", "figures", "summary.json", "run_dem.json"};
const std::vector<std::string> kContinuumOutputs = {"continuum", "run_continuum.json"};
const std::vector<std::string> kReportOutputs = {"report.html", "metrics.json", "compare"};
// What any run writes besides its solver's outputs: its log, its scene, the calibration and the
// packing it makes, and the consoles of `run --jobs`.
const std::vector<std::string> kRunFiles = {"log.txt",      "scene.resolved.toml", "calibration",
                                            "packing",      "console.txt",         "pack.txt",
                                            "calibrate.txt"};

// The identity of a run directory: the scene as given (variant applied, before the calibration
// fills in the continuum), hashed. A DEM run, which does not calibrate, and a continuum run,
// which does, of the same scene share a directory; another scene does not. Written as a comment
// line of scene.resolved.toml (for the reader; the check reads .demfem/scene.toml).
constexpr std::string_view kIdentityTag = "# scene identity: ";
std::string scene_identity(const scene::Scene& given) {
  dem::KeyHash h;
  std::istringstream in(scene::to_toml(given));
  for (std::string l; std::getline(in, l);)
    if (l.rfind('#', 0) != 0) h.str(l); // the header names the file; the scene is the rest
  return fmt::format("{}{:016x}", kIdentityTag, h.h);
}

// .demfem/scene.toml: the scene of the folder's results; .demfem/dem.toml: the scene and engine
// of the DEM run whose checkpoint is in dem/.
fs::path scene_record(const fs::path& out) {
  return out / kOwnDir / "scene.toml";
}
fs::path dem_record(const fs::path& out) {
  return out / kOwnDir / "dem.toml";
}
constexpr std::string_view kLabelTag = "# scene: ";
constexpr std::string_view kEngineTag = "# DEM engine fingerprint: ";

std::string slurp(const fs::path& f) {
  std::ifstream in(f, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The value of a "# tag: value" line of a record ("" when absent).
std::string tagged(const std::string& text, std::string_view tag) {
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);)
    if (l.starts_with(tag)) return l.substr(tag.size());
  return {};
}

// (key path, value) in file order; continuation lines of a multi-line value belong to it.
std::vector<std::pair<std::string, std::string>> toml_entries(const std::string& text) {
  std::vector<std::pair<std::string, std::string>> v;
  std::map<std::string, int> tables; // [[name]] → how many so far
  std::string section;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) {
    if (l.empty() || l[0] == '#') continue;
    if (l.starts_with("[[")) {
      const std::string name = l.substr(2, l.find("]]") - 2);
      section = fmt::format("{}[{}]", name, tables[name]++);
      continue;
    }
    if (l[0] == '[') {
      section = l.substr(1, l.find(']') - 1);
      continue;
    }
    if ((l[0] == ' ' || l[0] == '\t' || l[0] == ']') && !v.empty()) {
      v.back().second += "\n" + l;
      continue;
    }
    const auto eq = l.find(" = ");
    const std::string key = eq == std::string::npos ? l : l.substr(0, eq);
    v.emplace_back(section.empty() ? key : section + "." + key,
                   eq == std::string::npos ? std::string() : l.substr(eq + 3));
  }
  return v;
}

std::string shown(std::string v) {
  std::replace(v.begin(), v.end(), '\n', ' ');
  std::string c;
  for (const char ch : v) // multi-line arrays' indentation folded
    if (!(ch == ' ' && !c.empty() && c.back() == ' ')) c += ch;
  return c.size() > 60 ? c.substr(0, 57) + "…" : c;
}

std::string read_or_empty(const fs::path& f) {
  std::error_code ec;
  return fs::is_regular_file(f, ec) ? slurp(f) : std::string();
}

} // namespace

const std::vector<std::string> kRunOutputs = [] {
  std::vector<std::string> v = kDemOutputs;
  v.insert(v.end(), kContinuumOutputs.begin(), kContinuumOutputs.end());
  v.insert(v.end(), kReportOutputs.begin(), kReportOutputs.end());
  return v;
}();

std::string first_difference(const std::string& here, const std::string& there,
                             const std::vector<std::string>& ignore) {
  auto a = toml_entries(here), b = toml_entries(there);
  const auto drop = [&](auto& v) {
    std::erase_if(v, [&](const auto& kv) {
      return std::find(ignore.begin(), ignore.end(), kv.first) != ignore.end();
    });
  };
  drop(a);
  drop(b);
  for (std::size_t i = 0; i < std::max(a.size(), b.size()); ++i) {
    if (i < a.size() && i < b.size() && a[i] == b[i]) continue;
    if (i < a.size() && i < b.size() && a[i].first == b[i].first)
      return fmt::format("{} = {} here, {} there", a[i].first, shown(a[i].second),
                         shown(b[i].second));
    // a key one of them has and the other has not (the first in file order)
    const bool here_only = i < a.size() && std::none_of(b.begin(), b.end(), [&](const auto& kv) {
                             return kv.first == a[i].first;
                           });
    if (i < a.size() && (here_only || i >= b.size()))
      return fmt::format("{} = {} here, not set there", a[i].first, shown(a[i].second));
    return fmt::format("{} = {} there, not set here", b[i].first, shown(b[i].second));
  }
  return {};
}

fs::path child_dir(const fs::path& base, const std::string& name, std::string_view what) {
  const bool bad = name.empty() || name == "." || name == ".." ||
                   name.find('/') != std::string::npos || name.find('\0') != std::string::npos;
  if (bad)
    throw UsageError(fmt::format(
        "the {} '{}' cannot name a folder (it would be empty, '.', '..', hold '/' or NUL, and so "
        "write outside {}): give it a plain name such as [A-Za-z0-9._-]+. Nothing was run.",
        what, name.find('\0') != std::string::npos ? name.substr(0, name.find('\0')) : name,
        base.empty() ? std::string("the run directory") : base.string()));
  return base / name;
}

fs::path run_dir_for(const scene::Scene& s, const RunArgs& a, std::size_t count,
                     std::string_view leaf) {
  fs::path out = a.out.empty() ? child_dir("runs", s.info.name, "scene name") : fs::path(a.out);
  if (a.out.empty() && !leaf.empty()) out /= leaf;
  if (count > 1 || (!s.variant.empty() && a.out.empty()))
    out = s.variant.empty() ? out / "base" : child_dir(out, s.variant, "variant name");
  return with_seed_dir(out, a);
}

int start_run_dir(const scene::Scene& s, const scene::Scene& given, const fs::path& out,
                  bool resume) {
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) {
    fmt::print(stderr, "demfem: cannot create the run directory {}: {}\n", out.string(),
               ec.message());
    return kRunFailed;
  }
  try {
    std::string text = scene::to_toml(s);
    text.insert(text.find('\n') + 1,
                scene_identity(given) +
                    " (the scene before calibration; a run into this directory must have it)\n");
    // under an MPI launcher the first rank writes it, after its checks (open_run_dir)
    if (studies::study_rank() == 0) scene::write_file_atomic(out / "scene.resolved.toml", text);
    setup_run_log(out, resume);
  } catch (const std::exception& e) {
    fmt::print(stderr, "demfem: cannot write into the run directory {}: {}\n", out.string(),
               e.what());
    return kRunFailed;
  }
  return kOk;
}

int open_run_dir(const scene::Scene& given, const fs::path& out, const RunArgs& a,
                 const RunDirUse& use, Ownership& own) {
  OwnRequest req;
  req.command = use.sub;
  req.writes = kRunFiles;
  std::vector<std::string> fresh;
  for (const auto* part :
       {use.dem ? &kDemOutputs : nullptr, use.continuum ? &kContinuumOutputs : nullptr,
        use.report ? &kReportOutputs : nullptr})
    if (part) fresh.insert(fresh.end(), part->begin(), part->end());
  req.writes.insert(req.writes.end(), fresh.begin(), fresh.end());
  req.must_exist = a.resume;
  req.must_exist_why = "no run to resume (start it without --resume)";
  if (const int rc = take_ownership(out, req, own); rc != kOk) return rc;
  if (!own.held()) return kOk; // an MPI rank > 0: the first rank checks and records

  const std::string sub = a.resume ? fmt::format("{} --resume", use.sub) : use.sub;
  const std::string here = scene::to_toml(given);
  const std::string there = read_or_empty(scene_record(out));
  const std::string there_label = tagged(there, kLabelTag);
  const auto refuse = [&](const std::string& why) {
    fmt::print(stderr, "demfem {}: {}. Nothing was run.\n", sub, why);
    own.release();
    return kBadInput;
  };
  std::vector<std::string> clear;
  // A DEM resume may run further; a continuum checkpoint holds its duration (the step
  // schedule): with one, the resume runs the same duration.
  std::vector<std::string> resumable;
  std::error_code exists_ec;
  if (!use.continuum || !fs::exists(out / "continuum" / "checkpoint.ckpt", exists_ec))
    resumable.push_back("scene.duration");
  const std::string dem_text = use.dem ? read_or_empty(dem_record(out)) : std::string();
  if (a.resume) {
    if (there.empty())
      return refuse(fmt::format("{} holds no record of the scene its results are of ({}): "
                                "there is no run to resume; start it without --resume",
                                out.string(), scene_record(out).string()));
    if (const auto d = first_difference(here, there, resumable); !d.empty())
      return refuse(fmt::format(
          "{} holds the results of another scene ('{}'; first difference: {}). A resume "
          "continues the same computation: run this scene without --resume into another --out "
          "(or with --force into this one, which replaces its results)",
          out.string(), there_label, d));
    if (use.dem) {
      if (dem_text.empty())
        return refuse(
            fmt::format("{} holds no DEM run to resume (no {}); start it without --resume",
                        out.string(), dem_record(out).string()));
      const std::string engine = tagged(dem_text, kEngineTag);
      if (engine != dem::engine_fingerprint())
        return refuse(fmt::format(
            "the DEM checkpoint in {} was written by DEM engine {}, this demfem is engine {}: "
            "a resume would not continue the same computation. Run the scene again without "
            "--resume (with --force if the folder holds another scene's results), or resume "
            "it with the demfem that started it",
            (out / "dem").string(), engine.empty() ? "?" : engine, dem::engine_fingerprint()));
      if (const auto d = first_difference(here, dem_text, resumable); !d.empty())
        return refuse(
            fmt::format("the scene is not the one the DEM checkpoint in {} was made with (first "
                        "difference: {}). A resume continues the same computation: run this scene "
                        "without --resume into another --out (or with --force into this one)",
                        (out / "dem").string(), d));
    }
  } else if (!there.empty()) {
    if (const auto d = first_difference(here, there); !d.empty()) {
      if (!a.force)
        return refuse(fmt::format(
            "{} holds the results of a different scene: '{}' (first difference: {}). Use "
            "another --out, or --force to clear the results demfem wrote there ({}) first",
            out.string(), there_label, d, fmt::join(kRunOutputs, ", ")));
      if (!use.check_only)
        fmt::print(stderr,
                   "demfem {}: --force: clearing the results of another scene in {} ('{}'; "
                   "first difference: {})\n",
                   sub, out.string(), there_label, d);
      clear = kRunOutputs;
    }
  }
  try {
    if (use.check_only) {
      own.commit();
      return kOk;
    }
    own.remove(clear);
    if (!a.resume) own.remove(fresh);
    std::error_code ec;
    if (!clear.empty()) fs::remove(dem_record(out), ec); // its checkpoint is gone
    const std::string label = fmt::format("{}{}\n", kLabelTag, given.label());
    scene::write_file_atomic(
        scene_record(out),
        "# demfem: the scene of this folder's results (as chosen, before calibration); a run of "
        "another scene into this folder is refused unless --force\n" +
            label + here);
    if (use.dem)
      scene::write_file_atomic(
          dem_record(out),
          "# demfem: the scene and the DEM engine of the run whose checkpoint is in dem/; "
          "--resume continues only that\n" +
              label + fmt::format("{}{}\n", kEngineTag, dem::engine_fingerprint()) + here);
    own.commit(); // the manifest (nothing it lists is written before), then the other ranks go on
  } catch (const std::exception& e) {
    fmt::print(stderr, "demfem {}: cannot write into the run directory {}: {}\n", sub, out.string(),
               e.what());
    return kRunFailed;
  }
  return kOk;
}

} // namespace demfem::app
