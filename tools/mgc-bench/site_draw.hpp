// SPDX-License-Identifier: Apache-2.0
#pragma once

// What the site generators (site_families.cpp, site_scale.cpp) share: a random stream that names
// one site by its seed everywhere, the text of the numbers they write, and the writing.

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

namespace mgc::bench::site_draw {

//! splitmix64: the same numbers on every platform and standard library, so a seed names one
//! site everywhere (std::uniform_real_distribution is not specified bit for bit).
class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t state) : state_(state) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  double uniform(double lo, double hi) { return lo + (hi - lo) * static_cast<double>(next() >> 11) * 0x1.0p-53; }
  int integer(int lo, int hi) { return lo + static_cast<int>(next() % static_cast<std::uint64_t>(hi - lo + 1)); }
  double sign() { return (next() & 1U) != 0U ? 1.0 : -1.0; }

 private:
  std::uint64_t state_;
};

//! Fixed-point text with three decimals and no trailing zeros: short files, identical on every run.
inline std::string num(double v) {
  char buffer[48];
  std::snprintf(buffer, sizeof buffer, "%.3f", v);
  std::string s = buffer;
  while (s.back() == '0') s.pop_back();
  if (s.back() == '.') s.pop_back();
  if (s == "-0") s = "0";
  return s;
}

//! An angle in [-180, 180). [deg]
inline double wrap_deg(double a) {
  a = std::fmod(a + 180.0, 360.0);
  if (a < 0.0) a += 360.0;
  return a - 180.0;
}

//! Writes a generated site's text to file; throws std::runtime_error naming the file when it cannot.
inline void write_text(const std::filesystem::path& file, const std::string& text) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out << text;
  out.close();
  if (!out) throw std::runtime_error(file.string() + ": cannot write the generated site");
}

}  // namespace mgc::bench::site_draw
