// Scene loading: a valid scene resolves to the expected typed values, and each malformed input
// is rejected with the specific message at the right line.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include <gtest/gtest.h>

#include "constitutive/soil.hpp"
#include "demfem/app/vocabulary.hpp"
#include "demfem/scene/load.hpp"

using namespace demfem::scene;
namespace cst = demfem::continuum::constitutive;

namespace {

// Line numbers matter: tests below refer to them.
const std::string kValid = R"([scene]
name = "box"
solvers = ["dem", "continuum"]
duration = 2.0

[domain]
polygon = [[0, 0], [8, 0], [8, 5.6], [0, 5.6]]

[soil.dem]
count = 100
radius = { uniform = [0.04, 0.075] }
contact = "cundall-rebound"
kn = 1.0e6
ks = 3.0e5
mu_static = 0.5
mu_dynamic = 0.2

[soil.continuum]
model = "mohr-coulomb"
young = 3.0e7
friction_angle = 30

[[structure]]
name = "wall"
kind = "wall"
shape = "segment"
from = [8, 0]
to = [8, 5.6]
record = ["thrust"]

[load]
gravity = 9.81
shaking = { direction = "x", amplitude = 4.0, frequency = 3.6 }

[[variant]]
name = "case-2"
set = { "load.shaking.amplitude" = 8.0 }

[[variant]]
name = "rough"
set = { "soil.dem.mu_static" = 1.0, "soil.dem.mu_dynamic" = 0.5 }

[[wall]]
name = "base"
points = [[0, 0], [8, 0]]

[[wall]]
name = "left"
points = [[0, 5.6], [0, 0]]
)";

// Replace the first occurrence of `from` with `to` in the valid scene.
std::string mutate(const std::string& from, const std::string& to) {
  std::string s = kValid;
  const auto pos = s.find(from);
  EXPECT_NE(pos, std::string::npos) << "test bug: '" << from << "' not in the valid scene";
  if (pos != std::string::npos) s.replace(pos, from.size(), to);
  return s;
}

// Expects a SceneError with a diagnostic at `line` whose message contains `needle`.
void expect_error(const std::string& text, int line, const std::string& needle,
                  const std::string& key = "") {
  try {
    (void)parse_scene(text, "test.toml", demfem::app::vocabulary());
    FAIL() << "expected a SceneError containing '" << needle << "'";
  } catch (const SceneError& e) {
    bool found = false;
    for (const auto& d : e.diagnostics()) {
      if (d.message.find(needle) != std::string::npos && (line <= 0 || d.line == line) &&
          (key.empty() || d.key == key)) {
        found = true;
        EXPECT_EQ(d.file, "test.toml");
        EXPECT_NE(d.format().find("test.toml:"), std::string::npos);
      }
    }
    EXPECT_TRUE(found) << "wanted line " << line << " '" << needle << "', got:\n" << e.what();
  }
}

} // namespace

TEST(SceneLoad, ValidSceneResolves) {
  const auto f = parse_scene(kValid, "test.toml", demfem::app::vocabulary());
  const auto& s = f.base;
  EXPECT_EQ(s.info.name, "box");
  EXPECT_TRUE(s.uses(Solver::Dem));
  EXPECT_TRUE(s.uses(Solver::Continuum));
  ASSERT_TRUE(s.soil.dem);
  EXPECT_EQ(s.soil.dem->count, 100);
  EXPECT_DOUBLE_EQ(s.soil.dem->radius.min, 0.04);
  EXPECT_DOUBLE_EQ(s.soil.dem->radius.max, 0.075);
  ASSERT_NE(s.soil.dem->model("contact"), nullptr);
  EXPECT_EQ(s.soil.dem->model("contact")->keyword, "cundall-rebound");
  EXPECT_EQ(value_of(*s.soil.dem->model("contact"), "rebound"), 0.1); // default K (§2.1.2)
  EXPECT_EQ(s.soil.dem->fill.size(), 4u);                             // defaults to the domain
  ASSERT_TRUE(s.soil.continuum);
  EXPECT_NEAR(cst::strength_block(*s.soil.continuum).friction_angle,
              30.0 * std::numbers::pi / 180.0, 1e-12);
  ASSERT_EQ(s.structures.size(), 1u);
  EXPECT_EQ(s.structures[0].kind, StructureKind::Wall);
  EXPECT_GT(signed_area(s.structures[0].outline), 0.0);
  ASSERT_TRUE(s.load.shaking);
  EXPECT_NEAR(s.load.shaking->acceleration(1.0 / (4 * 3.6)), 4.0, 1e-12);
}

TEST(SceneLoad, VariantsAreResolvedSeparately) {
  const auto f = parse_scene(kValid, "test.toml", demfem::app::vocabulary());
  ASSERT_EQ(f.variants.size(), 2u);
  EXPECT_EQ(f.variants[0].variant, "case-2");
  EXPECT_DOUBLE_EQ(f.variants[0].load.shaking->acceleration.amplitude, 8.0);
  EXPECT_DOUBLE_EQ(f.base.load.shaking->acceleration.amplitude, 4.0);
  EXPECT_DOUBLE_EQ(f.select("rough").soil.dem->mu_static, 1.0);
  EXPECT_DOUBLE_EQ(f.select("rough").soil.dem->mu_dynamic, 0.5);
  EXPECT_DOUBLE_EQ(f.select("case-2").soil.dem->mu_static, 0.5);
  EXPECT_THROW((void)f.select("nope"), SceneError);
}

TEST(SceneLoad, VariantCanAddressArrayElementsByName) {
  const auto f = parse_scene(mutate(R"(set = { "load.shaking.amplitude" = 8.0 })",
                                    R"(set = { "structure.wall.to" = [8, 5.0] })"),
                             "test.toml", demfem::app::vocabulary());
  EXPECT_NEAR(f.select("case-2").structures[0].height, 5.0, 1e-12);
}

TEST(SceneLoad, VariantMayStateACalibratedKeyOnlyWithCalibrateDem) {
  // With calibrate = "dem" the calibrated keys (dilation_angle, …) exist implicitly.
  const std::string base_keys = "young = 3.0e7\nfriction_angle = 30";
  std::string text = mutate(R"(set = { "load.shaking.amplitude" = 8.0 })",
                            R"(set = { "soil.continuum.dilation_angle" = 5.0 })");
  text.replace(text.find(base_keys), base_keys.size(), "calibrate = \"dem\"");
  const auto g = parse_scene(text, "test.toml", demfem::app::vocabulary());
  const auto& c = *g.select("case-2").soil.continuum;
  EXPECT_NEAR(cst::strength_block(c).dilation_angle, 5.0 * std::numbers::pi / 180.0, 1e-12);
  EXPECT_NE(std::find(c.given.begin(), c.given.end(), "dilation_angle"), c.given.end());
  // Without calibrate = "dem" it is a missing key, as any other.
  expect_error(mutate(R"(set = { "load.shaking.amplitude" = 8.0 })",
                      R"(set = { "soil.continuum.cohesion" = 1.0 })"),
               37, "the base scene has no key 'cohesion' under 'soil.continuum'");
}

TEST(SceneLoad, ResolvedSceneRoundTrips) {
  const auto f = parse_scene(kValid, "test.toml", demfem::app::vocabulary());
  for (const Scene* s : {&f.base, &f.variants[0], &f.variants[1]}) {
    // The first line names the source file; the rest must be identical.
    auto body = [](const std::string& t) { return t.substr(t.find('\n')); };
    const std::string dumped = to_toml(*s);
    const auto again = parse_scene(dumped, "dumped.toml", demfem::app::vocabulary());
    EXPECT_EQ(body(to_toml(again.base)), body(dumped));
  }
}

TEST(SceneLoad, TomlSyntaxErrorPointsAtLine) {
  expect_error(mutate("kn = 1.0e6", "kn = = 1.0e6"), 13, "TOML syntax");
}
TEST(SceneLoad, WrongType) {
  expect_error(mutate("kn = 1.0e6", "kn = \"stiff\""), 13,
               "expected a number, got the string \"stiff\"", "soil.dem.kn");
}
TEST(SceneLoad, UnknownKey) {
  expect_error(mutate("ks = 3.0e5", "ks = 3.0e5\nkss = 1"), 15,
               "unknown key; valid keys here:", "soil.dem.kss");
}
TEST(SceneLoad, UnknownTopLevelTable) {
  expect_error(kValid + "\n[solver]\nx = 1\n", 0, "unknown key", "solver");
}
TEST(SceneLoad, NegativeRadius) {
  expect_error(mutate("uniform = [0.04, 0.075]", "uniform = [-0.04, 0.075]"), 11, "0 < min ≤ max");
}
TEST(SceneLoad, RadiusMinAboveMax) {
  expect_error(mutate("uniform = [0.04, 0.075]", "uniform = [0.08, 0.075]"), 11, "0 < min ≤ max");
}
TEST(SceneLoad, NegativeFriction) {
  expect_error(mutate("mu_static = 0.5", "mu_static = -0.5"), 15, "must be ≥ 0, got -0.5",
               "soil.dem.mu_static");
}
TEST(SceneLoad, DynamicFrictionAboveStatic) {
  expect_error(mutate("mu_dynamic = 0.2", "mu_dynamic = 0.7"), 16, "exceeds static friction");
}
TEST(SceneLoad, EmptyPolygon) {
  expect_error(mutate("polygon = [[0, 0], [8, 0], [8, 5.6], [0, 5.6]]", "polygon = []"), 7,
               "empty polygon");
}
TEST(SceneLoad, SelfIntersectingPolygon) {
  expect_error(mutate("polygon = [[0, 0], [8, 0], [8, 5.6], [0, 5.6]]",
                      "polygon = [[0, 0], [8, 5.6], [8, 0], [0, 5.6]]"),
               7, "self-intersecting");
}
TEST(SceneLoad, MalformedPoint) {
  expect_error(mutate("[8, 0], [8, 5.6], [0, 5.6]]", "[8, 0, 1], [8, 5.6], [0, 5.6]]"), 7,
               "expected a point [x, z]");
}
TEST(SceneLoad, UnknownContactLaw) {
  expect_error(mutate("contact = \"cundall-rebound\"", "contact = \"hooke\""), 12,
               "unknown keyword 'hooke'; valid: cundall-rebound, cundall-dashpot, "
               "linear-restitution, hertz-mindlin");
}
TEST(SceneLoad, VariantOverridingMissingKey) {
  expect_error(mutate(R"("load.shaking.amplitude" = 8.0)", R"("load.shaking.amplitud" = 8.0)"), 37,
               "the base scene has no key 'amplitud' under 'load.shaking'");
}
TEST(SceneLoad, VariantOverridingMissingTable) {
  expect_error(mutate(R"("load.shaking.amplitude" = 8.0)", R"("lod.shaking.amplitude" = 8.0)"), 37,
               "the base scene has no 'lod'");
}
TEST(SceneLoad, VariantOverrideOfWrongTypeIsReportedAtTheVariant) {
  expect_error(mutate(R"("load.shaking.amplitude" = 8.0)", R"("load.shaking.amplitude" = "big")"),
               37, "expected a number");
}
TEST(SceneLoad, NaNIsRejected) {
  expect_error(mutate("kn = 1.0e6", "kn = nan"), 13, "must be a finite number");
}
TEST(SceneLoad, InfinityIsRejected) {
  expect_error(mutate("young = 3.0e7", "young = inf"), 20, "must be a finite number");
}
TEST(SceneLoad, ZeroStiffness) {
  expect_error(mutate("ks = 3.0e5", "ks = 0"), 14, "must be > 0, got 0");
}
TEST(SceneLoad, NonIntegerCount) {
  expect_error(mutate("count = 100", "count = 100.5"), 10, "expected an integer");
}
TEST(SceneLoad, MissingScene) {
  expect_error(mutate("[scene]\nname = \"box\"", "[scen]\nname = \"box\""), 0,
               "missing required table [scene]");
}
TEST(SceneLoad, MissingDemSoilForDemSolver) {
  std::string s = kValid;
  const auto a = s.find("[soil.dem]");
  const auto b = s.find("[soil.continuum]");
  s.erase(a, b - a);
  expect_error(s, 0, "lists \"dem\" but there is no [soil.dem]");
}
TEST(SceneLoad, UnknownShakingDirection) {
  expect_error(mutate("direction = \"x\"", "direction = \"y\""), 33, "must be \"x\" or \"z\"");
}
TEST(SceneLoad, PoissonOutOfRange) {
  expect_error(mutate("young = 3.0e7", "young = 3.0e7\npoisson = 0.5"), 21, "must be in [-1, 0.5)");
}
TEST(SceneLoad, NegativeMaxDisplacement) {
  expect_error(
      mutate("friction_angle = 30", "friction_angle = 30\n\n[continuum]\nmax_displacement = -1"),
      24, "must be ≥ 0, got -1", "continuum.max_displacement");
}
TEST(SceneLoad, ContinuumSurfaceBBarAndValidityLimit) {
  const std::string text = mutate(
      "friction_angle = 30",
      "friction_angle = 30\nsurface = 5.0\n\n[continuum]\nbbar = false\nmax_displacement = 0.5");
  const SceneFile f = parse_scene(text, "surface.toml", demfem::app::vocabulary());
  ASSERT_TRUE(f.base.soil.continuum.has_value());
  EXPECT_DOUBLE_EQ(*f.base.soil.continuum->surface, 5.0);
  EXPECT_FALSE(f.base.continuum.bbar);
  EXPECT_DOUBLE_EQ(f.base.continuum.max_displacement, 0.5);
  // and they survive the resolved-scene round trip
  const SceneFile again = parse_scene(to_toml(f.base), "again.toml", demfem::app::vocabulary());
  EXPECT_DOUBLE_EQ(*again.base.soil.continuum->surface, 5.0);
  EXPECT_FALSE(again.base.continuum.bbar);
  EXPECT_DOUBLE_EQ(again.base.continuum.max_displacement, 0.5);
}
TEST(SceneLoad, DilationCutoff) {
  // absent: none; given: kept through the resolved-scene round trip; out of [0, 1]: located error
  EXPECT_TRUE(
      std::isnan(cst::strength_block(
                     *parse_scene(kValid, "a.toml", demfem::app::vocabulary()).base.soil.continuum)
                     .dilation_cutoff));
  const SceneFile f =
      parse_scene(mutate("friction_angle = 30", "friction_angle = 30\ndilation_cutoff = 0.02"),
                  "cut.toml", demfem::app::vocabulary());
  EXPECT_DOUBLE_EQ(cst::strength_block(*f.base.soil.continuum).dilation_cutoff, 0.02);
  const SceneFile again = parse_scene(to_toml(f.base), "again.toml", demfem::app::vocabulary());
  EXPECT_DOUBLE_EQ(cst::strength_block(*again.base.soil.continuum).dilation_cutoff, 0.02);
  expect_error(mutate("friction_angle = 30", "friction_angle = 30\ndilation_cutoff = -0.1"), 22,
               "must be in [0, 1], got -0.1", "soil.continuum.dilation_cutoff");
}
TEST(SceneLoad, SeatStructures) {
  // absent: automatic (nullopt); given: kept, and it survives the resolved-scene round trip
  EXPECT_FALSE(parse_scene(kValid, "a.toml", demfem::app::vocabulary())
                   .base.continuum.seat_structures.has_value());
  const SceneFile f = parse_scene(
      mutate("friction_angle = 30", "friction_angle = 30\n\n[continuum]\nseat_structures = false"),
      "seat.toml", demfem::app::vocabulary());
  ASSERT_TRUE(f.base.continuum.seat_structures.has_value());
  EXPECT_FALSE(*f.base.continuum.seat_structures);
  const SceneFile again = parse_scene(to_toml(f.base), "again.toml", demfem::app::vocabulary());
  ASSERT_TRUE(again.base.continuum.seat_structures.has_value());
  EXPECT_FALSE(*again.base.continuum.seat_structures);
  expect_error(
      mutate("friction_angle = 30", "friction_angle = 30\n\n[continuum]\nseat_structures = 1"), 24,
      "expected true or false", "continuum.seat_structures");
}
TEST(SceneLoad, UnknownStructureKind) {
  expect_error(mutate("kind = \"wall\"", "kind = \"dam\""), 25, "valid: pile, footing, wall");
}
TEST(SceneLoad, ZeroLengthSegment) {
  expect_error(mutate("to = [8, 5.6]", "to = [8, 0]"), 28, "zero length");
}
TEST(SceneLoad, UnknownRecord) {
  expect_error(mutate("record = [\"thrust\"]", "record = [\"thrust\", \"pressure\"]"), 29,
               "unknown record 'pressure'");
}
TEST(SceneLoad, DuplicateVariantName) {
  expect_error(mutate("name = \"rough\"", "name = \"case-2\""), 0, "duplicate variant name");
}
TEST(SceneLoad, UnknownTimeFunctionType) {
  expect_error(kValid + "\n[[structure]]\nname = \"f\"\nbase = [4, 0]\nwidth = 1\nheight = 1\n"
                        "force_z = { type = \"cosine\", amplitude = 1 }\n",
               0, "unknown time function 'cosine'");
}
TEST(SceneLoad, TableTimesMustIncrease) {
  expect_error(kValid + "\n[[structure]]\nname = \"f\"\nbase = [4, 0]\nwidth = 1\nheight = 1\n"
                        "moment = { type = \"table\", points = [[0, 0], [2, 1], [1, 3]] }\n",
               0, "times must increase strictly");
}
TEST(SceneLoad, EventNamesUnknownGroup) {
  expect_error(kValid + "\n[[event]]\ntime = 10\naction = \"set-friction\"\ngroup = \"basal\"\n", 0,
               "names group 'basal', which no [[group]] defines");
}
TEST(SceneLoad, AllErrorsReportedAtOnce) {
  std::string s = mutate("kn = 1.0e6", "kn = -1");
  s.replace(s.find("ks = 3.0e5"), 10, "ks = -3");
  try {
    (void)parse_scene(s, "test.toml", demfem::app::vocabulary());
    FAIL();
  } catch (const SceneError& e) {
    EXPECT_GE(e.diagnostics().size(), 2u);
  }
}
TEST(SceneLoad, MissingFileIsAClearError) {
  try {
    (void)load_scene_file("/nonexistent/scene.toml", demfem::app::vocabulary());
    FAIL();
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos);
  }
}

// continuum.interface = "coulomb" (zero-thickness Coulomb contact) is an explicit-integrator
// feature: with the implicit integrator it is refused at the key, saying what is valid.
TEST(SceneLoad, CoulombInterfaceNeedsTheExplicitIntegrator) {
  const std::string implicit_coulomb =
      kValid + "\n[continuum]\nintegrator = \"implicit\"\ninterface = \"coulomb\"\n";
  const int line = int(std::count(kValid.begin(), kValid.end(), '\n')) + 4;
  expect_error(implicit_coulomb, line, "needs integrator = \"explicit\"");
  expect_error(kValid + "\n[continuum]\ninterface = \"sticky\"\n", 0,
               "valid: tied, frictional, coulomb");
  const auto ok =
      parse_scene(kValid + "\n[continuum]\nintegrator = \"explicit\"\ninterface = \"coulomb\"\n",
                  "test.toml", demfem::app::vocabulary());
  EXPECT_EQ(ok.base.continuum.interface, "coulomb");
}

// continuum.structure_interface (moving structures in Coulomb contact, or tied as before): an
// unknown value is refused at the key (line and column), saying what is valid.
TEST(SceneLoad, StructureInterfaceValues) {
  const int line = int(std::count(kValid.begin(), kValid.end(), '\n')) + 5;
  expect_error(kValid + "\n[continuum]\nintegrator = \"explicit\"\ninterface = \"coulomb\"\n"
                        "structure_interface = \"glued\"\n",
               line, "valid: contact, tied");
  const auto ok = parse_scene(kValid + "\n[continuum]\nintegrator = \"explicit\"\ninterface = "
                                       "\"coulomb\"\nstructure_interface = \"tied\"\n",
                              "test.toml", demfem::app::vocabulary());
  EXPECT_EQ(ok.base.continuum.structure_interface, "tied");
  EXPECT_EQ(parse_scene(kValid, "test.toml", demfem::app::vocabulary())
                .base.continuum.structure_interface,
            "contact");
}

// scene::thrust_normal: the chord's normal, pointing out of the soil (away from the domain's
// centroid) whichever way the wall was drawn; without a domain, the chord's right-hand normal.
TEST(SceneGeometry, ThrustNormalPointsOutOfTheSoil) {
  using demfem::scene::Polygon;
  using demfem::scene::thrust_normal;
  const Polygon box = {{0, 0}, {8, 0}, {8, 5}, {0, 5}};
  auto expect = [](demfem::scene::Vec2 n, double x, double z) {
    EXPECT_NEAR(n.x, x, 1e-15);
    EXPECT_NEAR(n.z, z, 1e-15);
  };
  expect(thrust_normal({{8, 0}, {8, 5}}, box), 1, 0);  // right wall, drawn upwards
  expect(thrust_normal({{8, 5}, {8, 0}}, box), 1, 0);  // … and downwards
  expect(thrust_normal({{0, 5}, {0, 0}}, box), -1, 0); // left wall
  expect(thrust_normal({{0, 0}, {0, 5}}, box), -1, 0);
  expect(thrust_normal({{8, 0}, {0, 0}}, box), 0, -1); // base
  expect(thrust_normal({{0, 0}, {8, 0}}, box), 0, -1);
  // a wall structure's outline (x = 8 … 8.2): its chord (8.2, 5) → (8.2, 0), normal still +x
  expect(thrust_normal({{8.2, 5}, {8, 5}, {8, 0}, {8.2, 0}}, box), 1, 0);
  expect(thrust_normal({{8, 5}, {8, 0}}, {}), -1, 0);  // no domain: right-hand normal
  const auto d = thrust_normal({{8, 0}, {9, 1}}, box); // inclined: unit length
  EXPECT_NEAR(std::hypot(d.x, d.z), 1.0, 1e-15);
  EXPECT_GT(d.x, 0.0);
}

// [output] vtk_compression: a keyword (lz4 by default), kept through the resolved scene's dump
// only when not the default; anything else is an error located at the key.
TEST(SceneLoad, VtkCompressionKeyword) {
  EXPECT_EQ(parse_scene(kValid, "test.toml", demfem::app::vocabulary()).base.output.vtk_compression,
            VtkCompression::Lz4);
  const std::string zlib = std::string(kValid) + "\n[output]\nvtk_compression = \"zlib\"\n";
  const Scene s = parse_scene(zlib, "test.toml", demfem::app::vocabulary()).base;
  EXPECT_EQ(s.output.vtk_compression, VtkCompression::Zlib);
  const std::string dumped = to_toml(s);
  EXPECT_NE(dumped.find("vtk_compression"), std::string::npos) << dumped;
  EXPECT_EQ(
      parse_scene(dumped, "dumped.toml", demfem::app::vocabulary()).base.output.vtk_compression,
      VtkCompression::Zlib);
  EXPECT_EQ(to_toml(parse_scene(kValid, "test.toml", demfem::app::vocabulary()).base)
                .find("vtk_compression"),
            std::string::npos);
  const std::string bad = std::string(kValid) + "\n[output]\nvtk_compression = \"gzip\"\n";
  const int line = static_cast<int>(std::count(bad.begin(), bad.end(), '\n'));
  expect_error(bad, line, "unknown keyword 'gzip'; valid: zlib, lz4, none");
}

// ---- probes: every key a kind takes has an effect; the others are refused --------------------
namespace {
std::string with_probes(const std::string& probes) {
  return kValid + "\n" + probes;
}
} // namespace

TEST(SceneLoad, ProbeKindStructureSaysWhatToWriteInstead) {
  expect_error(with_probes("[[probe]]\nkind = \"structure\"\ntarget = \"wall\"\n"), 0,
               "there is no probe kind 'structure': structures.csv records every structure");
}
TEST(SceneLoad, ProbeKeyItsKindDoesNotTakeIsRefused) {
  expect_error(with_probes("[[probe]]\nkind = \"loci\"\npoints = [[1, 1]]\nbins = 4\n"), 0,
               "a loci probe takes no 'bins' (it would have no effect); its keys: kind, interval, "
               "points");
  expect_error(with_probes("[[probe]]\nkind = \"energy\"\ntarget = \"wall\"\n"), 0,
               "an energy probe takes no 'target'");
}
TEST(SceneLoad, OneProbeOfAKindPerTarget) {
  expect_error(with_probes("[[probe]]\nkind = \"surface-profile\"\n\n[[probe]]\nkind = "
                           "\"surface-profile\"\nbins = 8\n"),
               0, "a second 'surface-profile' probe (probe[0] is one)");
  expect_error(with_probes("[[probe]]\nkind = \"pressure-profile\"\ntarget = \"wall\"\n\n[[probe]]"
                           "\nkind = \"pressure-profile\"\ntarget = \"wall\"\n"),
               0, "a second 'pressure-profile' probe on 'wall'");
  expect_error(with_probes("[[probe]]\nkind = \"wall-thrust\"\ntarget = \"wall\"\n\n[[probe]]"
                           "\nkind = \"wall-thrust\"\ntarget = \"wall\"\ninterval = 0.1\n"),
               0, "the wall-thrust probes write one file, walls.csv, at one interval");
}
TEST(SceneLoad, ProbesRoundTripWithTheirKeys) {
  const auto f = parse_scene(
      with_probes("[[probe]]\nkind = \"energy\"\ninterval = 0.05\n\n[[probe]]\nkind = "
                  "\"pressure-profile\"\ntarget = \"wall\"\nbins = 7\ninterval = 0.02\n\n[[probe]]"
                  "\nkind = \"loci\"\npoints = [[1, 1], [2, 2]]\n"),
      "test.toml", demfem::app::vocabulary());
  ASSERT_EQ(f.base.probes.size(), 3u);
  EXPECT_EQ(f.base.probes[0].interval, 0.05);
  EXPECT_EQ(f.base.probes[1].bins, 7);
  EXPECT_EQ(f.base.probes[1].interval, 0.02);
  const std::string dumped = to_toml(f.base);
  const auto again = parse_scene(dumped, "dumped.toml", demfem::app::vocabulary());
  ASSERT_EQ(again.base.probes.size(), 3u);
  EXPECT_EQ(again.base.probes[1].target, "wall");
  EXPECT_EQ(again.base.probes[2].points.size(), 2u);
  auto body = [](const std::string& t) { return t.substr(t.find('\n')); };
  EXPECT_EQ(body(to_toml(again.base)), body(dumped));
}

// The step limits come with the vocabulary the loader is given, not from process-wide state: the
// same text is refused under a vocabulary whose DEM limit it exceeds, and accepted under one
// without limits, in the same process and in either order.
TEST(SceneLoad, StepLimitsComeWithTheVocabulary) {
  const std::string text = mutate("ks = 3.0e5\n", "ks = 3.0e5\ndt = 1.0e-3\n");
  Vocabulary strict = demfem::app::vocabulary();
  strict.dem_step_limit = [](const Scene&) {
    return std::optional<DemStepLimit>(DemStepLimit{1.0e-4, "a test's limit"});
  };
  Vocabulary none = demfem::app::vocabulary();
  none.dem_step_limit = nullptr;
  none.continuum_step_limit = nullptr;
  for (int round = 0; round < 2; ++round) {
    EXPECT_NO_THROW((void)parse_scene(text, "test.toml", none));
    try {
      (void)parse_scene(text, "test.toml", strict);
      ADD_FAILURE() << "expected the strict vocabulary to refuse dt";
    } catch (const SceneError& e) {
      EXPECT_EQ(e.diagnostics().at(0).key, "soil.dem.dt");
      EXPECT_EQ(e.diagnostics().at(0).line, 15); // the dt line
      EXPECT_NE(e.diagnostics().at(0).message.find("a test's limit"), std::string::npos);
    }
  }
}

// record = ["pressure-profile"] on a structure profiles it (a pressure-profile probe with the
// default bins), once: a [[probe]] that already profiles it is not doubled.
TEST(SceneLoad, StructureRecordPressureProfileAddsItsProbe) {
  const auto count = [](const Scene& s) {
    return std::count_if(s.probes.begin(), s.probes.end(), [](const Probe& p) {
      return p.kind == ProbeKind::PressureProfile && p.target == "wall";
    });
  };
  const auto plain = parse_scene(kValid, "test.toml", demfem::app::vocabulary());
  EXPECT_EQ(count(plain.base), 0);
  const auto recorded =
      parse_scene(mutate("record = [\"thrust\"]", "record = [\"thrust\", \"pressure-profile\"]"),
                  "test.toml", demfem::app::vocabulary());
  ASSERT_EQ(count(recorded.base), 1);
  EXPECT_EQ(recorded.base.probes.back().bins, Probe{}.bins);
  const auto both =
      parse_scene(mutate("record = [\"thrust\"]", "record = [\"thrust\", \"pressure-profile\"]") +
                      "\n[[probe]]\nkind = \"pressure-profile\"\ntarget = \"wall\"\nbins = 7\n",
                  "test.toml", demfem::app::vocabulary());
  ASSERT_EQ(count(both.base), 1);
  EXPECT_EQ(both.base.probes.back().bins, 7);
}
