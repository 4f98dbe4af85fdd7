// Parameter blocks: a model's keys, each listed once, with everything the program does with them.
//
// A parameter block is a plain struct: its members are the values (their initialisers are the
// defaults), and one member function lists every key once, with its rule, unit and meaning:
//
//   struct LinearSpring {
//     static constexpr const char* kName = "linear-spring"; // the block's name, unique
//     double kn = 1.0e6;
//     void fields(scene::ParamVisitor& v) {
//       v.number({"kn", "K_n", "N/m", "normal spring stiffness: f_n = K_n δ (paper eq. 2.6)",
//                 scene::Scale::stiffness}, kn, scene::positive());
//     }
//     // optional: checks across keys, run when the block's model is the chosen one
//     void check(scene::ParamCheck& c) const;
//   };
//
// From that one list come: reading the keys from the scene file (through the Reader, with its
// file:line:col messages, read_params in load.cpp), writing them back into the resolved scene
// (dump.cpp), the report's description (describe) and the schema that documentation and its sync
// test enumerate (schema).
//
// Why a small virtual visitor and not a template `fields(V&)`: the scene stores a block whose type
// it does not know (ParamBlock below, chosen at load time by keyword), and every operation on it
// is a visitor implemented once in scene/ — so the models never include the TOML reader, and
// scene/ never includes the models. The virtual calls happen per key when the scene is read,
// written or described; a model's physics reads the block's members directly (get<T>()), never
// through the visitor, so nothing virtual runs per contact or per quadrature point.
//
// This header is C++17 (the continuum's deal.II targets include it).
#pragma once

#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <typeinfo>
#include <utility>
#include <vector>

namespace demfem::scene {

// What a number must satisfy; the reader refuses anything else with the rule in the message.
struct Rule {
  enum class Kind { any, positive, non_negative, range } kind = Kind::any;
  double lo = 0.0, hi = 0.0;
  bool open_hi = false; // range: [lo, hi) instead of [lo, hi]
};
inline constexpr Rule any_number() {
  return {};
}
inline constexpr Rule positive() {
  return {Rule::Kind::positive};
}
inline constexpr Rule non_negative() {
  return {Rule::Kind::non_negative};
}
inline constexpr Rule in_range(double lo, double hi, bool open_hi = false) {
  return {Rule::Kind::range, lo, hi, open_hi};
}

// How a value responds to a change of the material's stiffness scale (a study multiplying every
// stiffness by a factor: scale_stiffness).
enum class Scale { none, stiffness };

// One key of a block.
struct Field {
  std::string_view key;     // the scene file's key
  std::string_view symbol;  // short name in the report ("K_n"); empty: the key
  std::string_view unit;    // "N/m", "Pa", "m/s"; empty when dimensionless
  std::string_view meaning; // one sentence: what it is, where it acts, its source
  Scale scale = Scale::none;
  // How a number is stated: Value::plain as held; Value::degrees an angle the file states in
  // degrees (its rule too) and the block holds in radians (written back in degrees to 1e-9°);
  // Value::optional unset while NaN (not read when absent, not written back); Value::nonzero
  // written back only when not 0 (a refinement that is off by default).
  enum class Value { plain, degrees, optional, nonzero } value = Value::plain;
};

// Visits each key of a block with a reference to its value. The reader writes the value; the
// writer, the describer and the schema only read it.
class ParamVisitor {
public:
  virtual ~ParamVisitor() = default;
  virtual void number(const Field& f, double& value, Rule rule) = 0;
  virtual void integer(const Field& f, int& value, int lo, int hi) = 0;
  virtual void flag(const Field& f, bool& value) = 0;
  virtual void text(const Field& f, std::string& value) = 0;
};

// Where a block's cross-key check reports (a located error at one of its keys).
class ParamCheck {
public:
  virtual ~ParamCheck() = default;
  virtual void error(std::string_view key, const std::string& message) = 0;
};

// A copyable, type-erased parameter block (any struct as described above).
class ParamBlock {
public:
  ParamBlock() = default;
  template <class T, class = std::enable_if_t<!std::is_same_v<std::decay_t<T>, ParamBlock>>>
  explicit ParamBlock(T block) : self_(std::make_unique<Model<T>>(std::move(block))) {}
  ParamBlock(const ParamBlock& o) : self_(o.self_ ? o.self_->clone() : nullptr) {}
  ParamBlock(ParamBlock&&) noexcept = default;
  ParamBlock& operator=(const ParamBlock& o) {
    if (this != &o) self_ = o.self_ ? o.self_->clone() : nullptr;
    return *this;
  }
  ParamBlock& operator=(ParamBlock&&) noexcept = default;
  ~ParamBlock() = default;

  [[nodiscard]] bool empty() const { return !self_; }
  [[nodiscard]] std::string_view name() const { return self_ ? self_->name() : std::string_view{}; }
  // Each key in the order fields() lists them.
  void visit(ParamVisitor& v) {
    if (self_) self_->visit(v);
  }
  // For visitors that only read the values (writer, describer, schema).
  void visit(ParamVisitor& v) const {
    if (self_) self_->visit(v); // the block is owned and not const: the visitor does not write
  }
  void check(ParamCheck& c) const {
    if (self_) self_->check(c);
  }
  // The block as its type, or nullptr when it is another.
  template <class T> [[nodiscard]] const T* get_if() const {
    return self_ && self_->type() == typeid(T) ? static_cast<const T*>(self_->data()) : nullptr;
  }
  template <class T> [[nodiscard]] T* get_if() {
    return self_ && self_->type() == typeid(T) ? static_cast<T*>(self_->data()) : nullptr;
  }

private:
  struct Concept {
    virtual ~Concept() = default;
    [[nodiscard]] virtual std::unique_ptr<Concept> clone() const = 0;
    [[nodiscard]] virtual std::string_view name() const = 0;
    virtual void visit(ParamVisitor& v) = 0;
    virtual void check(ParamCheck& c) const = 0;
    [[nodiscard]] virtual const std::type_info& type() const = 0;
    [[nodiscard]] virtual void* data() = 0;
  };
  template <class T, class = void> struct HasCheck : std::false_type {};
  template <class T>
  struct HasCheck<
      T, std::void_t<decltype(std::declval<const T&>().check(std::declval<ParamCheck&>()))>>
      : std::true_type {};
  template <class T> struct Model final : Concept {
    explicit Model(T v) : value(std::move(v)) {}
    T value;
    [[nodiscard]] std::unique_ptr<Concept> clone() const override {
      return std::make_unique<Model>(value);
    }
    [[nodiscard]] std::string_view name() const override { return T::kName; }
    void visit(ParamVisitor& v) override { value.fields(v); }
    void check(ParamCheck& c) const override {
      if constexpr (HasCheck<T>::value) value.check(c);
    }
    [[nodiscard]] const std::type_info& type() const override { return typeid(T); }
    [[nodiscard]] void* data() override { return &value; }
  };
  std::unique_ptr<Concept> self_;
};

// ---- models chosen by keyword ------------------------------------------------------------------
// A slot is a key that chooses one model among several ([soil.dem] contact = "hertz-mindlin");
// each model reads the keys of its parameter blocks from the same table. A block may serve
// several models of a slot (the linear spring's kn serves three contact laws): it is read once.

struct ModelEntry {
  std::string keyword;            // the slot's value that chooses it
  std::string summary;            // one line for the report and the docs
  std::vector<ParamBlock> blocks; // its parameter blocks with their defaults, in reading order
};

struct ModelSlot {
  std::string key;             // the scene key, e.g. "contact"
  std::string meaning;         // one line for the docs
  std::string default_keyword; // the model when the key is absent
  // true: the resolved scene always states the slot and every key of every model of the slot
  // (so that a variant may switch the model and set its keys); false: a slot left at its default
  // is not written at all (an optional sub-model that is off).
  bool always_written = true;
  std::vector<ModelEntry> entries;
  [[nodiscard]] const ModelEntry* find(std::string_view keyword) const {
    for (const auto& e : entries)
      if (e.keyword == keyword) return &e;
    return nullptr;
  }
  [[nodiscard]] std::vector<std::string> keywords() const {
    std::vector<std::string> k;
    for (const auto& e : entries) k.push_back(e.keyword);
    return k;
  }
  // Every block of every model of the slot, once each (by name), in first-use order.
  [[nodiscard]] std::vector<ParamBlock> all_blocks() const {
    std::vector<ParamBlock> out;
    for (const auto& e : entries)
      for (const auto& b : e.blocks) {
        bool seen = false;
        for (const auto& o : out) seen = seen || o.name() == b.name();
        if (!seen) out.push_back(b);
      }
    return out;
  }
};

// The scene's record of one slot: the chosen model and the values of the slot's keys.
struct ModelChoice {
  std::string key;                // the slot's key
  std::string keyword;            // the chosen model
  std::string default_keyword;    // the slot's default
  bool always_written = true;     // ModelSlot::always_written
  std::vector<ParamBlock> blocks; // every block of the slot (ModelSlot::all_blocks), as read
  std::vector<std::string> uses;  // names of the chosen model's blocks

  // The block of type T (a block of the chosen model, or of another model of the slot).
  template <class T> [[nodiscard]] const T& get() const {
    for (const auto& b : blocks)
      if (const T* p = b.template get_if<T>()) return *p;
    throw std::logic_error(std::string("no parameter block ") + T::kName + " for " + key);
  }
  template <class T> [[nodiscard]] T& get() {
    for (auto& b : blocks)
      if (T* p = b.template get_if<T>()) return *p;
    throw std::logic_error(std::string("no parameter block ") + T::kName + " for " + key);
  }
  [[nodiscard]] bool chosen_uses(std::string_view block) const {
    for (const auto& u : uses)
      if (u == block) return true;
    return false;
  }
  [[nodiscard]] bool written() const { return always_written || keyword != default_keyword; }
};

// The slot at its default model, every block at its defaults (a scene built in code).
[[nodiscard]] ModelChoice default_choice(const ModelSlot& slot);
// The slot with the given model chosen (the blocks keep their values); false for an unknown one.
bool choose(ModelChoice& choice, const ModelSlot& slot, std::string_view keyword);

// ---- what the program does with a block
// ----------------------------------------------------------

// One key as the report shows it: "K_n = 1e+06 N/m".
struct ParamText {
  std::string key, symbol, value; // value with its unit
  [[nodiscard]] std::string text() const { return symbol + " = " + value; }
};
[[nodiscard]] std::vector<ParamText> describe(const ParamBlock& block);
// The keys of the chosen model of a choice, block by block, in reading order.
[[nodiscard]] std::vector<ParamText> describe(const ModelChoice& choice);

// One key as the documentation lists it.
struct ParamSchema {
  std::string key;
  std::string type;     // "number", "integer", "boolean", "string"
  std::string unit;     // "" when dimensionless
  std::string fallback; // the default, as the resolved scene writes it
  std::string rule;     // "> 0", "≥ 0", "in [0, 1]", "" for any
  std::string meaning;
  std::string block; // the block's name
};
[[nodiscard]] std::vector<ParamSchema> schema(const ParamBlock& block);
// Every key of a slot (each block once), after a row for the slot's own key.
[[nodiscard]] std::vector<ParamSchema> schema(const ModelSlot& slot);

// Sets a key of the choice's blocks (a number, an integer, or a flag: value ≠ 0) without the
// rules' checks (code and tests that build a model); false when no block has the key.
bool set(ModelChoice& choice, std::string_view key, double value);

// The value of a key of the choice's blocks (a flag as 0 or 1), or nothing when no block has it.
[[nodiscard]] std::optional<double> value_of(const ModelChoice& choice, std::string_view key);
// The keys of the chosen model's blocks, in reading order (those of numbers, integers, flags).
[[nodiscard]] std::vector<std::string> chosen_keys(const ModelChoice& choice);

// Multiplies every number whose Field::scale is stiffness, in every block of the choice, by f.
void scale_stiffness(ModelChoice& choice, double f);

} // namespace demfem::scene
