// The continuum's constitutive models, chosen by keyword (soil.continuum.model). A model is its
// file in this folder (seam.hpp says what it provides: parameter blocks, per-point variables,
// stress update with its tangent) and one entry in `Registry` below; nothing else changes. The
// scene reads the chosen model's keys through the vocabulary's continuum slot (model_slot()).
//
// `Material` is one registered model with its parameters; both integrators call it per
// quadrature point (no virtual call: a std::variant). Pure C++ without deal.II;
// C++17-compatible (the deal.II translation units include it).
#pragma once

#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "elastic.hpp"
#include "hypoplastic.hpp"
#include "mohr_coulomb.hpp"
#include "seam.hpp"

namespace demfem::scene {
struct ModelSlot;
} // namespace demfem::scene

namespace demfem::continuum::constitutive {

// The registered models.
using Registry = ModelList<Elastic, MohrCoulomb, Hypoplastic>;

// soil.continuum.model: the registered models by keyword (default "mohr-coulomb"), each with its
// parameter blocks; every block of every model is read and written (scene/vocabulary.hpp).
[[nodiscard]] scene::ModelSlot model_slot();

// A point's state: what every model keeps (PointStress) and its model's own variables.
struct State : PointStress {
  Registry::Internal internal;
};

class Material {
public:
  Material() : model_(Elastic(Elastic::Parameters{})) {} // elastic, E = 30 MPa, ν = 0.3
  template <class M, class = std::enable_if_t<Registry::contains<M>>>
  explicit Material(M model) : model_(std::move(model)) {}

  // The model a scene chose (its keyword and parameter blocks, model_slot()); throws
  // std::invalid_argument for a keyword no model has, naming the registered ones.
  [[nodiscard]] static Material from(const scene::ModelChoice& choice);
  // "elastic, mohr-coulomb, hypoplastic"
  [[nodiscard]] static std::string keywords();

  [[nodiscard]] const char* keyword() const {
    return std::visit([](const auto& m) { return std::decay_t<decltype(m)>::keyword; }, model_);
  }
  template <class M> [[nodiscard]] const M* get_if() const { return std::get_if<M>(&model_); }

  // The model's reference elasticity (elastic tangent, wave speeds, stable step) and its tangent.
  [[nodiscard]] const Elasticity& elasticity() const {
    return std::visit([](const auto& m) -> const Elasticity& { return m.elasticity(); }, model_);
  }
  [[nodiscard]] VoigtMatrix elastic_tangent() const { return elasticity().tangent(); }
  // Whether every tangent the model returns is symmetric (the linear solver's choice).
  [[nodiscard]] bool symmetric_tangent() const {
    return std::visit([](const auto& m) { return m.symmetric_tangent(); }, model_);
  }

  // A point's modulus follows its stress (a stress-dependent modulus, set_stiffness_from_stress),
  // and the largest factor it can take (the explicit step is bounded with it before the points'
  // stresses are known; infinite: no bound).
  [[nodiscard]] bool stiffness_from_stress() const { return elasticity().modulus.active(); }
  [[nodiscard]] double stiffness_cap() const { return elasticity().modulus.max_factor; }
  // Caps the stress-dependent modulus at its value at in-plane mean stress p_max [Pa] (the
  // deepest geostatic stress of a scene); no-op without one.
  void cap_stiffness_at(double p_max);

  // A stress-free point at rest.
  [[nodiscard]] State initial_state() const {
    return std::visit(
        [](const auto& m) {
          State s;
          s.internal.template emplace<Registry::index<std::decay_t<decltype(m)>>()>();
          return s;
        },
        model_);
  }
  // The point put at the stress it holds (s.stress, s.syy, at its stiffness): the initial-stress
  // procedure (K0 state).
  void set_stress(State& s) const {
    std::visit(
        [&](const auto& m) {
          constexpr std::size_t I = Registry::index<std::decay_t<decltype(m)>>();
          m.set_stress(s, std::get<I>(s.internal));
        },
        model_);
  }
  // The point's modulus from its in-plane mean stress (stress-dependent modulus; no-op without
  // one), its stress kept.
  void set_stiffness_from_stress(State& s) const {
    const StressDependentModulus& law = elasticity().modulus;
    if (!law.active()) return;
    s.stiffness = law.factor(-0.5 * (s.stress[0] + s.stress[1]));
    set_stress(s);
  }
  // Integrates the strain increment `deps` (Δεxx, Δεzz, Δγxz; Δεyy = 0, plane strain) from the
  // committed state `c0` into `s` (c0 and s distinct). When `tangent` is given it receives dσ/dε
  // (with `predictor`, the first Newton iteration of a step: a point that was yielding keeps the
  // tangent of the surface it sits on). Returns where the update ended.
  Return update(const State& c0, const Voigt& deps, State& s, VoigtMatrix* tangent,
                bool predictor = false) const {
    return std::visit(
        [&](const auto& m) {
          constexpr std::size_t I = Registry::index<std::decay_t<decltype(m)>>();
          auto* i = std::get_if<I>(&s.internal);
          if (!i) i = &s.internal.template emplace<I>();
          return m.update(c0, std::get<I>(c0.internal), deps, s, *i, tangent, predictor);
        },
        model_);
  }
  // √(2/3 εp:εp) of a point (0 for a model without plastic strain), for output.
  [[nodiscard]] double equivalent_plastic_strain(const State& s) const {
    return std::visit(
        [&](const auto& m) {
          constexpr std::size_t I = Registry::index<std::decay_t<decltype(m)>>();
          return m.equivalent_plastic_strain(std::get<I>(s.internal));
        },
        model_);
  }

  // The model's own point variables in the snapshots (Model::output_names; none for most).
  [[nodiscard]] std::vector<const char*> output_names() const {
    return std::visit(
        [](const auto& m) {
          const auto& n = std::decay_t<decltype(m)>::output_names;
          return std::vector<const char*>(n.begin(), n.end());
        },
        model_);
  }
  // Their values at a point, into v[0 … output_names().size() − 1].
  void output(const State& s, double* v) const {
    std::visit(
        [&](const auto& m) {
          constexpr std::size_t I = Registry::index<std::decay_t<decltype(m)>>();
          m.output(std::get<I>(s.internal), v);
        },
        model_);
  }

private:
  Registry::Model model_;
};

// The frictional interface layer along structures (fem::Problem::interface_friction): Mohr–Coulomb
// with the soil's elasticity (its stress-dependent modulus included), friction angle `friction`
// [rad], `cohesion` [Pa] and ψ = 0, and the soil's tension cut-off when it has one.
[[nodiscard]] Material interface_layer(const Material& soil, double friction, double cohesion);

} // namespace demfem::continuum::constitutive
