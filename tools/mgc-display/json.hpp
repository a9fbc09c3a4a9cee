// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <Eigen/Core>

#include <string>
#include <string_view>

namespace mgc::display {

//! A small JSON text builder for the page's messages: values are appended in order, commas are
//! placed by the builder, and a non-finite number is written as null (JSON has no NaN).
class Json {
 public:
  Json& begin_object();
  Json& end_object();
  Json& begin_array();
  Json& end_array();
  Json& key(std::string_view name);
  Json& value(double v);
  Json& value(long long v);
  Json& value(int v) { return value(static_cast<long long>(v)); }
  Json& value(bool v);
  Json& value(std::string_view text);
  Json& value(const char* text) { return value(std::string_view(text)); }
  Json& null();
  Json& point(const Eigen::Vector3d& p);  //!< [x, y, z], 3 decimals [m]
  //! Appends already formatted JSON as one value.
  Json& raw(std::string_view json);

  [[nodiscard]] const std::string& str() const noexcept { return text_; }

 private:
  void separate();
  std::string text_;
  bool need_comma_ = false;
};

}  // namespace mgc::display
