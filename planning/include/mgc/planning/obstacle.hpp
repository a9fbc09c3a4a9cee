// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <string>
#include <vector>

namespace mgc::planning {

enum class ShapeKind : std::uint8_t {
  Box,       //!< size_m = full extents along x, y, z
  Cylinder,  //!< size_m = (2 r, 2 r, length along z)
  Capsule,   //!< size_m = (2 r, 2 r, length of the cylindrical part along z)
  Mesh,      //!< triangles over vertices_m
};

[[nodiscard]] const char* to_string(ShapeKind kind) noexcept;

//! One rigid shape and its pose relative to its owner (the world for a static obstacle, the
//! obstacle's own frame for a part of a dynamic one).
struct ShapePart {
  ShapeKind kind = ShapeKind::Box;
  Eigen::Vector3d size_m = Eigen::Vector3d::Ones();              //!< see ShapeKind [m]
  std::vector<Eigen::Vector3d> vertices_m;                       //!< Mesh only [m]
  std::vector<Eigen::Vector3i> triangles;                        //!< Mesh only, indices into vertices_m
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();        //!< owner_from_shape
};

//! The 8 corners of a box of full extents `size_m` placed by `pose`. [m]
[[nodiscard]] std::vector<Eigen::Vector3d> box_corners(const Eigen::Isometry3d& pose, const Eigen::Vector3d& size_m);

//! The points that outline a shape in drawings: a mesh's vertices, else the corners of the
//! shape's bounding box (a capsule's with its hemispherical ends), placed by owner * shape.pose. [m]
[[nodiscard]] std::vector<Eigen::Vector3d> outline_points(const ShapePart& shape,
                                                          const Eigen::Isometry3d& owner = Eigen::Isometry3d::Identity());

//! A fixed obstacle of the site: one shape placed in the world.
struct StaticObstacle {
  std::string name;
  ShapePart shape;
};

//! An obstacle that moves as one rigid body (a second crane, a truck, a worker): its parts are
//! fixed in its own frame, and its pose in the world changes every cycle.
struct DynamicObstacle {
  std::string name;
  std::vector<ShapePart> parts;
};

}  // namespace mgc::planning
