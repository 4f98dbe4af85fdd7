#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "../scratch.hpp"
#include <nlohmann/json.hpp>

#include "demfem/compare/report.hpp"
#include "demfem/dem/engine.hpp"
#include "demfem/dem/io.hpp"

namespace fs = std::filesystem;
using namespace demfem;

namespace {
// dem/ and continuum/structures.csv of a structure "foot": settlement rate × t / 0.1 s in each
// solver (dem_rate, cont_rate [m]), vertical force 100 + t / 0.1 s [N], for t = 0 … 2 s.
void write_foot(const fs::path& run, double dem_rate, double cont_rate) {
  for (const char* side : {"dem", "continuum"}) {
    fs::create_directories(run / side);
    std::ofstream f(run / side / "structures.csv");
    f << "time [s],foot.settlement [m],foot.force_z [N]\n";
    for (int k = 0; k <= 20; ++k)
      f << k * 0.1 << "," << (side[0] == 'd' ? dem_rate : cont_rate) * k << "," << 100 + k << "\n";
  }
}

// One unit-square soil cell (points (0,0) (1,0) (1,1) (0,1)) as an ASCII .vtu, with the given
// PointData and CellData arrays (VTK XML DataArray elements; the cell's material array is added).
void write_unit_cell_vtu(const fs::path& path, const std::string& point_data,
                         const std::string& cell_data) {
  std::ofstream v(path);
  v << R"(<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">
<UnstructuredGrid><Piece NumberOfPoints="4" NumberOfCells="1">
<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">0 0 0 1 0 0 1 1 0 0 1 0</DataArray></Points>
<Cells><DataArray type="Int32" Name="connectivity" format="ascii">0 1 2 3</DataArray>
<DataArray type="Int32" Name="offsets" format="ascii">4</DataArray>
<DataArray type="UInt8" Name="types" format="ascii">9</DataArray></Cells>
)" << (point_data.empty() ? "" : "<PointData>" + point_data + "</PointData>\n")
    << "<CellData>" << cell_data
    << R"(<DataArray type="Float64" Name="material" format="ascii">0</DataArray></CellData>
</Piece></UnstructuredGrid></VTKFile>
)";
}

// A ParaView collection of (time, file) entries, the files relative to the collection's folder.
void write_pvd(const fs::path& path, const std::vector<std::pair<double, std::string>>& entries) {
  std::ofstream pvd(path);
  pvd << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\"><Collection>\n";
  for (const auto& [t, f] : entries)
    pvd << "<DataSet timestep=\"" << t << "\" group=\"\" part=\"0\" file=\"" << f << "\"/>\n";
  pvd << "</Collection></VTKFile>\n";
}
} // namespace

TEST(Report, InterpolateIsLinearAndHeld) {
  const std::vector<double> t{0, 1, 3}, y{0, 2, 6};
  EXPECT_DOUBLE_EQ(compare::interpolate(t, y, 0.5), 1.0);
  EXPECT_DOUBLE_EQ(compare::interpolate(t, y, 2.0), 4.0);
  EXPECT_DOUBLE_EQ(compare::interpolate(t, y, -1.0), 0.0);
  EXPECT_DOUBLE_EQ(compare::interpolate(t, y, 9.0), 6.0);
}

// A profile's largest values both ways, and the sentence the report prints: a continuum that rises
// 0.42 mm beside a footing while settling 0.069 mm elsewhere is not summed up by its settlement.
TEST(Report, SubsidenceSummaryGivesTheLargestSettlementAndRiseWithTheirPlaces) {
  const std::vector<double> x{1.25, 63.75, 80.0, 96.25, 158.75};
  const std::vector<double> cont{6.94e-5, -4.18e-4, std::nan(""), -3.80e-4, 5.86e-5};
  const auto c = compare::profile_extremes(x, cont);
  EXPECT_DOUBLE_EQ(c.down, 6.94e-5);
  EXPECT_DOUBLE_EQ(c.x_down, 1.25);
  EXPECT_DOUBLE_EQ(c.up, -4.18e-4);
  EXPECT_DOUBLE_EQ(c.x_up, 63.75);
  const auto d = compare::profile_extremes(x, {0.0, 1e-6, 2e-6, 0.0, 0.0}); // never rises
  EXPECT_DOUBLE_EQ(d.down, 2e-6);
  EXPECT_DOUBLE_EQ(d.x_down, 80.0);
  EXPECT_DOUBLE_EQ(d.up, 0.0);
  EXPECT_TRUE(std::isnan(d.x_up));
  EXPECT_EQ(compare::subsidence_summary(0.0, 8.0, d, c),
            "Surface from t = 0 s to t = 8 s: the DEM surface settles by at most 0.002 mm "
            "(x = 80 m) and nowhere rises; the continuum surface settles by at most 0.0694 mm "
            "(x = 1.25 m) and rises by at most 0.418 mm (x = 63.75 m).");
}

// A continuum beyond small strains: the report warns (share of the soil, largest strain, where)
// and the verdict of a displacement says that its continuum side is not a soil's; a force's does
// not. One unit-square soil cell with ε_v = 0.5 in an ASCII .vtu.
TEST(Report, WarnsWhenTheContinuumIsBeyondSmallStrains) {
  const fs::path run = demfem::test::scratch("report-strain");
  write_foot(run, 1e-3, 2e-3);
  write_unit_cell_vtu(
      run / "continuum" / "c_0.vtu", "",
      R"(<DataArray type="Float64" Name="volumetric_strain" format="ascii">0.5</DataArray>
<DataArray type="Float64" Name="plastic_strain" format="ascii">0</DataArray>)");
  write_pvd(run / "continuum" / "continuum.pvd", {{2.0, "c_0.vtu"}});
  compare::ReportOptions o;
  o.title = "test";
  o.fields = false;
  const auto r = compare::write_report(run, o);
  ASSERT_EQ(r.compared.size(), 2u);
  for (const auto& m : r.compared) {
    const bool marked =
        m.verdict.find("beyond its small strains over 100.0 % of the soil") != std::string::npos;
    EXPECT_EQ(marked, m.def.unit == "m") << m.def.key << ": " << m.verdict;
  }
  const auto j = nlohmann::json::parse(std::ifstream(r.metrics_json));
  ASSERT_EQ(j["warnings"].size(), 1u);
  EXPECT_NE(j["warnings"][0].get<std::string>().find(
                "100.0 % of the soil's area has a volumetric or plastic strain above 10 % "
                "(largest volumetric strain 0.5 at x = 0.5 m, z = 0.5 m"),
            std::string::npos)
      << j["warnings"][0];
}

// A settlement far below the grain size: its verdict gives the scale (the mean particle
// diameter); a force's does not.
TEST(Report, ADisplacementFarBelowTheGrainSizeIsSaidToBe) {
  const fs::path run = demfem::test::scratch("report-grain");
  write_foot(run, 1e-4, 3e-4);
  scene::Scene sc;
  sc.soil.dem = scene::DemSoil{};
  sc.soil.dem->radius.kind = scene::RadiusDistribution::Kind::Equal;
  sc.soil.dem->radius.min = sc.soil.dem->radius.max = 0.5; // diameter 1 m
  compare::ReportOptions o;
  o.title = "test";
  o.fields = false;
  o.scene = &sc;
  const auto r = compare::write_report(run, o);
  ASSERT_EQ(r.compared.size(), 2u);
  for (const auto& m : r.compared) {
    const bool marked = m.verdict.find("of a mean particle diameter (1 m): far below the grain "
                                       "scale") != std::string::npos;
    EXPECT_EQ(marked, m.def.unit == "m") << m.def.key << ": " << m.verdict;
  }
  // 10 × larger settlements (up to 6 % of a diameter): no remark.
  write_foot(run, 1e-3, 3e-3);
  for (const auto& m : compare::write_report(run, o).compared)
    EXPECT_EQ(m.verdict.find("grain scale"), std::string::npos) << m.verdict;
}

TEST(Report, ComparesWallThrustAndPressureProfiles) {
  const fs::path run = demfem::test::scratch("report");
  fs::create_directories(run / "dem");
  fs::create_directories(run / "continuum");
  {
    // DEM: thrust = 100 for t < 1, then 200; continuum: 100 throughout, on a coarser time base.
    std::ofstream d(run / "dem" / "walls.csv");
    d << "time [s],wall.thrust [N]\n";
    for (int k = 0; k <= 200; ++k) d << k * 0.01 << "," << (k * 0.01 < 1.0 ? 100 : 200) << "\n";
    std::ofstream c(run / "continuum" / "walls.csv");
    c << "time [s],wall.thrust [N]\n";
    for (int k = 0; k <= 20; ++k) c << k * 0.1 << ",100\n";
    // A pressure profile (two bins): compared as a profile (at rest and late), not as 2 series.
    std::ofstream dp(run / "dem" / "pressure_wall.csv");
    dp << "time [s],wall.bin0 [Pa],wall.bin1 [Pa]\n";
    std::ofstream cp(run / "continuum" / "pressure_wall.csv");
    cp << "time [s],wall.bin0 [Pa],wall.bin1 [Pa]\n";
    for (int k = 0; k <= 20; ++k) {
      dp << k * 0.1 << (k < 10 ? ",10,5\n" : ",30,15\n");
      cp << k * 0.1 << ",20,10\n";
    }
  }
  scene::Scene sc; // shaking from t = 1 s
  scene::Shaking sh;
  sh.acceleration = scene::TimeFunction::sine(1.0, 2.0, 0.0, 1.0);
  sc.load.shaking = sh;
  compare::ReportOptions o;
  o.title = "test";
  o.scene = &sc;
  o.fields = false;
  const auto r = compare::write_report(run, o);
  ASSERT_EQ(r.compared.size(), 1u);
  const auto& m = r.compared[0];
  EXPECT_EQ(m.def.key, "wall.thrust");
  EXPECT_NEAR(m.static_part.dem, 100.0, 1e-9);
  EXPECT_NEAR(m.static_part.continuum, 100.0, 1e-9);
  EXPECT_NEAR(m.increment.dem, 100.0, 1e-9); // the step, after the load starts
  EXPECT_NEAR(m.increment.continuum, 0.0, 1e-9);
  EXPECT_NEAR(m.first_divergence, 1.0, 1e-9);
  EXPECT_TRUE(m.diverges);
  EXPECT_TRUE(fs::exists(r.html));
  ASSERT_EQ(r.profile_figures.size(), 1u);
  const auto j = nlohmann::json::parse(std::ifstream(r.metrics_json));
  EXPECT_EQ(j["rows"].size(), 1u);
  const auto& prof = j["pressure_profiles"]["wall"];
  ASSERT_EQ(prof.size(), 2u);
  EXPECT_NEAR(prof[0]["dem_rest_Pa"].get<double>(), 10.0, 1e-9);
  EXPECT_NEAR(prof[0]["dem_late_Pa"].get<double>(), 30.0, 1e-9);
  EXPECT_NEAR(prof[0]["continuum_rest_Pa"].get<double>(), 20.0, 1e-9);
  std::ifstream h(r.html);
  const std::string html((std::istreambuf_iterator<char>(h)), std::istreambuf_iterator<char>());
  EXPECT_NE(html.find("wall thrust"), std::string::npos);
  EXPECT_NE(html.find("data:image/png;base64,"), std::string::npos);
  // No DEM soil here: no seed ensemble is suggested. A deposited bed is one realisation of the
  // soil: the verdicts say so and give the ensemble command.
  EXPECT_EQ(html.find("--seeds"), std::string::npos);
  sc.soil.dem = scene::DemSoil{};
  sc.info.seed = 7;
  sc.source_file = "bed.toml";
  const auto r2 = compare::write_report(run, o);
  std::ifstream h2(r2.html);
  const std::string html2((std::istreambuf_iterator<char>(h2)), std::istreambuf_iterator<char>());
  EXPECT_NE(html2.find("one realisation of the bed (packing seed 7)"), std::string::npos);
  EXPECT_NE(html2.find("demfem compare bed.toml --seeds 7,8,9</code>"), std::string::npos) << html2;
}

// A pressure profile one solver does not write has no values on that side (null in
// metrics.json), not zeros: three DEM bins, no continuum pressure file.
TEST(Report, APressureProfileOneSolverLacksIsNullOnItsSide) {
  const fs::path run = demfem::test::scratch("report-pressure-one-side");
  write_foot(run, 1e-3, 2e-3);
  {
    std::ofstream dp(run / "dem" / "pressure_wall.csv");
    dp << "time [s],wall.bin0 [Pa],wall.bin1 [Pa],wall.bin2 [Pa]\n";
    for (int k = 0; k <= 20; ++k) dp << k * 0.1 << ",30,20,10\n";
  }
  compare::ReportOptions o;
  o.title = "test";
  o.fields = false;
  const auto r = compare::write_report(run, o);
  const auto prof =
      nlohmann::json::parse(std::ifstream(r.metrics_json))["pressure_profiles"]["wall"];
  ASSERT_EQ(prof.size(), 3u) << prof;
  for (const auto& b : prof) {
    EXPECT_NEAR(b["dem_late_Pa"].get<double>(), b["dem_rest_Pa"].get<double>(), 1e-9) << b;
    EXPECT_TRUE(b["continuum_rest_Pa"].is_null()) << b;
    EXPECT_TRUE(b["continuum_late_Pa"].is_null()) << b;
  }
}

// The subsidence profile's DEM line follows the particles that formed the surface at rest, as the
// continuum's line follows its top nodes; without particle snapshots at both times it falls back
// to the top of the bed per bin (surface.csv). Two bins over x 0…1 m: the top of the bed says
// bin 0 rose 0.2 m (a deep particle thrown up) and bin 1 did not move; the surface particles
// settled 0.01 and 0.02 m. The continuum's top nodes settle 0.004 m.
TEST(Report, SubsidenceProfileFollowsTheDemSurfaceParticles) {
  const fs::path run = demfem::test::scratch("report-profile");
  write_foot(run, 1e-3, 2e-3);
  {
    std::ofstream f(run / "dem" / "surface.csv");
    f << "time [s],surface.bin0 [m],surface.bin1 [m]\n0,1.05,1.05\n1,1.15,1.05\n2,1.25,1.05\n";
  }
  for (int k = 0; k < 2; ++k)
    write_unit_cell_vtu(
        run / "continuum" / ("c_" + std::to_string(k) + ".vtu"),
        std::string(R"(<DataArray type="Float64" Name="displacement_z" format="ascii">)") +
            (k == 0 ? "0 0 0 0" : "0 0 -0.004 -0.004") + "</DataArray>",
        "");
  write_pvd(run / "continuum" / "continuum.pvd", {{0.0, "c_0.vtu"}, {2.0, "c_1.vtu"}});
  compare::ReportOptions o;
  o.title = "test";
  o.fields = false;
  auto profile = [&] {
    const auto r = compare::write_report(run, o);
    return nlohmann::json::parse(std::ifstream(r.metrics_json))["surface_subsidence_profile"];
  };
  // no particle snapshots: the top of the bed
  auto p = profile();
  ASSERT_EQ(p["bins"].size(), 2u) << p;
  EXPECT_EQ(p["dem_surface"], "top of the bed");
  EXPECT_NEAR(p["bins"][0]["dem_m"].get<double>(), -0.2, 1e-12);
  EXPECT_NEAR(p["bins"][0]["continuum_m"].get<double>(), 0.004, 1e-12);
  // particle snapshots at t = 0 and 2 s: ids 0 and 1 on top, id 2 deep and thrown up
  auto snapshot = [](const fs::path& path, const std::vector<double>& z) {
    dem::Engine e(dem::EngineConfig{});
    const std::vector<double> x{0.25, 0.75, 0.25};
    for (std::size_t i = 0; i < x.size(); ++i) e.add_particle(x[i], z[i], 0.05); // ids 0, 1, 2
    dem::io::write_particles_vtp(path, e.particles());
  };
  snapshot(run / "dem" / "p_0.vtp", {1.0, 1.0, 0.7});
  snapshot(run / "dem" / "p_1.vtp", {0.99, 0.98, 1.2});
  write_pvd(run / "dem" / "particles.pvd", {{0.0, "p_0.vtp"}, {2.0, "p_1.vtp"}});
  p = profile();
  ASSERT_EQ(p["bins"].size(), 2u) << p;
  EXPECT_EQ(p["dem_surface"], "surface particles followed");
  EXPECT_NEAR(p["bins"][0]["dem_m"].get<double>(), 0.01, 1e-12);
  EXPECT_NEAR(p["bins"][1]["dem_m"].get<double>(), 0.02, 1e-12);
  EXPECT_NE(p["summary"].get<std::string>().find("the particles that formed the surface at rest"),
            std::string::npos);
}
