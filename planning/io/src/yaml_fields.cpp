// SPDX-License-Identifier: Apache-2.0
#include "yaml_fields.hpp"

#include <yaml-cpp/eventhandler.h>

#include <cmath>
#include <limits>
#include <sstream>

namespace mgc::planning::io {

namespace {

// Appended piece by piece: GCC 12 at -O3 misreads the equivalent chain of operator+ temporaries as
// an overlapping memcpy (-Wrestrict) and would fail a Release build. Every piece is echoed, so the
// line stays one line of at most kMaxMessageChars whatever the file held.
std::string input_error_text(const std::string& file, int line, const std::string& field, const std::string& message) {
  std::string text = echo(file, kMaxPathEchoChars);
  if (line > 0) text.append(":").append(std::to_string(line));
  text.append(": ");
  if (!field.empty()) text.append(echo(field, kMaxEchoChars)).append(": ");
  const std::size_t room = kMaxMessageChars > text.size() + 40 ? kMaxMessageChars - text.size() : 40;
  text.append(echo(message, room));
  return text;
}

}  // namespace

InputError::InputError(const std::string& file, int line, const std::string& field, const std::string& message)
    : std::runtime_error(input_error_text(file, line, field, message)),
      file_(file),
      line_(line),
      field_(field.size() > kMaxEchoChars ? echo(field, kMaxEchoChars) : field) {}

Value::Value(YAML::Node node, std::string path, const std::string* file, int fallback_line, int key_line)
    : node_(std::move(node)), path_(std::move(path)), file_(file), fallback_line_(fallback_line), key_line_(key_line) {}

int Value::line() const noexcept {
  if (key_line_ > 0) return key_line_;
  const YAML::Mark mark = node_.Mark();
  return mark.line >= 0 ? mark.line + 1 : fallback_line_;
}

std::string Value::describe() const {
  if (!node_.IsDefined() || node_.IsNull()) return "nothing";
  if (node_.IsScalar()) return "'" + echo(node_.Scalar()) + "'";
  if (node_.IsSequence()) return "a list of " + std::to_string(node_.size());
  return "a map";
}

void Value::fail(const std::string& expected) const {
  throw InputError(*file_, line(), path_, "expected " + expected + ", got " + describe());
}

void Value::fail_plain(const std::string& message) const { throw InputError(*file_, line(), path_, message); }

double Value::number() const {
  if (!node_.IsScalar()) fail("a number");
  double v = 0.0;
  try {
    v = node_.as<double>();
  } catch (const YAML::Exception&) {
    fail("a number");
  }
  if (!std::isfinite(v)) fail("a finite number");
  return v;
}

double Value::positive() const {
  const double v = number();
  if (!(v > 0.0)) fail("a positive number");
  return v;
}

double Value::non_negative() const {
  const double v = number();
  if (v < 0.0) fail("a number >= 0");
  return v;
}

double Value::number_in(double lo, double hi) const {
  const double v = number();
  if (v < lo || v > hi) {
    std::ostringstream s;
    s << "a number in [" << lo << ", " << hi << "]";
    fail(s.str());
  }
  return v;
}

int Value::integer(int lo, int hi) const {
  const std::string expected = "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  if (!node_.IsScalar()) fail(expected);
  long long v = 0;
  try {
    v = node_.as<long long>();
  } catch (const YAML::Exception&) {
    fail(expected);
  }
  if (v < lo || v > hi) fail(expected);
  return static_cast<int>(v);
}

std::uint64_t Value::unsigned_integer() const {
  if (!node_.IsScalar() || node_.Scalar().empty() || node_.Scalar()[0] == '-') fail("an integer >= 0");
  try {
    return node_.as<std::uint64_t>();
  } catch (const YAML::Exception&) {
    fail("an integer >= 0");
  }
}

std::string Value::text() const {
  if (!node_.IsScalar() || node_.Scalar().empty()) fail("text");
  return node_.Scalar();
}

std::string Value::name() const {
  const std::string t = text();
  if (t.size() > kMaxNameChars) fail("a name of at most " + std::to_string(kMaxNameChars) + " characters");
  for (const char c : t) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7f) fail("a name without control characters");
  }
  return t;
}

namespace {

std::string extent_text() {
  std::ostringstream s;
  s << kSiteExtent_m;
  return s.str();
}

}  // namespace

double Value::coordinate_m() const {
  const double v = number();
  if (!(std::abs(v) <= kSiteExtent_m)) fail("a coordinate within the site extent [-" + extent_text() + ", " + extent_text() + "] m");
  return v;
}

double Value::length_m() const {
  const double v = positive();
  if (!(v <= kSiteExtent_m)) fail("a length of at most " + extent_text() + " m (the site extent)");
  return v;
}

double Value::non_negative_length_m() const {
  const double v = non_negative();
  if (!(v <= kSiteExtent_m)) fail("a length of at most " + extent_text() + " m (the site extent)");
  return v;
}

double Value::angle_deg() const {
  const double v = number();
  if (!(std::abs(v) <= kMaxAngle_deg)) {
    std::ostringstream s;
    s << "an angle within [-" << kMaxAngle_deg << ", " << kMaxAngle_deg << "] deg";
    fail(s.str());
  }
  return v;
}

Eigen::Vector3d Value::position_m() const {
  if (!node_.IsSequence() || node_.size() != 3) fail("a list of 3 numbers [x, y, z]");
  Eigen::Vector3d v;
  const auto items = list();
  for (int i = 0; i < 3; ++i) v[i] = items[static_cast<std::size_t>(i)].coordinate_m();
  return v;
}

Eigen::Vector3d Value::size_m() const {
  if (!node_.IsSequence() || node_.size() != 3) fail("a list of 3 positive numbers");
  Eigen::Vector3d v;
  const auto items = list();
  for (int i = 0; i < 3; ++i) v[i] = items[static_cast<std::size_t>(i)].length_m();
  return v;
}

bool Value::boolean() const {
  if (!node_.IsScalar()) fail("true or false");
  try {
    return node_.as<bool>();
  } catch (const YAML::Exception&) {
    fail("true or false");
  }
}

Eigen::Vector3d Value::vec3() const {
  if (!node_.IsSequence() || node_.size() != 3) fail("a list of 3 numbers [x, y, z]");
  Eigen::Vector3d v;
  const auto items = list();
  for (int i = 0; i < 3; ++i) v[i] = items[static_cast<std::size_t>(i)].number();
  return v;
}

Eigen::Vector3d Value::positive_vec3() const {
  if (!node_.IsSequence() || node_.size() != 3) fail("a list of 3 positive numbers");
  Eigen::Vector3d v;
  const auto items = list();
  for (int i = 0; i < 3; ++i) v[i] = items[static_cast<std::size_t>(i)].positive();
  return v;
}

std::pair<double, double> Value::increasing_pair() const {
  if (!node_.IsSequence() || node_.size() != 2) fail("a pair [min, max]");
  const auto items = list();
  const double lo = items[0].number();
  const double hi = items[1].number();
  if (!(lo < hi)) fail("a pair [min, max] with min < max");
  return {lo, hi};
}

std::vector<Value> Value::list() const {
  if (!node_.IsSequence()) fail("a list");
  std::vector<Value> out;
  out.reserve(node_.size());
  for (std::size_t i = 0; i < node_.size(); ++i) {
    out.emplace_back(node_[i], path_ + "[" + std::to_string(i) + "]", file_, line());
  }
  return out;
}

std::vector<Value> Value::non_empty_list() const {
  auto out = list();
  if (out.empty()) fail("a non-empty list");
  return out;
}

std::vector<double> Value::numbers(bool ascending) const {
  std::vector<double> out;
  for (const Value& v : non_empty_list()) {
    out.push_back(v.number());
    if (ascending && out.size() > 1 && !(out[out.size() - 1] > out[out.size() - 2])) {
      v.fail("a value above the previous one (the list must increase)");
    }
  }
  return out;
}

Fields Value::fields() const {
  if (!node_.IsMap()) fail("a map of fields");
  return Fields(*this, node_);
}

std::string Value::choice(std::initializer_list<const char*> choices) const {
  std::string expected = "one of";
  for (const char* c : choices) expected += std::string(expected == "one of" ? " " : ", ") + c;
  if (!node_.IsScalar()) fail(expected);
  const std::string v = node_.Scalar();
  for (const char* c : choices) {
    if (v == c) return v;
  }
  fail(expected);
}

Fields::Fields(const Value& map_value, const YAML::Node& node) : self_(map_value) {
  entries_.reserve(node.size());
  for (const auto& kv : node) {
    if (!kv.first.IsScalar()) {
      const Value key(kv.first, self_.path(), &self_.file(), self_.line());
      key.fail_plain("field names must be plain text");
    }
    const std::string& name = kv.first.Scalar();
    if (!index_.emplace(name, entries_.size()).second) {
      const Value key(kv.first, self_.path(), &self_.file(), self_.line());
      throw InputError(self_.file(), key.line(), child_path(name), "duplicate field");
    }
    entries_.push_back({name, kv.first, kv.second});
  }
}

std::string Fields::child_path(const std::string& key) const {
  return self_.path().empty() ? key : self_.path() + "." + key;
}

bool Fields::has(const std::string& key) const { return index_.find(key) != index_.end(); }

Value Fields::child(const std::string& key) const {
  const auto it = index_.find(key);
  if (it == index_.end()) return Value(YAML::Node(), child_path(key), &self_.file(), self_.line());
  const Entry& e = entries_[it->second];
  return Value(e.value, child_path(key), &self_.file(), self_.line(), e.key_node.Mark().line + 1);
}

Value Fields::required(const std::string& key) {
  used_.insert(key);
  if (!has(key)) throw InputError(self_.file(), self_.line(), child_path(key), "missing field");
  return child(key);
}

std::optional<Value> Fields::optional(const std::string& key) {
  used_.insert(key);
  if (!has(key)) return std::nullopt;
  return child(key);
}

std::pair<std::string, Value> Fields::one_of(std::initializer_list<std::string> keys) {
  std::string found;
  std::string names;
  for (const std::string& k : keys) {
    used_.insert(k);
    names += (names.empty() ? "" : " or ") + k;
    if (has(k)) {
      if (!found.empty()) {
        throw InputError(self_.file(), self_.line(), child_path(k), "give only one of " + names);
      }
      found = k;
    }
  }
  if (found.empty()) throw InputError(self_.file(), self_.line(), child_path(*keys.begin()), "missing field (one of " + names + ")");
  return {found, child(found)};
}

void Fields::finish() const {
  for (const Entry& e : entries_) {
    if (used_.count(e.key) != 0) continue;
    std::string known;
    for (const std::string& u : used_) known += (known.empty() ? "" : ", ") + u;
    const Value v(e.key_node, child_path(e.key), &self_.file(), self_.line());
    v.fail_plain("unknown field (known fields here: " + known + ")");
  }
}

namespace {

// Counts the values of a document's parse events and stops the parse past kMaxYamlValues, before a
// node tree is built: yaml-cpp spends some 500 bytes on each node, so a few megabytes of "0," would
// otherwise take gigabytes.
class ValueCounter : public YAML::EventHandler {
 public:
  struct TooMany {
    YAML::Mark mark;
  };
  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& mark, YAML::anchor_t) override { count(mark); }
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override { count(mark); }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t, const std::string&) override { count(mark); }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    count(mark);
  }
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override { count(mark); }
  void OnMapEnd() override {}

 private:
  void count(const YAML::Mark& mark) {
    if (++values_ > kMaxYamlValues) throw TooMany{mark};
  }
  std::size_t values_ = 0;
};

}  // namespace

YAML::Node load_yaml(const std::string& file) {
  std::string text;
  if (std::string problem = read_input_file(file, text); !problem.empty()) throw InputError(file, 0, "", problem);
  try {
    {
      std::istringstream in(text);
      YAML::Parser parser(in);
      ValueCounter counter;
      // Only the first document: it is the one YAML::Load reads.
      (void)parser.HandleNextDocument(counter);
    }
    return YAML::Load(text);
  } catch (const ValueCounter::TooMany& e) {
    throw InputError(file, e.mark.line + 1, "",
                     "more than " + std::to_string(kMaxYamlValues) + " YAML values (scalars, lists and maps), the limit");
  } catch (const YAML::ParserException& e) {
    throw InputError(file, e.mark.line + 1, "", "YAML syntax error: " + e.msg);
  } catch (const YAML::Exception& e) {
    throw InputError(file, e.mark.line + 1, "", "YAML error: " + e.msg);
  }
}

}  // namespace mgc::planning::io
