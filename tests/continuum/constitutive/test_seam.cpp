// The constitutive seam: models chosen by keyword through the registry, their points' states,
// the elastic model, the interface layer, the numerical tangent and K0.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "constitutive/k0.hpp"
#include "constitutive/registry.hpp"
#include "constitutive/soil.hpp"
#include "demfem/scene/params.hpp"
#include "demfem/scene/reader.hpp"

using namespace demfem::continuum::constitutive;
namespace scene = demfem::scene;

namespace {
constexpr double kPi = 3.14159265358979323846;
} // namespace

TEST(ConstitutiveRegistry, ModelsAreChosenByKeywordWithTheirBlocks) {
  EXPECT_EQ(Material::keywords(), "elastic, mohr-coulomb, hypoplastic");
  const scene::ModelSlot slot = model_slot();
  EXPECT_EQ(slot.key, "model");
  EXPECT_EQ(slot.default_keyword, "mohr-coulomb");
  std::size_t k = 0;
  for (const char* kw : Registry::keywords) {
    scene::ModelChoice c = scene::default_choice(slot);
    ASSERT_TRUE(scene::choose(c, slot, kw));
    const Material m = Material::from(c);
    EXPECT_STREQ(m.keyword(), kw);
    // the point's internal variables are the model's own
    EXPECT_EQ(m.initial_state().internal.index(), k++);
  }
  // the blocks' values reach the model
  scene::ModelChoice c = scene::default_choice(slot);
  c.get<Elastic::Parameters>().young = 4.0e7;
  c.get<MohrCoulomb::Parameters>().cohesion = 7.0;
  const Material m = Material::from(c);
  EXPECT_EQ(m.elasticity().hooke.young, 4.0e7);
  ASSERT_NE(m.get_if<MohrCoulomb>(), nullptr);
  EXPECT_EQ(m.get_if<MohrCoulomb>()->strength.cohesion, 7.0);
  c.keyword = "sanisand";
  try {
    (void)Material::from(c);
    FAIL() << "an unknown model was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("valid: elastic, mohr-coulomb, hypoplastic"),
              std::string::npos);
  }
}

// The keys the models own, each once, and how the resolved scene writes them: angles in degrees,
// unset optional values and a zero modulus exponent left out.
TEST(ConstitutiveRegistry, BlocksOwnTheSoilKeys) {
  std::vector<std::string> keys;
  for (const auto& row : scene::schema(model_slot())) keys.push_back(row.key);
  EXPECT_EQ(keys, (std::vector<std::string>{"model",
                                            "young",
                                            "poisson",
                                            "modulus_exponent",
                                            "modulus_reference_stress",
                                            "modulus_min_stress",
                                            "friction_angle",
                                            "cohesion",
                                            "dilation_angle",
                                            "tension_cutoff",
                                            "dilation_cutoff",
                                            "critical_friction_angle",
                                            "granular_hardness",
                                            "compression_exponent",
                                            "densest_void_ratio",
                                            "critical_void_ratio",
                                            "loosest_void_ratio",
                                            "density_peak_exponent",
                                            "density_stiffness_exponent",
                                            "intergranular_strain",
                                            "igs_radius",
                                            "igs_reversal_factor",
                                            "igs_transverse_factor",
                                            "igs_beta_r",
                                            "igs_chi",
                                            "initial_void_ratio",
                                            "initial_void_ratio_at_zero_stress",
                                            "minimum_mean_stress",
                                            "substep_tolerance"}));
  // every block of every model is read from the one [soil.continuum] table and written back into
  // it: a key two blocks listed would be read by both and written twice, so each is listed once,
  // and none is one of the table's own keys (scene/src/load.cpp read_continuum_soil)
  std::set<std::string> once(keys.begin(), keys.end());
  EXPECT_EQ(once.size(), keys.size());
  for (const char* own : {"density", "k0", "surface", "calibrate", "provenance"})
    EXPECT_EQ(once.count(own), 0u) << own;
  scene::ModelChoice c = scene::default_choice(model_slot());
  toml::table t;
  scene::write_model(c, t);
  EXPECT_EQ(t["friction_angle"].value<double>(), 30.0); // 30° held as π/6
  EXPECT_FALSE(t.contains("dilation_cutoff"));
  EXPECT_FALSE(t.contains("modulus_exponent"));
  EXPECT_FALSE(t.contains("modulus_reference_stress"));
  EXPECT_EQ(t["model"].value<std::string>(), "mohr-coulomb");
  c.get<MohrCoulomb::Parameters>().dilation_cutoff = 0.02;
  c.get<Elastic::Parameters>().modulus_exponent = 0.25;
  toml::table u;
  scene::write_model(c, u);
  EXPECT_EQ(u["dilation_cutoff"].value<double>(), 0.02);
  EXPECT_EQ(u["modulus_exponent"].value<double>(), 0.25);
}

// Hooke: σ = D ε at the point's stiffness, the tangent D, set_stress its inverse.
TEST(ConstitutiveElastic, StressTangentAndInverse) {
  Elastic::Parameters p;
  p.young = 2.0e7;
  p.poisson = 0.25;
  const Material m{Elastic(p)};
  State c = m.initial_state(), s;
  c.stiffness = 2.0;
  const Voigt de{{1e-4, -3e-4, 2e-4}};
  VoigtMatrix t{};
  EXPECT_EQ(m.update(c, de, s, &t), Return::Elastic);
  const VoigtMatrix D = elastic_tangent(with_stiffness(Hooke{2.0e7, 0.25}, 2.0));
  for (std::size_t i = 0; i < 3; ++i) {
    double sig = 0.0;
    for (std::size_t j = 0; j < 3; ++j) {
      sig += D[i][j] * de[j];
      EXPECT_DOUBLE_EQ(t[i][j], D[i][j]);
    }
    EXPECT_NEAR(s.stress[i], sig, 1e-9 * std::abs(D[0][0] * 3e-4));
  }
  EXPECT_DOUBLE_EQ(s.stiffness, 2.0);
  // a point put at that stress has that elastic strain
  State r = m.initial_state();
  r.stiffness = 2.0;
  r.stress = s.stress;
  r.syy = s.syy;
  m.set_stress(r);
  const auto& ee = std::get<Elastic::Internal>(r.internal).ee;
  for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(ee.in_plane[k], de[k], 1e-15);
  EXPECT_NEAR(ee.out_of_plane, 0.0, 1e-15);
  EXPECT_EQ(m.equivalent_plastic_strain(s), 0.0);
}

// The stress-dependent modulus: the factor from the in-plane mean stress, capped.
TEST(ConstitutiveElastic, StressDependentModulusFollowsTheMeanStress) {
  Elastic::Parameters p;
  p.modulus_exponent = 0.5;
  p.modulus_reference_stress = 1.0e5;
  Material m{MohrCoulomb(p, MohrCoulomb::Parameters{})};
  ASSERT_TRUE(m.stiffness_from_stress());
  State s = m.initial_state();
  s.stress = {{-3.0e5, -5.0e5, 0.0}}; // p = 4e5: E/E_ref = 2
  s.syy = -3.0e5;
  m.set_stiffness_from_stress(s);
  EXPECT_DOUBLE_EQ(s.stiffness, 2.0);
  m.cap_stiffness_at(2.25e5); // cap 1.5
  EXPECT_DOUBLE_EQ(m.stiffness_cap(), 1.5);
  m.set_stiffness_from_stress(s);
  EXPECT_DOUBLE_EQ(s.stiffness, 1.5);
  // the elastic strain was re-derived: an update without strain keeps the stress
  State t;
  m.update(s, Voigt{{0, 0, 0}}, t, nullptr);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(t.stress[k], s.stress[k], 1e-9 * 5e5);
  EXPECT_FALSE(Material(MohrCoulomb(Elastic::Parameters{}, MohrCoulomb::Parameters{}))
                   .stiffness_from_stress());
}

// numerical_tangent (for models without a closed-form tangent) against Mohr–Coulomb's consistent
// tangent, elastic and on the main plane.
TEST(ConstitutiveSeam, NumericalTangentMatchesTheConsistentOne) {
  Elastic::Parameters e;
  e.young = 2.0e7;
  MohrCoulomb::Parameters p;
  p.friction_angle = 30.0 * kPi / 180.0;
  p.cohesion = 1.0e4;
  p.dilation_angle = 10.0 * kPi / 180.0;
  const Material m{MohrCoulomb(e, p)};
  State c = m.initial_state();
  c.stress = {{-1.0e5, -1.0e5, 0.0}};
  c.syy = -1.0e5;
  m.set_stress(c);
  const std::pair<Voigt, Return> increments[] = {{Voigt{{-1e-5, -2e-5, 1e-5}}, Return::Elastic},
                                                 {Voigt{{4e-3, -4e-3, 6e-3}}, Return::MainPlane}};
  for (const auto& [de, expected] : increments) {
    State s;
    VoigtMatrix t{};
    const Return region = m.update(c, de, s, &t);
    EXPECT_EQ(region, expected);
    const VoigtMatrix n = numerical_tangent(
        [&](const Voigt& d) {
          State x;
          m.update(c, d, x, nullptr);
          return x.stress;
        },
        de);
    double err = 0.0, scale = 0.0;
    for (std::size_t i = 0; i < 3; ++i)
      for (std::size_t j = 0; j < 3; ++j) {
        err = std::max(err, std::abs(n[i][j] - t[i][j]));
        scale = std::max(scale, std::abs(t[i][j]));
      }
    EXPECT_LT(err, 1e-5 * scale) << "region " << int(region);
  }
}

// The frictional interface layer: Mohr–Coulomb with the soil's elasticity, the given φ and c,
// ψ = 0, and the soil's tension cut-off.
TEST(ConstitutiveSeam, InterfaceLayerKeepsTheSoilsElasticity) {
  Elastic::Parameters e;
  e.young = 4.0e7;
  e.poisson = 0.2;
  MohrCoulomb::Parameters p;
  p.friction_angle = 0.6;
  p.dilation_angle = 0.3;
  p.tension_cutoff = 1.0e3;
  const Material layer = interface_layer(Material(MohrCoulomb(e, p)), 0.25, 5.0);
  const auto* mc = layer.get_if<MohrCoulomb>();
  ASSERT_NE(mc, nullptr);
  EXPECT_EQ(layer.elasticity().hooke.young, 4.0e7);
  EXPECT_EQ(layer.elasticity().hooke.poisson, 0.2);
  EXPECT_EQ(mc->strength.friction, 0.25);
  EXPECT_EQ(mc->strength.cohesion, 5.0);
  EXPECT_EQ(mc->strength.dilation, 0.0);
  EXPECT_EQ(mc->strength.tension_cutoff, 1.0e3);
  EXPECT_FALSE(layer.symmetric_tangent()); // φ = 0.25, ψ = 0
  const Material from_elastic = interface_layer(Material(Elastic(Elastic::Parameters{})), 0.0, 5.0);
  EXPECT_LT(from_elastic.get_if<MohrCoulomb>()->strength.tension_cutoff, 0.0); // none
  EXPECT_TRUE(from_elastic.symmetric_tangent());                               // φ = ψ = 0
}

TEST(ConstitutiveK0, JakyUnlessStated) {
  EXPECT_NEAR(jaky_k0(30.0 * kPi / 180.0), 0.5, 1e-15);
  EXPECT_EQ(k0_at_rest(0.4, 30.0 * kPi / 180.0), 0.4);
  EXPECT_NEAR(k0_at_rest(-1.0, 30.0 * kPi / 180.0), 0.5, 1e-15);
}

// A scene's soil: Jaky's K0 from Mohr–Coulomb's friction_angle, or from the critical friction
// angle φ_c of a hypoplastic soil; a stated k0 wins.
TEST(ConstitutiveK0, SoilK0FromTheChosenModel) {
  scene::ContinuumSoil soil;
  choose_model(soil, "mohr-coulomb");
  strength_block(soil).friction_angle = 30.0 * kPi / 180.0;
  soil_model(soil).get<Hypoplastic::Parameters>().critical_friction_angle = 36.0 * kPi / 180.0;
  EXPECT_NEAR(soil_k0(soil), 0.5, 1e-15);
  choose_model(soil, "hypoplastic");
  EXPECT_NEAR(soil_k0(soil), 1.0 - std::sin(36.0 * kPi / 180.0), 1e-15);
  soil.k0 = 0.7;
  EXPECT_EQ(soil_k0(soil), 0.7);
}
