// SPDX-License-Identifier: Apache-2.0
// Hostile and broken input files: every one ends in a single InputError that names the file, on one
// line of bounded length, and none blocks, aborts, exhausts memory or reaches the collision library
// with coordinates it cannot handle (docs/scenario-format.md, "Limits").
#include <catch2/catch.hpp>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <future>
#include <random>
#include <sstream>
#include <thread>

#include "mgc/planning/io/input_limits.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
namespace fs = std::filesystem;

namespace {

//! A scratch folder, removed with everything in it when the object goes.
class TempDir {
 public:
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "mgc-loader-XXXXXX").string();
    REQUIRE(::mkdtemp(pattern.data()) != nullptr);
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  [[nodiscard]] const fs::path& path() const { return path_; }
  fs::path write(const std::string& name, const std::string& text) const {
    const fs::path file = path_ / name;
    std::ofstream(file, std::ios::binary) << text;
    return file;
  }

 private:
  fs::path path_;
};

std::string read_text(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string machine_path() { return mgc::test::source_path("scenarios/machines/grove-tms870.yaml").string(); }

// A small valid scenario with one box and one steel frame; each test replaces one piece of it.
std::string scenario_text(const std::string& machine = machine_path()) {
  return "name: hardening-base\n"
         "machine: " + machine + "\n"
         "base:\n"
         "  position_m: [0, 0, 0]\n"
         "  yaw_deg: 0\n"
         "task:\n"
         "  load_lb: 20000\n"
         "  outriggers: fully_extended\n"
         "  counterweight_lb: 18000\n"
         "  constraint: load_chart\n"
         "  load_size_m: [2, 2, 1]\n"
         "  sling_length_m: 1\n"
         "obstacles:\n"
         "  - name: block\n"
         "    type: box\n"
         "    size_m: [2, 2, 2]\n"
         "    position_m: [0, 15, 1]\n"
         "  - name: frame\n"
         "    type: steel_frame\n"
         "    origin_m: [30, -5, 0]\n"
         "    bays: [2, 1]\n"
         "    bay_size_m: [6, 6]\n"
         "    storeys: 2\n"
         "    storey_height_m: 4\n"
         "    column_section_m: [0.4, 0.4]\n"
         "    beam_section_m: [0.3, 0.5]\n"
         "start:\n"
         "  swing_deg: 0\n"
         "  boom_elevation_deg: 45\n"
         "  boom_length_m: 20\n"
         "  cable_length_m: 5\n"
         "goal:\n"
         "  swing_deg: 180\n"
         "  boom_elevation_deg: 45\n"
         "  boom_length_m: 20\n"
         "  cable_length_m: 5\n"
         "planner:\n"
         "  seed: 1\n";
}

// The message contract every InputError keeps, whatever the input.
void check_one_bounded_line(const std::string& what) {
  CAPTURE(what.substr(0, 400));
  CHECK(what.find('\n') == std::string::npos);
  CHECK(what.find('\r') == std::string::npos);
  CHECK(what.size() <= io::kMaxMessageChars);
}

// Loads and builds `file` expecting an InputError: returns it after checking that its message is one
// bounded line beginning with `named` (the file it blames).
io::InputError expect_error(const fs::path& file, const std::string& named) {
  try {
    auto loaded = io::load_and_build(file);
    const auto errors = io::check_endpoints(loaded);
    REQUIRE(!errors.empty());
    throw errors.front();
  } catch (const io::InputError& e) {
    const std::string what = e.what();
    check_one_bounded_line(what);
    CHECK(what.rfind(named, 0) == 0);
    return e;
  }
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace

TEST_CASE("hardening: the base scenario is valid", "[unit]") {
  TempDir dir;
  auto loaded = io::load_and_build(dir.write("scenario.yaml", scenario_text()));
  CHECK(io::check_endpoints(loaded).empty());
  CHECK(loaded.scenario.obstacles.size() == 1 + 2 * (3 * 2 + 2 * 2 + 3 * 1));
}

TEST_CASE("hardening: only regular files are read", "[unit]") {
  TempDir dir;
  SECTION("a directory as the scenario") {
    const auto e = expect_error(dir.path(), dir.path().string() + ": ");
    CHECK(contains(e.what(), "expected a regular file, got a directory"));
  }
  SECTION("a character device as the scenario") {
    const auto e = expect_error("/dev/zero", "/dev/zero: ");
    CHECK(contains(e.what(), "got a character device"));
  }
  SECTION("a /proc file that is regular by its type but cannot be read") {
    const auto e = expect_error("/proc/self/mem", "/proc/self/mem: ");
    CHECK(contains(e.what(), "cannot read the file"));
  }
  SECTION("a machine file that is a directory names the scenario's machine field") {
    fs::create_directory(dir.path() / "machines");
    const fs::path file = dir.write("scenario.yaml", scenario_text("machines"));
    const auto e = expect_error(file, file.string() + ":2: machine: ");
    CHECK(e.field() == "machine");
    CHECK(e.line() == 2);
    CHECK(contains(e.what(), "got a directory"));
  }
  SECTION("a machine path with a NUL is refused, not cut short") {
    const fs::path file = dir.write("scenario.yaml", scenario_text("\"" + machine_path() + "\\0.bak\""));
    const auto e = expect_error(file, file.string() + ":2: machine: ");
    CHECK(contains(e.what(), "expected a path without control characters, got '" + machine_path() + "\\x00.bak'"));
  }
  SECTION("a machine file under /proc that cannot be read names it") {
    const fs::path file = dir.write("scenario.yaml", scenario_text("/proc/self/mem"));
    const auto e = expect_error(file, "/proc/self/mem: ");
    CHECK(contains(e.what(), "cannot read the file"));
  }
  SECTION("a machine file that is a FIFO") {
    REQUIRE(::mkfifo((dir.path() / "machine.fifo").c_str(), 0600) == 0);
    const fs::path file = dir.write("scenario.yaml", scenario_text("machine.fifo"));
    const auto e = expect_error(file, file.string() + ":2: machine: ");
    CHECK(contains(e.what(), "got a FIFO"));
  }
}

TEST_CASE("hardening: a FIFO without a writer is refused without blocking", "[unit]") {
  TempDir dir;
  const fs::path fifo = dir.path() / "scenario.fifo";
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  auto result = std::async(std::launch::async, [&]() -> std::string {
    try {
      (void)io::load_scenario(fifo);
      return "no error";
    } catch (const io::InputError& e) {
      return e.what();
    }
  });
  if (result.wait_for(std::chrono::seconds(5)) != std::future_status::ready) {
    // Release the reader blocked in open(): a writer that opens and closes gives it end of file.
    const int fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
    if (fd >= 0) ::close(fd);
    (void)result.get();
    FAIL("load_scenario blocked on a FIFO without a writer");
  }
  const std::string what = result.get();
  check_one_bounded_line(what);
  CHECK(what.rfind(fifo.string() + ": ", 0) == 0);
  CHECK(contains(what, "expected a regular file, got a FIFO"));
}

TEST_CASE("hardening: file size and path length are bounded", "[unit]") {
  TempDir dir;
  SECTION("a file above the size limit is refused before it is read") {
    const fs::path big = dir.path() / "big.yaml";
    std::ofstream(big) << "name: big\n";
    fs::resize_file(big, io::kMaxFileBytes + 1);  // sparse: no disk or time spent
    const auto e = expect_error(big, big.string() + ": ");
    CHECK(contains(e.what(), "above the limit of 16777216 (16 MiB)"));
  }
  SECTION("a file of more YAML values than the limit is refused before its tree is built") {
    std::string text = "name: [";
    for (std::size_t i = 0; i < io::kMaxYamlValues; ++i) text += "0,";
    const fs::path file = dir.write("values.yaml", text + "0]\n");
    const auto e = expect_error(file, file.string() + ":1: ");
    CHECK(contains(e.what(), "more than 200000 YAML values (scalars, lists and maps), the limit"));
  }
  SECTION("a scenario path with a name too long for the system") {
    const fs::path file = dir.path() / (std::string(300, 'a') + ".yaml");
    try {
      (void)io::load_scenario(file);
      FAIL("no error");
    } catch (const io::InputError& e) {
      check_one_bounded_line(e.what());
      CHECK(e.file() == file.string());
      CHECK(contains(e.what(), "the path name is too long"));
      CHECK(std::string(e.what()).rfind(dir.path().string(), 0) == 0);
    }
  }
  SECTION("a machine name of 300 bytes names the machine field") {
    const fs::path file = dir.write("scenario.yaml", scenario_text(std::string(300, 'm') + ".yaml"));
    const auto e = expect_error(file, file.string() + ":2: machine: ");
    CHECK(contains(e.what(), "the path name is too long"));
  }
}

TEST_CASE("hardening: coordinates beyond the site extent are refused", "[unit]") {
  TempDir dir;
  const auto position = [&](const std::string& y) {
    return dir.write("scenario.yaml", mgc::test::replace_first(scenario_text(), "position_m: [0, 15, 1]", "position_m: [0, " + y + ", 1]"));
  };
  for (const char* huge : {"1e200", "-1e308", "1e100", "10000.5"}) {
    CAPTURE(huge);
    const fs::path file = position(huge);
    const auto e = expect_error(file, file.string() + ":17: obstacles[0].position_m[1]: ");
    CHECK(contains(e.what(), "expected a coordinate within the site extent [-10000, 10000] m, got '" + std::string(huge) + "'"));
  }
  SECTION("the extent itself is accepted and the world builds") {
    auto loaded = io::load_and_build(position("-10000"));
    CHECK(loaded.scenario.obstacles[0].shape.pose.translation().y() == -10000.0);
    CHECK(io::check_endpoints(loaded).empty());
  }
  SECTION("lengths, frame origins, envelope, scripted keys and the base") {
    const auto refused = [&](const std::string& text, int line, const std::string& field, const std::string& expected) {
      const fs::path file = dir.write("scenario.yaml", text);
      const auto e = expect_error(file, file.string() + ":" + std::to_string(line) + ": " + field + ": ");
      CHECK(contains(e.what(), expected));
    };
    refused(mgc::test::replace_first(scenario_text(), "size_m: [2, 2, 2]", "size_m: [2, 1e200, 2]"), 16, "obstacles[0].size_m[1]",
            "a length of at most 10000 m");
    refused(mgc::test::replace_first(scenario_text(), "origin_m: [30, -5, 0]", "origin_m: [-1e308, -5, 0]"), 20, "obstacles[1].origin_m[0]",
            "site extent");
    refused(mgc::test::replace_first(scenario_text(), "bay_size_m: [6, 6]", "bay_size_m: [6000, 6]"), 22, "obstacles[1].bay_size_m",
            "the frame is 12000 m by 6 m");
    refused(mgc::test::replace_first(scenario_text(), "  position_m: [0, 0, 0]\n", "  position_m: [0, 0, 1e100]\n"), 4, "base.position_m[2]",
            "site extent");
    refused(mgc::test::replace_first(scenario_text(), "  yaw_deg: 0\n", "  yaw_deg: 1e300\n"), 5, "base.yaw_deg", "an angle within [-3600, 3600] deg");
    refused(mgc::test::replace_first(scenario_text(), "sling_length_m: 1", "sling_length_m: 1e200"), 12, "task.sling_length_m", "at most 10000 m");
    refused(scenario_text() + "envelope:\n  points: [hook]\n  walls:\n    - {normal: [1, 0, 0], offset_m: 1e200}\n", 42,
            "envelope.walls[0].offset_m", "site extent");
    refused(scenario_text() + "envelope:\n  points: [hook]\n  height_ceiling_m: -1e308\n", 41, "envelope.height_ceiling_m",
            "site extent");
    const std::string dynamic =
        "dynamic_obstacles:\n"
        "  - name: truck\n"
        "    parts: [{type: box, size_m: [8, 2.5, 3], position_m: [0, 0, 1.5], rpy_deg: [0, 0, ROLL]}]\n"
        "    motion:\n"
        "      - {t_s: 0, position_m: [X, -30, 0], yaw_deg: YAW}\n"
        "      - {t_s: T, position_m: [0, -20, 0], yaw_deg: 0}\n"
        "start:\n";
    const auto truck = [&](const char* roll, const char* x, const char* yaw, const char* t) {
      return mgc::test::replace_first(scenario_text(), "start:\n",
                     mgc::test::replace_first(mgc::test::replace_first(mgc::test::replace_first(mgc::test::replace_first(dynamic, "ROLL", roll), "X", x), "YAW", yaw), "T", t));
    };
    refused(truck("0", "1e200", "0", "5"), 31, "dynamic_obstacles[0].motion[0].position_m[0]", "site extent");
    refused(truck("0", "0", "-1e308", "5"), 31, "dynamic_obstacles[0].motion[0].yaw_deg", "an angle within");
    refused(truck("0", "0", "0", "1e300"), 32, "dynamic_obstacles[0].motion[1].t_s", "a number in [0, 1e+06]");
    refused(truck("1e100", "0", "0", "5"), 29, "dynamic_obstacles[0].parts[0].rpy_deg[2]", "an angle within");
    // A direction needs no extent: a huge normal is as good as a unit one.
    TempDir other;
    const Scenario s = io::load_scenario(
        other.write("scenario.yaml", scenario_text() + "envelope:\n  points: [hook]\n  walls:\n    - {normal: [1e300, 0, 0], offset_m: 5}\n"));
    REQUIRE(s.envelope.has_value());
    CHECK(s.envelope->walls[0].normal.isApprox(Eigen::Vector3d::UnitX()));
  }
}

TEST_CASE("hardening: names are at most 64 characters", "[unit]") {
  TempDir dir;
  SECTION("a steel frame with a 2 MB name is refused before any member is made") {
    const std::string name(2 << 20, 'n');
    const fs::path file = dir.write("scenario.yaml", mgc::test::replace_first(scenario_text(), "  - name: frame\n", "  - name: " + name + "\n"));
    const auto start = std::chrono::steady_clock::now();
    const auto e = expect_error(file, file.string() + ":18: obstacles[1].name: ");
    CHECK(std::chrono::steady_clock::now() - start < std::chrono::seconds(10));  // generous: a loaded 2-core machine
    CHECK(contains(e.what(), "expected a name of at most 64 characters, got 'nnnn"));
    CHECK(contains(e.what(), "... (2097152 characters)'"));
  }
  SECTION("64 characters pass, 65 do not") {
    const fs::path ok = dir.write("ok.yaml", mgc::test::replace_first(scenario_text(), "name: block", "name: " + std::string(64, 'b')));
    CHECK(io::load_scenario(ok).obstacles[0].name.size() == 64);
    const fs::path file = dir.write("scenario.yaml", mgc::test::replace_first(scenario_text(), "name: block", "name: " + std::string(65, 'b')));
    (void)expect_error(file, file.string() + ":14: obstacles[0].name: ");
    const fs::path scenario_name = dir.write("name.yaml", mgc::test::replace_first(scenario_text(), "name: hardening-base", "name: " + std::string(65, 's')));
    (void)expect_error(scenario_name, scenario_name.string() + ":1: name: ");
  }
  SECTION("a frame too big for the obstacle limit is refused before it is expanded") {
    const fs::path file = dir.write("scenario.yaml", mgc::test::replace_first(mgc::test::replace_first(mgc::test::replace_first(scenario_text(), "bays: [2, 1]", "bays: [100, 100]"),
                                                                      "storeys: 2", "storeys: 100"),
                                                             "bay_size_m: [6, 6]", "bay_size_m: [1, 1]"));
    const auto e = expect_error(file, file.string() + ":21: obstacles[1].bays: ");
    CHECK(contains(e.what(), "the frame has 3040100 members"));
  }
}

TEST_CASE("hardening: echoed values are cut and kept on one line", "[unit]") {
  TempDir dir;
  SECTION("a 1 MB value") {
    const fs::path file = dir.write("scenario.yaml", mgc::test::replace_first(scenario_text(), "load_lb: 20000", "load_lb: " + std::string(1 << 20, '9') + "x"));
    const auto e = expect_error(file, file.string() + ":7: task.load_lb: expected a number, got '99999");
    CHECK(contains(e.what(), "... (1048577 characters)'"));
  }
  SECTION("a 1 MB unknown field name") {
    // An explicit key ("? "): YAML allows no plain key over 1024 characters.
    const std::string key(1 << 20, 'k');
    const fs::path file =
        dir.write("scenario.yaml", mgc::test::replace_first(scenario_text(), "  sling_length_m: 1\n", "  sling_length_m: 1\n  ? " + key + "\n  : 2\n"));
    const auto e = expect_error(file, file.string() + ":13: task.kkkk");
    CHECK(contains(e.what(), "unknown field"));
    CHECK(e.field().size() <= io::kMaxEchoChars);
  }
  SECTION("embedded newlines and control characters are escaped") {
    const fs::path file = dir.write("scenario.yaml", mgc::test::replace_first(scenario_text(), "type: box", "type: \"box\\nfire\\rescape\\x1b[2J\""));
    const auto e = expect_error(file, file.string() + ":15: obstacles[0].type: ");
    CHECK(contains(e.what(), "got 'box\\nfire\\rescape\\x1b[2J'"));
    const fs::path named = dir.write("named.yaml", mgc::test::replace_first(scenario_text(), "name: block", "name: \"two\\nlines\""));
    const auto n = expect_error(named, named.string() + ":14: obstacles[0].name: ");
    CHECK(contains(n.what(), "expected a name without control characters, got 'two\\nlines'"));
  }
  SECTION("a long file path is cut too") {
    const fs::path deep = dir.path() / std::string(200, 'd');
    fs::create_directory(deep);
    const fs::path file = deep / "scenario.yaml";
    std::ofstream(file) << mgc::test::replace_first(scenario_text(), "load_lb: 20000", "load_lb: heavy");
    const auto e = expect_error(file, file.string().substr(0, 60));
    CHECK(e.file() == file.string());
    CHECK(contains(e.what(), "task.load_lb: expected a number, got 'heavy'"));
  }
  SECTION("echo cuts at the limit and marks the original length") {
    CHECK(io::echo("short") == "short");
    CHECK(io::echo("a\tb\x01") == "a\\tb\\x01");
    const std::string cut = io::echo(std::string(100, 'x'));
    CHECK(cut.size() == io::kMaxEchoChars);
    const std::string marker = "... (100 characters)";
    CHECK(cut == std::string(io::kMaxEchoChars - marker.size(), 'x') + marker);
    // A multi-byte character is never split.
    std::string accents;
    for (int i = 0; i < 60; ++i) accents += "\xc3\xa9";
    const std::string cut_accents = io::echo(accents);
    const std::string kept = cut_accents.substr(0, cut_accents.find("..."));
    CHECK(kept.size() % 2 == 0);
    CHECK(cut_accents.size() <= io::kMaxEchoChars);
  }
}

// A cheap fuzz: the shipped scenarios and their machine files, truncated, with bytes flipped and
// numbers made huge. Every outcome is a success or an InputError of one bounded line.
TEST_CASE("hardening: mutated shipped scenarios never crash the loader", "[unit]") {
  TempDir dir;
  std::mt19937_64 rng(20261205);
  const auto pick = [&](std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng); };
  std::vector<fs::path> scenarios;
  for (const auto& entry : fs::directory_iterator(mgc::test::source_path("scenarios"))) {
    if (entry.path().extension() == ".yaml") scenarios.push_back(entry.path());
  }
  std::sort(scenarios.begin(), scenarios.end());
  REQUIRE(scenarios.size() >= 5);
  const char* huge[] = {"1e200", "-1e308", "1e100", ".nan", "-.inf", "1e4", "4294967296", "-0", "0x7fffffff", "~", "[]", "{}"};

  const auto mutate = [&](std::string text) {
    switch (pick(4)) {
      case 0:  // truncated
        text.resize(pick(text.size()));
        break;
      case 1:  // a few bytes flipped
        for (std::size_t n = 1 + pick(4); n > 0; --n) text[pick(text.size())] ^= static_cast<char>(1u << pick(8));
        break;
      case 2: {  // a number replaced
        std::size_t at = pick(text.size());
        while (at < text.size() && !std::isdigit(static_cast<unsigned char>(text[at]))) ++at;
        std::size_t end = at;
        while (end < text.size() && (std::isdigit(static_cast<unsigned char>(text[end])) || text[end] == '.')) ++end;
        if (at < text.size()) text.replace(at, end - at, huge[pick(std::size(huge))]);
        break;
      }
      default: {  // a line doubled or dropped
        const std::size_t at = text.rfind('\n', pick(text.size()));
        const std::size_t begin = at == std::string::npos ? 0 : at + 1;
        const std::size_t end = text.find('\n', begin);
        const std::string line = text.substr(begin, end == std::string::npos ? std::string::npos : end - begin + 1);
        if (pick(2) == 0) {
          text.insert(begin, line);
        } else {
          text.erase(begin, line.size());
        }
      }
    }
    return text;
  };

  int succeeded = 0;
  int refused = 0;
  for (int round = 0; round < 240; ++round) {
    const fs::path source = scenarios[pick(scenarios.size())];
    std::string text = read_text(source);
    const bool mutate_machine = pick(4) == 0;
    // Every scenario names machines/<file>; point it at the shipped one or a mutated copy.
    const std::size_t m = text.find("machine: machines/");
    REQUIRE(m != std::string::npos);
    const std::size_t m_end = text.find('\n', m);
    const std::string machine_name = text.substr(m + 18, m_end - m - 18);
    fs::path machine = mgc::test::source_path("scenarios/machines/" + machine_name);
    if (mutate_machine) machine = dir.write("machine.yaml", mutate(read_text(machine)));
    text.replace(m, m_end - m, "machine: " + machine.string());
    if (!mutate_machine) text = mutate(text);
    const fs::path file = dir.write("scenario.yaml", text);
    CAPTURE(round, source.filename().string(), mutate_machine);
    try {
      auto loaded = io::load_and_build(file);
      for (const io::InputError& e : io::check_endpoints(loaded)) check_one_bounded_line(e.what());
      ++succeeded;
    } catch (const io::InputError& e) {
      check_one_bounded_line(e.what());
      const std::string what = e.what();
      CHECK((what.rfind(file.string(), 0) == 0 || what.rfind(machine.string(), 0) == 0));
      ++refused;
    }
  }
  // The sweep exercises both outcomes.
  CHECK(succeeded > 10);
  CHECK(refused > 10);
}
