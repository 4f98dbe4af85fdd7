// The hypoplastic soil chosen by a scene ([soil.continuum] model = "hypoplastic" with its keys,
// tests/continuum/hypoplastic_wall.toml): `demfem check` accepts the scene and refuses an
// inconsistent set of its keys at the key, and `demfem run --solver continuum` runs it with the
// explicit integrator, its snapshots holding the void ratio and the intergranular strain. Shaken
// for 0.4 s, the hypoplastic fill compacts and settles (measured:
// 25 mm at mid-fill) where the same fill as a Mohr–Coulomb soil (the scene's variant) does not
// (−0.6 mm, a slight heave).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "cli_util.hpp"

#ifdef DEMFEM_TEST_CONTINUUM
namespace fs = std::filesystem;

using demfem::test::Result;
using demfem::test::run;

namespace {

const std::string kScene =
    std::string(DEMFEM_SOURCE_DIR) + "/tests/continuum/hypoplastic_wall.toml";

// The settlement [m] in a run's continuum/surface_profile.csv at the row nearest to x [m]; NaN
// when the file has no row.
double settlement_near(const fs::path& out, double x) {
  std::istringstream in(demfem::test::slurp(out / "continuum" / "surface_profile.csv"));
  std::string line;
  std::getline(in, line); // header
  double best = NAN, dist = 1e300;
  while (std::getline(in, line)) {
    const auto comma = line.find(',');
    if (comma == std::string::npos) continue;
    const double xi = std::stod(line.substr(0, comma));
    if (std::abs(xi - x) < dist) {
      dist = std::abs(xi - x);
      best = std::stod(line.substr(comma + 1));
    }
  }
  return best;
}

} // namespace

TEST(HypoplasticScene, CheckAcceptsTheKeysAndRefusesAnInconsistentSet) {
  const Result ok = run("check " + kScene);
  EXPECT_EQ(ok.code, 0) << ok.out;
  // e_d0 above e_c0: refused at the key
  const std::string text = demfem::test::slurp(kScene);
  const fs::path bad = demfem::test::write_temp(
      "hypoplastic_bad.toml", demfem::test::with_values(text, {{"densest_void_ratio", "0.97"}}));
  const Result b = run("check " + bad.string());
  EXPECT_EQ(b.code, 2) << b.out;
  EXPECT_NE(b.out.find("soil.continuum.densest_void_ratio"), std::string::npos) << b.out;
}

TEST(HypoplasticScene, RunsExplicitAndCompactsWhereMohrCoulombDoesNot) {
  const fs::path hypo = demfem::test::scratch("hypoplastic_run");
  const Result h = run("run " + kScene + " --solver continuum --out " + hypo.string());
  ASSERT_EQ(h.code, 0) << h.out;
  const fs::path mc = demfem::test::scratch("mohr_coulomb_run");
  const Result m =
      run("run " + kScene + " --solver continuum --variant mohr-coulomb --out " + mc.string());
  ASSERT_EQ(m.code, 0) << m.out;
  const double sh = settlement_near(hypo, 4.0), sm = settlement_near(mc, 4.0);
  std::printf("settlement at x = 4 m after 0.4 s of shaking: hypoplastic %.4f m, "
              "Mohr–Coulomb %.4f m\n",
              sh, sm);
  EXPECT_GT(sh, 0.01);
  EXPECT_LT(std::abs(sm), 0.005);
}

// The snapshots carry the hypoplastic soil's void ratio and intergranular strain (cell means over
// the soil); a Mohr–Coulomb soil's snapshots do not.
TEST(HypoplasticScene, SnapshotsHoldTheVoidRatioAndTheIntergranularStrain) {
  const fs::path scene = demfem::test::write_temp(
      "hypoplastic_vtk.toml",
      demfem::test::with_values(demfem::test::slurp(kScene),
                                {{"duration", "0.1"}, {"interval", "0.05"}, {"vtk", "true"}}));
  const auto has_array = [](const fs::path& dir, const std::string& name) {
    for (const auto& e : fs::directory_iterator(dir / "continuum"))
      if (e.path().extension() == ".vtu" &&
          demfem::test::slurp(e.path()).find("Name=\"" + name + "\"") != std::string::npos)
        return true;
    return false;
  };
  const fs::path hypo = demfem::test::scratch("hypoplastic_vtk");
  const Result h = run("run " + scene.string() + " --solver continuum --out " + hypo.string());
  ASSERT_EQ(h.code, 0) << h.out;
  EXPECT_TRUE(has_array(hypo, "void_ratio"));
  EXPECT_TRUE(has_array(hypo, "intergranular_strain"));
  const fs::path mc = demfem::test::scratch("mohr_coulomb_vtk");
  const Result m = run("run " + scene.string() +
                       " --solver continuum --variant mohr-coulomb --out " + mc.string());
  ASSERT_EQ(m.code, 0) << m.out;
  EXPECT_FALSE(has_array(mc, "void_ratio"));
  EXPECT_TRUE(has_array(mc, "plastic_strain"));
}

#endif
