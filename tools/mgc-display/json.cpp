// SPDX-License-Identifier: Apache-2.0
#include "json.hpp"

#include <cmath>
#include <cstdio>

namespace mgc::display {

void Json::separate() {
  if (need_comma_) text_ += ',';
  need_comma_ = true;
}

Json& Json::begin_object() {
  separate();
  text_ += '{';
  need_comma_ = false;
  return *this;
}

Json& Json::end_object() {
  text_ += '}';
  need_comma_ = true;
  return *this;
}

Json& Json::begin_array() {
  separate();
  text_ += '[';
  need_comma_ = false;
  return *this;
}

Json& Json::end_array() {
  text_ += ']';
  need_comma_ = true;
  return *this;
}

Json& Json::key(std::string_view name) {
  value(name);
  text_ += ':';
  need_comma_ = false;
  return *this;
}

Json& Json::value(double v) {
  if (!std::isfinite(v)) return null();
  separate();
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  text_ += buf;
  return *this;
}

Json& Json::value(long long v) {
  separate();
  text_ += std::to_string(v);
  return *this;
}

Json& Json::value(bool v) {
  separate();
  text_ += v ? "true" : "false";
  return *this;
}

Json& Json::value(std::string_view text) {
  separate();
  text_ += '"';
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') {
      text_ += '\\';
      text_ += c;
    } else if (u < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(u));
      text_ += buf;
    } else {
      text_ += c;
    }
  }
  text_ += '"';
  return *this;
}

Json& Json::null() {
  separate();
  text_ += "null";
  return *this;
}

Json& Json::point(const Eigen::Vector3d& p) {
  begin_array();
  for (int i = 0; i < 3; ++i) {
    separate();
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3f", std::isfinite(p[i]) ? p[i] : 0.0);
    text_ += buf;
  }
  return end_array();
}

Json& Json::raw(std::string_view json) {
  separate();
  text_ += json;
  return *this;
}

}  // namespace mgc::display
