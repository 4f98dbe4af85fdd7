// The profile rows of the metric table (metric_table.hpp) reduced for the report: a pressure
// profile per probe target (the mean at rest and over the late window, per height bin) and the
// surface subsidence profile (rest − end per x bin, with its largest settlement and rise).
#pragma once

#include <filesystem>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "demfem/compare/metric_table.hpp"
#include "demfem/compare/metrics.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::compare::detail {

// One profile row reduced for one owner.
struct ProfileResult {
  std::string owner;     // the probe's target; "" for the scene's
  std::string record;    // metrics.json member: record[owner], or record itself for the scene
  std::string figure;    // relative to the run directory; "" when it could not be drawn
  std::string note;      // what it shows, in one sentence ("" none)
  nlohmann::json values; // what metrics.json records
};

// Every profile row of `table` for every owner the run directory has, figures written to figdir.
[[nodiscard]] std::vector<ProfileResult>
compare_profiles(const std::filesystem::path& run_dir, const std::filesystem::path& figdir,
                 std::span<const Metric> table, const SplitOptions& so, const scene::Scene* scene);

// The x range of the scene's domain ([0, 1] without a scene or a domain).
[[nodiscard]] std::pair<double, double> domain_x(const scene::Scene* scene);

// Throws scene::WriteError when `plot`'s error says the figure could not be written (a full disk,
// a file size limit, gnuplot failing): the report fails on it. A figure with nothing to draw is
// only left out.
void fail_on_write_error(const std::string& plot_error);

// A figure's file name from a metric's key: what is not [A-Za-z0-9.-] becomes '_'.
[[nodiscard]] std::string safe_name(const std::string& s);

} // namespace demfem::compare::detail
