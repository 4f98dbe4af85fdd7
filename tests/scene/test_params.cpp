// Parameter blocks (scene/params.hpp): one list of keys gives reading (with the reader's located
// messages), writing back, the report's description, the schema and stiffness scaling; model
// slots choose a model by keyword and read every model's keys once.
#include <gtest/gtest.h>

#include <sstream>

#include "demfem/scene/params.hpp"
#include "demfem/scene/reader.hpp"

namespace demfem::scene {
namespace {

struct Spring {
  static constexpr const char* kName = "spring";
  double k = 2.0e6;
  double ratio = 0.25;
  bool bonded = false;
  int layers = 3;
  std::string label = "soft";
  void fields(ParamVisitor& v) {
    v.number({"k", "K", "N/m", "the spring's stiffness", Scale::stiffness}, k, positive());
    v.number({"ratio", "", "", "a fraction", Scale::none}, ratio, in_range(0.0, 1.0, true));
    v.flag({"bonded", "", "", "carries tension", Scale::none}, bonded);
    v.integer({"layers", "", "", "how many", Scale::none}, layers, 1, 9);
    v.text({"label", "", "", "a name", Scale::none}, label);
  }
  void check(ParamCheck& c) const {
    if (bonded && ratio == 0.0) c.error("ratio", "a bonded spring needs ratio > 0");
  }
};

struct Damper {
  static constexpr const char* kName = "damper";
  double eta = 0.0;
  void fields(ParamVisitor& v) {
    v.number({"eta", "η", "N·s/m", "dashpot", Scale::none}, eta, non_negative());
  }
};

ModelSlot slot() {
  ModelSlot s;
  s.key = "law";
  s.meaning = "which law";
  s.default_keyword = "elastic";
  s.entries = {{"elastic", "a spring", {ParamBlock(Spring{})}},
               {"damped", "a spring and a dashpot", {ParamBlock(Spring{}), ParamBlock(Damper{})}}};
  return s;
}

// Reads `text` (a TOML table) as the table "soil" of file "f.toml".
struct Read {
  ModelChoice choice;
  std::vector<Diagnostic> diags;
  std::vector<std::string> valid;
};
Read read(const std::string& text) {
  Read out;
  const toml::table t = toml::parse(std::string_view(text), std::string_view("f.toml"));
  Reader r(t, "soil", "f.toml", out.diags, t.source());
  out.choice = read_model(r, slot(), out.valid);
  r.finish(out.valid);
  return out;
}

TEST(SceneParams, DefaultsFromTheMemberInitialisers) {
  const auto r = read("");
  ASSERT_TRUE(r.diags.empty());
  EXPECT_EQ(r.choice.keyword, "elastic");
  EXPECT_EQ(r.choice.get<Spring>().k, 2.0e6);
  EXPECT_EQ(r.choice.get<Damper>().eta, 0.0); // a block of the other model, read all the same
  EXPECT_EQ(r.valid,
            (std::vector<std::string>{"law", "k", "ratio", "bonded", "layers", "label", "eta"}));
}

TEST(SceneParams, ReadsEveryKeyOfTheSlotOnce) {
  const auto r = read("law = \"damped\"\nk = 5e6\nratio = 0.5\nbonded = true\nlayers = 4\n"
                      "label = \"stiff\"\neta = 3.0\n");
  ASSERT_TRUE(r.diags.empty()) << r.diags.front().format();
  EXPECT_EQ(r.choice.keyword, "damped");
  const auto& s = r.choice.get<Spring>();
  EXPECT_EQ(s.k, 5e6);
  EXPECT_EQ(s.ratio, 0.5);
  EXPECT_TRUE(s.bonded);
  EXPECT_EQ(s.layers, 4);
  EXPECT_EQ(s.label, "stiff");
  EXPECT_EQ(r.choice.get<Damper>().eta, 3.0);
  EXPECT_EQ(r.choice.blocks.size(), 2u); // the spring is shared by both models: one block
  EXPECT_EQ(r.choice.uses, (std::vector<std::string>{"spring", "damper"}));
}

TEST(SceneParams, RulesGiveTheReadersLocatedMessages) {
  const auto r = read("k = -1.0\nratio = 1.0\nlayers = 0\nlaw = \"plastic\"\nfoo = 1\n");
  std::vector<std::string> got;
  for (const auto& d : r.diags) got.push_back(d.format());
  ASSERT_EQ(got.size(), 5u);
  EXPECT_EQ(got[0], "f.toml:4:7: error: soil.law: unknown keyword 'plastic'; valid: elastic, "
                    "damped");
  EXPECT_EQ(got[1], "f.toml:1:5: error: soil.k: must be > 0, got -1");
  EXPECT_EQ(got[2], "f.toml:2:9: error: soil.ratio: must be in [0, 1), got 1");
  EXPECT_EQ(got[3], "f.toml:3:10: error: soil.layers: must be an integer in [1, 9], got 0");
  EXPECT_NE(got[4].find("soil.foo: unknown key; valid keys here: law, k, ratio"), std::string::npos)
      << got[4];
}

TEST(SceneParams, ChecksRunForTheChosenModelsBlocks) {
  const auto r = read("bonded = true\nratio = 0.0\n");
  ASSERT_EQ(r.diags.size(), 1u);
  EXPECT_EQ(r.diags[0].format(), "f.toml:2:9: error: soil.ratio: a bonded spring needs ratio > 0");
}

TEST(SceneParams, WritesBackWhatReadsBackTheSame) {
  const auto r = read("law = \"damped\"\nk = 5e6\neta = 3.0\n");
  toml::table t;
  write_model(r.choice, t);
  std::ostringstream os;
  os << t;
  const auto back = read(os.str());
  ASSERT_TRUE(back.diags.empty());
  EXPECT_EQ(back.choice.keyword, "damped");
  EXPECT_EQ(back.choice.get<Spring>().k, 5e6);
  EXPECT_EQ(back.choice.get<Damper>().eta, 3.0);
  EXPECT_EQ(os.str(), "bonded = false\neta = 3.0\nk = 5000000.0\nlabel = 'soft'\nlaw = 'damped'\n"
                      "layers = 3\nratio = 0.25");
}

TEST(SceneParams, AnOptionalSlotAtItsDefaultIsNotWritten) {
  ModelChoice c = default_choice(slot());
  c.always_written = false;
  toml::table t;
  write_model(c, t);
  EXPECT_TRUE(t.empty());
  ASSERT_TRUE(choose(c, slot(), "damped"));
  write_model(c, t);
  EXPECT_EQ(t["law"].value<std::string>(), "damped");
  EXPECT_TRUE(t.contains("eta"));
}

TEST(SceneParams, DescribesTheChosenModelsKeys) {
  const auto r = read("law = \"damped\"\neta = 3.0\n");
  std::vector<std::string> got;
  for (const auto& t : describe(r.choice)) got.push_back(t.text());
  EXPECT_EQ(got, (std::vector<std::string>{"K = 2e+06 N/m", "ratio = 0.25", "bonded = no",
                                           "layers = 3", "label = soft", "η = 3 N·s/m"}));
  EXPECT_EQ(describe(read("").choice).size(), 5u); // elastic: the spring only
}

TEST(SceneParams, SchemaListsKeyTypeUnitDefaultRuleAndMeaning) {
  const auto rows = schema(slot());
  ASSERT_EQ(rows.size(), 7u);
  EXPECT_EQ(rows[0].key, "law");
  EXPECT_EQ(rows[0].fallback, "\"elastic\"");
  EXPECT_EQ(rows[0].rule, "one of elastic, damped");
  EXPECT_EQ(rows[1].key, "k");
  EXPECT_EQ(rows[1].type, "number");
  EXPECT_EQ(rows[1].unit, "N/m");
  EXPECT_EQ(rows[1].fallback, "2e+06");
  EXPECT_EQ(rows[1].rule, "> 0");
  EXPECT_EQ(rows[1].meaning, "the spring's stiffness");
  EXPECT_EQ(rows[1].block, "spring");
  EXPECT_EQ(rows[2].rule, "in [0, 1)");
  EXPECT_EQ(rows[3].type, "boolean");
  EXPECT_EQ(rows[4].type, "integer");
  EXPECT_EQ(rows[6].key, "eta");
  EXPECT_EQ(rows[6].rule, "≥ 0");
}

TEST(SceneParams, ScalesTheStiffnessesOnly) {
  ModelChoice c = default_choice(slot());
  c.get<Damper>().eta = 2.0;
  scale_stiffness(c, 10.0);
  EXPECT_EQ(c.get<Spring>().k, 2.0e7);
  EXPECT_EQ(c.get<Spring>().ratio, 0.25);
  EXPECT_EQ(c.get<Damper>().eta, 2.0);
}

TEST(SceneParams, BlocksCopyByValue) {
  ModelChoice a = default_choice(slot());
  ModelChoice b = a;
  b.get<Spring>().k = 1.0;
  EXPECT_EQ(a.get<Spring>().k, 2.0e6);
  EXPECT_EQ(a.blocks[0].get_if<Damper>(), nullptr);
  EXPECT_THROW((void)default_choice(ModelSlot{}).get<Spring>(), std::logic_error);
}

} // namespace
} // namespace demfem::scene
