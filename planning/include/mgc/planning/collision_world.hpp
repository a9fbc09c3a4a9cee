// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mgc/planning/machine_model.hpp"
#include "mgc/planning/obstacle.hpp"

namespace mgc::planning {

//! What a configuration hits: a machine body and a static obstacle, a dynamic obstacle, or
//! another body of the same machine.
struct Contact {
  enum class With : std::uint8_t { Nothing, Static, Dynamic, Self };
  With with = With::Nothing;
  int body = -1;   //!< index into MachineModel::bodies()
  int other = -1;  //!< static obstacle index, dynamic obstacle index, or other body index
};

//! Why a configuration is not valid, checked cheapest first: joint ranges, the machine's
//! engineering constraints, the world's configuration rule (the working envelope), then collision.
struct Validity {
  enum class Status : std::int16_t { Valid = 0, JointOutOfRange = -310, Constraint = -311, Collision = -312, Rule = -313 };
  Status status = Status::Valid;
  int joint = -1;                 //!< JointOutOfRange: the joint
  ConstraintVerdict constraint;   //!< Constraint: the rule that failed
  Contact contact;                //!< Collision: what hit what
  int rule_limit = -1;            //!< Rule: which of the rule's limits refused (ConfigurationRule::describe)

  [[nodiscard]] bool valid() const noexcept { return status == Status::Valid; }
};

//! Nearest obstacle to the machine at one configuration.
struct Clearance {
  double distance_m = 0.0;  //!< between the dilated bodies and the nearest obstacle; 0 in contact [m]
  int body = -1;            //!< machine body nearest to an obstacle
  Contact::With with = Contact::With::Nothing;
  int other = -1;           //!< static or dynamic obstacle index
};

//! A rule on configurations beyond the joint ranges and the machine's own constraints: the site's
//! working envelope (guidance::EnvelopeRule), which a plan must keep as the limiter will. A world
//! consults it in validate(), so every planner and every edge check keeps it.
class ConfigurationRule {
 public:
  virtual ~ConfigurationRule() = default;
  //! Whether q is allowed; when not, `limit` receives which of the rule's limits refuses it.
  //! RT-safe: no allocation, no throw.
  [[nodiscard]] virtual bool allows(const JointVector& q, int* limit) noexcept = 0;
  //! The refusing limit in words, e.g. "hook within 1.25 m of the height ceiling". Not RT.
  [[nodiscard]] virtual std::string describe(int limit) const = 0;
};

//! The site as FCL sees it: static obstacles in a dynamic-AABB-tree broad phase, dynamic
//! obstacles whose poses change every cycle, and the machine's bodies posed by forward kinematics
//! and dilated by a safety margin.
//!
//! Build with add_*() then finalize(); after that, queries and set_dynamic_pose() do not allocate
//! (a test counts), except that a machine body touching a triangle-mesh obstacle goes through
//! FCL's mesh path, which may.
//! Queries pose the machine's own FCL objects, so a world is not shared between threads: give
//! each planning thread its own.
class CollisionWorld {
 public:
  //! The model must outlive the world. dilation_m is added around every machine body.
  CollisionWorld(const MachineModel& model, double dilation_m);
  ~CollisionWorld();
  CollisionWorld(const CollisionWorld&) = delete;
  CollisionWorld& operator=(const CollisionWorld&) = delete;

  //! Adds before finalize(); returns the obstacle's index. Throws std::invalid_argument for a
  //! degenerate shape (non-positive size, a mesh without triangles or with bad indices).
  int add_static(StaticObstacle obstacle);
  int add_dynamic(DynamicObstacle obstacle);
  //! Builds the broad phase. Throws std::logic_error if called twice.
  void finalize();

  //! Moves a dynamic obstacle. RT-safe. A pose equal to its present one (bit for bit) changes
  //! nothing: remembered dynamic results and clearance balls stay.
  void set_dynamic_pose(int index, const Eigen::Isometry3d& world_from_obstacle) noexcept;
  [[nodiscard]] const Eigen::Isometry3d& dynamic_pose(int index) const noexcept;
  //! Resizes part `part` of dynamic obstacle `index` in place, size_m as its ShapePart takes it (a
  //! box's extents; a cylinder's or capsule's (2 r, 2 r, length)): another machine's telescoping
  //! boom or paying-out cable posed as an obstacle. A mesh part, a size not positive and finite or
  //! an index out of range change nothing. The obstacle is no longer anyone's twin. RT-safe.
  void set_dynamic_part_size(int index, int part, const Eigen::Vector3d& size_m) noexcept;
  //! The farthest any point of dynamic obstacle `index` lies from the vertical axis through its
  //! own origin, about which its yaw turns it: with DynamicObstacleSpec::max_travel_m, how far its
  //! points can move. From the parts' bounding boxes, so never less than the true reach. [m]
  [[nodiscard]] double dynamic_reach_m(int index) const noexcept;
  //! False when bounding boxes alone (no narrow phase) show every body of the dilated machine at q
  //! farther than distance_m from dynamic obstacle `index` at its present pose; true otherwise.
  //! An obstacle whose points all move less than distance_m cannot reach a machine standing at q
  //! where this is false. RT-safe after finalize().
  [[nodiscard]] bool dynamic_may_be_within(const JointVector& q, int index, double distance_m) noexcept;

  //! Collision only. RT-safe after finalize().
  [[nodiscard]] bool is_free(const JointVector& q, Contact* contact = nullptr) noexcept;
  //! Collision with the dynamic obstacles only, at their current poses: what a move of those
  //! can newly break in a configuration that was valid. RT-safe after finalize().
  [[nodiscard]] bool hits_dynamic(const JointVector& q, Contact* contact = nullptr) noexcept;
  //! Joint ranges, constraints, the configuration rule (if set), then collision.
  [[nodiscard]] Validity validate(const JointVector& q) noexcept;
  //! The rule validate() consults after the constraints; null (the default) for none. The rule
  //! must outlive the world or be replaced first.
  void set_rule(ConfigurationRule* rule) noexcept { rule_ = rule; }
  [[nodiscard]] ConfigurationRule* rule() const noexcept { return rule_; }
  //! Validates the straight joint-space edge from -> to at n evenly spaced configurations after
  //! `from` (continuous joints the short way round). n is the larger of max_i ceil(|d_i| /
  //! max_step_i) and the number of samples that keeps every body point from moving more than the
  //! dilation between two of them (MachineModel::displacement_bound). So when the edge is valid,
  //! the machine's real bodies keep at least half the dilation from every obstacle along the whole
  //! continuous motion, not only at the samples. On failure, `at` (if given) receives the first
  //! invalid configuration. Every sample is a full validate() (joint ranges, constraints,
  //! collision), and the verdict is the one validating the samples one by one gives; when they
  //! all pass, the model's constraints are checked between them too
  //! (MachineModel::check_edge_constraints: the load chart along the whole edge), `at` then on
  //! the boundary of the first failing stretch. A body the
  //! edge does not move (upstream of the joint a one-joint edge moves) keeps its pose, so its
  //! results are found at the first sample and reused at the rest (see body_checks()).
  [[nodiscard]] Validity validate_edge(const JointVector& from, const JointVector& to, const JointVector& max_step,
                                       JointVector* at = nullptr) noexcept;
  //! Whether validate_edge(from, to, max_step) is valid, for a caller that needs no more: the same
  //! samples, each checked as validate_edge checks it, and the same constraints between them, but
  //! every kCoarseStride-th sample first, so that an edge an obstacle blocks over a stretch is
  //! refused after a few checks. RT-safe after finalize().
  [[nodiscard]] bool edge_valid(const JointVector& from, const JointVector& to, const JointVector& max_step) noexcept;
  //! edge_valid()'s stride through an edge's samples before it checks the rest. [-]
  static constexpr int kCoarseStride = 8;
  //! Which machine bodies a clearance query measures.
  enum class Bodies : std::uint8_t {
    All,
    Moving,  //!< bodies whose pose or size depends on the configuration (boom, cable, load)
    Fixed,   //!< the rest (a carrier, an undercarriage): their clearance changes only when a dynamic obstacle moves
  };
  //! Which obstacles a clearance query measures against.
  enum class Obstacles : std::uint8_t { All, Static, Dynamic };
  //! Distance from the dilated machine (all of it, or its moving or fixed bodies) to the nearest
  //! obstacle (static, dynamic or either). All and Moving bodies report 0 when the machine collides
  //! anywhere at q. The fixed bodies' distance to the static obstacles never changes after
  //! finalize(): callers may measure it once.
  [[nodiscard]] Clearance clearance(const JointVector& q, Bodies bodies = Bodies::All,
                                    Obstacles obstacles = Obstacles::All) noexcept;
  //! The nearest static and the nearest dynamic obstacle of the chosen bodies, each only when nearer
  //! than its bound.
  struct NearestBelow {
    Clearance static_obstacle;   //!< With::Static; or With::Nothing and distance_m = the static bound
    Clearance dynamic_obstacle;  //!< With::Dynamic; or With::Nothing and distance_m = the dynamic bound
  };
  //! clearance(q, bodies, Obstacles::Static) and (..., Obstacles::Dynamic) for a caller that needs them
  //! only below bounds (the stop check, every control cycle; a bound <= 0 skips that kind). Below its
  //! bound a distance is clearance()'s (the same FCL query on the same pair; where two obstacles tie
  //! either may be named), found without the broad phase's full distance pass: the machine is posed
  //! once, and subtrees and pairs whose AABBs, or boxes round them and the body's box grown by the best
  //! distance so far, are no nearer than that best are never measured; so the lower the bounds the less
  //! is measured. hint (e.g. the previous call's result) names pairs measured first to start with a low
  //! best; it changes only the cost. No collision pass first: a chosen body in contact with an obstacle
  //! gives 0 with that obstacle, and (bodies All or Moving) two bodies of a self pair in contact give 0
  //! with With::Self in both results (a pair's verdict reused as is_free() reuses it, see
  //! body_checks()); a fixed body's contact does not count for Moving. RT-safe after
  //! finalize() (a mesh obstacle within a bound goes through FCL's mesh path).
  [[nodiscard]] NearestBelow nearest_below(const JointVector& q, Bodies bodies, double static_bound_m,
                                           double dynamic_bound_m, const NearestBelow* hint = nullptr) noexcept;
  //! Whether body i moves with the joints: found at construction by posing the machine at the
  //! middle of every joint range and at each joint's limits; a body identical in all is fixed.
  [[nodiscard]] bool body_moves(int body) const noexcept;

  [[nodiscard]] const MachineModel& model() const noexcept { return model_; }
  [[nodiscard]] double dilation_m() const noexcept { return dilation_m_; }
  //! Dilates the bodies no joint moves (body_moves() false: a carrier, an undercarriage) by
  //! dilation_m instead of dilation_m(). A margin kept for the motion of the machine means nothing
  //! for a body that cannot move, and would make a machine set up close to a structure collide in
  //! every configuration. After finalize(), before the first query. Throws std::invalid_argument
  //! for a negative or non-finite value. [m]
  void set_fixed_body_dilation(double dilation_m);
  [[nodiscard]] double fixed_body_dilation_m() const noexcept { return fixed_dilation_m_; }
  [[nodiscard]] int num_static() const noexcept { return static_cast<int>(static_names_.size()); }
  [[nodiscard]] int num_dynamic() const noexcept;
  [[nodiscard]] const std::string& static_name(int index) const { return static_names_.at(static_cast<std::size_t>(index)); }
  [[nodiscard]] const std::string& dynamic_name(int index) const;
  //! "boom hits static obstacle 'frame/column[2,1,0]'" and the like.
  [[nodiscard]] std::string describe(const Contact& contact) const;
  [[nodiscard]] std::string describe(const Validity& validity) const;

  //! Collision queries made since construction (one per configuration checked).
  [[nodiscard]] std::uint64_t collision_checks() const noexcept { return collision_checks_; }
  //! Machine bodies checked against the static site since construction (one broad-phase query
  //! each). A body whose pose and size are bit for bit those of a recent check reuses that
  //! check's results instead: its static ones always, its dynamic ones unless a dynamic obstacle
  //! has moved since; a self pair likewise when neither body moved. Along an edge that moves one
  //! joint, the bodies upstream of it are so checked once, not at every sample.
  [[nodiscard]] std::uint64_t body_checks() const noexcept;
  //! Turns that reuse off (every query checks every body and pair afresh, as a reference for
  //! tests) or back on (the default). Either way it forgets the results remembered so far.
  void reuse_results(bool on) noexcept;
  [[nodiscard]] bool reuses_results() const noexcept;
  //! Turns clearance certification of edge samples on (the default) or off. When on, a sample
  //! validate_edge() checks fully also leaves a clearance ball: a lower bound on how far its
  //! moving bodies are from every obstacle and from each other, found from bounding boxes alone (no
  //! narrow phase). A later sample, of this edge or another, whose travel from the ball's centre
  //! (MachineModel::box_displacement_bound over a box around it, per joint times its motion,
  //! summed) is below that bound cannot collide, so only its joint ranges, constraints and rule
  //! are checked. Verdicts are unchanged; only collision_checks() drop. Balls last until a
  //! dynamic obstacle moves or forget_results(); a model whose displacement bound is not strict
  //! (the dual crane's girder equilibrium) never certifies.
  void certify_edges(bool on) noexcept;
  [[nodiscard]] bool certifies_edges() const noexcept;
  //! Edge samples certified collision free by a clearance ball since construction.
  [[nodiscard]] std::uint64_t certified_samples() const noexcept;
  //! Forgets the results remembered so far, so that the next query starts cold (benchmarks
  //! timing one query at a time). RT-safe.
  void forget_results() noexcept;

 private:
  [[nodiscard]] Validity validate_without_collision(const JointVector& q) const noexcept;
  //! Samples validate_edge() checks after `from`.
  [[nodiscard]] int edge_samples(const JointVector& from, const JointVector& to, const JointVector& max_step) const noexcept;
  //! Sample k of `steps` of the edge, validated (with certify: certified by a clearance ball where
  //! one holds it, else leaving one); `at` receives it when it is invalid.
  [[nodiscard]] Validity validate_edge_sample(const JointVector& from, const JointVector& to, int k, int steps, bool certify,
                                              JointVector* at) noexcept;
  //! The model's constraints between the samples of a valid edge (the load chart along it).
  [[nodiscard]] Validity validate_edge_constraints(const JointVector& from, const JointVector& to, JointVector* at) const noexcept;
  [[nodiscard]] bool in_ball(const JointVector& q) const noexcept;
  //! Leaves a clearance ball at q, where the machine is posed and free (unless waiting).
  void add_ball(const JointVector& q) noexcept;
  struct Impl;
  void pose_machine(const JointVector& q) noexcept;

  const MachineModel& model_;
  double dilation_m_ = 0.0;
  double fixed_dilation_m_ = 0.0;
  std::vector<std::string> static_names_;
  std::unique_ptr<Impl> impl_;
  std::uint64_t collision_checks_ = 0;
  ConfigurationRule* rule_ = nullptr;
};

}  // namespace mgc::planning
