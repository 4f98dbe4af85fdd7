#include "scenes.hpp"

#include <optional>

#include <fmt/format.h>

#include "command.hpp"
#include "demfem/app/vocabulary.hpp"
#include "demfem/calibrate/calibrate.hpp"
#include "demfem/scene/validate.hpp"
#include "run_dir.hpp"

namespace fs = std::filesystem;

namespace demfem::app {

scene::SceneFile load_or_report(const std::string& path, int& rc) {
  try {
    rc = kOk;
    auto f = scene::load_scene_file(path, vocabulary());
    for (const auto& w : f.warnings) fmt::print(stderr, "{}\n", w.format()); // accepted, but…
    return f;
  } catch (const scene::SceneError& e) {
    fmt::print(stderr, "{}\n", e.what());
    fmt::print(stderr, "demfem: {} problem(s) in {}\n", e.diagnostics().size(), path);
    rc = kBadInput;
    return {};
  }
}

scene::SceneFile load_for(const RunArgs& a, int& rc) {
  auto f = load_or_report(a.scene, rc);
  if (rc == kOk && a.seed >= 0) {
    f.base.info.seed = static_cast<unsigned long>(a.seed);
    for (auto& v : f.variants) v.info.seed = static_cast<unsigned long>(a.seed);
  }
  return f;
}

fs::path with_seed_dir(fs::path out, const RunArgs& a) {
  if (a.seed >= 0 && a.out.empty()) out /= fmt::format("seed-{}", a.seed);
  return out;
}

std::vector<const scene::Scene*> pick(const scene::SceneFile& f, const RunArgs& a, int& rc) {
  std::vector<const scene::Scene*> out;
  rc = kOk;
  try {
    if (a.all_variants) {
      if (f.variants.empty()) out.push_back(&f.base);
      for (const auto& v : f.variants) out.push_back(&v);
    } else if (a.variants.empty()) {
      out.push_back(&f.base);
    } else {
      for (const auto& v : a.variants) out.push_back(&f.select(v));
    }
    // every folder name the chosen scenes give, before anything runs (run_dir.hpp)
    for (const scene::Scene* s : out) {
      if (a.out.empty()) (void)child_dir("runs", s->info.name, "scene name");
      if (!s->variant.empty()) (void)child_dir(a.out, s->variant, "variant name");
    }
  } catch (const scene::SceneError& e) {
    fmt::print(stderr, "{}\n", e.what());
    rc = kBadInput;
  } catch (const UsageError& e) {
    fmt::print(stderr, "demfem: {}\n", e.what());
    rc = kBadInput;
  }
  return out;
}

} // namespace demfem::app
