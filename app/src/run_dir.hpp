// Run directories: where a run writes, which scene a directory holds, the refusal to mix two
// scenes' results in one, and the check that a resume continues the same computation.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "demfem/scene/scene.hpp"
#include "ownership.hpp"
#include "scenes.hpp"

namespace demfem::app {

// What the solvers, figures and report write into a run directory (what --force clears).
extern const std::vector<std::string> kRunOutputs;

// base/name, where `name` must be one folder name: not empty, not "." or "..", no '/' and no NUL
// (so that nothing composed from a scene's or variant's name is absolute or leaves `base`).
// Throws UsageError naming `what` (e.g. "scene name") otherwise.
[[nodiscard]] std::filesystem::path child_dir(const std::filesystem::path& base,
                                              const std::string& name, std::string_view what);

// runs/<scene>[/<leaf>] or --out; /<variant> (or /base) when several scenes are chosen or a
// variant is run into the default; /seed-N for a --seed run into the default. Every component
// taken from a name goes through child_dir.
[[nodiscard]] std::filesystem::path run_dir_for(const scene::Scene& s, const RunArgs& a,
                                                std::size_t count, std::string_view leaf = {});

// What a command does in a run directory.
struct RunDirUse {
  const char* sub = "run"; // "run" or "compare" (messages)
  bool dem = false;        // runs the DEM solver
  bool continuum = false;  // runs the continuum solver
  bool report = false;     // writes report.html, metrics.json and compare/
  // Only check and record the entries (run --jobs, before it starts the runs that open the
  // directories themselves): nothing is cleared and no record is written.
  bool check_only = false;
};

// Opens the run directory `out` for a run of `given` (the scene as chosen, before calibration):
// takes it (ownership.hpp: a folder that is not demfem's, or that another command holds, is
// refused), then checks the scene against the directory's record (.demfem/scene.toml):
//  - a run of another scene is refused unless --force, which clears the listed outputs
//    (kRunOutputs) first; a run of the same scene clears the outputs it is about to write, so
//    figures and summaries are built only from files this run wrote;
//  - --resume needs the directory's record and, for the DEM, the record of the run its
//    checkpoint belongs to (.demfem/dem.toml: the scene and the DEM engine fingerprint); a
//    different scene (any key but scene.duration) or engine is refused, naming the first key
//    that differs.
// A refused command changes nothing in the directory. Returns kOk (the records written, `own`
// holding the lock), kBadInput or kRunFailed (message printed, naming `use.sub`).
int open_run_dir(const scene::Scene& given, const std::filesystem::path& out, const RunArgs& a,
                 const RunDirUse& use, Ownership& own);

// Writes scene.resolved.toml (the scene as run, with the identity of `given`) and opens log.txt.
// Returns kOk, or kRunFailed with a message naming the directory or file and the cause.
int start_run_dir(const scene::Scene& s, const scene::Scene& given,
                  const std::filesystem::path& out, bool resume);

// The first key (as section.key, e.g. "soil.dem.kn") whose value differs between two scenes
// written by scene::to_toml, with both values: "soil.dem.kn = 3000000.0 here, 1000000.0 there";
// "" when they are the same. Keys in `ignore` are not compared.
[[nodiscard]] std::string first_difference(const std::string& here, const std::string& there,
                                           const std::vector<std::string>& ignore = {});

} // namespace demfem::app
