// Element tests: one material point driven along a path of strain, stress or mixed control
// (isotropic and oedometric compression, biaxial and triaxial compression, simple shear, their
// cyclic and undrained variants), for the verification of the models and for calibration.
//
// A point is a Material (Material::from a scene's model choice): either a plane-strain point of
// any registered model (εyy = 0, σyy carried: what the continuum's integration points see) or a
// hypoplastic point whose out-of-plane strain is free (the 3D-consistent isotropic and triaxial
// paths). Each leg of a path runs in equal increments; per component it prescribes either the
// strain increment over the leg or the stress at its end, the stress-controlled components'
// strains being found by Newton iterations on the model's tangent. Pure C++ without deal.II;
// C++17-compatible. Conventions: seam.hpp (tension positive).
#pragma once

#include <array>
#include <cstddef>
#include <limits>
#include <variant>
#include <vector>

#include "hypoplastic.hpp"
#include "registry.hpp"

namespace demfem::continuum::constitutive {

// A point's strain or stress in the element tests: components (xx, zz, xz, yy); the strain's
// shear is the engineering γxz (seam.hpp's Voigt order with yy appended).
using Components = std::array<double, 4>;
inline constexpr std::size_t kXX = 0, kZZ = 1, kXZ = 2, kYY = 3;

enum class Control : unsigned char { Strain, Stress };

// One leg of a path, run in `increments` equal steps: per component the strain increment over
// the leg (Control::Strain) or the stress at its end (Control::Stress), reached linearly from the
// stress at the leg's start.
struct Leg {
  std::array<Control, 4> control{
      {Control::Strain, Control::Strain, Control::Strain, Control::Strain}};
  Components value{{0.0, 0.0, 0.0, 0.0}};
  int increments = 100;

  // every component strain-controlled
  static Leg strain(const Components& increment, int increments) {
    Leg l;
    l.value = increment;
    l.increments = increments;
    return l;
  }
  // component k stress-controlled, at `target` [Pa] at the leg's end
  Leg& stress(std::size_t k, double target) {
    control[k] = Control::Stress;
    value[k] = target;
    return *this;
  }
};

// The state after an increment.
struct Sample {
  Components strain{{0.0, 0.0, 0.0, 0.0}}; // accumulated (small strain)
  Components stress{{0.0, 0.0, 0.0, 0.0}};
  double void_ratio = std::numeric_limits<double>::quiet_NaN(); // hypoplastic points only
  double igs = 0.0; // ‖δ‖/R of a hypoplastic point with intergranular strain, else 0
};

class ElementTest {
public:
  // A plane-strain point of a registered model (Material::from a scene's choice) at state `s`
  // (Material::initial_state and set_stress place it); its yy component must stay
  // strain-controlled with a zero increment.
  ElementTest(Material model, State s);
  // A point with a free out-of-plane strain at state `s`: `model` must be hypoplastic (else
  // std::invalid_argument).
  ElementTest(const Material& model, const hypoplastic::PointState& s);

  // Runs a leg, appending one sample per increment; throws std::runtime_error when a stress
  // target is not met (Newton not converged) or a plane-strain point is asked for εyy ≠ 0.
  void run(const Leg& leg);

  [[nodiscard]] const Sample& now() const { return history_.back(); }
  // The initial sample and one per increment since.
  [[nodiscard]] const std::vector<Sample>& history() const { return history_; }
  [[nodiscard]] long newton_iterations() const { return newton_; }

private:
  struct Plane {
    Material model;
    State state;
  };
  struct Free {
    Hypoplastic model;
    hypoplastic::PointState state;
  };
  struct Trial {
    State plane;
    hypoplastic::PointState free;
    Components stress{{0.0, 0.0, 0.0, 0.0}};
    double tangent[4][4] = {}; // dσ_i/dε_j (engineering shear), when asked
  };
  Trial attempt(const Components& d, bool with_tangent) const;
  void commit(const Trial& t, const Components& d);
  [[nodiscard]] Sample sample_of(const Components& strain) const;

  std::variant<Plane, Free> point_;
  std::vector<Sample> history_;
  long newton_ = 0;
};

} // namespace demfem::continuum::constitutive
