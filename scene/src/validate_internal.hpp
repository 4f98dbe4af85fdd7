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

// The continuum mesh's and the DEM's estimated memory against the machine's available memory
// (validate_resources.cpp). False when the continuum mesh is refused: then nothing may build it.
bool validate_memory(const Scene& scene, const Vocabulary& vocabulary, const toml::table& root,
                     const std::string& file, std::vector<Diagnostic>& diags);

// The particles' container (validate_geometry.cpp): every fill edge that does not face upwards is
// held by a wall or a structure, or what leaves through it lands on one (error otherwise); wall
// corners outside the domain (warning).
void validate_container(const Scene& scene, const toml::table& root, const std::string& file,
                        std::vector<Diagnostic>& diags);

} // namespace demfem::scene::detail
