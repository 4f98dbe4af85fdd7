// The wall thrust is signed (walls.csv <w>.thrust = F·n, n out of the soil,
// scene::thrust_normal): > 0 while the soil presses on the wall, < 0 when a tied continuum is
// pulled into tension. |F·n| showed that tension as thrust.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "cli_util.hpp"

#ifdef DEMFEM_TEST_CONTINUUM
namespace fs = std::filesystem;

using demfem::test::run;
using demfem::test::scratch;
using demfem::test::write_temp;

namespace {

struct Series {
  std::vector<std::string> names;
  std::vector<std::vector<double>> rows;
  [[nodiscard]] double at(std::size_t row, const std::string& name) const {
    for (std::size_t k = 0; k < names.size(); ++k)
      if (names[k] == name) return rows.at(row).at(k);
    ADD_FAILURE() << "no column " << name;
    return NAN;
  }
};

Series read_series(const fs::path& f) {
  Series s;
  std::ifstream in(f);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream ss(line);
    std::string cell;
    std::vector<std::string> cells;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    if (s.names.empty()) {
      s.names = cells;
      continue;
    }
    std::vector<double> row;
    for (const auto& c : cells) row.push_back(std::stod(c));
    s.rows.push_back(row);
  }
  return s;
}

// An elastic backfill (4 m × 3 m, K0 stresses) tied to a rigid wall on its right, x = 4 … 4.2 m,
// given as a polygon whose first-to-last chord, (4.2, 3) → (4.2, 0), has its right-hand normal
// pointing into the soil (−x): the thrust's normal must still point out of it (+x). The wall is
// pulled away from the soil by `pull` [m] over 0.5 s: the at-rest thrust ½ K0 γ H² ≈ 37.5 kN/m
// turns into tension (the box's horizontal stiffness ≈ E H / L ≈ 2e7 N/m per m).
std::string wall_scene(double pull) {
  return "[scene]\n"
         "name = \"thrust-sign\"\n"
         "solvers = [\"continuum\"]\n"
         "duration = 0.5\n"
         "[domain]\n"
         "polygon = [[0, 0], [4, 0], [4, 3], [0, 3]]\n"
         "[soil.continuum]\n"
         "model = \"elastic\"\n"
         "young = 3.0e7\n"
         "poisson = 0.3\n"
         "density = 1700\n"
         "k0 = 0.5\n"
         "[continuum]\n"
         "refinement = 1\n"
         "degree = 2\n"
         "dt = 0.05\n"
         "integrator = \"implicit\"\n"
         "linear_solver = \"direct\"\n"
         "rayleigh_alpha = 5.0\n"
         "[[structure]]\n"
         "name = \"wall\"\n"
         "kind = \"wall\"\n"
         "shape = \"polygon\"\n"
         "polygon = [[4.2, 3], [4, 3], [4, 0], [4.2, 0]]\n"
         "dof_x = \"prescribed\"\n"
         "dof_z = \"fixed\"\n"
         "dof_rotation = \"fixed\"\n"
         "motion_x = { type = \"ramp\", rate = " +
         std::to_string(pull / 0.5) +
         " }\n"
         "record = [\"thrust\"]\n"
         "[load]\n"
         "gravity = 9.81\n"
         "[output]\n"
         "vtk = false\n"
         "probe_interval = 0.05\n";
}

} // namespace

TEST(ThrustSign, PositiveAtRestNegativeWhenATiedWallPullsTheSoil) {
  const double P0 = 0.5 * 0.5 * 1700 * 9.81 * 3 * 3; // ½ K0 γ H²
  const fs::path out = scratch("thrust_sign");
  const auto scene = write_temp("thrust_sign.toml", wall_scene(0.01));
  const auto r = run("run " + scene.string() + " --solver continuum --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const Series w = read_series(out / "continuum" / "walls.csv");
  ASSERT_GE(w.rows.size(), 3U);
  const double t0 = w.at(0, "wall.thrust [N]"), fx0 = w.at(0, "wall.reaction_x [N]");
  const std::size_t last = w.rows.size() - 1;
  const double t1 = w.at(last, "wall.thrust [N]"), fx1 = w.at(last, "wall.reaction_x [N]");
  std::printf("thrust at rest %.1f N/m (P0 %.1f), after pulling 10 mm %.1f N/m\n", t0, P0, t1);
  // a vertical wall with the soil on its left: thrust = F_x, pressing at rest (≈ P0; the coarse
  // mesh and the fixed base corner allow 10 %), pulling at the end
  EXPECT_NEAR(t0, P0, 0.1 * P0);
  EXPECT_DOUBLE_EQ(t0, fx0);
  EXPECT_LT(t1, -P0);
  EXPECT_DOUBLE_EQ(t1, fx1);
}
#endif
