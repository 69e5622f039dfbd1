// Fixed obstacles the sheet cannot pass: planes (a table, the floor) and axis-aligned boxes, each with a
// Coulomb friction coefficient (docs/scenario-format.md, "obstacles"). Plain data.
#pragma once

#include <Eigen/Core>

#include <vector>

namespace pt {

struct Obstacle {
  enum class Kind { Plane, Box };
  Kind kind = Kind::Plane;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();       // plane: a point on it
  Eigen::Vector3d normal = Eigen::Vector3d(0, 0, 1);     // plane: the side the sheet stays on (unit once loaded)
  Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();  // box corners, min < max
  double friction = 0.5;                                  // Coulomb μ ≥ 0
};

}  // namespace pt
