// The report's "what differs between the two models" and "parameters" sections
// (compare/model_differences.hpp) follow the scene and the run's records, and the report links the
// scene's study pages.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "../scratch.hpp"
#include "constitutive/soil.hpp"
#include "demfem/compare/model_differences.hpp"
#include "demfem/compare/report.hpp"

namespace fs = std::filesystem;
using namespace demfem;

namespace {

// An 8 m × 5.6 m box of soil with a base and a left wall and a rigid wall on the right, shaken.
scene::Scene wall_scene() {
  scene::Scene s;
  s.info.name = "box-wall";
  s.source_file = "cases/box_wall.toml";
  s.variant = "quick";
  s.info.solvers = {scene::Solver::Dem, scene::Solver::Continuum};
  s.info.duration = 3.0;
  s.domain = {{0, 0}, {8, 0}, {8, 5.6}, {0, 5.6}};
  scene::DemSoil d;
  d.count = 3400;
  d.radius.kind = scene::RadiusDistribution::Kind::Uniform;
  d.radius.min = 0.04;
  d.radius.max = 0.075;
  s.soil.dem = d;
  scene::ContinuumSoil c;
  demfem::continuum::constitutive::choose_model(c, "mohr-coulomb");
  s.soil.continuum = c;
  s.walls.push_back({"base", {{0, 0}, {8, 0}}, {}, {}, {}, false});
  s.walls.push_back({"left", {{0, 5.6}, {0, 0}}, {}, {}, {}, false});
  scene::Structure w;
  w.name = "wall";
  w.kind = scene::StructureKind::Wall;
  w.outline = {{8, 0}, {8.2, 0}, {8.2, 5.6}, {8, 5.6}};
  s.structures.push_back(w);
  scene::Shaking sh;
  sh.acceleration = scene::TimeFunction::sine(8.0, 3.6, 0.0, 1.0);
  s.load.shaking = sh;
  return s;
}

const compare::DiffRow* row(const std::vector<compare::DiffRow>& rows, const std::string& aspect) {
  for (const auto& r : rows)
    if (r.aspect == aspect) return &r;
  return nullptr;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

} // namespace

TEST(ReportModels, StructureFaceRowFollowsTheContinuumInterface) {
  auto s = wall_scene();
  const compare::ModelFacts none;
  const auto tied = compare::model_differences(s, none);
  const auto* t = row(tied, "boundary: structure faces");
  ASSERT_NE(t, nullptr);
  EXPECT_NE(t->continuum.find("tied"), std::string::npos) << t->continuum;
  EXPECT_NE(t->dem.find("μ_s 0.5 / μ_D 0.2"), std::string::npos) << t->dem;
  EXPECT_FALSE(t->matched);

  s.continuum.interface = "frictional";
  s.continuum.interface_friction_angle = 0.3491; // 20°
  const auto fr = compare::model_differences(s, none);
  const auto* f = row(fr, "boundary: structure faces");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->continuum.find("tied"), std::string::npos) << f->continuum;
  EXPECT_NE(f->continuum.find("one cell thick"), std::string::npos) << f->continuum;
  EXPECT_NE(f->continuum.find("δ = 20.0°"), std::string::npos) << f->continuum;
}

TEST(ReportModels, BoundariesAreWhatEachSolverDoes) {
  const auto rows = compare::model_differences(wall_scene(), {});
  const auto* base = row(rows, "boundary: base");
  ASSERT_NE(base, nullptr);
  EXPECT_NE(base->dem.find("frictional wall 'base'"), std::string::npos) << base->dem;
  EXPECT_NE(base->continuum.find("fixed"), std::string::npos) << base->continuum;
  // 8 m/s² > μ_s g = 4.9 m/s² (Newmark sliding block)
  EXPECT_NE(base->consequence.find("can slide on its base"), std::string::npos)
      << base->consequence;
  const auto* left = row(rows, "boundary: left side");
  ASSERT_NE(left, nullptr);
  EXPECT_NE(left->continuum.find("roller"), std::string::npos);
  EXPECT_FALSE(left->matched);
  // the right side of the mesh is the rigid wall's: no roller row for it
  EXPECT_EQ(row(rows, "boundary: right side"), nullptr);
  const auto* ex = row(rows, "excitation");
  ASSERT_NE(ex, nullptr);
  EXPECT_TRUE(ex->matched);
}

// continuum.interface = "coulomb": the walls are Coulomb contact planes with the DEM's μ and the
// fixed wall an unmeshed contact body, so the boundary rows say matched; a moving structure is a
// moving contact body too (matched), unless continuum.structure_interface = "tied", and then its
// row says so.
TEST(ReportModels, CoulombInterfaceMatchesTheBoundaries) {
  auto s = wall_scene();
  s.continuum.integrator = "explicit";
  s.continuum.interface = "coulomb";
  const auto rows = compare::model_differences(s, {});
  for (const char* aspect : {"boundary: base", "boundary: left side"}) {
    const auto* r = row(rows, aspect);
    ASSERT_NE(r, nullptr) << aspect;
    EXPECT_TRUE(r->matched) << aspect;
    EXPECT_NE(r->continuum.find("Coulomb contact plane"), std::string::npos) << r->continuum;
    EXPECT_NE(r->continuum.find("μ_s 0.5 / μ_D 0.2"), std::string::npos) << r->continuum;
  }
  const auto* faces = row(rows, "boundary: structure faces");
  ASSERT_NE(faces, nullptr);
  EXPECT_TRUE(faces->matched);
  EXPECT_NE(faces->continuum.find("zero-thickness Coulomb contact"), std::string::npos)
      << faces->continuum;

  s.structures[0].dof_rotation = scene::DofMode::Free;
  const auto moving_contact = compare::model_differences(s, {}); // (row points into it)
  const auto* in_contact = row(moving_contact, "boundary: structure faces");
  ASSERT_NE(in_contact, nullptr);
  EXPECT_TRUE(in_contact->matched);
  s.continuum.structure_interface = "tied";
  const auto moving = compare::model_differences(s, {});
  const auto* m = row(moving, "boundary: structure faces");
  ASSERT_NE(m, nullptr);
  EXPECT_FALSE(m->matched);
  EXPECT_NE(m->continuum.find("tied"), std::string::npos) << m->continuum;
}

TEST(ReportModels, SoilModelAndInitialStressRowsFollowTheScene) {
  auto s = wall_scene();
  compare::ModelFacts f;
  f.calibration = true;
  f.cal_k0 = 0.8;
  f.cal_surface = 5.0;
  f.cal_bulk_density = 2200.0;
  f.cal_soil_mass = 2200.0 * 40.0;
  s.soil.continuum->k0 = 0.8;
  s.soil.continuum->surface = 5.0;
  s.soil.continuum->density = 2200.0;
  auto rows = compare::model_differences(s, f);
  ASSERT_NE(row(rows, "initial stress"), nullptr);
  EXPECT_TRUE(row(rows, "initial stress")->matched);
  const auto* mass = row(rows, "soil surface, density and mass");
  ASSERT_NE(mass, nullptr);
  EXPECT_TRUE(mass->matched);
  // 8 m × 5 m of soil at 2200 kg/m³ (the wall lies outside the domain)
  EXPECT_NE(mass->continuum.find("mass 8.8e+04 kg"), std::string::npos) << mass->continuum;
  EXPECT_NE(row(rows, "soil model (constitutive behaviour)")->continuum.find("Mohr–Coulomb"),
            std::string::npos);

  s.soil.continuum->k0 = 0.5; // Jaky-like, not the bed's
  s.soil.continuum->surface = 5.6;
  demfem::continuum::constitutive::choose_model(*s.soil.continuum, "elastic");
  rows = compare::model_differences(s, f);
  EXPECT_FALSE(row(rows, "initial stress")->matched);
  EXPECT_NE(row(rows, "initial stress")->consequence.find("0.500 against the bed's 0.800"),
            std::string::npos)
      << row(rows, "initial stress")->consequence;
  EXPECT_FALSE(row(rows, "soil surface, density and mass")->matched);
  const auto* model = row(rows, "soil model (constitutive behaviour)");
  EXPECT_NE(model->continuum.find("linear elastic"), std::string::npos) << model->continuum;
  EXPECT_EQ(model->continuum.find("Mohr–Coulomb"), std::string::npos);
  // A hypoplastic soil: the row names it and says both models can compact
  demfem::continuum::constitutive::choose_model(*s.soil.continuum, "hypoplastic");
  rows = compare::model_differences(s, f);
  model = row(rows, "soil model (constitutive behaviour)");
  EXPECT_NE(model->continuum.find("hypoplastic"), std::string::npos) << model->continuum;
  EXPECT_NE(model->consequence.find("Both can compact"), std::string::npos) << model->consequence;
}

TEST(ReportModels, DampingRowSaysWhetherTheContinuumUsesTheMeasuredDamping) {
  auto s = wall_scene();
  compare::ModelFacts f;
  f.cal_cyclic = {{1.4e-4, 1.5e6, 0.008}, {4.6e-3, 1.1e6, 0.061}};
  auto rows = compare::model_differences(s, f);
  const auto* d = row(rows, "damping");
  ASSERT_NE(d, nullptr);
  EXPECT_NE(d->continuum.find("no Rayleigh damping"), std::string::npos) << d->continuum;
  EXPECT_NE(d->consequence.find("measured but not used"), std::string::npos) << d->consequence;
  s.continuum.rayleigh_alpha = 0.5;
  s.continuum.rayleigh_beta = 1e-3;
  s.soil.continuum->provenance = {{"continuum.rayleigh", "dem calibration abc: ξ0 = 0.0080"}};
  rows = compare::model_differences(s, f);
  d = row(rows, "damping");
  EXPECT_NE(d->continuum.find("Rayleigh α = 0.5 /s"), std::string::npos) << d->continuum;
  EXPECT_NE(d->continuum.find("calibrated"), std::string::npos) << d->continuum;
  EXPECT_EQ(d->consequence.find("measured but not used"), std::string::npos) << d->consequence;
}

TEST(ReportModels, ParametersCarryTheirProvenance) {
  auto s = wall_scene();
  s.soil.continuum->given = {"k0"};
  s.soil.continuum->provenance = {{"young", "dem calibration abc: 2 G0 (1 + ν)"}};
  const auto rows = compare::model_parameters(s, {});
  auto find = [&](const std::string& key) -> const compare::ParamRow* {
    for (const auto& r : rows)
      if (r.name == key) return &r;
    return nullptr;
  };
  ASSERT_NE(find("soil.continuum.young"), nullptr);
  EXPECT_NE(find("soil.continuum.young")->provenance.find("calibrated from the DEM"),
            std::string::npos);
  EXPECT_EQ(find("soil.continuum.k0")->provenance, "stated in the scene");
  EXPECT_EQ(find("soil.continuum.poisson")->provenance, "default");
  ASSERT_NE(find("soil.dem.kn"), nullptr);
}

TEST(ReportModels, SolverRunRoundTrips) {
  const fs::path dir = demfem::test::scratch("run");
  compare::SolverRun r;
  r.solver = "continuum";
  r.ok = true;
  r.solver_seconds = 12.5;
  r.total_seconds = 14.0;
  r.steps = 700;
  r.dt = 3.7e-4;
  r.dofs = 14690;
  r.cells = 1800;
  r.refinement = 3;
  r.degree = 2;
  r.integrator = "explicit";
  r.seated = {{"footing", 0.01}};
  compare::write_solver_run(dir, r);
  EXPECT_TRUE(fs::exists(dir / "run_continuum.json"));
  const auto b = compare::read_solver_run(dir, "continuum");
  EXPECT_TRUE(b.present);
  EXPECT_DOUBLE_EQ(b.solver_seconds, 12.5);
  EXPECT_EQ(b.dofs, 14690u);
  EXPECT_EQ(b.integrator, "explicit");
  ASSERT_EQ(b.seated.size(), 1u);
  EXPECT_EQ(b.seated[0].first, "footing");
  EXPECT_FALSE(compare::read_solver_run(dir, "dem").present);
}

// The page: what differs, parameters, run times with the reproducing command, the study link.
TEST(ReportModels, ReportShowsModelsRunTimesAndStudies) {
  const fs::path root = demfem::test::scratch("report-models");
  const fs::path run = root / "quick";
  fs::create_directories(run / "dem");
  fs::create_directories(run / "continuum");
  {
    std::ofstream d(run / "dem" / "walls.csv");
    d << "time [s],wall.thrust [N]\n";
    for (int k = 0; k <= 30; ++k) d << k * 0.1 << "," << (k < 10 ? 100 : 150) << "\n";
    std::ofstream c(run / "continuum" / "walls.csv");
    c << "time [s],wall.thrust [N]\n";
    for (int k = 0; k <= 30; ++k) c << k * 0.1 << ",100\n";
  }
  compare::SolverRun dem;
  dem.solver = "dem";
  dem.ok = true;
  dem.solver_seconds = 61.0;
  dem.total_seconds = 75.0;
  dem.steps = 123456;
  dem.dt = 2.4e-5;
  compare::write_solver_run(run, dem);
  // a stability study of this scene beside the run, and one of another scene
  fs::create_directories(root / "study-stability" / "quick");
  std::ofstream(root / "study-stability" / "quick" / "study.json")
      << R"({"study": "stability", "scene": "box-wall/quick", "rows": [{"outcome": "completed"},)"
      << R"( {"outcome": "refused"}]})";
  std::ofstream(root / "study-stability" / "quick" / "study.html") << "<html></html>";
  // an error-vs-time study of this scene without a closed form: its summary names the
  // reference runs, the primary metric and the Pareto front
  fs::create_directories(root / "study-error-vs-time" / "quick");
  std::ofstream(root / "study-error-vs-time" / "quick" / "study.json")
      << R"({"study": "error-vs-time", "scene": "box-wall/quick", "solver": "both", )"
      << R"("duration": 2, "primary_metric": "wall.thrust.amplitude", )"
      << R"("reference_runs": {"continuum": "cont-q2-r3-explicit", "dem": "dem-dt-1/8"}, )"
      << R"("fits": [], "points": [{"name": "dem-dt-1/2", "pareto": true}, )"
      << R"({"name": "dem-dt-1/8", "pareto": false}]})";
  std::ofstream(root / "study-error-vs-time" / "quick" / "study.html") << "<html></html>";
  fs::create_directories(root / "study-other");
  std::ofstream(root / "study-other" / "study.json")
      << R"({"study": "stability", "scene": "other-scene", "rows": []})";
  std::ofstream(root / "study-other" / "study.html") << "<html></html>";

  auto s = wall_scene();
  compare::ReportOptions o;
  o.title = "test";
  o.scene = &s;
  o.fields = false;
  o.command = "demfem compare cases/box_wall.toml --variant quick";
  const auto r = compare::write_report(run, o);
  const std::string html = slurp(r.html);
  EXPECT_NE(html.find("What differs between the two models"), std::string::npos);
  EXPECT_NE(html.find("boundary: structure faces"), std::string::npos);
  EXPECT_NE(html.find("Parameters of both models"), std::string::npos);
  EXPECT_NE(html.find("demfem compare cases/box_wall.toml --variant quick"), std::string::npos);
  EXPECT_NE(html.find("61.0 s"), std::string::npos); // the DEM's recorded wall time
  EXPECT_NE(html.find("not recorded"),
            std::string::npos); // the continuum wrote no run_continuum.json
  ASSERT_EQ(r.studies.size(), 2u);
  EXPECT_EQ(r.studies[0].kind, "error-vs-time"); // same scene: sorted by kind
  EXPECT_EQ(r.studies[0].summary,
            "both (2 s simulated), 2 runs against the most resolved run of each solver "
            "(continuum: cont-q2-r3-explicit, dem: dem-dt-1/8); primary metric "
            "wall.thrust.amplitude; Pareto front dem-dt-1/2");
  EXPECT_NE(html.find("href=\"../study-error-vs-time/quick/study.html\""), std::string::npos);
  EXPECT_EQ(r.studies[1].scene, "box-wall/quick");
  EXPECT_EQ(r.studies[1].summary, "2 rows: 1 completed, 1 refused");
  EXPECT_NE(html.find("href=\"../study-stability/quick/study.html\""), std::string::npos);
  EXPECT_EQ(html.find("study-other"), std::string::npos);
  const auto j = nlohmann::json::parse(slurp(r.metrics_json));
  EXPECT_EQ(j["what_differs"].size(), r.differences.size());
  EXPECT_FALSE(r.differences.empty());
  EXPECT_DOUBLE_EQ(j["run_times"]["dem"]["solver_seconds"].get<double>(), 61.0);

  // The same run with a frictional continuum interface: the table says so.
  s.continuum.interface = "frictional";
  const auto r2 = compare::write_report(run, o);
  const std::string html2 = slurp(r2.html);
  EXPECT_EQ(html.find("one cell thick"), std::string::npos);
  EXPECT_NE(html2.find("one cell thick"), std::string::npos);
}
