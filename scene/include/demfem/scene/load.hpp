// Reading scene files: TOML → validated Scene structs, with [[variant]] expansion.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "demfem/scene/scene.hpp"
#include "demfem/scene/vocabulary.hpp"

namespace demfem::scene {

// One problem found in a scene file: where, which key, what is wrong and what would be valid.
struct Diagnostic {
  std::string file;
  int line = 0;
  int column = 0;
  std::string key;     // dotted path, e.g. soil.dem.kn or structure[pile].width
  std::string message; // what is wrong, and what would be valid
  // A warning: the scene is accepted (SceneFile::warnings), but probably not what was meant.
  bool warning = false;
  [[nodiscard]] std::string format() const; // "file:line:col: error: key: message"
};

class SceneError : public std::runtime_error {
public:
  explicit SceneError(std::vector<Diagnostic> diagnostics);
  [[nodiscard]] const std::vector<Diagnostic>& diagnostics() const { return diagnostics_; }

private:
  std::vector<Diagnostic> diagnostics_;
};

struct SceneFile {
  std::string path;
  Scene base;                       // the file without any variant applied
  std::vector<Scene> variants;      // one fully resolved scene per [[variant]], in file order
  std::vector<Diagnostic> warnings; // accepted, but worth a look (every command prints them)

  [[nodiscard]] std::vector<std::string> variant_names() const;
  // "" selects the base scene; an unknown name throws SceneError listing the valid names.
  [[nodiscard]] const Scene& select(const std::string& variant) const;
};

// Throws SceneError with every problem found (not only the first). The vocabulary gives the
// models and the step limits (vocabulary.hpp).
[[nodiscard]] SceneFile load_scene_file(const std::filesystem::path& path,
                                        const Vocabulary& vocabulary);
[[nodiscard]] SceneFile parse_scene(std::string_view text, const std::string& source_name,
                                    const Vocabulary& vocabulary);

// The resolved scene written back as TOML (all defaults explicit), for `demfem check` and the
// run directory. Reading it back gives the same Scene.
[[nodiscard]] std::string to_toml(const Scene& scene);

} // namespace demfem::scene
