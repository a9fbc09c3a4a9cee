// SPDX-License-Identifier: Apache-2.0
#pragma once

// The bounds every scenario and machine file is read within (docs/scenario-format.md, "Limits").
// They keep hostile or broken input from exhausting memory, blocking the reader or reaching the
// collision library with coordinates it cannot handle, and keep every error message one short line.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace mgc::planning::io {

//! Largest file read. The largest shipped file is a few kilobytes; a site with thousands of
//! obstacles written out member by member stays below a megabyte or two.
inline constexpr std::uintmax_t kMaxFileBytes = std::uintmax_t{16} << 20;

//! Values (scalars, lists and maps) in a file's YAML document. Each costs the parser some 500
//! bytes, so this bounds its memory near 100 MB where kMaxFileBytes of short values would take
//! gigabytes. The shipped files have at most about 550; 200,000 leave room for some 15,000 boxes
//! written out one by one.
inline constexpr std::size_t kMaxYamlValues = 200'000;

//! Every coordinate within +-kSiteExtent_m of the site origin, and every length, size or radius at
//! most this: a construction site is far smaller than 10 km, and at that distance doubles still
//! resolve far below a micrometre, so the collision library's bounding-volume arithmetic stays exact
//! enough and never overflows. [m]
inline constexpr double kSiteExtent_m = 1e4;

//! Every angle given as a pose (yaw, roll, pitch, a joint's range or position, a key's yaw) within
//! +-kMaxAngle_deg: ten turns, room for a scripted obstacle that slews several times, and far from
//! where sin and cos of the value lose their precision. [deg]
inline constexpr double kMaxAngle_deg = 3600.0;

//! The last time a dynamic obstacle's script may name, as mgc-sim's scenario time offset. [s]
inline constexpr double kMaxScriptTime_s = 1e6;

//! Static obstacles after steel frames are expanded into their members.
inline constexpr std::size_t kMaxStaticObstacles = 100'000;

//! Names (of the scenario, the machine, obstacles, envelope key points): longer ones are refused.
inline constexpr std::size_t kMaxNameChars = 64;

//! A value or field path echoed in an error message is cut to this many characters.
inline constexpr std::size_t kMaxEchoChars = 80;

//! A file path in an error message is cut to this many characters.
inline constexpr std::size_t kMaxPathEchoChars = 120;

//! Every error message is one line of at most this many characters.
inline constexpr std::size_t kMaxMessageChars = 300;

//! `text` made fit for a one-line message: control characters escaped (\n, \t, \xNN) and, when the
//! result is longer than max_chars, cut to max_chars characters in all, the cut marked by
//! "... (<N> characters)" with N the original length. max_chars must be at least 40.
[[nodiscard]] std::string echo(std::string_view text, std::size_t max_chars = kMaxEchoChars);

//! Why `path` cannot be read as an input file: not found, a path name too long, not a regular file
//! (a directory, FIFO, device or socket), or larger than kMaxFileBytes; empty when it can. Looks
//! without opening, so a FIFO never blocks.
[[nodiscard]] std::string input_file_problem(const std::filesystem::path& path);

//! Reads a regular file of at most kMaxFileBytes into `text`. Returns empty on success, otherwise
//! why it could not (as input_file_problem(), or a read error such as /proc/self/mem's).
[[nodiscard]] std::string read_input_file(const std::filesystem::path& path, std::string& text);

}  // namespace mgc::planning::io
