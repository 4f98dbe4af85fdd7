// The comparison report's page (report_page.cpp) and its sections about the two models and the
// run (report_sections.cpp): the reproducing command and run times, what differs between the
// models, both models' parameters with the calibration, and the study pages.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "demfem/compare/model_differences.hpp"
#include "demfem/compare/report.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::compare::detail {

// <figure> with the PNG embedded as a data URI ("" when the file does not exist).
[[nodiscard]] std::string embed_png(const std::filesystem::path& png, const std::string& caption);

// report.html: every section, from what write_report compared and read.
[[nodiscard]] std::string report_page(const std::filesystem::path& run_dir,
                                      const ReportOptions& options,
                                      const std::vector<std::string>& warnings,
                                      const SplitOptions& so, const ReportResult& res,
                                      const ModelFacts& facts, const std::string& command);

// `demfem compare <scene file> [--variant V]`.
[[nodiscard]] std::string default_command(const scene::Scene& scene);

[[nodiscard]] std::string runs_section(const ModelFacts& facts, const std::string& command);
[[nodiscard]] std::string differences_section(const std::vector<DiffRow>& rows);
[[nodiscard]] std::string parameters_section(const std::filesystem::path& run_dir,
                                             const std::vector<ParamRow>& rows,
                                             const ModelFacts& facts, const scene::Scene* scene);
[[nodiscard]] std::string studies_section(const std::filesystem::path& run_dir,
                                          const std::vector<StudyLink>& studies,
                                          const scene::Scene* scene);

} // namespace demfem::compare::detail
