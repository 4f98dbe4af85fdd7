// The scene file's reader (reader.hpp).
#include "demfem/scene/reader.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

namespace demfem::scene {

Reader::Reader(const toml::table& table, std::string path, std::string file,
               std::vector<Diagnostic>& diags, const toml::source_region& where)
    : t_(table), path_(std::move(path)), file_(std::move(file)), diags_(diags), where_(where) {}

void Reader::error_here(const std::string& msg) {
  error_at(where_, path_, msg);
}

bool Reader::has(std::string_view key) const {
  return t_.contains(key);
}

double Reader::number(std::string_view key, double def) {
  return opt_number(key).value_or(def);
}

void Reader::mark_used(std::string_view key) {
  used_.insert(std::string(key));
}

std::string Reader::key_path(std::string_view key) const {
  return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
}

void Reader::error_at(const toml::source_region& src, const std::string& key,
                      const std::string& msg) {
  Diagnostic d;
  d.file = src.path ? std::string(*src.path) : file_;
  if (d.file.empty()) d.file = file_;
  d.line = static_cast<int>(src.begin.line);
  d.column = static_cast<int>(src.begin.column);
  d.key = key;
  d.message = msg;
  diags_.push_back(std::move(d));
}

void Reader::error(std::string_view key, const std::string& msg) {
  const toml::node* n = t_.get(key);
  error_at(n ? n->source() : where_, key_path(key), msg);
}

const toml::node* Reader::node(std::string_view key) {
  used_.insert(std::string(key));
  return t_.get(key);
}

std::optional<double> Reader::opt_number(std::string_view key) {
  const toml::node* n = node(key);
  if (!n) return std::nullopt;
  if (!n->is_number()) {
    error(key, fmt::format("expected a number, got {}", type_name(*n)));
    return std::nullopt;
  }
  const double v = n->value<double>().value_or(0.0);
  if (!std::isfinite(v)) {
    error(key, fmt::format("must be a finite number, got {}", v));
    return std::nullopt;
  }
  return v;
}

double Reader::required_number(std::string_view key) {
  if (!has(key)) {
    error_here(fmt::format("missing required key '{}' (a number)", key));
    return 0.0;
  }
  return number(key, 0.0);
}

double Reader::positive(std::string_view key, double def, bool required) {
  if (required && !has(key)) return required_number(key);
  const auto v = opt_number(key);
  if (v && !(*v > 0.0)) error(key, fmt::format("must be > 0, got {}", *v));
  return v.value_or(def);
}

double Reader::non_negative(std::string_view key, double def) {
  const auto v = opt_number(key);
  if (v && *v < 0.0) error(key, fmt::format("must be ≥ 0, got {}", *v));
  return v.value_or(def);
}

double Reader::in_range(std::string_view key, double def, double lo, double hi, bool open_hi) {
  const auto v = opt_number(key);
  if (v && (*v < lo || (open_hi ? *v >= hi : *v > hi)))
    error(key, fmt::format("must be in [{}, {}{}, got {}", lo, hi, open_hi ? ")" : "]", *v));
  return v.value_or(def);
}

int Reader::integer(std::string_view key, int def, int lo, int hi) {
  const toml::node* n = node(key);
  if (!n) return def;
  if (!n->is_integer()) {
    error(key, fmt::format("expected an integer, got {}", type_name(*n)));
    return def;
  }
  const auto v = n->value<int64_t>().value_or(def);
  if (v < lo || v > hi) {
    error(key, fmt::format("must be an integer in [{}, {}], got {}", lo, hi, v));
    return def;
  }
  return static_cast<int>(v);
}

bool Reader::boolean(std::string_view key, bool def) {
  const toml::node* n = node(key);
  if (!n) return def;
  if (!n->is_boolean()) {
    error(key, fmt::format("expected true or false, got {}", type_name(*n)));
    return def;
  }
  return n->value<bool>().value_or(def);
}

std::optional<std::string> Reader::opt_string(std::string_view key) {
  const toml::node* n = node(key);
  if (!n) return std::nullopt;
  if (!n->is_string()) {
    error(key, fmt::format("expected a string, got {}", type_name(*n)));
    return std::nullopt;
  }
  return n->value<std::string>();
}

std::string Reader::string(std::string_view key, const std::string& def) {
  return opt_string(key).value_or(def);
}

std::optional<Vec2> Reader::point(std::string_view key) {
  const toml::node* n = node(key);
  if (!n) return std::nullopt;
  return as_point(*n, key_path(key));
}

std::optional<Vec2> Reader::as_point(const toml::node& n, const std::string& kp) {
  const auto* a = n.as_array();
  if (!a || a->size() != 2 || !(*a)[0].is_number() || !(*a)[1].is_number()) {
    error_at(n.source(), kp,
             fmt::format("expected a point [x, z] of two numbers, got {}", type_name(n)));
    return std::nullopt;
  }
  Vec2 p{(*a)[0].value<double>().value_or(0.0), (*a)[1].value<double>().value_or(0.0)};
  if (!std::isfinite(p.x) || !std::isfinite(p.z)) {
    error_at(n.source(), kp, "point coordinates must be finite numbers");
    return std::nullopt;
  }
  return p;
}

std::vector<Vec2> Reader::points(std::string_view key, std::size_t min_count) {
  const toml::node* n = node(key);
  if (!n) return {};
  const auto* a = n->as_array();
  if (!a) {
    error(key, fmt::format("expected a list of points [[x, z], …], got {}", type_name(*n)));
    return {};
  }
  std::vector<Vec2> out;
  for (std::size_t i = 0; i < a->size(); ++i)
    if (auto p = as_point((*a)[i], fmt::format("{}[{}]", key_path(key), i))) out.push_back(*p);
  if (out.size() < min_count && out.size() == a->size())
    error(key, fmt::format("needs at least {} points, got {}", min_count, out.size()));
  return out;
}

Polygon Reader::polygon(std::string_view key, bool required) {
  if (!has(key)) {
    node(key);
    if (required) error_here(fmt::format("missing required key '{}' (a polygon [[x, z], …])", key));
    return {};
  }
  Polygon p = points(key, 3);
  if (p.size() < 3) {
    if (p.empty() && node(key)->as_array() && node(key)->as_array()->empty())
      error(key, "empty polygon; give at least 3 points [[x, z], …]");
    return {};
  }
  if (self_intersects(p)) {
    error(key, "polygon is self-intersecting; list its corners in order around the boundary");
    return {};
  }
  const double area = signed_area(p);
  if (std::abs(area) <= 0.0) {
    error(key, "polygon has zero area (collinear points)");
    return {};
  }
  if (area < 0.0) std::reverse(p.begin(), p.end()); // store counter-clockwise
  return p;
}

const toml::table* Reader::table(std::string_view key) {
  const toml::node* n = node(key);
  if (!n) return nullptr;
  if (!n->is_table()) {
    error(key, fmt::format("expected a table, got {}", type_name(*n)));
    return nullptr;
  }
  return n->as_table();
}

const toml::array* Reader::array_of_tables(std::string_view key) {
  const toml::node* n = node(key);
  if (!n) return nullptr;
  if (!n->is_array_of_tables() && !(n->is_array() && n->as_array()->empty())) {
    error(key, fmt::format("expected an array of tables ([[{}]]), got {}", key, type_name(*n)));
    return nullptr;
  }
  return n->as_array();
}

void Reader::finish(const std::vector<std::string>& valid) {
  for (auto&& [k, v] : t_) {
    const std::string ks(k.str());
    if (used_.count(ks)) continue;
    error_at(k.source(), key_path(ks),
             fmt::format("unknown key; valid keys here: {}", fmt::join(valid, ", ")));
  }
}

std::string Reader::type_name(const toml::node& n) {
  switch (n.type()) {
  case toml::node_type::table:
    return "a table";
  case toml::node_type::array:
    return "an array";
  case toml::node_type::string:
    return fmt::format("the string \"{}\"", n.value<std::string>().value_or(""));
  case toml::node_type::integer:
    return fmt::format("the integer {}", n.value<int64_t>().value_or(0));
  case toml::node_type::floating_point:
    return fmt::format("the number {}", n.value<double>().value_or(0));
  case toml::node_type::boolean:
    return n.value<bool>().value_or(false) ? "true" : "false";
  default:
    return "a date/time";
  }
}
namespace {

// An angle the file states in degrees (Field::Value::degrees), as the loader converted it
constexpr double kRadPerDeg = std::numbers::pi / 180.0;
constexpr double kDegPerRad = 180.0 / std::numbers::pi;

class ParamReader final : public ParamVisitor {
public:
  explicit ParamReader(Reader& r) : r_(r) {}
  void number(const Field& f, double& v, Rule rule) override {
    if (f.value == Field::Value::degrees) { // the rule in degrees, the value kept in radians
      if (!r_.has(f.key)) return;
      double d = 0.0;
      read(f, d, rule);
      v = d * kRadPerDeg;
      return;
    }
    read(f, v, rule);
  }
  void integer(const Field& f, int& v, int lo, int hi) override {
    v = r_.integer(f.key, v, lo, hi);
  }
  void flag(const Field& f, bool& v) override { v = r_.boolean(f.key, v); }
  void text(const Field& f, std::string& v) override { v = r_.string(f.key, v); }

private:
  // an absent key keeps v (the default; NaN for an unset optional value)
  void read(const Field& f, double& v, Rule rule) {
    switch (rule.kind) {
    case Rule::Kind::any:
      v = r_.number(f.key, v);
      break;
    case Rule::Kind::positive:
      v = r_.positive(f.key, v);
      break;
    case Rule::Kind::non_negative:
      v = r_.non_negative(f.key, v);
      break;
    case Rule::Kind::range:
      v = r_.in_range(f.key, v, rule.lo, rule.hi, rule.open_hi);
      break;
    }
  }
  Reader& r_;
};

class KeyLister final : public ParamVisitor {
public:
  std::vector<std::string>* out;
  explicit KeyLister(std::vector<std::string>& o) : out(&o) {}
  void number(const Field& f, double&, Rule) override { out->emplace_back(f.key); }
  void integer(const Field& f, int&, int, int) override { out->emplace_back(f.key); }
  void flag(const Field& f, bool&) override { out->emplace_back(f.key); }
  void text(const Field& f, std::string&) override { out->emplace_back(f.key); }
};

class TomlWriter final : public ParamVisitor {
public:
  explicit TomlWriter(toml::table& t) : t_(t) {}
  void number(const Field& f, double& v, Rule) override {
    if (f.value == Field::Value::optional && std::isnan(v)) return;
    if (f.value == Field::Value::nonzero && v == 0.0) return;
    // degrees rounded to 1e-9° so that 30° does not come back as 29.999999999999996
    t_.insert_or_assign(
        f.key, f.value == Field::Value::degrees ? std::round(v * kDegPerRad * 1e9) / 1e9 : v);
  }
  void integer(const Field& f, int& v, int, int) override {
    t_.insert_or_assign(f.key, static_cast<int64_t>(v));
  }
  void flag(const Field& f, bool& v) override { t_.insert_or_assign(f.key, v); }
  void text(const Field& f, std::string& v) override { t_.insert_or_assign(f.key, v); }

private:
  toml::table& t_;
};

class ReaderCheck final : public ParamCheck {
public:
  explicit ReaderCheck(Reader& r) : r_(r) {}
  void error(std::string_view key, const std::string& message) override { r_.error(key, message); }

private:
  Reader& r_;
};

} // namespace

void read_params(ParamBlock& block, Reader& r) {
  ParamReader v(r);
  block.visit(v);
}

ModelChoice read_model(Reader& r, const ModelSlot& slot, std::vector<std::string>& valid) {
  ModelChoice c = default_choice(slot);
  valid.push_back(slot.key);
  if (const auto kw = r.opt_string(slot.key); kw && !choose(c, slot, *kw))
    r.error(slot.key,
            fmt::format("unknown keyword '{}'; valid: {}", *kw, fmt::join(slot.keywords(), ", ")));
  for (auto& b : c.blocks) {
    read_params(b, r);
    KeyLister keys(valid);
    b.visit(keys);
  }
  ReaderCheck check(r);
  for (const auto& b : c.blocks)
    if (c.chosen_uses(b.name())) b.check(check);
  return c;
}

void write_params(const ParamBlock& block, toml::table& t) {
  TomlWriter w(t);
  block.visit(w);
}

void write_model(const ModelChoice& c, toml::table& t) {
  if (!c.written()) return;
  t.insert_or_assign(c.key, c.keyword);
  for (const auto& b : c.blocks)
    if (c.chosen_uses(b.name())) write_params(b, t); // the chosen model's keys only
}

} // namespace demfem::scene
