// The contact registry and the composition of laws from sub-models (dem/contact/): each law's
// name is its scene keyword, a scene's keys reach the law the engine builds, and laws that share
// a sub-model compute the same with it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <fmt/format.h>

#include "../scratch.hpp"
#include "demfem/app/vocabulary.hpp"
#include "demfem/dem/contact/registry.hpp"
#include "demfem/dem/engine.hpp"
#include "demfem/dem/pack.hpp"
#include "demfem/dem/run.hpp"
#include "demfem/scene/load.hpp"

using namespace demfem;
using namespace demfem::dem;

namespace {

std::string scene_with(const std::string& soil_keys) {
  return R"([scene]
name = "pair"
duration = 0.1
[domain]
polygon = [[-1, -1], [1, -1], [1, 1], [-1, 1]]
[soil.dem]
count = 2
radius = { equal = 0.05 }
particles = [[-0.06, 0, 0.05], [0.06, 0, 0.05]]
)" + soil_keys;
}

scene::DemSoil soil_of(const std::string& soil_keys) {
  return *scene::parse_scene(scene_with(soil_keys), "pair.toml", app::vocabulary()).base.soil.dem;
}

} // namespace

TEST(DemContact, EachLawsNameIsItsKeyword) {
  const auto slot = contact::law_slot();
  ASSERT_EQ(slot.keywords(), (std::vector<std::string>{"cundall-rebound", "cundall-dashpot",
                                                       "linear-restitution", "hertz-mindlin"}));
  EXPECT_EQ(slot.default_keyword, "cundall-rebound");
  for (const auto& kw : slot.keywords()) {
    const auto law = contact::make_law(kw);
    EXPECT_EQ(contact::law_name(law), kw);
    EXPECT_EQ(contact::rolling_name(law), "none");
    EXPECT_EQ(std::visit([](const auto& m) { return m.kHistory; }, law), 0u) << kw;
  }
  EXPECT_THROW((void)contact::make_law("jkr"), std::invalid_argument);
  EXPECT_THROW((void)contact::make_law("cundall-rebound", {{"young", 1.0}, {"no_such_key", 1.0}}),
               std::invalid_argument);
}

// The scene's keys reach the engine's law: a Hertz law built from E and ν of the file.
TEST(DemContact, SceneKeysReachTheEnginesLaw) {
  const auto law =
      contact::make_law(soil_of("contact = \"hertz-mindlin\"\nyoung = 2.0e9\npoisson = 0.2\n"));
  EXPECT_EQ(contact::law_name(law), "hertz-mindlin");
  const double e_star = 2.0e9 / (2.0 * (1.0 - 0.04)), r = 0.025, delta = 1e-4;
  const double f = std::visit([&](const auto& m) { return m.elastic_force(delta, r); }, law);
  EXPECT_NEAR(f, 4.0 / 3.0 * e_star * std::sqrt(r * delta) * delta, 1e-9 * f); // Johnson 4.22
  const double back = std::visit([&](const auto& m) { return m.overlap(f, r); }, law);
  EXPECT_NEAR(back, delta, 1e-12);
  // an unknown law is refused at its key, listing the valid ones
  try {
    (void)soil_of("contact = \"jkr\"\n");
    FAIL() << "expected a SceneError";
  } catch (const scene::SceneError& e) {
    EXPECT_EQ(e.diagnostics().at(0).key, "soil.dem.contact");
    EXPECT_NE(e.diagnostics().at(0).message.find("valid: cundall-rebound, cundall-dashpot"),
              std::string::npos)
        << e.what();
  }
}

// cundall-dashpot with η_n = η_s = 0 and cundall-rebound below V_0 share the linear spring and
// the linear shear spring: the same forces and energies, step by step, over a contact that
// touches, slides and releases.
TEST(DemContact, SharedSubModelsComputeTheSame) {
  const auto a = contact::make_law("cundall-rebound", {{"kn", 2e6}, {"ks", 5e5}});
  const auto b = contact::make_law("cundall-dashpot", {{"kn", 2e6}, {"ks", 5e5}});
  ContactHistory ha, hb;
  double delta = -1e-5;
  for (int k = 0; k < 200; ++k) {
    ContactInput in{};
    in.delta = delta;
    in.vn = 0.2 * std::cos(0.05 * k); // closes, then opens
    in.vs = 0.1;
    in.m_eff = 0.3;
    in.r_eff = 0.02;
    in.mu_s = 0.5;
    in.mu_d = 0.3;
    in.dt = 1e-4;
    const auto ra = std::visit([&](const auto& m) { return m.evaluate(in, ha, nullptr); }, a);
    const auto rb = std::visit([&](const auto& m) { return m.evaluate(in, hb, nullptr); }, b);
    ASSERT_EQ(ra.fn, rb.fn) << k;
    ASSERT_EQ(ra.ft, rb.ft) << k;
    ASSERT_EQ(ra.e_friction, rb.e_friction) << k;
    ASSERT_EQ(ra.e_normal, rb.e_normal) << k;
    ASSERT_EQ(ra.touching, rb.touching) << k;
    ASSERT_EQ(ha.flags, hb.flags) << k;
    delta += in.vn * in.dt;
  }
  EXPECT_EQ(ha.flags, 0); // released
}

// The report's and the docs' view of the laws: every key of [soil.dem]'s contact slot once, with
// its unit, default and meaning.
TEST(DemContact, SchemaListsEveryKeyOnce) {
  const auto rows = scene::schema(contact::law_slot());
  std::vector<std::string> keys;
  for (const auto& r : rows) {
    keys.push_back(r.key);
    EXPECT_FALSE(r.meaning.empty()) << r.key;
  }
  EXPECT_EQ(keys, (std::vector<std::string>{"contact", "kn", "tension", "tensile_strength", "ks",
                                            "rebound", "rebound_speed", "eta_n", "eta_s",
                                            "restitution", "young", "poisson"}));
  EXPECT_EQ(rows[1].unit, "N/m");
  EXPECT_EQ(rows[1].fallback, "1e+06");
}

// hertz-mindlin has no K_n: its deposition damping, its run and its overlap check ask the law.
// The same scene with kn = 1e6 and with an absurd kn = 1e15 (a key hertz-mindlin does not read)
// deposits the same bed and runs to the same end, bit for bit.
TEST(DemContact, HertzMindlinNeverReadsKn) {
  auto text = [](const char* kn) {
    return fmt::format(R"([scene]
name = "hertz-bed"
duration = 0.05
seed = 3
[domain]
polygon = [[0, 0], [0.6, 0], [0.6, 0.8], [0, 0.8]]
[soil.dem]
count = 60
radius = {{ uniform = [0.02, 0.03] }}
contact = "hertz-mindlin"
young = 5.0e7
poisson = 0.3
kn = {}
[soil.dem.packing]
damping = 0.2
max_time = 0.3
[output]
vtk = false
figures = false
[[wall]]
name = "box"
points = [[0, 0.8], [0, 0], [0.6, 0], [0.6, 0.8]]
)",
                       kn);
  };
  std::vector<std::string> energy;
  std::vector<dem::Particles> beds;
  std::vector<double> overlap;
  for (const char* kn : {"1.0e6", "1.0e15"}) {
    const auto file = scene::parse_scene(text(kn), "hertz-bed.toml", app::vocabulary());
    const auto out = demfem::test::scratch(std::string("hertz-kn-") + kn);
    beds.push_back(dem::pack(file.base, out).particles);
    dem::RunOptions o;
    o.out_dir = out;
    const auto s = dem::run(file.base, o);
    ASSERT_TRUE(s.ok) << s.message;
    overlap.push_back(s.max_overlap_ratio);
    std::ifstream in(out / "dem" / "energy.csv");
    energy.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    std::filesystem::remove_all(out);
  }
  ASSERT_EQ(beds[0].size(), beds[1].size());
  for (std::size_t i = 0; i < beds[0].size(); ++i) {
    ASSERT_EQ(beds[0].x[i], beds[1].x[i]) << i;
    ASSERT_EQ(beds[0].z[i], beds[1].z[i]) << i;
  }
  EXPECT_EQ(energy[0], energy[1]);
  EXPECT_EQ(overlap[0], overlap[1]);
  EXPECT_GT(overlap[0], 0.0);
}

// The overlap check reads a wall contact's overlap from the law: a Hertz disk resting on a floor
// has δ = (3mg/(4E*√r))^{2/3} (Johnson, Contact Mechanics, eq. 4.22 inverted), which
// largest_overlap_ratio() returns as δ/r to 1 %.
TEST(DemContact, OverlapOfAHertzContactFromItsForce) {
  EngineConfig c;
  const double young = 1.0e8, poisson = 0.3, r = 0.05;
  c.law = contact::make_law("hertz-mindlin", {{"young", young}, {"poisson", poisson}});
  c.damping_c = c.damping_d = 20.0; // comes to rest
  Engine e(c);
  e.add_wall({{-1.0, 0.0}, {1.0, 0.0}}, "floor");
  e.add_particle(0.0, r, r);
  e.set_dt(e.auto_dt());
  e.run_steps(20000);
  const double m = c.density * 3.14159265358979 * r * r * c.thickness;
  const double e_star = young / (2.0 * (1.0 - poisson * poisson));
  const double delta = std::cbrt(std::pow(3.0 * m * c.gravity / (4.0 * e_star * std::sqrt(r)), 2));
  EXPECT_NEAR(e.largest_overlap_ratio(), delta / r, 0.01 * delta / r);
  EXPECT_NEAR(r - e.particles().z[0], delta, 0.01 * delta); // the geometry agrees
}

// linear-restitution: a head-on collision of two equal disks rebounds at the requested
// coefficient of restitution, within 1 %, at the automatic step (the damping ratio of the
// clamped dashpot, restitution.hpp), and e(ζ(e)) = e to round-off.
TEST(DemContact, LinearRestitutionReboundsAtTheRequestedCoefficient) {
  for (const double e : {0.1, 0.5, 0.9}) {
    EXPECT_NEAR(contact::Restitution::restitution_of(contact::Restitution::damping_ratio(e)), e,
                1e-12);
    EngineConfig c;
    c.gravity = 0.0;
    c.materials = {Material{0.5, 0.3}};
    c.law =
        contact::make_law("linear-restitution", {{"kn", 1.0e6}, {"ks", 3.0e5}, {"restitution", e}});
    Engine en(c);
    const double r = 0.05, v = 0.5, gap = 0.002;
    en.add_particle(-r - gap / 2, 0.0, r, v, 0.0);
    en.add_particle(r + gap / 2, 0.0, r, -v, 0.0);
    en.set_dt(en.auto_dt());
    en.run_steps(static_cast<long long>(0.05 / en.dt())); // the contact lasts ≈ 0.01 s
    const auto& p = en.particles();
    const double rebound = (p.vx[1] - p.vx[0]) / (2.0 * v);
    std::printf("e = %.2f: rebound %.5f (ζ = %.4f)\n", e, rebound,
                contact::Restitution::damping_ratio(e));
    EXPECT_NEAR(rebound, e, 0.01 * e);
    EXPECT_GT(p.x[1] - p.x[0], 2.0 * r); // apart
  }
}
