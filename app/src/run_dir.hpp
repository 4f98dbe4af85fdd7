// Run directories: where a run writes, which scene a directory holds, and the refusal to mix two
// scenes' results in one.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "demfem/scene/scene.hpp"
#include "scenes.hpp"

namespace demfem::app {

// What the solvers, figures and report write into a run directory (what --force clears).
extern const std::vector<std::string> kRunOutputs;

// runs/<scene> or --out; /<variant> (or /base) when several scenes are chosen or a variant is run
// into the default; /seed-N for a --seed run into the default.
[[nodiscard]] std::filesystem::path run_dir_for(const scene::Scene& s, const RunArgs& a,
                                                std::size_t count);

// Before a run writes into `out`: a directory holding another scene's results (its
// scene.resolved.toml differs, or it has solver outputs and no scene.resolved.toml) is refused
// unless --force, which clears every solver output first. A fresh run of the same scene clears
// the outputs it is about to write (`fresh`), so figures and summaries are built only from files
// this run wrote; --resume keeps them. `s`: the scene as run (calibrated); `given`: as chosen.
// Returns kOk or kBadInput (message printed, naming `sub`).
int prepare_run_dir(const scene::Scene& s, const scene::Scene& given,
                    const std::filesystem::path& out, const RunArgs& a, const char* sub,
                    const std::vector<std::string>& fresh);

// Creates the run directory, writes scene.resolved.toml (with the identity of `given`) and opens
// log.txt. Returns kOk, or kRunFailed with a message naming the directory or file and the cause
// (e.g. an unwritable --out).
int start_run_dir(const scene::Scene& s, const scene::Scene& given,
                  const std::filesystem::path& out, bool resume);

} // namespace demfem::app
