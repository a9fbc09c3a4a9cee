// SPDX-License-Identifier: Apache-2.0
#pragma once

// Strict reading of YAML input: every value knows its file, line and field path, so every
// complaint names all three; maps reject unknown and duplicate fields.

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "mgc/planning/io/input_error.hpp"
#include "mgc/planning/io/input_limits.hpp"

namespace mgc::planning::io {

class Fields;

class Value {
 public:
  //! key_line: the line of the key that names this value (0 for list items), reported in
  //! preference to the value's own, which for a block map or list is its first entry's line.
  Value(YAML::Node node, std::string path, const std::string* file, int fallback_line, int key_line = 0);

  [[nodiscard]] const std::string& path() const noexcept { return path_; }
  [[nodiscard]] int line() const noexcept;
  [[nodiscard]] const std::string& file() const noexcept { return *file_; }
  [[nodiscard]] bool is_null() const noexcept { return node_.IsNull(); }

  //! Throws InputError "<file>:<line>: <path>: expected <expected>, got <this value>".
  [[noreturn]] void fail(const std::string& expected) const;
  //! Throws InputError "<file>:<line>: <path>: <message>".
  [[noreturn]] void fail_plain(const std::string& message) const;

  [[nodiscard]] double number() const;                   //!< finite
  [[nodiscard]] double positive() const;                 //!< finite, > 0
  [[nodiscard]] double non_negative() const;             //!< finite, >= 0
  [[nodiscard]] double number_in(double lo, double hi) const;
  [[nodiscard]] int integer(int lo, int hi) const;
  [[nodiscard]] std::uint64_t unsigned_integer() const;
  [[nodiscard]] std::string text() const;                //!< non-empty scalar
  //! Text of at most kMaxNameChars characters, none of them a control character.
  [[nodiscard]] std::string name() const;
  //! Site-extent bounds (input_limits.hpp): a coordinate within +-kSiteExtent_m, a length in
  //! (0, kSiteExtent_m] or [0, kSiteExtent_m], an angle within +-kMaxAngle_deg.
  [[nodiscard]] double coordinate_m() const;
  [[nodiscard]] double length_m() const;
  [[nodiscard]] double non_negative_length_m() const;
  [[nodiscard]] double angle_deg() const;
  [[nodiscard]] Eigen::Vector3d position_m() const;     //!< [x, y, z], each a coordinate
  [[nodiscard]] Eigen::Vector3d size_m() const;         //!< [x, y, z], each a length
  [[nodiscard]] bool boolean() const;
  [[nodiscard]] Eigen::Vector3d vec3() const;            //!< [x, y, z], finite
  [[nodiscard]] Eigen::Vector3d positive_vec3() const;   //!< [x, y, z], each > 0
  //! [min, max] with min < max.
  [[nodiscard]] std::pair<double, double> increasing_pair() const;
  [[nodiscard]] std::vector<Value> list() const;
  [[nodiscard]] std::vector<Value> non_empty_list() const;
  //! Numbers; ascending = strictly increasing.
  [[nodiscard]] std::vector<double> numbers(bool ascending) const;
  [[nodiscard]] Fields fields() const;
  //! Text that must be one of `choices`.
  [[nodiscard]] std::string choice(std::initializer_list<const char*> choices) const;

 private:
  [[nodiscard]] std::string describe() const;

  YAML::Node node_;
  std::string path_;
  const std::string* file_;
  int fallback_line_;
  int key_line_;
};

class Fields {
 public:
  explicit Fields(const Value& map_value, const YAML::Node& node);

  [[nodiscard]] Value required(const std::string& key);
  [[nodiscard]] std::optional<Value> optional(const std::string& key);
  [[nodiscard]] bool has(const std::string& key) const;
  //! Exactly one of the keys must be present; returns which and its value.
  [[nodiscard]] std::pair<std::string, Value> one_of(std::initializer_list<std::string> keys);
  //! Throws for the first field that no required()/optional() call asked for.
  void finish() const;
  [[nodiscard]] const Value& self() const noexcept { return self_; }

 private:
  //! One field of the map, in file order.
  struct Entry {
    std::string key;
    YAML::Node key_node;
    YAML::Node value;
  };

  [[nodiscard]] std::string child_path(const std::string& key) const;
  [[nodiscard]] Value child(const std::string& key) const;

  Value self_;
  // The map's fields are listed once here: yaml-cpp finds a key in a map by a linear scan that
  // builds a node and a string for every field it passes, so asking a map of n fields for each
  // of them through the node costs n^2 of those.
  std::vector<Entry> entries_;
  std::map<std::string, std::size_t, std::less<>> index_;
  std::set<std::string> used_;
};

//! Parses a file into its root value; syntax errors become InputError with the line.
[[nodiscard]] YAML::Node load_yaml(const std::string& file);

}  // namespace mgc::planning::io
