#include "demfem/dem/contact/registry.hpp"

#include <stdexcept>

#include <fmt/format.h>

namespace demfem::dem::contact {

namespace {

template <class M> scene::ModelEntry entry() {
  return {M::name, M::summary, M::blocks()};
}
template <class... M> std::vector<scene::ModelEntry> entries(List<M...>) {
  return {entry<M>()...};
}
template <class First, class... M> const char* first_name(List<First, M...>) {
  return First::name;
}

template <class L, class... R>
bool build_row(const scene::ModelChoice& law, const scene::ModelChoice& rolling, AnyContactLaw& out,
               List<R...>) {
  return ((rolling.keyword == R::name
               ? (out = ContactModel<L, R>{L::template make<L>(law), R::from(rolling)}, true)
               : false) ||
          ...);
}
template <class... L>
bool build(const scene::ModelChoice& law, const scene::ModelChoice& rolling, AnyContactLaw& out,
           List<L...>) {
  return ((law.keyword == L::name ? build_row<L>(law, rolling, out, RollingModels{}) : false) ||
          ...);
}

AnyContactLaw make(const scene::ModelChoice& law, const scene::ModelChoice& rolling) {
  AnyContactLaw out;
  if (!build(law, rolling, out, Laws{}))
    throw std::invalid_argument(
        fmt::format("no contact law '{}' with rolling model '{}'", law.keyword, rolling.keyword));
  return out;
}

scene::ModelChoice with_values(const scene::ModelSlot& slot, std::string_view keyword,
                               const Values& values) {
  scene::ModelChoice c = scene::default_choice(slot);
  if (!scene::choose(c, slot, keyword))
    throw std::invalid_argument(fmt::format("no {} model '{}'", slot.key, keyword));
  for (const auto& [k, v] : values)
    if (!scene::set(c, k, v))
      throw std::invalid_argument(fmt::format("no key '{}' in the {} models", k, slot.key));
  return c;
}

} // namespace

scene::ModelSlot law_slot() {
  scene::ModelSlot s;
  s.key = kLawKey;
  s.meaning = "the contact law between particles, and between particles and walls or structures";
  s.default_keyword = first_name(Laws{});
  s.always_written = true;
  s.entries = entries(Laws{});
  return s;
}

scene::ModelSlot rolling_slot() {
  scene::ModelSlot s;
  s.key = kRollingKey;
  s.meaning = "rolling resistance at the contacts (a moment against the relative rotation)";
  s.default_keyword = first_name(RollingModels{});
  s.always_written = false; // off: not in the resolved scene
  s.entries = entries(RollingModels{});
  return s;
}

std::vector<scene::ModelSlot> slots() {
  return {law_slot(), rolling_slot()};
}

std::vector<scene::ModelChoice> default_models() {
  std::vector<scene::ModelChoice> m;
  for (const auto& s : slots()) m.push_back(scene::default_choice(s));
  return m;
}

const scene::ModelChoice* law_choice(const scene::DemSoil& soil) {
  return soil.model(kLawKey);
}
const scene::ModelChoice* rolling_choice(const scene::DemSoil& soil) {
  return soil.model(kRollingKey);
}

scene::ModelChoice law_of(const scene::DemSoil& soil) {
  const auto* c = law_choice(soil);
  return c ? *c : scene::default_choice(law_slot());
}
scene::ModelChoice rolling_of(const scene::DemSoil& soil) {
  const auto* c = rolling_choice(soil);
  return c ? *c : scene::default_choice(rolling_slot());
}

void scale_stiffness(scene::DemSoil& soil, double f) {
  if (soil.models.empty()) soil.models = default_models();
  for (auto& m : soil.models) scene::scale_stiffness(m, f);
}

AnyContactLaw make_law(const scene::DemSoil& soil) {
  const auto* law = law_choice(soil);
  const auto* rolling = rolling_choice(soil);
  if (law && rolling) return make(*law, *rolling);
  const scene::ModelChoice dl = scene::default_choice(law_slot());
  const scene::ModelChoice dr = scene::default_choice(rolling_slot());
  return make(law ? *law : dl, rolling ? *rolling : dr);
}

AnyContactLaw make_law(std::string_view law, const Values& values, std::string_view rolling,
                       const Values& rolling_values) {
  return make(with_values(law_slot(), law, values),
              with_values(rolling_slot(), rolling, rolling_values));
}

StepStiffness reference_stiffness(const AnyContactLaw& law, double r) {
  return std::visit([r](const auto& m) { return m.law.step_stiffness(r, 1.0); }, law);
}

namespace {
template <class... L> int version_of(std::string_view keyword, List<L...>) {
  int v = 0;
  ((keyword == L::name ? (v = L::kVersion, true) : false) || ...);
  return v;
}
} // namespace

int law_version(std::string_view keyword) {
  return version_of(keyword, Laws{});
}

std::string_view law_name(const AnyContactLaw& law) {
  return std::visit([](const auto& m) -> std::string_view { return m.law.name; }, law);
}
std::string_view rolling_name(const AnyContactLaw& law) {
  return std::visit([](const auto& m) -> std::string_view { return m.rolling.name; }, law);
}
std::string_view force_formula(const AnyContactLaw& law) {
  return std::visit([](const auto& m) -> std::string_view { return m.law.normal.kForceFormula; },
                    law);
}

} // namespace demfem::dem::contact
