#include "demfem/output/probe.hpp"

#include <stdexcept>

#include <fmt/format.h>

namespace demfem::output {
namespace {
[[noreturn]] void not_offered(const char* what) {
  throw std::logic_error(fmt::format("this solver's probe source offers no {}", what));
}
} // namespace

EnergyTerms ProbeSource::energy() {
  not_offered("energy budget");
}
StructureState ProbeSource::structure(std::size_t) {
  not_offered("structure state");
}
WallReaction ProbeSource::wall(std::string_view) {
  not_offered("wall reaction");
}
void ProbeSource::pressure(std::string_view, std::span<double>) {
  not_offered("boundary pressure");
}
void ProbeSource::surface(std::span<double>) {
  not_offered("surface profile");
}
std::vector<std::uint32_t> ProbeSource::trace(std::span<const scene::Vec2>) {
  not_offered("particles to trace");
}
scene::Vec2 ProbeSource::position(std::uint32_t) {
  not_offered("particle positions");
}
double ProbeSource::coordination() {
  not_offered("coordination number");
}

void Probe::open(const std::filesystem::path& dir, const CsvOptions& options) {
  csv_.emplace(dir / file_, columns(), options);
}

void Probe::sample(ProbeSource& source) {
  const double t = source.time();
  row_.clear();
  row_.push_back(t);
  fill(source, row_);
  if (csv_) csv_->append(row_);
  last_ = t;
}

void Probe::flush() {
  if (csv_) csv_->flush();
}

void Probe::close() {
  if (csv_) csv_->close();
}

} // namespace demfem::output
