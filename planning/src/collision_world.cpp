// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/collision_world.hpp"

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/math/bv/OBB.h>
#include <fcl/narrowphase/detail/convexity_based_algorithm/gjk.h>
#include <fcl/narrowphase/detail/convexity_based_algorithm/minkowski_diff.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace mgc::planning {

const char* to_string(ShapeKind kind) noexcept {
  switch (kind) {
    case ShapeKind::Box: return "box";
    case ShapeKind::Cylinder: return "cylinder";
    case ShapeKind::Capsule: return "capsule";
    case ShapeKind::Mesh: return "mesh";
  }
  return "unknown";
}

std::vector<Eigen::Vector3d> box_corners(const Eigen::Isometry3d& pose, const Eigen::Vector3d& size_m) {
  std::vector<Eigen::Vector3d> corners;
  corners.reserve(8);
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d unit((c & 1) ? 0.5 : -0.5, (c & 2) ? 0.5 : -0.5, (c & 4) ? 0.5 : -0.5);
    corners.push_back(pose * unit.cwiseProduct(size_m));
  }
  return corners;
}

std::vector<Eigen::Vector3d> outline_points(const ShapePart& shape, const Eigen::Isometry3d& owner) {
  if (shape.kind == ShapeKind::Mesh) {
    std::vector<Eigen::Vector3d> out;
    out.reserve(shape.vertices_m.size());
    for (const auto& v : shape.vertices_m) out.push_back(owner * shape.pose * v);
    return out;
  }
  Eigen::Vector3d size = shape.size_m;
  if (shape.kind == ShapeKind::Capsule) size.z() += size.x();  // the hemispherical ends
  return box_corners(owner * shape.pose, size);
}

namespace {

using CollisionObject = fcl::CollisionObjectd;

// FCL's GJKSolver_indep defaults.
constexpr unsigned int kGjkMaxIterations = 128;
constexpr double kGjkTolerance = 1e-6;
using GeometryPtr = std::shared_ptr<fcl::CollisionGeometryd>;

bool positive_finite(const Eigen::Vector3d& v) { return v.allFinite() && (v.array() > 0.0).all(); }

GeometryPtr make_geometry(const ShapePart& part) {
  switch (part.kind) {
    case ShapeKind::Box:
      if (!positive_finite(part.size_m)) throw std::invalid_argument("box size must be three positive numbers");
      return std::make_shared<fcl::Boxd>(part.size_m);
    case ShapeKind::Cylinder:
      if (!positive_finite(part.size_m)) throw std::invalid_argument("cylinder radius and length must be positive");
      return std::make_shared<fcl::Cylinderd>(0.5 * part.size_m.x(), part.size_m.z());
    case ShapeKind::Capsule:
      if (!positive_finite(part.size_m)) throw std::invalid_argument("capsule radius and length must be positive");
      return std::make_shared<fcl::Capsuled>(0.5 * part.size_m.x(), part.size_m.z());
    case ShapeKind::Mesh: {
      if (part.triangles.empty()) throw std::invalid_argument("mesh has no triangles");
      const int n = static_cast<int>(part.vertices_m.size());
      for (const auto& v : part.vertices_m) {
        if (!v.allFinite()) throw std::invalid_argument("mesh vertex is not finite");
      }
      std::vector<fcl::Triangle> triangles;
      triangles.reserve(part.triangles.size());
      for (const auto& t : part.triangles) {
        if ((t.array() < 0).any() || (t.array() >= n).any()) {
          throw std::invalid_argument("mesh triangle index outside the vertex list");
        }
        triangles.emplace_back(static_cast<std::size_t>(t.x()), static_cast<std::size_t>(t.y()),
                               static_cast<std::size_t>(t.z()));
      }
      auto model = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
      model->beginModel();
      model->addSubModel(part.vertices_m, triangles);
      model->endModel();
      model->computeLocalAABB();
      return model;
    }
  }
  throw std::invalid_argument("unknown shape kind");
}

// Obstacle indices travel through FCL as user data.
void* encode_index(int index) { return reinterpret_cast<void*>(static_cast<std::intptr_t>(index) + 1); }
int decode_index(void* data) { return static_cast<int>(reinterpret_cast<std::intptr_t>(data) - 1); }

// A CollisionObject whose world AABB is the AABB of its rotated local box, |R| * half extents
// about the rotated centre. FCL's computeAABB() takes the cube around the local box's bounding
// sphere instead, which for a long boom or a pipeline is several times larger; both contain the
// shape, this one is never the larger (each |R| row has unit length), so the broad phase passes
// fewer pairs to the narrow phase and misses none.
class PosedObject final : public CollisionObject {
 public:
  explicit PosedObject(const std::shared_ptr<fcl::CollisionGeometryd>& geometry) : CollisionObject(geometry) {}

  //! The shape, for resizing in place (CollisionWorld::set_dynamic_part_size).
  [[nodiscard]] fcl::CollisionGeometryd* geometry() noexcept { return cgeom.get(); }

  void compute_tight_aabb() noexcept {
    const fcl::AABBd& local = cgeom->aabb_local;
    const Eigen::Vector3d centre = t * local.center();
    const Eigen::Vector3d half = t.linear().cwiseAbs() * (0.5 * (local.max_ - local.min_));
    aabb.min_ = centre - half;
    aabb.max_ = centre + half;
  }
};

// Boxes that bound a primitive and that fit inside it, as half extents in its own frame (FCL's
// shapes are centred, cylinder and capsule along z). [m]
struct BoxBounds {
  Eigen::Vector3d outer;
  Eigen::Vector3d inner;
};

bool box_bounds(const CollisionObject* o, BoxBounds& out) noexcept {
  switch (o->getNodeType()) {
    case fcl::GEOM_BOX: {
      const auto* box = static_cast<const fcl::Boxd*>(o->collisionGeometry().get());
      out.outer = 0.5 * box->side;
      out.inner = out.outer;
      return true;
    }
    case fcl::GEOM_CYLINDER: {
      const auto* c = static_cast<const fcl::Cylinderd*>(o->collisionGeometry().get());
      out.outer = Eigen::Vector3d(c->radius, c->radius, 0.5 * c->lz);
      out.inner = Eigen::Vector3d(c->radius * std::numbers::sqrt2 / 2, c->radius * std::numbers::sqrt2 / 2, 0.5 * c->lz);
      return true;
    }
    case fcl::GEOM_CAPSULE: {
      const auto* c = static_cast<const fcl::Capsuled*>(o->collisionGeometry().get());
      out.outer = Eigen::Vector3d(c->radius, c->radius, 0.5 * c->lz + c->radius);
      out.inner = Eigen::Vector3d(c->radius * std::numbers::sqrt2 / 2, c->radius * std::numbers::sqrt2 / 2, 0.5 * c->lz);
      return true;
    }
    default: return false;
  }
}

// FCL's separating-axis test of two oriented boxes given by half extents in the objects' frames.
// Its 1e-6 padding only ever reports overlap, never separation, for boxes that barely miss.
bool boxes_overlap(const CollisionObject* a, const Eigen::Vector3d& half_a, const CollisionObject* b,
                   const Eigen::Vector3d& half_b) noexcept {
  const Eigen::Matrix3d& ra = a->getTransform().linear();
  const Eigen::Matrix3d relative_rotation = ra.transpose() * b->getTransform().linear();
  const Eigen::Vector3d relative_translation =
      ra.transpose() * (b->getTransform().translation() - a->getTransform().translation());
  return !fcl::obbDisjoint(relative_rotation, relative_translation, half_a, half_b);
}

// Squared distance from the segment p0 + t d, t in [0, 1], to the box |x_i| <= half_i (the
// box's own frame). The distance from a point to the box, sum_i max(|x_i| - half_i, 0)^2, is
// convex along the segment and a quadratic between the at most six t where a coordinate crosses a
// face plane, so its minimum is at one of those t, at an end, or at a piece's own vertex. [m^2]
double segment_box_distance_sq(const Eigen::Vector3d& p0, const Eigen::Vector3d& d, const Eigen::Vector3d& half) noexcept {
  const auto at = [&](double t) {
    double sum = 0.0;
    for (int i = 0; i < 3; ++i) {
      const double out = std::abs(p0[i] + t * d[i]) - half[i];
      if (out > 0.0) sum += out * out;
    }
    return sum;
  };
  std::array<double, 8> cuts{};
  int n = 0;
  cuts[static_cast<std::size_t>(n++)] = 0.0;
  for (int i = 0; i < 3; ++i) {
    if (d[i] == 0.0) continue;
    for (const double side : {-half[i], half[i]}) {
      const double t = (side - p0[i]) / d[i];
      if (t > 0.0 && t < 1.0) cuts[static_cast<std::size_t>(n++)] = t;
    }
  }
  cuts[static_cast<std::size_t>(n++)] = 1.0;
  // Insertion sort: at most eight values.
  for (int a = 1; a < n; ++a) {
    const double v = cuts[static_cast<std::size_t>(a)];
    int b = a;
    for (; b > 0 && cuts[static_cast<std::size_t>(b - 1)] > v; --b) cuts[static_cast<std::size_t>(b)] = cuts[static_cast<std::size_t>(b - 1)];
    cuts[static_cast<std::size_t>(b)] = v;
  }
  double best = std::min(at(0.0), at(1.0));
  for (int k = 0; k + 1 < n; ++k) {
    const double lo = cuts[static_cast<std::size_t>(k)];
    const double hi = cuts[static_cast<std::size_t>(k + 1)];
    if (!(hi > lo)) continue;
    // On this piece each coordinate stays on one side of its faces: the quadratic's vertex.
    const double mid = 0.5 * (lo + hi);
    double a2 = 0.0;
    double b1 = 0.0;
    for (int i = 0; i < 3; ++i) {
      const double x = p0[i] + mid * d[i];
      if (x > half[i]) {
        a2 += d[i] * d[i];
        b1 += (p0[i] - half[i]) * d[i];
      } else if (x < -half[i]) {
        a2 += d[i] * d[i];
        b1 += (p0[i] + half[i]) * d[i];
      }
    }
    const double t = a2 > 0.0 ? std::clamp(-b1 / a2, lo, hi) : lo;
    best = std::min(best, at(t));
  }
  return best;
}

// Distance from the segment centre +- half_axis (world frame) to a posed box. [m]
double segment_box_distance_m(const Eigen::Vector3d& centre, const Eigen::Vector3d& half_axis, const fcl::Transform3d& box_pose,
                              const Eigen::Vector3d& half) noexcept {
  const Eigen::Matrix3d box_t = box_pose.linear().transpose();
  const Eigen::Vector3d p0 = box_t * (centre - half_axis - box_pose.translation());
  const Eigen::Vector3d d = box_t * (2.0 * half_axis);
  return std::sqrt(segment_box_distance_sq(p0, d, half));
}

// Whether a capsule or a cylinder and a box intersect, from the distance between the box and
// the shape's axis: 1 contact, 0 none, -1 left open (to GJK, as before). A capsule is the points
// within its radius of its axis segment, so that distance decides it, except within a band of
// touching where rounding, and GJK's tolerance, could answer either way. A cylinder lies inside
// the capsule on its axis with its radius (apart from that: none) and holds the capsule of
// radius rho = min(radius, length / 2) on its axis shortened by rho at each end (within that:
// contact); between the two it is left open.
int round_box_contact(const CollisionObject* round, const CollisionObject* box_object) noexcept {
  const auto* box = static_cast<const fcl::Boxd*>(box_object->collisionGeometry().get());
  const fcl::Transform3d& pose = round->getTransform();
  double radius_m = 0.0;
  double half_length_m = 0.0;
  const bool capsule = round->getNodeType() == fcl::GEOM_CAPSULE;
  if (capsule) {
    const auto* c = static_cast<const fcl::Capsuled*>(round->collisionGeometry().get());
    radius_m = c->radius;
    half_length_m = 0.5 * c->lz;
  } else {
    const auto* c = static_cast<const fcl::Cylinderd*>(round->collisionGeometry().get());
    radius_m = c->radius;
    half_length_m = 0.5 * c->lz;
  }
  const Eigen::Vector3d axis = pose.linear().col(2);
  const Eigen::Vector3d half = 0.5 * box->side;
  const double band_m =
      1e-6 * (1.0 + (pose.translation() - box_object->getTransform().translation()).norm() + half_length_m + half.sum() + radius_m);
  const double distance_m = segment_box_distance_m(pose.translation(), half_length_m * axis, box_object->getTransform(), half);
  if (distance_m > radius_m + band_m) return 0;
  if (capsule) return distance_m < radius_m - band_m ? 1 : -1;
  const double inner_m = std::min(radius_m, half_length_m);
  const double inner_distance_m =
      segment_box_distance_m(pose.translation(), (half_length_m - inner_m) * axis, box_object->getTransform(), half);
  return inner_distance_m < inner_m - band_m ? 1 : -1;
}

// Yes/no intersection of two posed objects, without touching the heap on the paths our machines
// and primitive obstacles take:
//  - box, cylinder, capsule pairs: the separating-axis test first on boxes around both shapes
//    (apart: no contact) and on boxes inside both (overlapping: contact). For two boxes that is
//    the whole, exact answer; FCL's own box-box path (boxBoxIntersect) fills a local contact
//    vector even when no contacts are requested. A capsule or a cylinder and a box it leaves open
//    are mostly decided by the distance from the round shape's axis to the box
//    (round_box_contact). Pairs still open go to FCL's GJK. Both of
//    FCL's narrow-phase solvers allocate there (libccd builds its shape objects per call, the
//    independent solver always follows an overlap with EPA for the penetration depth), so GJK
//    runs alone: a yes/no answer needs no depth. An iteration limit (Failed) counts as contact,
//    the safe side.
//  - triangle meshes: fcl::collide, which may allocate on contact (documented in the header).
bool intersects(const CollisionObject* a, const CollisionObject* b, const fcl::CollisionRequestd& request,
                fcl::CollisionResultd& result) {
  BoxBounds bounds_a;
  BoxBounds bounds_b;
  if (box_bounds(a, bounds_a) && box_bounds(b, bounds_b)) {
    if (!boxes_overlap(a, bounds_a.outer, b, bounds_b.outer)) return false;
    if (boxes_overlap(a, bounds_a.inner, b, bounds_b.inner)) return true;
    // A hoist line beside a jib or a load, a boom beside a silo: most without GJK's iterations.
    const auto round = [](const CollisionObject* o) {
      return o->getNodeType() == fcl::GEOM_CAPSULE || o->getNodeType() == fcl::GEOM_CYLINDER;
    };
    int contact = -1;
    if (round(a) && b->getNodeType() == fcl::GEOM_BOX) {
      contact = round_box_contact(a, b);
    } else if (a->getNodeType() == fcl::GEOM_BOX && round(b)) {
      contact = round_box_contact(b, a);
    }
    if (contact >= 0) return contact == 1;
  }
  if (a->getObjectType() == fcl::OT_GEOM && b->getObjectType() == fcl::OT_GEOM) {
    // As GJKSolver_indep's shapeIntersect sets it up, minus the EPA stage.
    fcl::detail::MinkowskiDiff<double> difference;
    difference.shapes[0] = static_cast<const fcl::ShapeBased*>(a->collisionGeometry().get());
    difference.shapes[1] = static_cast<const fcl::ShapeBased*>(b->collisionGeometry().get());
    const fcl::Transform3d& tf_a = a->getTransform();
    const fcl::Transform3d& tf_b = b->getTransform();
    difference.toshape1.noalias() = tf_b.linear().transpose() * tf_a.linear();
    difference.toshape0 = tf_a.inverse(Eigen::Isometry) * tf_b;
    fcl::detail::GJK<double> gjk(kGjkMaxIterations, kGjkTolerance);
    return gjk.evaluate(difference, Eigen::Vector3d(-1.0, 0.0, 0.0)) != fcl::detail::GJK<double>::Valid;
  }
  result.clear();
  fcl::collide(a, b, request, result);
  return result.isCollision();
}

struct CollideData {
  const fcl::CollisionRequestd* request = nullptr;
  fcl::CollisionResultd* result = nullptr;
  int hit = -1;
};

bool collide_callback(CollisionObject* a, CollisionObject* b, void* raw) {
  auto* data = static_cast<CollideData*>(raw);
  if (!intersects(a, b, *data->request, *data->result)) return false;
  // The machine body carries no user data; the obstacle does.
  data->hit = decode_index(a->getUserData() != nullptr ? a->getUserData() : b->getUserData());
  return true;
}

struct DistanceData {
  const fcl::DistanceRequestd* request = nullptr;
  fcl::DistanceResultd* result = nullptr;
  double best = std::numeric_limits<double>::infinity();
  int nearest = -1;
};

bool distance_callback(CollisionObject* a, CollisionObject* b, void* raw, double& dist) {
  auto* data = static_cast<DistanceData*>(raw);
  data->result->clear();
  fcl::distance(a, b, *data->request, *data->result);
  const double d = std::max(0.0, data->result->min_distance);
  if (d < data->best) {
    data->best = d;
    data->nearest = decode_index(a->getUserData() != nullptr ? a->getUserData() : b->getUserData());
  }
  dist = data->best;
  return data->best <= 0.0;
}

// Bit-for-bit equality: a pose or size that equal gives every query the same inputs, so the same
// answer (operator== would also match -0.0 with 0.0, and never a NaN with itself).
template <typename Derived>
bool same_bits(const Eigen::DenseBase<Derived>& a, const Eigen::DenseBase<Derived>& b) noexcept {
  static_assert(Derived::SizeAtCompileTime > 0);
  return std::memcmp(a.derived().data(), b.derived().data(), sizeof(double) * Derived::SizeAtCompileTime) == 0;
}

// fcl::AABB::overlap, which FCL's library instantiates out of line: here it inlines.
inline bool aabbs_overlap(const fcl::AABBd& a, const fcl::AABBd& b) noexcept {
  for (int i = 0; i < 3; ++i) {
    if (a.min_[i] > b.max_[i] || a.max_[i] < b.min_[i]) return false;
  }
  return true;
}

// Squared Euclidean distance between two AABBs (FCL's AABB::distance without the root). [m^2]
inline double aabb_distance_sq(const fcl::AABBd& a, const fcl::AABBd& b) noexcept {
  double sum = 0.0;
  for (int i = 0; i < 3; ++i) {
    double gap = a.min_[i] - b.max_[i];
    if (gap <= 0.0) gap = b.min_[i] - a.max_[i];
    if (gap > 0.0) sum += gap * gap;
  }
  return sum;
}

// One body's search for its nearest obstacle below a bound (CollisionWorld::nearest_below).
struct BoundedSearch {
  const CollisionObject* body = nullptr;
  fcl::AABBd body_aabb;
  BoxBounds body_box;
  bool body_has_box = false;
  Eigen::Matrix3d body_rotation_t;  //!< transpose of the body's rotation
  Eigen::Vector3d body_centre;
  const fcl::DistanceRequestd* request = nullptr;
  fcl::DistanceResultd* result = nullptr;
  double best = 0.0;  //!< the bound, then the least distance found [m]
  int nearest = -1;   //!< obstacle index, -1: none below the bound
  const CollisionObject* skip = nullptr;  //!< the hint's obstacle, already measured

  void start(const CollisionObject* b) noexcept {
    body = b;
    body_aabb = b->getAABB();
    body_has_box = box_bounds(b, body_box);
    body_rotation_t = b->getTransform().linear().transpose();
    body_centre = b->getTransform().translation();
    nearest = -1;
  }

  // Whether the body's box grown by best misses the axis-aligned box `box` along one of the body's
  // own axes (so every point of the box is at least best from the body): the first three axes of
  // the separating-axis test, which is all a long boom needs against the frame's subtrees.
  [[nodiscard]] bool box_apart(const fcl::AABBd& box) const noexcept {
    if (!body_has_box || !std::isfinite(best)) return false;
    const Eigen::Vector3d offset = 0.5 * (box.min_ + box.max_) - body_centre;
    const Eigen::Vector3d half = 0.5 * (box.max_ - box.min_);
    for (int i = 0; i < 3; ++i) {
      const auto axis = body_rotation_t.row(i);
      const double reach = body_box.outer[i] + best + axis.cwiseAbs().dot(half.transpose());
      if (std::abs(axis.dot(offset.transpose())) > reach) return true;
    }
    return false;
  }

  // Measures one body-obstacle pair unless its bounding volumes show it no nearer than best.
  // obstacle_first: FCL's argument order as clearance() has it (the broad phase passes the
  // obstacle first, the dynamic parts are measured body first), so the distances are the same.
  void measure(const CollisionObject* obstacle, const fcl::AABBd& obstacle_aabb, int index, bool obstacle_first) noexcept {
    if (best <= 0.0 || obstacle == skip) return;
    if (aabb_distance_sq(body_aabb, obstacle_aabb) >= best * best) return;
    if (box_apart(obstacle_aabb)) return;
    BoxBounds bounds;
    if (body_has_box && std::isfinite(best) && box_bounds(obstacle, bounds)) {
      // The body's box grown by best on every side holds every point within best of the body.
      if (!boxes_overlap(body, body_box.outer + Eigen::Vector3d::Constant(best), obstacle, bounds.outer)) return;
    }
    result->clear();
    if (obstacle_first) {
      fcl::distance(obstacle, body, *request, *result);
    } else {
      fcl::distance(body, obstacle, *request, *result);
    }
    const double d = std::max(0.0, result->min_distance);
    if (d < best) {
      best = d;
      nearest = index;
    }
  }

  // The broad phase's tree, nearer child first; subtrees whose AABB is no nearer than best skipped.
  void search(const fcl::detail::NodeBase<fcl::AABBd>* node) noexcept {
    if (best <= 0.0) return;
    if (node->isLeaf()) {
      const auto* obstacle = static_cast<const CollisionObject*>(node->data);
      measure(obstacle, node->bv, decode_index(obstacle->getUserData()), true);
      return;
    }
    if (box_apart(node->bv)) return;
    const double d0 = aabb_distance_sq(body_aabb, node->children[0]->bv);
    const double d1 = aabb_distance_sq(body_aabb, node->children[1]->bv);
    const int first = d1 < d0 ? 1 : 0;
    if (std::min(d0, d1) < best * best) search(node->children[first]);
    if (std::max(d0, d1) < best * best) search(node->children[1 - first]);
  }
};

// An oriented box: a primitive's outer bounding box, or a mesh's world AABB.
struct OrientedBox {
  Eigen::Matrix3d rotation;
  Eigen::Vector3d centre;
  Eigen::Vector3d half;  //!< half extents along the box's own axes [m]
};

OrientedBox outer_box(const CollisionObject* o) noexcept {
  BoxBounds bounds;
  if (box_bounds(o, bounds)) return {o->getTransform().linear(), o->getTransform().translation(), bounds.outer};
  const fcl::AABBd& aabb = o->getAABB();
  return {Eigen::Matrix3d::Identity(), aabb.center(), 0.5 * (aabb.max_ - aabb.min_)};
}

// A lower bound on the distance between two boxes, no narrow phase: the widest gap between their
// projections on the six face normals. Each projection gap is a distance no point pair beats. [m]
double box_gap_m(const OrientedBox& a, const OrientedBox& b) noexcept {
  const Eigen::Matrix3d m = (a.rotation.transpose() * b.rotation).cwiseAbs();
  const Eigen::Vector3d d = b.centre - a.centre;
  const Eigen::Vector3d in_a = (a.rotation.transpose() * d).cwiseAbs() - a.half - m * b.half;
  const Eigen::Vector3d in_b = (b.rotation.transpose() * d).cwiseAbs() - b.half - m.transpose() * a.half;
  return std::max({0.0, in_a.maxCoeff(), in_b.maxCoeff()});
}

// The least box_gap_m() from one body to the obstacles of the broad phase, searched below a bound:
// subtrees whose AABB is at least the bound away are skipped, their obstacles being no nearer.
struct GapSearch {
  OrientedBox body;
  fcl::AABBd body_aabb;
  double best = 0.0;  //!< the bound, then the least lower bound found [m]

  void measure(const CollisionObject* obstacle, const fcl::AABBd& aabb) noexcept {
    const double aabb_sq = aabb_distance_sq(body_aabb, aabb);
    if (aabb_sq >= best * best) return;
    best = std::min(best, std::max(std::sqrt(aabb_sq), box_gap_m(body, outer_box(obstacle))));
  }
  void search(const fcl::detail::NodeBase<fcl::AABBd>* node) noexcept {
    if (best <= 0.0) return;
    if (node->isLeaf()) {
      measure(static_cast<const CollisionObject*>(node->data), node->bv);
      return;
    }
    const double d0 = aabb_distance_sq(body_aabb, node->children[0]->bv);
    const double d1 = aabb_distance_sq(body_aabb, node->children[1]->bv);
    const int first = d1 < d0 ? 1 : 0;
    if (std::min(d0, d1) < best * best) search(node->children[first]);
    if (std::max(d0, d1) < best * best) search(node->children[1 - first]);
  }
};

}  // namespace

struct CollisionWorld::Impl {
  struct Body {
    std::shared_ptr<fcl::Boxd> box;
    std::shared_ptr<fcl::Capsuled> capsule;
    std::unique_ptr<PosedObject> object;
  };
  struct DynamicPart {
    std::unique_ptr<PosedObject> object;
    Eigen::Isometry3d obstacle_from_part;
  };
  struct Dynamic {
    std::string name;
    std::vector<DynamicPart> parts;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    fcl::AABBd bounds;  //!< around every part's world AABB: a body clear of it is clear of them all
    double reach_m = 0.0;  //!< CollisionWorld::dynamic_reach_m
    //! The first obstacle added before this one with the very same parts (a copy of the same
    //! obstacle for another predicted time), -1 if none.
    int twin = -1;
    bool named_twin = false;  //!< a later obstacle may name this one its twin

    void bound() noexcept {
      bounds = parts.front().object->getAABB();
      for (const auto& part : parts) bounds += part.object->getAABB();
    }
  };

  static constexpr int kUnknown = -2;  //!< a result not yet found
  //! One body's collision results at one exact pose and size (bit for bit, as forward
  //! kinematics gave them). They depend on nothing else the world can change after finalize()
  //! but the dynamic obstacles' poses: the static result holds for good, the dynamic one while
  //! `dynamic_epoch` is the world's.
  struct Result {
    Eigen::Matrix4d pose = Eigen::Matrix4d::Zero();
    Eigen::Vector3d size = Eigen::Vector3d::Zero();
    std::uint64_t stamp = 0;          //!< unique per filling of the slot; 0: empty
    int static_hit = kUnknown;        //!< first static obstacle hit, -1 none
    std::uint64_t dynamic_epoch = 0;  //!< epoch dynamic_hit was found in; 0: not known
    int dynamic_hit = -1;             //!< first dynamic obstacle hit, -1 none
  };
  //! Poses remembered per body: the last few, so a tree node's neighbours tried one after the
  //! other (each moving another joint) still find the unmoved bodies' results.
  static constexpr std::size_t kSlots = 4;
  struct BodyResults {
    std::array<Result, kSlots> slots{};
    std::size_t current = 0;  //!< slot of the body's present pose
    std::size_t next = 0;     //!< slot a new pose replaces (round robin)
  };
  //! A self pair's result for the two bodies' slot stamps.
  struct PairResult {
    std::uint64_t stamp_a = 0;
    std::uint64_t stamp_b = 0;
    bool hit = false;
  };

  std::vector<Body> bodies;
  std::vector<unsigned char> body_moves;  //!< per body, see CollisionWorld::body_moves
  std::vector<BodyResults> results;       //!< per body
  std::vector<PairResult> pair_results;   //!< per MachineModel::self_pairs() entry
  std::uint64_t next_stamp = 1;
  std::uint64_t dynamic_epoch = 1;        //!< advances whenever a dynamic obstacle moves
  bool reuse = true;
  std::uint64_t body_checks = 0;

  //! A clearance ball (CollisionWorld::certify_edges): every configuration whose travel from
  //! `centre` is below `radius_m` is collision free, while the dynamic obstacles are where they
  //! were at `epoch`.
  struct Ball {
    JointVector centre;
    //! Per joint, the model's displacement bound over a joint box around the centre that holds
    //! every configuration the ball can certify (add_ball). [m/rad | m/m]
    JointVector bound;
    double radius_m = 0.0;  //!< 0: empty
    std::uint64_t epoch = 0;
  };
  //! Farthest a ball's radius is searched: larger finds larger balls at more obstacles measured
  //! (2, 4 and 8 m tried on the thesis, tower and excavator sites; 4 m was never the slowest). [m]
  static constexpr double kBallReach_m = 4.0;
  //! Taken off every ball, so that rounding in the bound can never certify a touching pose. [m]
  static constexpr double kBallMargin_m = 1e-4;
  //! Fewest samples certified since the last ball for the next to be made at once; below, the
  //! next waits twice as many fully checked samples as the last wait did, up to kMaxBallWait.
  static constexpr std::uint64_t kBallBreakEven = 2;
  static constexpr int kMaxBallWait = 64;
  bool certify = true;
  std::array<Ball, 8> balls{};
  std::size_t next_ball = 0;
  int ball_wait = 0;       //!< fully checked samples until the next ball
  int ball_backoff = 0;    //!< the last wait
  std::uint64_t certified_samples = 0;
  std::uint64_t certified_at_last_ball = 0;

  void forget_balls() noexcept {
    for (auto& b : balls) b.radius_m = 0.0;
    ball_wait = 0;
    ball_backoff = 0;
  }

  //! Forgets every remembered result (the obstacle set changed).
  void forget() noexcept {
    posed = false;
    for (auto& r : results) r = BodyResults{};
    for (auto& p : pair_results) p = PairResult{};
    forget_balls();
    ++dynamic_epoch;
  }
  //! The slot holding body b's results at its present pose, filled in pose_machine().
  Result& result(std::size_t b) noexcept { return results[b].slots[results[b].current]; }
  //! First static obstacle body b hits at its present pose, -1 if none.
  int static_hit(std::size_t b) noexcept;
  //! First dynamic obstacle body b hits at its present pose, -1 if none.
  int dynamic_hit(std::size_t b) noexcept;
  //! Whether self pair p collides at the two bodies' present poses.
  bool pair_hit(std::size_t p, const SelfPair& pair) noexcept;
  //! Whether dynamic obstacle d stands at the very pose of its twin (identical parts, added
  //! before it), so that every answer about it is its twin's.
  [[nodiscard]] bool stands_on_twin(std::size_t d) const noexcept {
    const int twin = dynamics[d].twin;
    return twin >= 0 && dynamics[d].pose.matrix() == dynamics[static_cast<std::size_t>(twin)].pose.matrix();
  }
  //! The dynamic obstacles of one shape (an obstacle and its copies for predicted times, twins
  //! of the first): the box round all of them, so that a body clear of it skips them all at
  //! once, as a bound over the prediction's whole horizon. Refreshed once per dynamic_epoch.
  struct Group {
    fcl::AABBd bounds;
    int members = 0;
    std::uint64_t query = 0;  //!< the dynamic_hit() call that last tested `bounds`
    bool near = false;        //!< that call's answer: the body's AABB overlaps `bounds`
  };
  std::vector<Group> groups;          //!< indexed by the group's first obstacle
  std::vector<int> group_of;          //!< per dynamic obstacle, its group's first obstacle
  std::vector<unsigned char> on_twin; //!< per dynamic obstacle, stands_on_twin() at groups_epoch
  std::uint64_t groups_epoch = 0;     //!< dynamic_epoch the groups were refreshed at; 0: never
  std::uint64_t dynamic_queries = 0;
  //! Groups, their bounds and the twins' standing, after an obstacle moved or changed shape.
  void refresh_groups() noexcept {
    if (groups_epoch == dynamic_epoch) return;
    for (std::size_t d = 0; d < dynamics.size(); ++d) {
      const int twin = dynamics[d].twin;
      group_of[d] = twin >= 0 ? group_of[static_cast<std::size_t>(twin)] : static_cast<int>(d);
      groups[d].members = 0;
    }
    for (std::size_t d = 0; d < dynamics.size(); ++d) {
      Group& g = groups[static_cast<std::size_t>(group_of[d])];
      g.bounds = g.members == 0 ? dynamics[d].bounds : g.bounds + dynamics[d].bounds;
      ++g.members;
      on_twin[d] = stands_on_twin(d) ? 1 : 0;
    }
    groups_epoch = dynamic_epoch;
  }
  std::vector<std::unique_ptr<PosedObject>> statics;
  std::vector<Dynamic> dynamics;
  std::vector<std::vector<ShapePart>> dynamic_shapes;  //!< each dynamic obstacle's parts as added, to find twins
  fcl::DynamicAABBTreeCollisionManagerd manager;
  bool finalized = false;
  Kinematics kinematics;
  //! The configuration the bodies were last posed at: posing it again changes nothing.
  JointVector posed_q;
  bool posed = false;

  fcl::CollisionRequestd collision_request;
  fcl::CollisionResultd collision_result;
  fcl::DistanceRequestd distance_request;
  fcl::DistanceResultd distance_result;
};

int CollisionWorld::Impl::static_hit(std::size_t b) noexcept {
  Result& r = result(b);
  if (reuse && r.static_hit != kUnknown) return r.static_hit;
  ++body_checks;
  CollideData data{&collision_request, &collision_result, -1};
  manager.collide(bodies[b].object.get(), &data, collide_callback);
  r.static_hit = data.hit;
  return data.hit;
}

int CollisionWorld::Impl::dynamic_hit(std::size_t b) noexcept {
  Result& r = result(b);
  if (reuse && r.dynamic_epoch == dynamic_epoch) return r.dynamic_hit;
  int hit = -1;
  CollisionObject* body = bodies[b].object.get();
  const fcl::AABBd& box = body->getAABB();
  refresh_groups();
  ++dynamic_queries;
  for (std::size_t d = 0; d < dynamics.size() && hit < 0; ++d) {
    // Clear of the box round the obstacle and all its copies: clear of this one.
    Group& group = groups[static_cast<std::size_t>(group_of[d])];
    if (group.members > 1) {
      if (group.query != dynamic_queries) {
        group.query = dynamic_queries;
        group.near = aabbs_overlap(box, group.bounds);
      }
      if (!group.near) continue;
    }
    if (!aabbs_overlap(box, dynamics[d].bounds)) continue;
    // Checked before it and missed: it misses too (the prediction's copies, all posed at the
    // present time while the machine moves out of it).
    if (on_twin[d] != 0) continue;
    for (auto& part : dynamics[d].parts) {
      if (!aabbs_overlap(box, part.object->getAABB())) continue;
      if (intersects(body, part.object.get(), collision_request, collision_result)) {
        hit = static_cast<int>(d);
        break;
      }
    }
  }
  r.dynamic_epoch = dynamic_epoch;
  r.dynamic_hit = hit;
  return hit;
}

bool CollisionWorld::Impl::pair_hit(std::size_t p, const SelfPair& pair) noexcept {
  const auto a = static_cast<std::size_t>(pair.body_a);
  const auto b = static_cast<std::size_t>(pair.body_b);
  PairResult& cached = pair_results[p];
  const std::uint64_t stamp_a = result(a).stamp;
  const std::uint64_t stamp_b = result(b).stamp;
  if (reuse && cached.stamp_a == stamp_a && cached.stamp_b == stamp_b && stamp_a != 0 && stamp_b != 0) return cached.hit;
  CollisionObject* object_a = bodies[a].object.get();
  CollisionObject* object_b = bodies[b].object.get();
  const bool hit = object_a->getAABB().overlap(object_b->getAABB()) &&
                   intersects(object_a, object_b, collision_request, collision_result);
  cached = {stamp_a, stamp_b, hit};
  return hit;
}

CollisionWorld::CollisionWorld(const MachineModel& model, double dilation_m)
    : model_(model), dilation_m_(dilation_m), fixed_dilation_m_(dilation_m), impl_(std::make_unique<Impl>()) {
  if (!(dilation_m >= 0.0) || !std::isfinite(dilation_m)) throw std::invalid_argument("dilation must be >= 0");
  impl_->bodies.reserve(model.bodies().size());
  for (const BodySpec& spec : model.bodies()) {
    Impl::Body body;
    GeometryPtr geometry;
    // Placeholder sizes; pose_machine() sets the real (dilated) ones before every query.
    if (spec.shape == BodyShape::Box) {
      body.box = std::make_shared<fcl::Boxd>(1.0, 1.0, 1.0);
      geometry = body.box;
    } else {
      body.capsule = std::make_shared<fcl::Capsuled>(0.5, 1.0);
      geometry = body.capsule;
    }
    body.object = std::make_unique<PosedObject>(geometry);
    impl_->bodies.push_back(std::move(body));
  }
  impl_->results.resize(impl_->bodies.size());
  impl_->pair_results.resize(model.self_pairs().size());
  // One contact is all a yes/no query needs; the result keeps its buffer across clear().
  impl_->collision_request.num_max_contacts = 1;
  impl_->collision_request.enable_contact = false;
  impl_->collision_request.gjk_solver_type = fcl::GST_INDEP;
  impl_->distance_request.gjk_solver_type = fcl::GST_INDEP;

  // A body is fixed when no joint moves or resizes it: compare its pose and size with every joint
  // at the middle of its range against each joint alone at either limit (continuous joints: a
  // quarter turn either way). Only exact equality counts, so any doubt leaves a body moving.
  const int n = model.dof();
  JointVector middle(n);
  for (int j = 0; j < n; ++j) {
    const JointSpec& spec = model.joints()[static_cast<std::size_t>(j)];
    middle[j] = spec.continuous ? 0.0 : 0.5 * (spec.position_min + spec.position_max);
  }
  Kinematics reference;
  Kinematics moved;
  model.forward_kinematics(middle, reference);
  impl_->body_moves.assign(impl_->bodies.size(), 0);
  for (int j = 0; j < n; ++j) {
    const JointSpec& spec = model.joints()[static_cast<std::size_t>(j)];
    for (const double end : {spec.continuous ? -0.5 * std::numbers::pi : spec.position_min,
                             spec.continuous ? 0.5 * std::numbers::pi : spec.position_max}) {
      JointVector q = middle;
      q[j] = end;
      model.forward_kinematics(q, moved);
      for (std::size_t b = 0; b < impl_->bodies.size(); ++b) {
        const BodyState& a = reference.bodies[b];
        const BodyState& z = moved.bodies[b];
        if (!(a.world_from_body.matrix() == z.world_from_body.matrix()) || !(a.size_m == z.size_m)) impl_->body_moves[b] = 1;
      }
    }
  }
}

CollisionWorld::~CollisionWorld() = default;

int CollisionWorld::add_static(StaticObstacle obstacle) {
  if (impl_->finalized) throw std::logic_error("add_static after finalize");
  auto object = std::make_unique<PosedObject>(make_geometry(obstacle.shape));
  object->setTransform(obstacle.shape.pose);
  object->compute_tight_aabb();
  const int index = static_cast<int>(impl_->statics.size());
  object->setUserData(encode_index(index));
  impl_->statics.push_back(std::move(object));
  static_names_.push_back(std::move(obstacle.name));
  impl_->forget();
  return index;
}

int CollisionWorld::add_dynamic(DynamicObstacle obstacle) {
  if (impl_->finalized) throw std::logic_error("add_dynamic after finalize");
  if (obstacle.parts.empty()) throw std::invalid_argument("dynamic obstacle has no parts");
  const int index = static_cast<int>(impl_->dynamics.size());
  Impl::Dynamic dynamic;
  dynamic.name = std::move(obstacle.name);
  for (const ShapePart& part : obstacle.parts) {
    Impl::DynamicPart p;
    p.object = std::make_unique<PosedObject>(make_geometry(part));
    p.object->setUserData(encode_index(index));
    p.obstacle_from_part = part.pose;
    p.object->setTransform(part.pose);
    p.object->compute_tight_aabb();
    dynamic.parts.push_back(std::move(p));
  }
  dynamic.bound();
  // The corners of each part's own bounding box, in the obstacle's frame.
  for (const Impl::DynamicPart& p : dynamic.parts) {
    const fcl::AABBd& local = p.object->collisionGeometry()->aabb_local;
    for (int corner = 0; corner < 8; ++corner) {
      const Eigen::Vector3d c((corner & 1) != 0 ? local.max_.x() : local.min_.x(), (corner & 2) != 0 ? local.max_.y() : local.min_.y(),
                              (corner & 4) != 0 ? local.max_.z() : local.min_.z());
      dynamic.reach_m = std::max(dynamic.reach_m, (p.obstacle_from_part * c).head<2>().norm());
    }
  }
  const auto same_part = [](const ShapePart& a, const ShapePart& b) {
    return a.kind == b.kind && a.size_m == b.size_m && a.vertices_m == b.vertices_m && a.triangles == b.triangles &&
           a.pose.matrix() == b.pose.matrix();
  };
  for (std::size_t d = 0; d < impl_->dynamic_shapes.size() && dynamic.twin < 0; ++d) {
    const std::vector<ShapePart>& other = impl_->dynamic_shapes[d];
    if (other.size() == obstacle.parts.size() && std::equal(other.begin(), other.end(), obstacle.parts.begin(), same_part)) {
      dynamic.twin = static_cast<int>(d);
      impl_->dynamics[d].named_twin = true;
    }
  }
  impl_->dynamic_shapes.push_back(obstacle.parts);
  impl_->dynamics.push_back(std::move(dynamic));
  impl_->groups.emplace_back();
  impl_->group_of.push_back(index);
  impl_->on_twin.push_back(0);
  impl_->forget();
  return index;
}

void CollisionWorld::finalize() {
  if (impl_->finalized) throw std::logic_error("finalize called twice");
  std::vector<CollisionObject*> objects;
  objects.reserve(impl_->statics.size());
  for (auto& o : impl_->statics) objects.push_back(o.get());
  impl_->manager.registerObjects(objects);
  impl_->manager.setup();
  impl_->collision_result.clear();
  impl_->finalized = true;
  impl_->forget();
}

int CollisionWorld::num_dynamic() const noexcept { return static_cast<int>(impl_->dynamics.size()); }

const std::string& CollisionWorld::dynamic_name(int index) const {
  return impl_->dynamics.at(static_cast<std::size_t>(index)).name;
}

void CollisionWorld::set_dynamic_pose(int index, const Eigen::Isometry3d& world_from_obstacle) noexcept {
  auto& dynamic = impl_->dynamics[static_cast<std::size_t>(index)];
  // Posed where it stands (a parked truck, a crane before or after its slew, the copies the
  // prediction puts past its motion's end): the results remembered and the balls still hold.
  if (dynamic.pose.matrix() == world_from_obstacle.matrix()) return;
  dynamic.pose = world_from_obstacle;
  for (auto& part : dynamic.parts) {
    part.object->setTransform(world_from_obstacle * part.obstacle_from_part);
    part.object->compute_tight_aabb();
  }
  dynamic.bound();
  ++impl_->dynamic_epoch;
}

void CollisionWorld::set_dynamic_part_size(int index, int part, const Eigen::Vector3d& size_m) noexcept {
  if (index < 0 || static_cast<std::size_t>(index) >= impl_->dynamics.size() || !positive_finite(size_m)) return;
  auto& dynamic = impl_->dynamics[static_cast<std::size_t>(index)];
  if (part < 0 || static_cast<std::size_t>(part) >= dynamic.parts.size()) return;
  fcl::CollisionGeometryd* geometry = dynamic.parts[static_cast<std::size_t>(part)].object->geometry();
  switch (geometry->getNodeType()) {
    case fcl::GEOM_BOX: {
      auto* box = static_cast<fcl::Boxd*>(geometry);
      if (box->side == size_m) return;
      box->side = size_m;
      break;
    }
    case fcl::GEOM_CAPSULE: {
      auto* capsule = static_cast<fcl::Capsuled*>(geometry);
      if (capsule->radius == 0.5 * size_m.x() && capsule->lz == size_m.z()) return;
      capsule->radius = 0.5 * size_m.x();
      capsule->lz = size_m.z();
      break;
    }
    case fcl::GEOM_CYLINDER: {
      auto* cylinder = static_cast<fcl::Cylinderd*>(geometry);
      if (cylinder->radius == 0.5 * size_m.x() && cylinder->lz == size_m.z()) return;
      cylinder->radius = 0.5 * size_m.x();
      cylinder->lz = size_m.z();
      break;
    }
    default:
      return;
  }
  geometry->computeLocalAABB();
  dynamic.parts[static_cast<std::size_t>(part)].object->compute_tight_aabb();
  dynamic.bound();
  dynamic.reach_m = 0.0;
  for (const Impl::DynamicPart& p : dynamic.parts) {
    const fcl::AABBd& local = p.object->collisionGeometry()->aabb_local;
    for (int corner = 0; corner < 8; ++corner) {
      const Eigen::Vector3d c((corner & 1) != 0 ? local.max_.x() : local.min_.x(), (corner & 2) != 0 ? local.max_.y() : local.min_.y(),
                              (corner & 4) != 0 ? local.max_.z() : local.min_.z());
      dynamic.reach_m = std::max(dynamic.reach_m, (p.obstacle_from_part * c).head<2>().norm());
    }
  }
  // Twins share every answer; a resized part makes this one a shape of its own.
  dynamic.twin = -1;
  // Once untwinned, nothing names it again: a resize every cycle need not walk every obstacle.
  if (dynamic.named_twin) {
    for (auto& other : impl_->dynamics) {
      if (other.twin == index) other.twin = -1;
    }
    dynamic.named_twin = false;
  }
  ++impl_->dynamic_epoch;
}

const Eigen::Isometry3d& CollisionWorld::dynamic_pose(int index) const noexcept {
  return impl_->dynamics[static_cast<std::size_t>(index)].pose;
}

double CollisionWorld::dynamic_reach_m(int index) const noexcept { return impl_->dynamics[static_cast<std::size_t>(index)].reach_m; }

bool CollisionWorld::dynamic_may_be_within(const JointVector& q, int index, double distance_m) noexcept {
  pose_machine(q);
  const auto& impl = *impl_;
  const Impl::Dynamic& dynamic = impl.dynamics[static_cast<std::size_t>(index)];
  const double limit_sq = distance_m * distance_m;
  for (const auto& body : impl.bodies) {
    const CollisionObject* object = body.object.get();
    // A body this far from the box round all the parts is at least as far from each.
    if (aabb_distance_sq(object->getAABB(), dynamic.bounds) > limit_sq) continue;
    const OrientedBox box = outer_box(object);
    for (const auto& part : dynamic.parts) {
      if (aabb_distance_sq(object->getAABB(), part.object->getAABB()) > limit_sq) continue;
      if (box_gap_m(box, outer_box(part.object.get())) <= distance_m) return true;
    }
  }
  return false;
}

void CollisionWorld::pose_machine(const JointVector& q) noexcept {
  // The way-out search and the checks between the prediction's copies ask about one standing
  // machine again and again while only the obstacles move.
  if (impl_->posed && impl_->posed_q.size() == q.size() &&
      std::memcmp(impl_->posed_q.data(), q.data(), sizeof(double) * static_cast<std::size_t>(q.size())) == 0) {
    return;
  }
  model_.forward_kinematics(q, impl_->kinematics);
  for (std::size_t i = 0; i < impl_->bodies.size(); ++i) {
    const double m = impl_->body_moves.empty() || impl_->body_moves[i] != 0 ? dilation_m_ : fixed_dilation_m_;
    auto& body = impl_->bodies[i];
    const BodyState& state = impl_->kinematics.bodies[i];
    // Shapes are resized in place (FCL primitives are plain data), so a telescoping boom or a
    // paying-out cable needs no new geometry; the local AABB is redone only when a size changed.
    bool resized = false;
    if (body.box) {
      const Eigen::Vector3d side = state.size_m + Eigen::Vector3d::Constant(2.0 * m);
      if (side != body.box->side) {
        body.box->side = side;
        body.box->computeLocalAABB();
        resized = true;
      }
    } else {
      const double radius_m = 0.5 * state.size_m.x() + m;
      const double length_m = state.size_m.z();
      if (radius_m != body.capsule->radius || length_m != body.capsule->lz) {
        body.capsule->radius = radius_m;
        body.capsule->lz = length_m;
        body.capsule->computeLocalAABB();
        resized = true;
      }
    }
    // A body the configuration did not move (the carrier always; whatever sits upstream of the
    // joints an edge moves) keeps its transform and world AABB.
    if (resized || !same_bits(body.object->getTransform().matrix(), state.world_from_body.matrix())) {
      body.object->setTransform(state.world_from_body);
      body.object->compute_tight_aabb();
    }
    // Its results at this exact pose and size, if remembered; else a fresh slot.
    Impl::BodyResults& results = impl_->results[i];
    std::size_t slot = Impl::kSlots;
    for (std::size_t k = 0; k < Impl::kSlots; ++k) {
      const Impl::Result& r = results.slots[(results.current + k) % Impl::kSlots];
      if (r.stamp != 0 && same_bits(r.pose, state.world_from_body.matrix()) && same_bits(r.size, state.size_m)) {
        slot = (results.current + k) % Impl::kSlots;
        break;
      }
    }
    if (slot == Impl::kSlots) {
      slot = results.next;
      results.next = (results.next + 1) % Impl::kSlots;
      Impl::Result& r = results.slots[slot];
      r.pose = state.world_from_body.matrix();
      r.size = state.size_m;
      r.stamp = impl_->next_stamp++;
      r.static_hit = Impl::kUnknown;
      r.dynamic_epoch = 0;
    }
    results.current = slot;
  }
  impl_->posed_q = q;
  impl_->posed = true;
}

bool CollisionWorld::is_free(const JointVector& q, Contact* contact) noexcept {
  ++collision_checks_;
  pose_machine(q);
  auto& impl = *impl_;
  // Body by body, static obstacles then dynamic ones, then the self pairs: the first contact in
  // this order is the one reported. A body at a pose already checked (bit for bit) reuses its
  // results, the dynamic one only while no dynamic obstacle has moved since.
  const int num_bodies = static_cast<int>(impl.bodies.size());
  for (int b = 0; b < num_bodies; ++b) {
    const int hit = impl.static_hit(static_cast<std::size_t>(b));
    if (hit >= 0) {
      if (contact) *contact = {Contact::With::Static, b, hit};
      return false;
    }
    const int dynamic = impl.dynamic_hit(static_cast<std::size_t>(b));
    if (dynamic >= 0) {
      if (contact) *contact = {Contact::With::Dynamic, b, dynamic};
      return false;
    }
  }
  const auto pairs = model_.self_pairs();
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    if (impl.pair_hit(p, pairs[p])) {
      if (contact) *contact = {Contact::With::Self, pairs[p].body_a, pairs[p].body_b};
      return false;
    }
  }
  if (contact) *contact = {};
  return true;
}

bool CollisionWorld::hits_dynamic(const JointVector& q, Contact* contact) noexcept {
  auto& impl = *impl_;
  if (impl.dynamics.empty()) return false;
  ++collision_checks_;
  pose_machine(q);
  for (std::size_t b = 0; b < impl.bodies.size(); ++b) {
    const int dynamic = impl.dynamic_hit(b);
    if (dynamic >= 0) {
      if (contact) *contact = {Contact::With::Dynamic, static_cast<int>(b), dynamic};
      return true;
    }
  }
  return false;
}

Validity CollisionWorld::validate(const JointVector& q) noexcept {
  Validity v = validate_without_collision(q);
  if (v.valid() && !is_free(q, &v.contact)) v.status = Validity::Status::Collision;
  return v;
}

Validity CollisionWorld::validate_without_collision(const JointVector& q) const noexcept {
  Validity v;
  v.joint = model_.joint_out_of_range(q);
  if (v.joint >= 0) {
    v.status = Validity::Status::JointOutOfRange;
    return v;
  }
  v.constraint = model_.check_constraints(q);
  if (!v.constraint.ok()) {
    v.status = Validity::Status::Constraint;
    return v;
  }
  if (rule_ != nullptr && !rule_->allows(q, &v.rule_limit)) v.status = Validity::Status::Rule;
  return v;
}

bool CollisionWorld::in_ball(const JointVector& q) const noexcept {
  const auto& impl = *impl_;
  const std::size_t count = impl.balls.size();
  const int dof = model_.dof();
  const auto& joints = model_.joints();
  // Newest first: a run of samples mostly stays in the ball its last full check left.
  for (std::size_t k = 1; k <= count; ++k) {
    const auto& ball = impl.balls[(impl.next_ball + count - k) % count];
    if (ball.radius_m <= 0.0 || ball.epoch != impl.dynamic_epoch) continue;
    // MachineModel::difference joint by joint, stopping once the travel reaches the radius.
    double travel_m = 0.0;
    for (int i = 0; i < dof && travel_m < ball.radius_m; ++i) {
      const double delta = q[i] - ball.centre[i];
      travel_m += ball.bound[i] * std::abs(joints[static_cast<std::size_t>(i)].continuous ? wrap_angle(delta) : delta);
    }
    if (travel_m < ball.radius_m) return true;
  }
  return false;
}

void CollisionWorld::add_ball(const JointVector& q) noexcept {
  auto& impl = *impl_;
  if (impl.ball_wait > 0) {
    --impl.ball_wait;
    return;
  }
  // Balls that certify little (a bucket working at the ground, a load threading a gap) cost more
  // than the checks they save: wait longer for the next one.
  if (impl.certified_samples - impl.certified_at_last_ball < Impl::kBallBreakEven) {
    impl.ball_backoff = std::min(std::max(1, 2 * impl.ball_backoff), Impl::kMaxBallWait);
  } else {
    impl.ball_backoff = 0;
  }
  impl.ball_wait = impl.ball_backoff;
  impl.certified_at_last_ball = impl.certified_samples;

  // The machine is posed at q, which was just found free. Every body point moves at most the
  // travel, so a moving body clears every obstacle while the travel stays below its distance to
  // it; both bodies of a self pair may move, so their gap closes at most twice as fast. Bodies
  // that no joint moves stay where they were found free.
  double radius_m = Impl::kBallReach_m;
  GapSearch search;
  const auto* root = impl.manager.getTree().getRoot();
  for (std::size_t b = 0; b < impl.bodies.size() && radius_m > 0.0; ++b) {
    if (impl.body_moves[b] == 0) continue;
    const CollisionObject* body = impl.bodies[b].object.get();
    search.body = outer_box(body);
    search.body_aabb = body->getAABB();
    search.best = radius_m;
    if (root != nullptr) search.search(root);
    for (std::size_t d = 0; d < impl.dynamics.size(); ++d) {
      const auto& dynamic = impl.dynamics[d];
      // Every part lies inside the obstacle's box, so no part is nearer than it; a copy on its
      // twin, measured before it, gives the same gaps again.
      if (aabb_distance_sq(search.body_aabb, dynamic.bounds) >= search.best * search.best) continue;
      if (impl.stands_on_twin(d)) continue;
      for (const auto& part : dynamic.parts) search.measure(part.object.get(), part.object->getAABB());
    }
    radius_m = search.best;
  }
  for (const SelfPair& pair : model_.self_pairs()) {
    const auto a = static_cast<std::size_t>(pair.body_a);
    const auto b = static_cast<std::size_t>(pair.body_b);
    if (impl.body_moves[a] == 0 && impl.body_moves[b] == 0) continue;
    const CollisionObject* object_a = impl.bodies[a].object.get();
    const CollisionObject* object_b = impl.bodies[b].object.get();
    const double gap_m = std::max(std::sqrt(aabb_distance_sq(object_a->getAABB(), object_b->getAABB())),
                                  box_gap_m(outer_box(object_a), outer_box(object_b)));
    radius_m = std::min(radius_m, 0.5 * gap_m);
  }
  radius_m -= Impl::kBallMargin_m;
  if (radius_m <= 0.0) return;
  auto& ball = impl.balls[impl.next_ball];
  impl.next_ball = (impl.next_ball + 1) % impl.balls.size();
  ball.centre = q;
  ball.radius_m = radius_m;
  ball.epoch = impl.dynamic_epoch;
  // The bound is taken over the box q +- radius / (the bound at q) per joint, within the joint
  // ranges. A box bound is nowhere below the bound at q, so a configuration whose travel under it
  // is below the radius moves no joint past the box's half width: it and its straight edge from
  // q lie in the box, where the bound holds. Tighter than the global bound wherever the boom is
  // short or steep.
  JointVector lo = q;
  JointVector hi = q;
  for (int i = 0; i < model_.dof(); ++i) {
    const JointSpec& joint = model_.joints()[static_cast<std::size_t>(i)];
    const double half_width = radius_m / model_.box_displacement_bound(q, q, i);
    lo[i] = q[i] - half_width;
    hi[i] = q[i] + half_width;
    if (!joint.continuous) {
      lo[i] = std::max(lo[i], joint.position_min);
      hi[i] = std::min(hi[i], joint.position_max);
    }
  }
  ball.bound.resize(model_.dof());
  for (int i = 0; i < model_.dof(); ++i) ball.bound[i] = model_.box_displacement_bound(lo, hi, i);
}

int CollisionWorld::edge_samples(const JointVector& from, const JointVector& to, const JointVector& max_step) const noexcept {
  const JointVector delta = model_.difference(from, to);
  int steps = std::max(1, model_.edge_min_samples(from, to));
  double travel = 0.0;
  for (int i = 0; i < model_.dof(); ++i) {
    steps = std::max(steps, static_cast<int>(std::ceil(std::abs(delta[i]) / max_step[i] - 1e-12)));
    travel += model_.edge_displacement_bound(from, to, i) * std::abs(delta[i]);
  }
  // No body point may move more than the dilation between two samples: then every point of the
  // continuous motion lies within half the dilation of a sampled pose.
  if (dilation_m_ > 0.0) steps = std::max(steps, static_cast<int>(std::ceil(travel / dilation_m_ - 1e-12)));
  return steps;
}

Validity CollisionWorld::validate_edge_sample(const JointVector& from, const JointVector& to, int k, int steps, bool certify,
                                              JointVector* at) noexcept {
  const JointVector q = k == steps ? to : model_.interpolate(from, to, static_cast<double>(k) / steps);
  const bool certified = certify && in_ball(q);
  Validity v = certified ? validate_without_collision(q) : validate(q);
  if (!v.valid()) {
    if (at) *at = q;
    return v;
  }
  if (certified) {
    ++impl_->certified_samples;
  } else if (certify) {
    add_ball(q);
  }
  return v;
}

Validity CollisionWorld::validate_edge_constraints(const JointVector& from, const JointVector& to, JointVector* at) const noexcept {
  // Every sample passed; the constraints between them as well (a load-chart row entered below its
  // angle in a slice thinner than a step).
  double t_constraint = 1.0;
  const ConstraintVerdict along = model_.check_edge_constraints(from, to, t_constraint);
  if (!along.ok()) {
    Validity v;
    v.status = Validity::Status::Constraint;
    v.constraint = along;
    if (at) *at = model_.interpolate(from, to, t_constraint);
    return v;
  }
  return {};
}

Validity CollisionWorld::validate_edge(const JointVector& from, const JointVector& to, const JointVector& max_step,
                                       JointVector* at) noexcept {
  const int steps = edge_samples(from, to, max_step);
  const bool certify = certifies_edges();
  for (int k = 1; k <= steps; ++k) {
    const Validity v = validate_edge_sample(from, to, k, steps, certify, at);
    if (!v.valid()) return v;
  }
  return validate_edge_constraints(from, to, at);
}

bool CollisionWorld::edge_valid(const JointVector& from, const JointVector& to, const JointVector& max_step) noexcept {
  const int steps = edge_samples(from, to, max_step);
  const bool certify = certifies_edges();
  // Every kCoarseStride-th sample first: an obstacle across the edge blocks a stretch of samples,
  // which this finds after a few checks where walking from `from` would check all before it.
  const bool coarse = steps >= 2 * kCoarseStride;
  if (coarse) {
    for (int k = kCoarseStride; k <= steps; k += kCoarseStride) {
      if (!validate_edge_sample(from, to, k, steps, certify, nullptr).valid()) return false;
    }
  }
  for (int k = 1; k <= steps; ++k) {
    if (coarse && k % kCoarseStride == 0) continue;
    if (!validate_edge_sample(from, to, k, steps, certify, nullptr).valid()) return false;
  }
  return validate_edge_constraints(from, to, nullptr).valid();
}

void CollisionWorld::reuse_results(bool on) noexcept {
  impl_->reuse = on;
  impl_->forget();
}

void CollisionWorld::forget_results() noexcept { impl_->forget(); }

bool CollisionWorld::reuses_results() const noexcept { return impl_->reuse; }

void CollisionWorld::certify_edges(bool on) noexcept {
  impl_->certify = on;
  impl_->forget_balls();
}

bool CollisionWorld::certifies_edges() const noexcept { return impl_->certify && model_.displacement_bound_is_strict(); }

std::uint64_t CollisionWorld::certified_samples() const noexcept { return impl_->certified_samples; }

std::uint64_t CollisionWorld::body_checks() const noexcept { return impl_->body_checks; }

void CollisionWorld::set_fixed_body_dilation(double dilation_m) {
  if (!(dilation_m >= 0.0) || !std::isfinite(dilation_m)) throw std::invalid_argument("fixed body dilation must be >= 0");
  fixed_dilation_m_ = dilation_m;
  impl_->posed = false;
  impl_->forget_balls();
}

bool CollisionWorld::body_moves(int body) const noexcept { return impl_->body_moves[static_cast<std::size_t>(body)] != 0; }

Clearance CollisionWorld::clearance(const JointVector& q, Bodies bodies, Obstacles obstacles) noexcept {
  Clearance c;
  if (bodies == Bodies::Fixed) {
    pose_machine(q);
  } else {
    Contact contact;
    if (!is_free(q, &contact)) {
      c.distance_m = 0.0;
      c.body = contact.body;
      c.with = contact.with;
      c.other = contact.other;
      return c;
    }
  }
  auto& impl = *impl_;
  c.distance_m = std::numeric_limits<double>::infinity();
  for (std::size_t b = 0; b < impl.bodies.size(); ++b) {
    if (bodies != Bodies::All && (impl.body_moves[b] != 0) != (bodies == Bodies::Moving)) continue;
    CollisionObject* body = impl.bodies[b].object.get();
    if (obstacles != Obstacles::Dynamic) {
      DistanceData data{&impl.distance_request, &impl.distance_result};
      impl.manager.distance(body, &data, distance_callback);
      if (data.nearest >= 0 && data.best < c.distance_m) {
        c = {data.best, static_cast<int>(b), Contact::With::Static, data.nearest};
      }
    }
    if (obstacles == Obstacles::Static) continue;
    for (std::size_t d = 0; d < impl.dynamics.size(); ++d) {
      for (auto& part : impl.dynamics[d].parts) {
        impl.distance_result.clear();
        fcl::distance(body, part.object.get(), impl.distance_request, impl.distance_result);
        const double dist = std::max(0.0, impl.distance_result.min_distance);
        if (dist < c.distance_m) c = {dist, static_cast<int>(b), Contact::With::Dynamic, static_cast<int>(d)};
      }
    }
  }
  return c;
}

CollisionWorld::NearestBelow CollisionWorld::nearest_below(const JointVector& q, Bodies bodies, double static_bound_m,
                                                          double dynamic_bound_m, const NearestBelow* hint) noexcept {
  pose_machine(q);
  auto& impl = *impl_;
  NearestBelow out;
  out.static_obstacle.distance_m = std::max(0.0, static_bound_m);
  out.dynamic_obstacle.distance_m = std::max(0.0, dynamic_bound_m);
  if (bodies != Bodies::Fixed) {
    // A self pair's verdict at these two poses is remembered where a query already found it (the
    // stop check and the meet scan ask about a machine that has not moved since).
    const auto pairs = model_.self_pairs();
    for (std::size_t p = 0; p < pairs.size(); ++p) {
      if (impl.pair_hit(p, pairs[p])) {
        out.static_obstacle = {0.0, pairs[p].body_a, Contact::With::Self, pairs[p].body_b};
        out.dynamic_obstacle = out.static_obstacle;
        return out;
      }
    }
  }
  const auto chosen = [&](int b) {
    return b >= 0 && b < static_cast<int>(impl.bodies.size()) &&
           (bodies == Bodies::All || (impl.body_moves[static_cast<std::size_t>(b)] != 0) == (bodies == Bodies::Moving));
  };
  BoundedSearch s;
  s.request = &impl.distance_request;
  s.result = &impl.distance_result;
  const auto take = [&](int b, Contact::With with, Clearance& into) {
    if (s.nearest >= 0) into = {s.best, b, with, s.nearest};
  };
  const auto* root = impl.manager.getTree().getRoot();

  // Static obstacles: the hinted pair first, then every chosen body's search from the best so far.
  if (static_bound_m > 0.0 && root != nullptr) {
    s.best = static_bound_m;
    const Clearance* h = hint != nullptr ? &hint->static_obstacle : nullptr;
    const CollisionObject* hinted = nullptr;
    if (h != nullptr && h->with == Contact::With::Static && chosen(h->body) && h->other >= 0 &&
        h->other < static_cast<int>(impl.statics.size())) {
      hinted = impl.statics[static_cast<std::size_t>(h->other)].get();
      s.start(impl.bodies[static_cast<std::size_t>(h->body)].object.get());
      s.measure(hinted, hinted->getAABB(), h->other, true);
      take(h->body, Contact::With::Static, out.static_obstacle);
    }
    for (int b = 0; b < static_cast<int>(impl.bodies.size()) && s.best > 0.0; ++b) {
      if (!chosen(b)) continue;
      s.start(impl.bodies[static_cast<std::size_t>(b)].object.get());
      s.skip = h != nullptr && h->body == b ? hinted : nullptr;
      s.search(root);
      s.skip = nullptr;
      take(b, Contact::With::Static, out.static_obstacle);
    }
  }
  // Dynamic obstacles: few parts, each pair behind the same bounding-volume tests.
  if (dynamic_bound_m > 0.0 && !impl.dynamics.empty()) {
    s.best = dynamic_bound_m;
    const auto measure_dynamic = [&](int d) {
      for (auto& part : impl.dynamics[static_cast<std::size_t>(d)].parts) {
        s.measure(part.object.get(), part.object->getAABB(), d, false);
      }
    };
    const Clearance* h = hint != nullptr ? &hint->dynamic_obstacle : nullptr;
    if (h != nullptr && h->with == Contact::With::Dynamic && chosen(h->body) && h->other >= 0 &&
        h->other < static_cast<int>(impl.dynamics.size())) {
      s.start(impl.bodies[static_cast<std::size_t>(h->body)].object.get());
      measure_dynamic(h->other);
      take(h->body, Contact::With::Dynamic, out.dynamic_obstacle);
    }
    for (int b = 0; b < static_cast<int>(impl.bodies.size()) && s.best > 0.0; ++b) {
      if (!chosen(b)) continue;
      s.start(impl.bodies[static_cast<std::size_t>(b)].object.get());
      for (int d = 0; d < static_cast<int>(impl.dynamics.size()); ++d) measure_dynamic(d);
      take(b, Contact::With::Dynamic, out.dynamic_obstacle);
    }
  }
  return out;
}

std::string CollisionWorld::describe(const Contact& contact) const {
  const auto body_name = [&](int i) {
    return i >= 0 && i < static_cast<int>(model_.bodies().size()) ? model_.bodies()[static_cast<std::size_t>(i)].name
                                                                    : std::string("?");
  };
  switch (contact.with) {
    case Contact::With::Nothing: return "no contact";
    case Contact::With::Static: return body_name(contact.body) + " hits obstacle '" + static_name(contact.other) + "'";
    case Contact::With::Dynamic:
      return body_name(contact.body) + " hits dynamic obstacle '" + dynamic_name(contact.other) + "'";
    case Contact::With::Self: return body_name(contact.body) + " hits the machine's own " + body_name(contact.other);
  }
  return "unknown contact";
}

std::string CollisionWorld::describe(const Validity& validity) const {
  switch (validity.status) {
    case Validity::Status::Valid: return "valid";
    case Validity::Status::JointOutOfRange: {
      const JointSpec& j = model_.joints()[static_cast<std::size_t>(validity.joint)];
      return "joint '" + j.name + "' outside its range";
    }
    case Validity::Status::Constraint: return std::string("engineering constraint: ") + to_string(validity.constraint.status);
    case Validity::Status::Collision: return "collision: " + describe(validity.contact);
    case Validity::Status::Rule: return rule_ != nullptr ? rule_->describe(validity.rule_limit) : "refused by a configuration rule";
  }
  return "unknown";
}

}  // namespace mgc::planning
