// SPDX-License-Identifier: Apache-2.0
// mgc-display: the operator's live guidance screen in the browser (docs/operator-display.md). A
// process of its own on the LCM operator feed: it keeps the latest message of every channel, serves
// the page (built into the binary) on loopback by default and pushes the state to it with
// Server-Sent Events at 20 Hz. It signs goals and acknowledgements with the operator key as
// mgc-operator does; the key never leaves this process.
#include <CLI/CLI.hpp>
#include <lcm/lcm-cpp.hpp>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <mgc/operator_command_t.hpp>

#include "assets.hpp"
#include "feed_state.hpp"
#include "mgc/firmware/command_auth.hpp"
#include "mgc/firmware/lcm_feed.hpp"
#include "mgc/planning/io/input_error.hpp"
#include "mgc/planning/io/site_loader.hpp"
#include "mgc/planning/site.hpp"
#include "mgc/tools/cli_checks.hpp"
#include "playback.hpp"
#include "scene.hpp"
#include "site_view.hpp"

// After Eigen: httplib brings <resolv.h>, whose _res macro breaks Eigen's headers included later.
#include <httplib.h>

namespace {

using mgc::display::FeedState;

constexpr std::int64_t kPushPeriod_us = 50'000;  // 20 Hz to the page
constexpr int kMaxEventStreams = 8;              // pages at once; the pool keeps threads for commands
constexpr int kServerThreads = 16;

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop = true; }

std::int64_t monotonic_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
std::int64_t wall_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

//! The operator's commands onto MGC_COMMAND, signed as mgc-operator signs them.
class Commander {
 public:
  Commander(const std::string& lcm_url, std::optional<mgc::firmware::CommandKey> key, int sender_id)
      : lcm_(lcm_url), key_(std::move(key)), sender_id_(sender_id) {}
  [[nodiscard]] bool good() { return lcm_.good(); }
  [[nodiscard]] bool has_key() const { return key_.has_value(); }
  [[nodiscard]] int sender_id() const { return sender_id_; }

  //! Publishes one command; returns its sequence.
  std::int64_t send(std::int8_t kind, const std::vector<double>& goal, std::int32_t alert_id) {
    const std::lock_guard lock(mutex_);
    mgc::operator_command_t cmd{};
    cmd.utime = monotonic_us();
    cmd.kind = kind;
    cmd.sender_id = sender_id_;
    // The wall clock in µs, which mgc checks against its own within the tolerated skew; bumped
    // when the clock has not moved, so that it never repeats (docs/operator-feed.md).
    cmd.sequence = std::max(wall_us(), last_sequence_ + 1);
    last_sequence_ = cmd.sequence;
    cmd.num_joints = static_cast<std::int8_t>(goal.size());
    for (std::size_t j = 0; j < goal.size(); ++j) cmd.goal_position[j] = goal[j];
    cmd.alert_id = alert_id;
    if (key_) mgc::firmware::sign_command(cmd, *key_);
    lcm_.publish(mgc::firmware::channel::kCommand, &cmd);
    return cmd.sequence;
  }

 private:
  std::mutex mutex_;
  lcm::LCM lcm_;
  std::optional<mgc::firmware::CommandKey> key_;
  int sender_id_;
  std::int64_t last_sequence_ = 0;
};

//! Feeds every message of the bus into the state; runs until stop.
class FeedListener {
 public:
  explicit FeedListener(FeedState& state) : state_(state) {}
  void on_raw(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    state_.on_message(channel, rbuf->data, static_cast<int>(rbuf->data_size), monotonic_us());
  }

 private:
  FeedState& state_;
};

// A literal IPv4 address or localhost, with a port: what the page may be opened as. A name that
// resolves through DNS is refused, so that a foreign site cannot rebind its own name to this
// server and post commands as if from the served origin.
bool literal_host(const std::string& host) {
  const auto colon = host.rfind(':');
  if (colon == std::string::npos) return false;
  const std::string name = host.substr(0, colon);
  const std::string port = host.substr(colon + 1);
  if (port.empty() || port.find_first_not_of("0123456789") != std::string::npos) return false;
  if (name == "localhost") return true;
  return !name.empty() && name.find_first_not_of("0123456789.") == std::string::npos;
}

// Commands are taken only from the page this server served: the browser's Origin must be this
// server as the browser reached it (docs/operator-display.md, "Controls").
bool from_served_origin(const httplib::Request& req, std::string& why) {
  const std::string host = req.get_header_value("Host");
  const std::string origin = req.get_header_value("Origin");
  if (!literal_host(host)) {
    why = "Host '" + host + "' is not an address with a port";
    return false;
  }
  if (origin != "http://" + host) {
    why = "Origin '" + origin + "' is not the served origin http://" + host;
    return false;
  }
  return true;
}

void reply(httplib::Response& res, int status, const std::string& json) {
  res.status = status;
  res.set_header("Cache-Control", "no-store");
  res.set_content(json, "application/json");
}

std::string error_json(const std::string& message) {
  mgc::display::Json j;
  j.begin_object().key("ok").value(false).key("error").value(message).end_object();
  return j.str();
}

// Reads a list of numbers "a,b,c"; false on anything else.
bool parse_numbers(const std::string& text, std::vector<double>& out) {
  std::stringstream s(text);
  std::string item;
  while (std::getline(s, item, ',')) {
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size() || errno != 0 || !std::isfinite(v)) return false;
    out.push_back(v);
  }
  return !out.empty();
}

// A key file must be readable by its owner only: the key lets its holder move the machine (or,
// for the site key, speak for one).
std::optional<std::string> key_file_problem(const std::string& path, const std::string& what = "command key file") {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return what + " " + path + ": " + std::strerror(errno);
  if (!S_ISREG(st.st_mode)) return what + " " + path + ": not a regular file";
  if ((st.st_mode & 077) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    return what + " " + path + ": mode " + mode + "; expected no access for group and others (chmod 600)";
  }
  return std::nullopt;
}

// SO_REUSEADDR only: httplib's default adds SO_REUSEPORT, with which a second server would share
// the port silently instead of failing to start.
void socket_options(socket_t sock) {
  int yes = 1;
  ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mgc-display: the operator's guidance screen in the browser, on the LCM feed (docs/operator-display.md)"};
  std::string bind = "127.0.0.1";
  int port = 8780;
  std::string lcm_url = mgc::firmware::kDefaultLcmUrl;
  std::string scenario_file;
  std::string key_file;
  std::string log_file;
  int sender_id = 2;
  std::string site_file;
  std::string site_key_file;
  std::string site_lcm_url;
  std::optional<int> machine_id;
  app.add_option("--bind", bind, "address to serve the page on (loopback by default; docs/operator-display.md before widening)")
      ->capture_default_str();
  app.add_option("--port", port, "TCP port of the page")->capture_default_str()->check(CLI::Range(1, 65535));
  app.add_option("--lcm-url", lcm_url, "LCM provider of the feed")->capture_default_str();
  app.add_option("--scenario", scenario_file, "scenario file: the site's obstacles and the machine model to draw (with --site: the machine's first lift by default)");
  app.add_option("--key", key_file, "shared command key (32 raw bytes, mode 600): enables goal and acknowledge");
  app.add_option("--sender-id", sender_id, "this station's sender id on MGC_COMMAND")->capture_default_str();
  app.add_option("--log", log_file, "play a recorded LCM log (lcm-logger) instead of the live feed");
  app.add_option("--site", site_file, "site file: draw the other machines of the site at their MGC_SITE_STATE joints");
  app.add_option("--site-key", site_key_file, "site key (32 raw bytes, mode 600): draw only verified site states; needs --machine-id");
  app.add_option("--machine-id", machine_id, "this display's machine in the site file: not drawn from the site channel");
  app.add_option("--site-lcm-url", site_lcm_url, "LCM provider of the site channel (default: the controllers' site group, udpm://239.255.76.68:7668?ttl=0)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "mgc-display: %s (see --help)\n", e.what());
    return 2;
  }

  std::unique_ptr<mgc::display::Scene> scene;
  std::optional<mgc::firmware::CommandKey> key;
  std::unique_ptr<mgc::display::Playback> playback;
  std::unique_ptr<mgc::display::SiteView> site;
  if (site_file.empty() && (!site_key_file.empty() || machine_id || !site_lcm_url.empty())) {
    std::fprintf(stderr, "mgc-display: --site-key, --machine-id and --site-lcm-url need --site\n");
    return 2;
  }
  if (!site_file.empty() && scenario_file.empty() && !machine_id) {
    std::fprintf(stderr, "mgc-display: --site: needs --machine-id or --scenario (the site is drawn in its machine's views)\n");
    return 2;
  }
  if (!site_key_file.empty() && !machine_id) {
    std::fprintf(stderr, "mgc-display: --site-key: needs --machine-id (this display's machine in the site file)\n");
    return 2;
  }
  try {
    if (!scenario_file.empty()) {
      scene = std::make_unique<mgc::display::Scene>(scenario_file);
    } else if (!site_file.empty()) {
      // The machine's first lift, as `mgc --site` plans it.
      const mgc::planning::Site s = mgc::planning::io::load_site(site_file);
      scene = std::make_unique<mgc::display::Scene>(
          mgc::planning::lift_scenario(s, mgc::planning::io::site_machine_index(s, *machine_id), 0));
    }
    if (!key_file.empty()) {
      if (const auto problem = key_file_problem(key_file)) {
        std::fprintf(stderr, "mgc-display: --key: %s\n", problem->c_str());
        return 2;
      }
      key.emplace(mgc::firmware::load_command_key(key_file));
    }
    if (!log_file.empty()) playback = std::make_unique<mgc::display::Playback>(log_file);
  } catch (const mgc::planning::io::InputError& e) {
    std::fprintf(stderr, "mgc-display: %s: %s\n", scenario_file.empty() ? "--site" : "--scenario", e.what());
    return 2;
  } catch (const mgc::firmware::CommandKeyError& e) {
    std::fprintf(stderr, "mgc-display: --key: %s\n", e.what());
    return 2;
  } catch (const mgc::display::PlaybackError& e) {
    std::fprintf(stderr, "mgc-display: --log: %s\n", e.what());
    return 2;
  }
  try {
    if (!site_file.empty()) {
      std::optional<mgc::firmware::SiteKey> site_key;
      if (!site_key_file.empty()) {
        if (const auto problem = key_file_problem(site_key_file, "site key file")) {
          std::fprintf(stderr, "mgc-display: --site-key: %s\n", problem->c_str());
          return 2;
        }
        site_key.emplace(mgc::firmware::load_site_key(site_key_file));
      }
      site = std::make_unique<mgc::display::SiteView>(site_file, machine_id ? std::optional<std::int32_t>(*machine_id) : std::nullopt,
                                                      std::move(site_key), &mgc::firmware::realtime_clock_us);
    }
  } catch (const mgc::planning::io::InputError& e) {
    std::fprintf(stderr, "mgc-display: --site: %s\n", e.what());
    return 2;
  } catch (const mgc::firmware::CommandKeyError& e) {
    std::fprintf(stderr, "mgc-display: --site-key: %s\n", e.what());
    return 2;
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "mgc-display: --site %s: %s\n", site_file.c_str(), e.what());
    return 2;
  }

  FeedState feed(scene.get());
  feed.set_site(site.get());
  Commander commander(lcm_url, std::move(key), sender_id);
  if (!commander.good()) {
    std::fprintf(stderr, "mgc-display: --lcm-url: cannot open '%s'\n", lcm_url.c_str());
    return 2;
  }
  std::unique_ptr<lcm::LCM> feed_lcm;
  FeedListener listener(feed);
  if (!playback) {
    feed_lcm = std::make_unique<lcm::LCM>(lcm_url);
    if (!feed_lcm->good()) {
      std::fprintf(stderr, "mgc-display: --lcm-url: cannot open '%s'\n", lcm_url.c_str());
      return 2;
    }
    namespace ch = mgc::firmware::channel;
    for (const char* c : {ch::kMachineState, ch::kOperatorGuidance, ch::kOperatorInstruction, ch::kAlert, ch::kPlan,
                          ch::kLoopTiming, ch::kHealth, ch::kCommandStatus, ch::kObstaclePoses}) {
      feed_lcm->subscribe(c, &FeedListener::on_raw, &listener);
    }
  }
  // The site channel, on the site's network when it is not the feed's.
  std::unique_ptr<lcm::LCM> site_lcm;
  if (site && !playback) {
    const std::string url = site_lcm_url.empty() ? std::string(mgc::firmware::kDefaultSiteLcmUrl) : site_lcm_url;
    site_lcm = std::make_unique<lcm::LCM>(url);
    if (!site_lcm->good()) {
      std::fprintf(stderr, "mgc-display: --site-lcm-url: cannot open '%s'\n", url.c_str());
      return 2;
    }
    site_lcm->subscribe(mgc::firmware::channel::kSiteState, &FeedListener::on_raw, &listener);
  }
  // The page's clock: monotonic time live, the log's time in playback (so a paused log is not stale).
  const auto feed_now_us = [&]() { return playback ? playback->position_us() : monotonic_us(); };

  httplib::Server server;
  server.new_task_queue = [] { return new httplib::ThreadPool(kServerThreads); };
  server.set_socket_options(socket_options);
  server.set_keep_alive_timeout(2);
  const std::string static_scene = scene ? scene->static_json() : "null";

  for (const auto& asset : mgc::display::assets()) {
    const std::string path = asset.path;
    const std::string type = path.ends_with(".html") ? "text/html; charset=utf-8"
                             : path.ends_with(".js") ? "text/javascript; charset=utf-8"
                                                     : "text/css; charset=utf-8";
    const auto serve = [asset, type](const httplib::Request&, httplib::Response& res) {
      res.set_header("Cache-Control", "no-store");
      // The page loads nothing from elsewhere and may not be framed by another site.
      res.set_header("Content-Security-Policy", "default-src 'self'; frame-ancestors 'none'");
      res.set_content(asset.data, asset.size, type.c_str());
    };
    server.Get(path, serve);
    if (path == "/index.html") server.Get("/", serve);
  }

  // Browsers ask for an icon; there is none, and an error would be noise in the console.
  server.Get("/favicon.ico", [](const httplib::Request&, httplib::Response& res) { res.status = 204; });

  server.Get("/api/config", [&](const httplib::Request&, httplib::Response& res) {
    mgc::display::Json j;
    j.begin_object();
    j.key("has_key").value(commander.has_key());
    j.key("sender_id").value(commander.sender_id());
    j.key("stale_after_s").value(static_cast<double>(mgc::display::kStaleAfter_us) * 1e-6);
    j.key("push_period_s").value(static_cast<double>(kPushPeriod_us) * 1e-6);
    j.key("lcm_url").value(lcm_url);
    j.key("playback").value(playback != nullptr);
    j.key("scene").raw(static_scene);
    j.key("site").value(site != nullptr);
    j.end_object();
    reply(res, 200, j.str());
  });

  std::atomic<int> streams{0};
  server.Get("/api/events", [&](const httplib::Request&, httplib::Response& res) {
    if (streams.fetch_add(1) >= kMaxEventStreams) {
      streams.fetch_sub(1);
      reply(res, 503, error_json("too many pages open"));
      return;
    }
    res.set_header("Cache-Control", "no-store");
    auto plan_version = std::make_shared<std::uint64_t>(0);
    auto next_us = std::make_shared<std::int64_t>(monotonic_us());
    res.set_chunked_content_provider(
        "text/event-stream",
        [&, plan_version, next_us](std::size_t, httplib::DataSink& sink) {
          const std::int64_t now = monotonic_us();
          if (*next_us > now) std::this_thread::sleep_for(std::chrono::microseconds(*next_us - now));
          *next_us = std::max(*next_us + kPushPeriod_us, monotonic_us());
          if (g_stop) return false;
          std::string message = "data: ";
          message += feed.json(feed_now_us(), plan_version.get());
          if (playback) {
            // The playback position rides along so the slider follows.
            message.pop_back();
            message += ",\"playback\":" + playback->json() + "}";
          }
          message += "\n\n";
          return sink.write(message.data(), message.size());
        },
        [&](bool) { streams.fetch_sub(1); });
  });

  const auto command_route = [&](const char* path, std::int8_t kind) {
    server.Post(path, [&, kind](const httplib::Request& req, httplib::Response& res) {
      std::string why;
      if (!from_served_origin(req, why)) {
        reply(res, 403, error_json(why));
        return;
      }
      if (kind != mgc::operator_command_t::KIND_STOP && !commander.has_key()) {
        reply(res, 403, error_json("no --key: this display sends STOP only"));
        return;
      }
      std::vector<double> goal;
      std::int32_t alert_id = 0;
      if (kind == mgc::operator_command_t::KIND_GOAL) {
        const std::size_t dof = scene ? static_cast<std::size_t>(scene->dof()) : mgc::operator_command_t::MAX_JOINTS;
        if (!parse_numbers(req.get_param_value("joints"), goal) || goal.size() > dof || (scene && goal.size() != dof)) {
          reply(res, 400, error_json("joints: expected " + std::to_string(dof) + " comma-separated finite numbers [rad | m]"));
          return;
        }
      } else if (kind == mgc::operator_command_t::KIND_ACKNOWLEDGE && req.has_param("alert_id")) {
        std::vector<double> id;
        if (!parse_numbers(req.get_param_value("alert_id"), id) || id.size() != 1 || id[0] < 0 || id[0] > 2147483647.0 ||
            id[0] != std::floor(id[0])) {
          reply(res, 400, error_json("alert_id: expected a non-negative integer (0: every alert)"));
          return;
        }
        alert_id = static_cast<std::int32_t>(id[0]);
      }
      const std::int64_t sequence = commander.send(kind, goal, alert_id);
      mgc::display::Json j;
      j.begin_object().key("ok").value(true).key("sequence").value(static_cast<long long>(sequence));
      j.key("signed").value(commander.has_key()).end_object();
      reply(res, 200, j.str());
    });
  };
  command_route("/api/stop", mgc::operator_command_t::KIND_STOP);
  command_route("/api/ack", mgc::operator_command_t::KIND_ACKNOWLEDGE);
  command_route("/api/goal", mgc::operator_command_t::KIND_GOAL);

  if (playback) {
    server.Post("/api/playback", [&](const httplib::Request& req, httplib::Response& res) {
      std::string why;
      if (!from_served_origin(req, why)) {
        reply(res, 403, error_json(why));
        return;
      }
      std::string error;
      if (!playback->control(req.get_param_value("action"), req.get_param_value("value"), error)) {
        reply(res, 400, error_json(error));
        return;
      }
      reply(res, 200, playback->json());
    });
  }

  if (!server.bind_to_port(bind, port)) {
    std::fprintf(stderr, "mgc-display: --port %d: cannot listen on %s:%d (address in use, not local, or not permitted)\n", port,
                 bind.c_str(), port);
    return 2;
  }

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGPIPE, SIG_IGN);
  std::thread feed_thread([&] {
    if (playback) {
      playback->run(feed, g_stop);
      return;
    }
    while (!g_stop) feed_lcm->handleTimeout(100);
  });
  std::thread site_thread([&] {
    while (site_lcm && !g_stop) site_lcm->handleTimeout(100);
  });
  std::thread stopper([&] {
    while (!g_stop) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    server.stop();
  });
  std::printf("mgc-display: http://%s:%d/ (%s%s)\n", bind.c_str(), port, playback ? "playback of " : "feed ",
              playback ? log_file.c_str() : lcm_url.c_str());
  std::fflush(stdout);
  const bool listened = server.listen_after_bind();
  g_stop = true;
  stopper.join();
  feed_thread.join();
  site_thread.join();
  std::printf("mgc-display: %lld messages received, %lld malformed\n", static_cast<long long>(feed.received()),
              static_cast<long long>(feed.malformed()));
  return listened ? 0 : 1;
}
