// docs/scene-reference.md lists exactly the keys the scene parser accepts.
//
// The accepted keys come from the parser's own behaviour, not from a list kept here: the test
// puts an unknown key into one table of a scene that has every table, parses it, and reads the
// valid keys from the error the Reader gives for it ("unknown key; valid keys here: …", the list
// each table gives Reader::finish). For a table read several ways (a structure's shapes, the
// time function types) it takes the union over every instance in the scene.
//
// Checked: every accepted key has a row in the table's section of the reference, and every row is
// an accepted key; every section of the reference is a table the test scene has; every row's type
// that is a table has its own section; every row fills its five columns; and every default given
// as a value (`2650`, `"lz4"`, `true`) is the parser's: the scene without the key and the scene
// with the key at that value resolve alike.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>
#include <toml++/toml.h>

#include "demfem/app/vocabulary.hpp"
#include "demfem/scene/load.hpp"

namespace fs = std::filesystem;

namespace {

const fs::path kSource = DEMFEM_SOURCE_DIR;
constexpr const char* kProbeKey = "zz_undocumented_key";

// A scene with every table of the reference: three structure shapes, every time function type,
// shaking, a porosity target, both event actions, a variant. It is valid as it stands.
constexpr const char* kEveryTable = R"(
[scene]
name = "every-table"
description = "one of each table"
solvers = ["dem", "continuum"]
duration = 1.0
seed = 3

[domain]
polygon = [[0, 0], [10, 0], [10, 5], [0, 5]]

[soil.dem]
count = 50
radius = { uniform = [0.05, 0.08] }
[soil.dem.packing]
placement = "random"
target = { porosity = 0.2 }

[soil.continuum]
model = "mohr-coulomb"

[continuum]
refinement = 1

[[wall]]
name = "base"
points = [[0, 0], [10, 0]]

[[wall]]
name = "left"
points = [[0, 5], [0, 0]]

[[wall]]
name = "right"
points = [[10, 0], [10, 5]]

[[structure]]
name = "footing"
shape = "rectangle"
width = 1.0
height = 0.5
base = [2, 4]
force_x = { type = "t-sine", amplitude = 1.0, frequency = 0.5 }
force_z = { type = "ramp", rate = -10.0 }
moment = { type = "sine", amplitude = 1.0, frequency = 2.0 }
motion_x = { type = "table", points = [[0, 0], [1, 0.01]] }
motion_z = { type = "sum", terms = [{ type = "constant", value = 0.0 }] }

[[structure]]
name = "screen"
kind = "wall"
shape = "segment"
from = [5, 1]
to = [5, 3]

[[structure]]
name = "pile"
kind = "pile"
shape = "polygon"
polygon = [[7, 2], [7.5, 2], [7.5, 4], [7, 4]]

[load]
gravity = 9.81
shaking = { direction = "x", amplitude = 1.0, frequency = 2.0 }

[[group]]
name = "all"
region = [[0, 0], [10, 0], [10, 5], [0, 5]]

[[event]]
time = 0.5
action = "set-friction"
group = "all"

[[event]]
time = 0.6
action = "open-wall"
wall = "left"

[[probe]]
kind = "wall-thrust"
target = "screen"

[[probe]]
kind = "coordination"

[[probe]]
kind = "pressure-profile"
target = "screen"
bins = 4
interval = 0.02

[[probe]]
kind = "loci"
points = [[5, 1]]

[output]
interval = 0.5

[[variant]]
name = "longer"
set = { "scene.duration" = 2.0 }
)";

std::string slurp(const fs::path& f) {
  std::ifstream in(f, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string k; std::getline(in, k, ',');) {
    k.erase(0, k.find_first_not_of(' '));
    k.erase(k.find_last_not_of(" \n") + 1);
    if (!k.empty()) out.push_back(k);
  }
  return out;
}

// ---- the reference ------------------------------------------------------------------------------
struct Row {
  std::string key, type, fallback; // fallback: the default column
  std::size_t cells = 0;
  bool empty_cell = false;
};
struct Section {
  std::string title; // "[soil.dem]", "[[structure]]", "Top level", "Time functions"
  std::vector<Row> rows;
};

std::vector<std::string> cells_of(const std::string& line) {
  std::vector<std::string> cells;
  std::string cur;
  bool code = false;
  for (std::size_t i = 1; i < line.size(); ++i) { // line[0] is the leading '|'
    const char c = line[i];
    if (c == '`') code = !code;
    if (c == '|' && !code && line[i - 1] != '\\') {
      cells.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  for (auto& x : cells) {
    x.erase(0, x.find_first_not_of(' '));
    x.erase(x.find_last_not_of(' ') + 1);
  }
  return cells;
}

// Every section with a "| key | type | unit | default | meaning |" table, in file order.
std::vector<Section> read_reference(const std::string& text) {
  std::vector<Section> out;
  std::istringstream in(text);
  std::string title;
  bool in_keys = false;
  const std::regex heading("^#{2,3} +(.*)$"), code_title("`([^`]+)`");
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (std::regex_match(line, m, heading)) {
      std::smatch c;
      const std::string h = m[1].str();
      title = std::regex_search(h, c, code_title) ? c[1].str() : h;
      in_keys = false;
      continue;
    }
    if (line.rfind("| key | type | unit | default | meaning |", 0) == 0) {
      out.push_back({title, {}});
      in_keys = true;
      continue;
    }
    if (!in_keys) continue;
    if (line.rfind("|---", 0) == 0) continue;
    if (line.rfind("| ", 0) != 0) {
      in_keys = false;
      continue;
    }
    const auto cells = cells_of(line);
    Row r;
    r.cells = cells.size();
    for (const auto& c : cells) r.empty_cell = r.empty_cell || c.empty();
    if (!cells.empty()) {
      std::smatch k;
      const std::regex key("^`([a-z_0-9]+)`$");
      r.key = std::regex_match(cells[0], k, key) ? k[1].str() : cells[0];
    }
    if (cells.size() > 1) r.type = cells[1];
    if (cells.size() > 3) r.fallback = cells[3];
    out.back().rows.push_back(r);
  }
  return out;
}

// ---- the parser ---------------------------------------------------------------------------------
// The tables of the scene that a section of the reference describes.
std::vector<toml::table*> tables_for(toml::table& root, const std::string& title) {
  std::vector<toml::table*> out;
  if (title == "Top level") return {&root};
  if (title == "Time functions") { // every table with a `type`: they are the time functions
    std::vector<toml::node*> todo{&root};
    while (!todo.empty()) {
      toml::node* n = todo.back();
      todo.pop_back();
      if (auto* t = n->as_table()) {
        if (t->contains("type")) out.push_back(t);
        for (auto&& [k, v] : *t) todo.push_back(&v);
      } else if (auto* a = n->as_array()) {
        for (auto& v : *a) todo.push_back(&v);
      }
    }
    return out;
  }
  const bool array = title.rfind("[[", 0) == 0;
  const std::string path = title.substr(array ? 2 : 1, title.size() - (array ? 4 : 2));
  if (array) {
    if (auto* a = root[path].as_array())
      for (auto& v : *a)
        if (auto* t = v.as_table()) out.push_back(t);
    return out;
  }
  toml::node* n = &root;
  std::stringstream parts(path);
  for (std::string p; n && std::getline(parts, p, '.');) {
    auto* t = n->as_table();
    n = t ? t->get(p) : nullptr;
  }
  if (n && n->as_table()) out.push_back(n->as_table());
  return out;
}

// The valid keys the parser lists when `table` holds an unknown key. First the key is added to
// the table; when that gives no list (a table that must hold exactly one key, as radius), the
// table holds the unknown key alone. Empty when neither gives a list.
std::set<std::string> accepted_keys(const std::string& scene, const std::string& title,
                                    std::size_t instance) {
  for (const bool alone : {false, true}) {
    toml::table root = toml::parse(scene);
    auto tables = tables_for(root, title);
    if (instance >= tables.size()) return {};
    if (alone) tables[instance]->clear();
    tables[instance]->insert_or_assign(kProbeKey, 1);
    std::ostringstream text;
    text << root;
    try {
      (void)demfem::scene::parse_scene(text.str(), "every_table.toml", demfem::app::vocabulary());
    } catch (const demfem::scene::SceneError& e) {
      for (const auto& d : e.diagnostics()) {
        const std::string tail = std::string(kProbeKey);
        const bool ours = d.key == tail || (d.key.size() > tail.size() &&
                                            d.key.compare(d.key.size() - tail.size() - 1,
                                                          tail.size() + 1, "." + tail) == 0);
        const std::string marker = "valid keys here: ";
        const auto at = d.message.find(marker);
        if (!ours || at == std::string::npos) continue;
        auto keys = split_list(d.message.substr(at + marker.size()));
        return {keys.begin(), keys.end()};
      }
    }
  }
  return {};
}

std::set<std::string> accepted_keys(const std::string& scene, const std::string& title) {
  std::set<std::string> all;
  toml::table root = toml::parse(scene);
  const std::size_t n = tables_for(root, title).size();
  for (std::size_t i = 0; i < n; ++i) {
    const auto keys = accepted_keys(scene, title, i);
    EXPECT_FALSE(keys.empty()) << title << " #" << i
                               << ": the parser listed no valid keys for an unknown key there";
    all.insert(keys.begin(), keys.end());
  }
  return all;
}

std::string joined(const std::set<std::string>& s) {
  std::string out;
  for (const auto& k : s) out += (out.empty() ? "" : ", ") + k;
  return out;
}

// Compares one section with the parser; returns the keys missing from the reference (for the
// negative test).
std::set<std::string> check_section(const Section& sec, const std::string& scene) {
  toml::table root = toml::parse(scene);
  EXPECT_FALSE(tables_for(root, sec.title).empty())
      << "the reference has a section " << sec.title
      << " that the test scene does not have: add that table to kEveryTable";
  const auto accepted = accepted_keys(scene, sec.title);
  std::set<std::string> documented, undocumented, ignored;
  for (const auto& r : sec.rows) {
    EXPECT_TRUE(documented.insert(r.key).second) << sec.title << ": two rows for " << r.key;
    EXPECT_EQ(r.cells, 5u) << sec.title << " row " << r.key
                           << ": expected key, type, unit, default, meaning";
    EXPECT_FALSE(r.empty_cell) << sec.title << " row " << r.key << " has an empty cell";
  }
  for (const auto& k : accepted)
    if (!documented.count(k)) undocumented.insert(k);
  for (const auto& k : documented)
    if (!accepted.count(k)) ignored.insert(k);
  EXPECT_TRUE(undocumented.empty())
      << "docs/scene-reference.md, " << sec.title
      << ": the parser accepts keys the reference does not list: " << joined(undocumented);
  EXPECT_TRUE(ignored.empty()) << "docs/scene-reference.md, " << sec.title
                               << ": the reference lists keys the parser does not accept: "
                               << joined(ignored);
  return undocumented;
}

// ---- defaults -----------------------------------------------------------------------------------
// A resolved scene file as a TOML tree, without its header comments.
std::optional<toml::table> resolved(const std::string& scene) {
  try {
    const auto f = demfem::scene::parse_scene(scene, "every_table.toml", demfem::app::vocabulary());
    std::string text;
    for (const auto* s : {&f.base}) text += demfem::scene::to_toml(*s);
    toml::table t = toml::parse(text);
    toml::array variants;
    for (const auto& v : f.variants) variants.push_back(toml::parse(demfem::scene::to_toml(v)));
    t.insert_or_assign("variants (resolved)", std::move(variants));
    return t;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// Equal trees, numbers within a relative 1e-3 (a default given in degrees in the reference and
// stored in radians comes back rounded).
bool same(const toml::node& a, const toml::node& b, std::string& where) {
  if (a.is_number() && b.is_number()) {
    const double x = a.value<double>().value_or(0), y = b.value<double>().value_or(0);
    return std::abs(x - y) <= 1e-3 * std::max(std::abs(x), std::abs(y));
  }
  if (a.type() != b.type()) return false;
  if (const auto* ta = a.as_table()) {
    const auto* tb = b.as_table();
    if (ta->size() != tb->size()) return false;
    for (auto&& [k, v] : *ta) {
      const auto* w = tb->get(k.str());
      if (!w || !same(v, *w, where)) {
        where = std::string(k.str()) + (where.empty() ? "" : "." + where);
        return false;
      }
    }
    return true;
  }
  if (const auto* aa = a.as_array()) {
    const auto* ab = b.as_array();
    if (aa->size() != ab->size()) return false;
    for (std::size_t i = 0; i < aa->size(); ++i)
      if (!same(*aa->get(i), *ab->get(i), where)) return false;
    return true;
  }
  if (a.is_string()) return a.value<std::string>() == b.value<std::string>();
  if (a.is_boolean()) return a.value<bool>() == b.value<bool>();
  return false; // dates and times: not in a scene
}

// The reference's default of `key` in section `title` agrees with the parser: in some instance
// of the table, the scene without the key and the scene with key = the default resolve alike.
// Returns "" or what went wrong.
std::string check_default(const std::string& scene, const std::string& title,
                          const std::string& key, const std::string& literal) {
  toml::table lit;
  try {
    lit = toml::parse("v = " + literal);
  } catch (const toml::parse_error&) {
    return "the default `" + literal + "` is not a TOML value";
  }
  toml::table root0 = toml::parse(scene);
  const std::size_t n = tables_for(root0, title).size();
  std::string why = "no instance of the table accepts the key";
  for (std::size_t i = 0; i < n; ++i) {
    toml::table without = toml::parse(scene), with = toml::parse(scene);
    tables_for(without, title)[i]->erase(key);
    lit.get("v")->visit(
        [&](const auto& v) { tables_for(with, title)[i]->insert_or_assign(key, v); });
    std::ostringstream a, b;
    a << without;
    b << with;
    const auto ra = resolved(a.str()), rb = resolved(b.str());
    if (!ra || !rb) continue; // this instance does not take the key (another shape or type)
    std::string where;
    if (same(*ra, *rb, where)) return "";
    return "the scene without the key and with " + key + " = " + literal +
           " resolve differently (at " + where + ")";
  }
  return why;
}

// The default column holds a TOML value in backticks (`2650`, `"lz4"`, `true`, `[]`): checked.
// Words ("required", "the soil's", "unset", "—") are not.
std::vector<std::string> check_defaults(const Section& sec, const std::string& scene) {
  std::vector<std::string> wrong;
  const std::regex literal("^`([^`]+)`$");
  for (const auto& r : sec.rows) {
    std::smatch m;
    if (!std::regex_match(r.fallback, m, literal)) continue;
    const std::string why = check_default(scene, sec.title, r.key, m[1].str());
    if (!why.empty()) wrong.push_back(sec.title + " " + r.key + ": " + why);
  }
  return wrong;
}

std::vector<Section> reference() {
  return read_reference(slurp(kSource / "docs/scene-reference.md"));
}

} // namespace

TEST(SceneReference, TheTestSceneIsValid) {
  EXPECT_NO_THROW(
      (void)demfem::scene::parse_scene(kEveryTable, "every_table.toml", demfem::app::vocabulary()));
}

TEST(SceneReference, ListsExactlyTheKeysTheParserAccepts) {
  const auto secs = reference();
  ASSERT_GE(secs.size(), 15u) << "no key tables found in docs/scene-reference.md";
  for (const auto& sec : secs) check_section(sec, kEveryTable);
}

TEST(SceneReference, DefaultsAreTheParsers) {
  std::size_t checked = 0;
  for (const auto& sec : reference()) {
    for (const auto& w : check_defaults(sec, kEveryTable)) ADD_FAILURE() << w;
    for (const auto& r : sec.rows) checked += r.fallback.size() > 2 && r.fallback[0] == '`';
  }
  EXPECT_GE(checked, 100u); // the reference gives most defaults as values
}

// The default check fails for a wrong default: [soil.dem] kn given as 2e6.
TEST(SceneReference, FailsForAWrongDefault) {
  auto secs = reference();
  auto sec = std::find_if(secs.begin(), secs.end(),
                          [](const Section& s) { return s.title == "[soil.dem]"; });
  ASSERT_NE(sec, secs.end());
  for (auto& r : sec->rows)
    if (r.key == "kn") r.fallback = "`2e6`";
  const auto wrong = check_defaults(*sec, kEveryTable);
  ASSERT_EQ(wrong.size(), 1u);
  EXPECT_NE(wrong[0].find("kn"), std::string::npos) << wrong[0];
}

// A row whose value is a table ("table", "array of tables") has its own section; "table of …"
// is a free-form table (provenance, a variant's overrides). A time function row points to
// "Time functions".
TEST(SceneReference, EveryTableKeyHasItsSection) {
  const auto secs = reference();
  std::set<std::string> titles;
  for (const auto& s : secs) titles.insert(s.title);
  const std::regex table_type("\\btable\\b(?! of)"), tf_type("time function");
  for (const auto& sec : secs)
    for (const auto& r : sec.rows) {
      if (std::regex_search(r.type, tf_type)) {
        EXPECT_TRUE(titles.count("Time functions")) << sec.title << "." << r.key;
        continue;
      }
      if (!std::regex_search(r.type, table_type)) continue;
      std::string want;
      if (sec.title == "Top level")
        want = r.type.find("array") != std::string::npos ? "[[" + r.key + "]]" : "[" + r.key + "]";
      else
        want = sec.title.substr(0, sec.title.size() - 1) + "." + r.key + "]";
      EXPECT_TRUE(titles.count(want))
          << sec.title << " row " << r.key << " is a table; the reference has no section " << want;
    }
}

// The check fails when the parser accepts a key the reference leaves out: here the reference of
// [soil.dem] without its `kn` row, as if `kn` had been added to the parser without docs.
TEST(SceneReference, FailsForAnUndocumentedKey) {
  auto secs = reference();
  auto sec = std::find_if(secs.begin(), secs.end(),
                          [](const Section& s) { return s.title == "[soil.dem]"; });
  ASSERT_NE(sec, secs.end());
  std::erase_if(sec->rows, [](const Row& r) { return r.key == "kn"; });
  std::set<std::string> missing;
  ::testing::TestPartResultArray failures;
  {
    ::testing::ScopedFakeTestPartResultReporter quiet(
        ::testing::ScopedFakeTestPartResultReporter::INTERCEPT_ONLY_CURRENT_THREAD, &failures);
    missing = check_section(*sec, kEveryTable);
  }
  EXPECT_EQ(failures.size(), 1) << "one failure: the undocumented key";
  EXPECT_EQ(missing, std::set<std::string>{"kn"});
}
