// Private to demfem_scene: the semantic checks with access to the TOML tree for source positions.
#pragma once

#include <string>
#include <vector>

#include <toml++/toml.h>

#include "demfem/scene/load.hpp"

namespace demfem::scene::detail {

// Appends one located Diagnostic per semantic problem of `scene`, read from `root` (the file, or a
// variant's copy of it with its overrides moved in, so an override is located at its own line).
void validate_semantics(const Scene& scene, const toml::table& root, const std::string& file,
                        const Vocabulary& vocabulary, std::vector<Diagnostic>& diags);

} // namespace demfem::scene::detail
