// SPDX-License-Identifier: Apache-2.0
// The test publisher for mgc-display's browser test: plays the controller's side of the operator
// feed on an LCM URL, step by step as told on standard input, and reports the commands it hears.
//
//   display_feeder LCM_URL SENT_LOG [KEY_FILE]
//
// Each line of standard input is one step; each is answered with one line on standard output.
//   state SUPERVISOR LOAD_PCT Q0 Q1 ...   the state that `stream` publishes
//   stream PERIOD_MS                      publish MGC_MACHINE_STATE every PERIOD_MS (0: stop); each
//                                         message gets a new utime, and "utime wall_us" goes to SENT_LOG
//   obstacle INDEX VALID STILL X Y YAW_DEG SPEED YAW_RATE_DEG_S   one tracked obstacle that `stream` publishes on
//                                         MGC_OBSTACLE_POSES with every 10th state (10 Hz at 10 ms)
//   obstacle none                         no more obstacle poses
//   site ID PRIORITY Q0 Q1 ...            another machine of the site: `stream` publishes its
//                                         unsigned MGC_SITE_STATE with every 5th state (20 Hz at 10 ms)
//   site none                             no more site states
//   guidance JOINT TARGET REMAINING SEGMENT NUM_SEGMENTS
//   instruction CLEARANCE_M TEXT...
//   alert ID SEVERITY SOURCE ACTIVE UNIT VALUE INDEX
//   plan Q,Q,..;Q,Q,..;...                 waypoints
//   junk CHANNEL                          bytes that are no message
//   command TIMEOUT_MS                    the next MGC_COMMAND heard: "command KIND SENDER VERDICT"
//   write-log FILE SECONDS                a recorded feed of SECONDS at 100 Hz into an LCM log
//   quit
#include <lcm/lcm-cpp.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <fstream>
#include <iostream>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <mgc/alert_t.hpp>
#include <mgc/machine_state_t.hpp>
#include <mgc/obstacle_poses_t.hpp>
#include <mgc/operator_command_t.hpp>
#include <mgc/operator_guidance_t.hpp>
#include <mgc/operator_instruction_t.hpp>
#include <mgc/plan_t.hpp>
#include <mgc/site_state_t.hpp>

#include "mgc/firmware/command_auth.hpp"
#include "mgc/firmware/lcm_feed.hpp"

namespace {

namespace ch = mgc::firmware::channel;

std::int64_t wall_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

struct Commands {
  std::mutex mutex;
  std::condition_variable cv;
  std::deque<mgc::operator_command_t> received;
  void on_command(const lcm::ReceiveBuffer*, const std::string&, const mgc::operator_command_t* c) {
    const std::lock_guard lock(mutex);
    received.push_back(*c);
    cv.notify_all();
  }
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: display_feeder LCM_URL SENT_LOG [KEY_FILE]\n");
    return 2;
  }
  lcm::LCM out(argv[1]);
  lcm::LCM in(argv[1]);
  if (!out.good() || !in.good()) {
    std::fprintf(stderr, "display_feeder: cannot open %s\n", argv[1]);
    return 2;
  }
  std::optional<mgc::firmware::CommandAuthenticator> auth;
  if (argc > 3) auth.emplace(mgc::firmware::load_command_key(argv[3]));
  std::ofstream sent(argv[2]);
  std::mutex out_mutex;

  Commands commands;
  in.subscribe(ch::kCommand, &Commands::on_command, &commands);
  std::atomic<bool> done{false};
  std::thread receiver([&] {
    while (!done) in.handleTimeout(50);
  });

  mgc::machine_state_t state{};
  state.machine_kind = mgc::machine_state_t::MACHINE_KIND_MOBILE_CRANE;
  mgc::obstacle_poses_t poses{};
  bool poses_on = false;
  mgc::site_state_t site{};
  bool site_on = false;
  std::atomic<int> period_ms{0};
  std::int64_t utime = 1'000'000;
  std::thread streamer([&] {
    auto next = std::chrono::steady_clock::now();
    while (!done) {
      const int p = period_ms;
      if (p <= 0) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        next = std::chrono::steady_clock::now();
        continue;
      }
      next += std::chrono::milliseconds(p);
      std::this_thread::sleep_until(next);
      const std::lock_guard lock(out_mutex);
      state.utime = ++utime;
      state.utime_sample = state.utime;
      out.publish(ch::kMachineState, &state);
      if (poses_on && utime % 10 == 0) {
        poses.utime = state.utime;
        out.publish(ch::kObstaclePoses, &poses);
      }
      if (site_on && utime % 5 == 0) {
        site.utime = state.utime;
        ++site.sequence;
        site.sender_time_us = wall_us();
        out.publish(ch::kSiteState, &site);
      }
      sent << state.utime << ' ' << wall_us() << '\n' << std::flush;  // read while the stream runs
    }
  });

  std::string line;
  while (std::getline(std::cin, line)) {
    std::istringstream s(line);
    std::string verb;
    s >> verb;
    std::string reply = "ok";
    if (verb == "state") {
      int sup = 0;
      double load = 0.0;
      std::vector<double> q;
      double v = 0.0;
      s >> sup >> load;
      while (s >> v) q.push_back(v);
      const std::lock_guard lock(out_mutex);
      state.supervisor_state = static_cast<std::int8_t>(sup);
      state.load_moment_pct = load;
      state.num_joints = static_cast<std::int8_t>(q.size());
      for (std::size_t j = 0; j < q.size() && j < 8; ++j) state.joint_position[j] = q[j];
    } else if (verb == "stream") {
      int p = 0;
      s >> p;
      period_ms = p;
      std::this_thread::sleep_for(std::chrono::milliseconds(2 * std::max(p, 5)));
    } else if (verb == "obstacle") {
      std::string first;
      s >> first;
      const std::lock_guard lock(out_mutex);
      if (first == "none") {
        poses_on = false;
      } else {
        int valid = 0, still = 0;
        double yaw_deg = 0.0;
        poses = {};
        for (int i = 0; i < mgc::obstacle_poses_t::MAX_OBSTACLES; ++i) {
          poses.obstacle_index[i] = -1;
          poses.x[i] = poses.y[i] = poses.z[i] = poses.yaw[i] = poses.position_sigma[i] = poses.speed[i] = poses.yaw_rate[i] =
              poses.fix_age[i] = NAN;
        }
        poses.num_tracked = poses.num_obstacles = 1;
        poses.obstacle_index[0] = std::stoi(first);
        double yaw_rate_deg_s = 0.0;
        s >> valid >> still >> poses.x[0] >> poses.y[0] >> yaw_deg >> poses.speed[0] >> yaw_rate_deg_s;
        poses.yaw_rate[0] = yaw_rate_deg_s * M_PI / 180.0;
        poses.valid[0] = valid != 0;
        poses.still[0] = still != 0;
        poses.z[0] = 0.0;
        poses.yaw[0] = yaw_deg * M_PI / 180.0;
        poses.position_sigma[0] = 0.1;
        poses.fix_age[0] = valid ? 0.02 : 2.0;
        poses_on = true;
      }
    } else if (verb == "site") {
      std::string first;
      s >> first;
      const std::lock_guard lock(out_mutex);
      if (first == "none") {
        site_on = false;
      } else {
        site = {};
        site.machine_id = std::stoi(first);
        s >> site.priority;
        double v = 0.0;
        int n = 0;
        while (n < 8 && s >> v) site.joint_position[n++] = v;
        site.num_joints = static_cast<std::int8_t>(n);
        site.supervisor_state = mgc::machine_state_t::SUPERVISOR_EXECUTING;
        site.sequence = wall_us();
        site_on = true;
      }
    } else if (verb == "guidance") {
      mgc::operator_guidance_t g{};
      int joint = 0;
      s >> joint >> g.target_position >> g.joint_distance_remaining >> g.segment_index >> g.num_segments;
      g.moving_joint = static_cast<std::int8_t>(joint);
      g.instruction = mgc::operator_guidance_t::INSTRUCTION_MOVE_JOINT;
      g.speed_scale = 1.0;
      g.time_remaining = 12.5;
      const std::lock_guard lock(out_mutex);
      out.publish(ch::kOperatorGuidance, &g);
    } else if (verb == "instruction") {
      mgc::operator_instruction_t i{};
      s >> i.obstacle_clearance;
      std::getline(s >> std::ws, i.text);
      i.obstacle_index = 0;
      i.limit_joint = mgc::operator_instruction_t::NO_JOINT;
      const std::lock_guard lock(out_mutex);
      out.publish(ch::kOperatorInstruction, &i);
    } else if (verb == "alert") {
      mgc::alert_t a{};
      int sev = 0, src = 0, active = 0, unit = 0;
      s >> a.alert_id >> sev >> src >> active >> unit >> a.value >> a.index;
      a.severity = static_cast<std::int8_t>(sev);
      a.source = static_cast<std::int8_t>(src);
      a.active = active != 0;
      a.value_unit = static_cast<std::int8_t>(unit);
      a.limit = 0.0;
      a.clear_condition = mgc::alert_t::CLEAR_WHEN_CONDITION_CLEARS;
      const std::lock_guard lock(out_mutex);
      out.publish(ch::kAlert, &a);
    } else if (verb == "plan") {
      mgc::plan_t p{};
      std::string text;
      s >> text;
      std::istringstream rows(text);
      std::string row;
      while (std::getline(rows, row, ';')) {
        std::vector<double> q;
        std::istringstream cells(row);
        std::string cell;
        while (std::getline(cells, cell, ',')) q.push_back(std::stod(cell));
        p.positions.push_back(q);
      }
      p.num_waypoints = static_cast<std::int32_t>(p.positions.size());
      p.num_joints = p.positions.empty() ? 0 : static_cast<std::int32_t>(p.positions[0].size());
      p.moving_joint.assign(p.positions.size(), mgc::plan_t::NO_JOINT);
      p.planner_name = "test";
      p.status = mgc::plan_t::STATUS_EXACT;
      const std::lock_guard lock(out_mutex);
      out.publish(ch::kPlan, &p);
    } else if (verb == "junk") {
      std::string channel;
      s >> channel;
      const char junk[] = "not an LCM message";
      const std::lock_guard lock(out_mutex);
      out.publish(channel, junk, sizeof junk);
    } else if (verb == "bad-plan") {
      // A plan_t whose counts claim 2^31 - 1 waypoints, and an operator_instruction_t whose text
      // length is 0: the generated decoders would allocate gigabytes or throw.
      std::vector<std::uint8_t> b;
      const auto put = [&](std::uint64_t v, int bytes) {
        for (int k = bytes - 1; k >= 0; --k) b.push_back(static_cast<std::uint8_t>(v >> (8 * k)));
      };
      put(static_cast<std::uint64_t>(mgc::plan_t::getHash()), 8);
      put(0, 8);           // utime
      put(2, 4);           // planner_name: "x\0"
      b.push_back('x');
      b.push_back(0);
      put(0, 8);           // seed
      b.push_back(1);      // status
      put(4, 4);           // num_joints
      put(0x7fffffff, 4);  // num_waypoints
      b.resize(b.size() + 16, 0);  // the rest of the fixed fields, never reached
      std::vector<std::uint8_t> t;
      b.swap(t);
      put(static_cast<std::uint64_t>(mgc::operator_instruction_t::getHash()), 8);
      put(0, 8);  // utime
      put(0, 4);  // text length 0: no room even for the terminating zero
      b.resize(b.size() + 32, 0);
      const std::lock_guard lock(out_mutex);
      out.publish(ch::kPlan, t.data(), static_cast<unsigned>(t.size()));
      out.publish(ch::kOperatorInstruction, b.data(), static_cast<unsigned>(b.size()));
    } else if (verb == "command") {
      int timeout_ms = 0;
      s >> timeout_ms;
      std::unique_lock lock(commands.mutex);
      if (commands.cv.wait_for(lock, std::chrono::milliseconds(timeout_ms), [&] { return !commands.received.empty(); })) {
        const mgc::operator_command_t c = commands.received.front();
        commands.received.pop_front();
        std::string verdict = "unchecked";
        if (auth) {
          const auto v = auth->check(c, wall_us());
          verdict = v.accepted ? "accepted" : mgc::firmware::command_reason_name(v.reason);
          for (char& ch_ : verdict) ch_ = ch_ == ' ' ? '_' : ch_;
        }
        reply = "command " + std::to_string(c.kind) + " " + std::to_string(c.sender_id) + " " + verdict;
      } else {
        reply = "command none";
      }
    } else if (verb == "write-log") {
      std::string file;
      double seconds = 0.0;
      s >> file >> seconds;
      lcm::LogFile log(file, "w");
      lcm::LogEvent e{};
      std::vector<std::uint8_t> buf(4096);
      mgc::machine_state_t m = state;
      for (int k = 0; k < static_cast<int>(seconds * 100); ++k) {
        m.utime = 1'000'000 + k * 10'000;
        m.joint_position[0] = 0.01 * k;
        m.supervisor_state = mgc::machine_state_t::SUPERVISOR_EXECUTING;
        const int len = m.encode(buf.data(), 0, static_cast<int>(buf.size()));
        e.eventnum = k;
        e.timestamp = m.utime;
        e.channel = ch::kMachineState;
        e.datalen = len;
        e.data = buf.data();
        log.writeEvent(&e);
      }
    } else if (verb == "quit") {
      break;
    } else {
      reply = "error unknown step '" + verb + "'";
    }
    std::cout << reply << std::endl;
  }
  done = true;
  streamer.join();
  receiver.join();
  return 0;
}
