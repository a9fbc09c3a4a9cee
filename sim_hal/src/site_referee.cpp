// SPDX-License-Identifier: Apache-2.0
#include "mgc/sim/site_referee.hpp"

#include <cinttypes>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/machine_model.hpp"

namespace mgc::sim {
namespace {

//! The smallest size a body is given: a cable paid in to nothing is still a body FCL can measure. [m]
constexpr double kMinBodySize_m = 1e-3;
//! Where machine b's bodies wait for the first sample: far below any site, so that nothing is
//! measured that the true joints did not pose. [m]
constexpr double kParkedDepth_m = 1e4;

planning::ShapePart body_part(const planning::BodySpec& spec, const planning::BodyState& state) {
  planning::ShapePart part;
  part.kind = spec.shape == planning::BodyShape::Box ? planning::ShapeKind::Box : planning::ShapeKind::Capsule;
  part.size_m = state.size_m.cwiseMax(Eigen::Vector3d::Constant(kMinBodySize_m));
  return part;
}

}  // namespace

//! Machine a's bodies against machine b's, every one of both, undilated: b's bodies are dynamic
//! obstacles posed (and sized) from its true joints at each sample.
struct SitePairReferee::PairWorld {
  std::size_t a = 0;
  std::size_t b = 0;
  std::unique_ptr<planning::MachineModel> model_a;
  std::unique_ptr<planning::MachineModel> model_b;
  std::unique_ptr<planning::CollisionWorld> world;
  planning::Kinematics kinematics{};
  planning::JointVector q_a;
  planning::JointVector q_b;
};

SitePairReferee::SitePairReferee(const planning::Site& site, double margin_m) : margin_m_(margin_m) {
  for (const planning::SiteMachine& m : site.machines) ids_.push_back(m.id);
  for (std::size_t a = 0; a < site.machines.size(); ++a) {
    for (std::size_t b = a + 1; b < site.machines.size(); ++b) {
      auto w = std::make_unique<PairWorld>();
      w->a = a;
      w->b = b;
      const planning::Scenario lift_a = planning::lift_scenario(site, a, 0);
      const planning::Scenario lift_b = planning::lift_scenario(site, b, 0);
      w->model_a = planning::build_model(lift_a);
      w->model_b = planning::build_model(lift_b);
      w->world = std::make_unique<planning::CollisionWorld>(*w->model_a, 0.0);
      w->q_a = lift_a.start;
      w->q_b = lift_b.start;
      w->model_b->forward_kinematics(w->q_b, w->kinematics);
      for (std::size_t k = 0; k < w->model_b->bodies().size(); ++k) {
        planning::DynamicObstacle d;
        d.name = "machine-" + std::to_string(site.machines[b].id) + "/" + w->model_b->bodies()[k].name;
        d.parts.push_back(body_part(w->model_b->bodies()[k], w->kinematics.bodies[k]));
        (void)w->world->add_dynamic(std::move(d));
      }
      w->world->finalize();
      for (std::size_t k = 0; k < w->model_b->bodies().size(); ++k) {
        w->world->set_dynamic_pose(static_cast<int>(k), Eigen::Isometry3d(Eigen::Translation3d(0.0, 0.0, -kParkedDepth_m)));
      }
      SitePairTruth t;
      t.machine_a = site.machines[a].id;
      t.machine_b = site.machines[b].id;
      pairs_.push_back(t);
      worlds_.push_back(std::move(w));
    }
  }
}

SitePairReferee::~SitePairReferee() = default;

void SitePairReferee::measure(double t_s, std::span<const TrueState* const> truths) noexcept {
  bool contact = false;
  bool below = false;
  for (std::size_t k = 0; k < worlds_.size(); ++k) {
    PairWorld& w = *worlds_[k];
    if (w.a >= truths.size() || w.b >= truths.size()) continue;
    const TrueState& ta = *truths[w.a];
    const TrueState& tb = *truths[w.b];
    for (int j = 0; j < w.q_a.size(); ++j) w.q_a[j] = ta.position[static_cast<std::size_t>(j)];
    for (int j = 0; j < w.q_b.size(); ++j) w.q_b[j] = tb.position[static_cast<std::size_t>(j)];
    w.model_b->forward_kinematics(w.q_b, w.kinematics);
    for (std::size_t b = 0; b < w.model_b->bodies().size(); ++b) {
      const planning::BodyState& body = w.kinematics.bodies[b];
      w.world->set_dynamic_part_size(static_cast<int>(b), 0, body.size_m.cwiseMax(Eigen::Vector3d::Constant(kMinBodySize_m)));
      w.world->set_dynamic_pose(static_cast<int>(b), body.world_from_body);
    }
    const planning::Clearance c =
        w.world->clearance(w.q_a, planning::CollisionWorld::Bodies::All, planning::CollisionWorld::Obstacles::Dynamic);
    SitePairTruth& t = pairs_[k];
    ++t.samples;
    if (c.distance_m < t.least_m) {
      t.least_m = c.distance_m;
      t.least_t_s = t_s;
      t.least_body_a = c.body;
      // A contact of machine a with itself reads 0 too; it names no body of b.
      t.least_body_b = c.with == planning::Contact::With::Dynamic ? c.other : -1;
    }
    if (c.distance_m <= 0.0) ++t.samples_in_contact;
    if (c.distance_m < margin_m_) ++t.samples_below_margin;
    contact = contact || c.distance_m <= 0.0;
    below = below || c.distance_m < margin_m_;
  }
  ++samples_;
  if (contact) ++samples_in_contact_;
  if (below) ++samples_below_margin_;
}

const SitePairTruth* SitePairReferee::least_pair() const noexcept {
  const SitePairTruth* least = nullptr;
  for (const SitePairTruth& p : pairs_) {
    if (least == nullptr || p.least_m < least->least_m) least = &p;
  }
  return least;
}

double SitePairReferee::least_m() const noexcept {
  const SitePairTruth* p = least_pair();
  return p == nullptr ? std::numeric_limits<double>::infinity() : p->least_m;
}

std::string SitePairReferee::summary_line() const {
  const SitePairTruth* p = least_pair();
  if (p == nullptr) return "one machine: no pair to measure";
  if (p->samples == 0) return "no samples";
  const auto k = static_cast<std::size_t>(p - pairs_.data());
  const PairWorld& w = *worlds_[k];
  const auto name = [](const planning::MachineModel& model, int body) {
    return body >= 0 && body < static_cast<int>(model.bodies().size()) ? model.bodies()[static_cast<std::size_t>(body)].name
                                                                      : std::string("?");
  };
  char buf[512];
  if (p->least_body_b >= 0) {
    std::snprintf(buf, sizeof buf, "machine %d %s to machine %d %s", static_cast<int>(p->machine_a),
                  name(*w.model_a, p->least_body_a).c_str(), static_cast<int>(p->machine_b),
                  name(*w.model_b, p->least_body_b).c_str());
  } else {
    std::snprintf(buf, sizeof buf, "machine %d %s in contact with itself", static_cast<int>(p->machine_a),
                  name(*w.model_a, p->least_body_a).c_str());
  }
  const std::string where = buf;
  std::snprintf(buf, sizeof buf, "least clearance %.2f m at %.2f s (", p->least_m, p->least_t_s);
  std::string line = buf;
  line += where;
  std::snprintf(buf, sizeof buf, "), %" PRIu64 " of %" PRIu64 " samples in contact, %" PRIu64 " below %.2f m",
                samples_in_contact_, samples_, samples_below_margin_, margin_m_);
  line += buf;
  if (pairs_.size() > 1) {
    line += "; per pair:";
    for (const SitePairTruth& q : pairs_) {
      std::snprintf(buf, sizeof buf, " %d-%d %.2f m", static_cast<int>(q.machine_a), static_cast<int>(q.machine_b), q.least_m);
      line += buf;
    }
  }
  return line;
}

}  // namespace mgc::sim
