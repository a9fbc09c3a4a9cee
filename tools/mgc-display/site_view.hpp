// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <mgc/site_state_t.hpp>

#include "json.hpp"
#include "mgc/firmware/site_auth.hpp"
#include "mgc/planning/machine_model.hpp"
#include "mgc/planning/site.hpp"

namespace mgc::display {

//! The other machines of a coordinated site (docs/site.md) as their controllers report them on
//! MGC_SITE_STATE: each member drawn through its own machine model, at its base, at its reported
//! joints. Without a site key the states are only decoded and checked against the site file
//! (unverified: anyone on the network could send them); with one, SiteVerifier checks each as the
//! controllers do and refused ones are counted by reason. Thread-safe: on_state() from the feed
//! thread, json() from the pushers.
class SiteView {
 public:
  //! Loads the site file (planning::io::load_site) and builds every member's model. own_id, when
  //! given, is the machine of this display's MGC_MACHINE_STATE: it is not drawn from the site
  //! channel. key, when given, needs own_id. realtime_us is the clock the verifier checks the
  //! senders' clocks against. Throws planning::io::InputError (the site file, an own_id it does
  //! not list) and std::invalid_argument (a key without own_id).
  SiteView(const std::string& site_file, std::optional<std::int32_t> own_id, std::optional<firmware::SiteKey> key,
           std::int64_t (*realtime_us)() noexcept);
  ~SiteView();
  SiteView(const SiteView&) = delete;
  SiteView& operator=(const SiteView&) = delete;

  //! One MGC_SITE_STATE message received at now_us (monotonic). False when it is refused: it does
  //! not decode, names no member of the site, another joint count or non-finite joints; with a
  //! key, whatever SiteVerifier refuses. The display's own machine's states are counted as its
  //! own echoes and not drawn (the feed draws that machine).
  //! realtime_now_us: the wall clock to check the sender's clock against; -1 (live) reads the
  //! clock given at construction, a recorded log passes the time its logger received the message.
  bool on_state(const void* data, int size, std::int64_t now_us, std::int64_t realtime_now_us = -1);

  //! The "site" object for the page: whether verified, and each member with its age and, once
  //! heard from, its bodies at its joints.
  void write_json(Json& out, std::int64_t now_us) const;

  //! Forgets every member's state and what the verifier has seen (playback seeks back, and the
  //! same messages come again); the refusal counts stay.
  void clear();

  [[nodiscard]] bool verified() const noexcept { return verifier_ != nullptr; }
  [[nodiscard]] const planning::Site& site() const noexcept { return site_; }

 private:
  struct Member {
    std::int32_t id = 0;
    std::int32_t priority = 0;
    std::string name;  //!< the machine file's name
    std::unique_ptr<planning::MachineModel> model;
    bool own = false;
    site_state_t last{};
    std::int64_t received_us = -1;  //!< -1: not heard from
  };

  planning::Site site_;
  std::optional<std::int32_t> own_id_;
  std::unique_ptr<firmware::SiteVerifier> verifier_;
  std::int64_t (*realtime_us_)() noexcept;
  std::int64_t stale_after_us_;
  mutable std::mutex mutex_;
  std::vector<Member> members_;
  std::map<std::string, std::int64_t> refused_;  //!< by reason
  std::int64_t own_echoes_ = 0;  //!< states of the display's own machine: accepted, not drawn
  std::optional<firmware::SiteKey> key_;  //!< to start the verifier afresh on clear()
};

}  // namespace mgc::display
