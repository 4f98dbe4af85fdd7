// Parameter blocks (params.hpp): the visitors that describe a block, list its schema and scale it;
// reading and writing through the TOML reader are in reader.cpp.
#include "demfem/scene/params.hpp"

#include <charconv>
#include <cmath>
#include <numbers>
#include <optional>

#include <fmt/format.h>

namespace demfem::scene {

namespace {

std::string with_unit(std::string value, std::string_view unit) {
  if (!unit.empty()) {
    value += ' ';
    value.append(unit);
  }
  return value;
}

// The shortest text that reads back to the same double, as a TOML float ("1000000.0", "0.1").
std::string toml_number(double v) {
  char buf[64];
  const auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, v);
  std::string s(buf, ec == std::errc{} ? ptr : buf);
  if (std::isfinite(v) && s.find_first_of(".eE") == std::string::npos) s += ".0";
  return s;
}

// A number as the file states it (degrees for an angle held in radians), or nothing when unset.
std::optional<double> as_stated(const Field& f, double v) {
  if (f.value == Field::Value::optional && std::isnan(v)) return std::nullopt;
  if (f.value == Field::Value::degrees)
    return std::round(v * (180.0 / std::numbers::pi) * 1e9) / 1e9;
  return v;
}

std::string rule_text(const Rule& r) {
  switch (r.kind) {
  case Rule::Kind::any:
    return "";
  case Rule::Kind::positive:
    return "> 0";
  case Rule::Kind::non_negative:
    return "≥ 0";
  case Rule::Kind::range:
    return fmt::format("in [{}, {}{}", r.lo, r.hi, r.open_hi ? ")" : "]");
  }
  return "";
}

class Describer final : public ParamVisitor {
public:
  std::vector<ParamText> out;
  void number(const Field& f, double& v, Rule /*rule*/) override {
    const auto x = as_stated(f, v);
    add(f, x ? with_unit(fmt::format("{:.3g}", *x), f.unit) : std::string("unset"));
  }
  void integer(const Field& f, int& v, int /*lo*/, int /*hi*/) override {
    add(f, with_unit(fmt::format("{}", v), f.unit));
  }
  void flag(const Field& f, bool& v) override { add(f, v ? "yes" : "no"); }
  void text(const Field& f, std::string& v) override { add(f, v); }

private:
  void add(const Field& f, std::string value) {
    out.push_back(
        {std::string(f.key), std::string(f.symbol.empty() ? f.key : f.symbol), std::move(value)});
  }
};

class SchemaLister final : public ParamVisitor {
public:
  explicit SchemaLister(std::string_view block) : block_(block) {}
  std::vector<ParamSchema> out;
  void number(const Field& f, double& v, Rule rule) override {
    const auto x = as_stated(f, v);
    add(f, "number", x ? toml_number(*x) : std::string("unset"), rule_text(rule));
  }
  void integer(const Field& f, int& v, int lo, int hi) override {
    add(f, "integer", fmt::format("{}", v), fmt::format("in [{}, {}]", lo, hi));
  }
  void flag(const Field& f, bool& v) override { add(f, "boolean", v ? "true" : "false", ""); }
  void text(const Field& f, std::string& v) override {
    add(f, "string", fmt::format("\"{}\"", v), "");
  }

private:
  void add(const Field& f, const char* type, std::string fallback, std::string rule) {
    out.push_back({std::string(f.key), type, std::string(f.unit), std::move(fallback),
                   std::move(rule), std::string(f.meaning), std::string(block_)});
  }
  std::string_view block_;
};

class StiffnessScaler final : public ParamVisitor {
public:
  explicit StiffnessScaler(double f) : f_(f) {}
  void number(const Field& f, double& v, Rule /*rule*/) override {
    if (f.scale == Scale::stiffness) v *= f_;
  }
  void integer(const Field&, int&, int, int) override {}
  void flag(const Field&, bool&) override {}
  void text(const Field&, std::string&) override {}

private:
  double f_;
};

class KeySetter final : public ParamVisitor {
public:
  KeySetter(std::string_view key, double value) : key_(key), value_(value) {}
  bool found = false;
  void number(const Field& f, double& v, Rule /*rule*/) override {
    if (f.key == key_) set(v, value_);
  }
  void integer(const Field& f, int& v, int /*lo*/, int /*hi*/) override {
    if (f.key == key_) set(v, static_cast<int>(value_));
  }
  void flag(const Field& f, bool& v) override {
    if (f.key == key_) set(v, value_ != 0.0);
  }
  void text(const Field&, std::string&) override {}

private:
  template <class T> void set(T& to, T v) {
    to = v;
    found = true;
  }
  std::string_view key_;
  double value_;
};

class KeyGetter final : public ParamVisitor {
public:
  explicit KeyGetter(std::string_view key) : key_(key) {}
  std::optional<double> value;
  std::vector<std::string> keys;
  void number(const Field& f, double& v, Rule /*rule*/) override { see(f, v); }
  void integer(const Field& f, int& v, int /*lo*/, int /*hi*/) override { see(f, v); }
  void flag(const Field& f, bool& v) override { see(f, v ? 1.0 : 0.0); }
  void text(const Field&, std::string&) override {}

private:
  void see(const Field& f, double v) {
    keys.emplace_back(f.key);
    if (f.key == key_ && !value) value = v;
  }
  std::string_view key_;
};

} // namespace

std::optional<double> value_of(const ModelChoice& choice, std::string_view key) {
  KeyGetter g(key);
  for (const auto& b : choice.blocks) b.visit(g);
  return g.value;
}

std::vector<std::string> chosen_keys(const ModelChoice& choice) {
  KeyGetter g("");
  for (const auto& name : choice.uses)
    for (const auto& b : choice.blocks)
      if (b.name() == name) b.visit(g);
  return std::move(g.keys);
}

bool set(ModelChoice& choice, std::string_view key, double value) {
  KeySetter s(key, value);
  for (auto& b : choice.blocks) b.visit(s);
  return s.found;
}

ModelChoice default_choice(const ModelSlot& slot) {
  ModelChoice c;
  c.key = slot.key;
  c.default_keyword = slot.default_keyword;
  c.always_written = slot.always_written;
  c.blocks = slot.all_blocks();
  choose(c, slot, slot.default_keyword);
  return c;
}

bool choose(ModelChoice& c, const ModelSlot& slot, std::string_view keyword) {
  const ModelEntry* e = slot.find(keyword);
  if (!e) return false;
  c.keyword = e->keyword;
  c.uses.clear();
  for (const auto& b : e->blocks) c.uses.emplace_back(b.name());
  return true;
}

std::vector<ParamText> describe(const ParamBlock& block) {
  Describer d;
  block.visit(d);
  return std::move(d.out);
}

std::vector<ParamText> describe(const ModelChoice& choice) {
  std::vector<ParamText> out;
  for (const auto& name : choice.uses)
    for (const auto& b : choice.blocks)
      if (b.name() == name)
        for (auto& t : describe(b)) out.push_back(std::move(t));
  return out;
}

std::vector<ParamSchema> schema(const ParamBlock& block) {
  SchemaLister s(block.name());
  block.visit(s);
  return std::move(s.out);
}

std::vector<ParamSchema> schema(const ModelSlot& slot) {
  std::string models;
  for (const auto& e : slot.entries) models += (models.empty() ? "" : ", ") + e.keyword;
  std::vector<ParamSchema> out{{slot.key, "string", "", fmt::format("\"{}\"", slot.default_keyword),
                                "one of " + models, slot.meaning, ""}};
  for (const auto& b : slot.all_blocks())
    for (auto& row : schema(b)) out.push_back(std::move(row));
  return out;
}

void scale_stiffness(ModelChoice& choice, double f) {
  StiffnessScaler s(f);
  for (auto& b : choice.blocks) b.visit(s);
}

} // namespace demfem::scene
