// DEM element tests for `demfem calibrate` (internal to the compare library): biaxial compression
// and cyclic biaxial loading of a rectangular specimen between four rigid platens, and the
// particle stress of a deposited bed. They drive the unchanged dem::Engine through its public
// interface only: the platens are rigid structures (dem/ structures), the lateral ones "free" in x
// under a constant applied force σ_c·h·t (a stress-controlled membrane with inertia, updated as the
// height h changes), the top and bottom ones "prescribed" (a displacement path or sine). No
// engine change was needed.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "demfem/dem/engine.hpp"
#include "demfem/dem/state.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::calibrate::calib {

// One sample of a biaxial or cyclic test (compression and contraction positive).
struct Sample {
  double time = 0.0;
  double e_axial = 0.0;   // ε_zz = (h0 − h)/h0
  double e_lateral = 0.0; // ε_xx = (w0 − w)/w0
  double s_axial = 0.0;   // σ_zz: mean of the top and bottom platen stresses [Pa]
  double s_lateral = 0.0; // σ_xx: mean of the left and right platen stresses [Pa]
};

struct ElementSettings {
  double inertial_number = 1e-3; // quasi-static: I = ε̇ d √(ρ_s/σ_c) (GDR MiDi 2004)
  double max_axial_strain = 0.15;
  int control_steps = 20; // samples are averaged over this many steps
  std::function<void(const std::string& stage, double fraction)> progress; // may be empty
};

struct Specimen {
  dem::EngineConfig config; // the scene's contact law, friction, density; gravity off
  dem::Particles particles; // the deposited specimen (scene packing procedure)
  double d_mean = 0.0;      // mean diameter [m]
  double thickness = 1.0;   // out-of-plane [m]
};

struct BiaxialResult {
  double sigma_c = 0.0;
  double porosity = 0.0; // after isotropic consolidation (area inside the platens)
  double strain_rate = 0.0;
  double consolidation_time = 0.0;
  std::vector<Sample> samples; // from the start of shearing
  long long steps = 0;
  std::string failure; // engine blow-up message, empty when fine
};

// Consolidates isotropically to σ_c, then compresses axially at the quasi-static strain rate to
// settings.max_axial_strain holding σ_c on the lateral platens.
BiaxialResult biaxial(const Specimen& sp, double sigma_c, const ElementSettings& settings);

struct CyclicLoop {
  double gamma_amplitude = 0.0; // amplitude of γ = ε_zz − ε_xx (first harmonic)
  double g_secant = 0.0;        // τ_a / γ_a, τ = (σ_zz − σ_xx)/2
  double damping = 0.0;         // ξ = W_D / (4π W_S) of the fitted first harmonic (½ sin δ)
  double nu_inplane = 0.0;      // ν' = −ε_xx/ε_zz, first harmonics, in phase with ε_zz
  std::vector<Sample> samples;  // the measured (last) cycle
};

// Consolidates to σ_c, then applies two sinusoidal axial strain cycles per amplitude (increasing
// amplitudes, lateral stress held) and measures the last cycle of each.
std::vector<CyclicLoop> cyclic(const Specimen& sp, double sigma_c,
                               const std::vector<double>& axial_amplitudes,
                               const ElementSettings& settings);

// Mean Love–Weber stress (σ_ij = (1/A) Σ_c f_i l_j, compression positive) of the particle–particle
// contacts whose contact point lies in the window.
struct StressWindow {
  double x0, x1, z0, z1;
};
struct BedStress {
  double sxx = 0.0, szz = 0.0, sxz = 0.0;
  std::size_t contacts = 0;
};
BedStress bed_stress(const dem::Engine& e, const StressWindow& w, double thickness,
                     const std::vector<StressWindow>& exclude = {});

} // namespace demfem::calibrate::calib
