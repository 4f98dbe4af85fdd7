#include "run_dir.hpp"

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string_view>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "command.hpp"
#include "demfem/dem/key_hash.hpp"
#include "demfem/scene/load.hpp"
#include "demfem/scene/write_file.hpp"
#include "demfem/studies/error_study.hpp"
#include "log.hpp"

namespace fs = std::filesystem;

namespace demfem::app {

const std::vector<std::string> kRunOutputs = {"dem",          "continuum",         "figures",
                                              "summary.json", "report.html",       "metrics.json",
                                              "run_dem.json", "run_continuum.json"};

namespace {

// The identity of a run directory: the scene as given (variant applied, before the calibration
// fills in the continuum), hashed. A DEM run, which does not calibrate, and a continuum run,
// which does, of the same scene share a directory; another scene does not. Written as a comment
// line of scene.resolved.toml.
constexpr std::string_view kIdentityTag = "# scene identity: ";
std::string scene_identity(const scene::Scene& given) {
  dem::KeyHash h;
  std::istringstream in(scene::to_toml(given));
  for (std::string l; std::getline(in, l);)
    if (l.rfind('#', 0) != 0) h.str(l); // the header names the file; the scene is the rest
  return fmt::format("{}{:016x}", kIdentityTag, h.h);
}

// The resolved scene without its comment lines (they name the file it came from).
std::vector<std::string> scene_lines(const std::string& toml) {
  std::vector<std::string> lines;
  std::istringstream in(toml);
  for (std::string l; std::getline(in, l);)
    if (l.rfind('#', 0) != 0) lines.push_back(l);
  return lines;
}

void remove_outputs(const fs::path& out, const std::vector<std::string>& names) {
  // Under an MPI launcher every rank runs this command; only the first clears (the others write
  // nothing into the run directory): two ranks clearing at once made the slower one fail with
  // "cannot clear …/continuum: No such file or directory" (exit 1) on a re-run into a used
  // directory with mpirun -np 2.
  if (studies::study_rank() != 0) return;
  for (const auto& n : names) {
    std::error_code ec;
    fs::remove_all(out / n, ec);
    if (ec)
      throw std::runtime_error(
          fmt::format("cannot clear {}: {}", (out / n).string(), ec.message()));
  }
}

} // namespace

fs::path run_dir_for(const scene::Scene& s, const RunArgs& a, std::size_t count) {
  fs::path out = a.out.empty() ? fs::path("runs") / s.info.name : fs::path(a.out);
  if (count > 1 || (!s.variant.empty() && a.out.empty()))
    out /= s.variant.empty() ? "base" : s.variant;
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
    scene::write_file_atomic(out / "scene.resolved.toml", text);
    setup_run_log(out, resume);
  } catch (const std::exception& e) {
    fmt::print(stderr, "demfem: cannot write into the run directory {}: {}\n", out.string(),
               e.what());
    return kRunFailed;
  }
  return kOk;
}

int prepare_run_dir(const scene::Scene& s, const scene::Scene& given, const fs::path& out,
                    const RunArgs& a, const char* sub, const std::vector<std::string>& fresh) {
  if (a.resume || !fs::exists(out)) return kOk;
  const fs::path resolved = out / "scene.resolved.toml";
  std::string why;
  if (fs::exists(resolved)) {
    std::ifstream in(resolved);
    std::stringstream ss;
    ss << in.rdbuf();
    const auto old_lines = scene_lines(ss.str()), new_lines = scene_lines(scene::to_toml(s));
    // The directory's identity (scene_identity) when it records one; else, from an older demfem,
    // the resolved scenes themselves.
    const std::string id = scene_identity(given);
    std::string old_id;
    {
      std::istringstream t(ss.str());
      for (std::string l; std::getline(t, l);)
        if (l.starts_with(kIdentityTag)) old_id = l.substr(0, id.size());
    }
    if (old_id.empty() ? old_lines != new_lines : old_id != id) {
      std::size_t i = 0;
      while (i < old_lines.size() && i < new_lines.size() && old_lines[i] == new_lines[i]) ++i;
      // "# resolved scene: <label> (from <file>)", the first line to_toml writes
      std::string label = ss.str().substr(0, ss.str().find('\n'));
      const std::string tag = "# resolved scene: ";
      label = label.rfind(tag, 0) == 0
                  ? label.substr(tag.size(), label.rfind(" (from") - tag.size())
                  : std::string("?");
      why = fmt::format("{} is scene '{}' (first difference: `{}` there, `{}` here)",
                        resolved.string(), label, i < old_lines.size() ? old_lines[i] : "",
                        i < new_lines.size() ? new_lines[i] : "");
    }
  } else {
    for (const char* n : {"dem", "continuum"})
      if (fs::exists(out / n) && why.empty())
        why = fmt::format("it holds {}/ but no scene.resolved.toml saying which scene wrote it",
                          (out / n).string());
  }
  if (!why.empty()) {
    if (!a.force) {
      fmt::print(stderr,
                 "demfem {}: {} holds the results of a different scene: {}. Nothing was run. Use "
                 "another --out, or --force to clear its results ({}) first.\n",
                 sub, out.string(), why, fmt::join(kRunOutputs, ", "));
      return kBadInput;
    }
    fmt::print(stderr, "demfem {}: --force: clearing the results of another scene in {} ({})\n",
               sub, out.string(), why);
    remove_outputs(out, kRunOutputs);
  }
  remove_outputs(out, fresh);
  return kOk;
}

} // namespace demfem::app
