// Scene files as the subcommands read them: the options they share, loading with the problems
// reported, the variants chosen.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "demfem/scene/load.hpp"

namespace demfem::app {

// The options of run, compare, calibrate, pack and study (each declares those it takes).
struct RunArgs {
  std::string scene;
  std::string solver = "dem";
  std::vector<std::string> variants;
  bool all_variants = false;
  std::string out;
  bool resume = false;
  int threads = 1; // results are bit-reproducible per thread count; 1 unless asked
  int refinement = -1;
  int degree = -1;
  bool report_only = false; // compare: rewrite the report from the run directory's outputs
  bool force = false;       // run into a directory that holds another scene's results
  int jobs = 1;             // run: variants at once, as separate processes
  // --seed: scene.seed (the packing's radii and placement) for every chosen scene, overriding the
  // file; -1 = the file's. --seeds (compare): a seed ensemble, one comparison per seed.
  long long seed = -1;
  std::vector<long long> seeds;
  bool target_not_met_ok = false; // pack: exit 0 when a porosity target is not met
};

// The scene file, or an empty one with rc = kBadInput after printing its problems.
scene::SceneFile load_or_report(const std::string& path, int& rc);
// load_or_report with --seed applied to the base scene and every variant.
scene::SceneFile load_for(const RunArgs& a, int& rc);
// The scenes --variant / --all-variants choose (the base scene by default); rc = kBadInput after
// printing the problem for an unknown variant.
std::vector<const scene::Scene*> pick(const scene::SceneFile& f, const RunArgs& a, int& rc);

// A default output directory for a --seed run: its own seed-N subdirectory (so realisations do
// not share a run directory); an explicit --out is used as given.
std::filesystem::path with_seed_dir(std::filesystem::path out, const RunArgs& a);

} // namespace demfem::app
