// Compares two CSV files cell by cell: identical text, or numbers within a relative tolerance.
// Usage: compare_csv A B [rel_tol]. Exit 0 when they agree.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  if (argc < 3) return 2;
  const double tol = argc > 3 ? std::atof(argv[3]) : 1e-8;
  std::ifstream a(argv[1]), b(argv[2]);
  if (!a || !b) {
    std::fprintf(stderr, "cannot open inputs\n");
    return 2;
  }
  std::string la, lb;
  int line = 0;
  double scale = 0.0;
  std::vector<std::vector<std::string>> ra, rb;
  auto split = [](const std::string& s) {
    std::vector<std::string> out;
    std::stringstream ss(s);
    std::string c;
    while (std::getline(ss, c, ',')) out.push_back(c);
    return out;
  };
  while (std::getline(a, la)) ra.push_back(split(la));
  while (std::getline(b, lb)) rb.push_back(split(lb));
  if (ra.size() != rb.size() || ra.empty()) {
    std::fprintf(stderr, "different number of lines: %zu vs %zu\n", ra.size(), rb.size());
    return 1;
  }
  for (std::size_t i = 1; i < ra.size(); ++i)
    for (const auto& c : ra[i]) scale = std::max(scale, std::abs(std::atof(c.c_str())));
  for (std::size_t i = 0; i < ra.size(); ++i, ++line) {
    if (ra[i].size() != rb[i].size()) return 1;
    for (std::size_t j = 0; j < ra[i].size(); ++j) {
      if (i == 0) {
        if (ra[i][j] != rb[i][j]) return 1;
        continue;
      }
      const double x = std::atof(ra[i][j].c_str()), y = std::atof(rb[i][j].c_str());
      // per column scale: relative to the column's largest magnitude
      double cs = 0.0;
      for (std::size_t k = 1; k < ra.size(); ++k)
        cs = std::max(cs, std::abs(std::atof(ra[k][j].c_str())));
      if (std::abs(x - y) > tol * std::max(cs, 1e-300)) {
        std::fprintf(stderr, "line %d column %zu: %s vs %s\n", line + 1, j + 1, ra[i][j].c_str(),
                     rb[i][j].c_str());
        return 1;
      }
    }
  }
  std::printf("%zu lines agree (rel. tol %g, largest value %g)\n", ra.size(), tol, scale);
  return 0;
}
