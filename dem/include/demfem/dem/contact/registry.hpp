// The DEM's contact laws and rolling-resistance sub-models. A law (a composition of sub-models,
// law.hpp) or a rolling sub-model is one header of this folder and one entry in a list below:
// from the lists come the keywords and keys of [soil.dem] (the `contact` and `rolling` slots of
// the DEM's vocabulary, dem/vocabulary.hpp), the engine's law (one instantiation of the pair loop
// per law and rolling model: AnyContactLaw) and the report's and docs' descriptions.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "demfem/dem/contact/cundall_dashpot.hpp"
#include "demfem/dem/contact/cundall_rebound.hpp"
#include "demfem/dem/contact/hertz_mindlin.hpp"
#include "demfem/dem/contact/law.hpp"
#include "demfem/dem/contact/linear_restitution.hpp"
#include "demfem/dem/contact/rolling_spring.hpp"
#include "demfem/scene/params.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::dem::contact {

template <class... T> struct List {};

// ---- the registry ----------------------------------------------------------------------------
// [soil.dem] contact = "…" (the first is the default)
using Laws = List<CundallRebound, CundallDashpot, LinearRestitution, HertzMindlin>;
// [soil.dem] rolling = "…" (the first is the default)
using RollingModels = List<NoRolling, RollingSpring>;
// ----------------------------------------------------------------------------------------------

namespace detail {
template <class... Ls> struct Concat;
template <class... A> struct Concat<List<A...>> { using type = List<A...>; };
template <class... A, class... B, class... Rest> struct Concat<List<A...>, List<B...>, Rest...> {
  using type = typename Concat<List<A..., B...>, Rest...>::type;
};
template <class Ls, class Rs> struct Models;
template <class... L, class... R> struct Models<List<L...>, List<R...>> {
  template <class One> using Row = List<ContactModel<One, R>...>;
  using type = typename Concat<Row<L>...>::type;
};
template <class Ls> struct Variant;
template <class... A> struct Variant<List<A...>> { using type = std::variant<A...>; };
} // namespace detail

// Every law with every rolling model; the engine holds one and visits it once per step.
using AnyContactLaw = detail::Variant<detail::Models<Laws, RollingModels>::type>::type;

inline constexpr const char* kLawKey = "contact";
inline constexpr const char* kRollingKey = "rolling";

// The slots of [soil.dem]: the contact law, the rolling resistance.
[[nodiscard]] scene::ModelSlot law_slot();
[[nodiscard]] scene::ModelSlot rolling_slot();
[[nodiscard]] std::vector<scene::ModelSlot> slots();
// Both at their defaults (a DemSoil built in code has no models: these are used then).
[[nodiscard]] std::vector<scene::ModelChoice> default_models();

// The law of a [soil.dem] (its `contact` and `rolling` choices; absent ones at their defaults).
[[nodiscard]] AnyContactLaw make_law(const scene::DemSoil& soil);
// A law by keyword with some of its keys set, e.g. make_law("hertz-mindlin", {{"young", 1e9}});
// an unknown keyword or key throws std::invalid_argument (for tests and benchmarks).
using Values = std::vector<std::pair<std::string, double>>;
[[nodiscard]] AnyContactLaw make_law(std::string_view law, const Values& values = {},
                                     std::string_view rolling = "none",
                                     const Values& rolling_values = {});

// The law's stiffnesses for a contact of two particles of radius r (contact.hpp: the linear laws'
// K_n, K_s; Hertz–Mindlin's tangents at kReferenceOverlap·r), for estimates and global damping.
[[nodiscard]] StepStiffness reference_stiffness(const AnyContactLaw& law, double r);

// A law's version (Law::kVersion; 0 for an unknown keyword).
[[nodiscard]] int law_version(std::string_view keyword);

// The keyword of the law and of the rolling model in a law.
[[nodiscard]] std::string_view law_name(const AnyContactLaw& law);
[[nodiscard]] std::string_view rolling_name(const AnyContactLaw& law);
// How the law's normal force follows the overlap, for figure titles ("K_n·δ").
[[nodiscard]] std::string_view force_formula(const AnyContactLaw& law);

// The [soil.dem] choice of a slot, or nullptr.
[[nodiscard]] const scene::ModelChoice* law_choice(const scene::DemSoil& soil);
[[nodiscard]] const scene::ModelChoice* rolling_choice(const scene::DemSoil& soil);
// The same, or the slot at its defaults when the soil has none (a DemSoil built in code).
[[nodiscard]] scene::ModelChoice law_of(const scene::DemSoil& soil);
[[nodiscard]] scene::ModelChoice rolling_of(const scene::DemSoil& soil);
// Multiplies every stiffness of the soil's contact law and rolling model by f (scene/params.hpp,
// Scale::stiffness): K_n, K_s, E, …; the soil gets the default models first when it has none.
void scale_stiffness(scene::DemSoil& soil, double f);

} // namespace demfem::dem::contact
