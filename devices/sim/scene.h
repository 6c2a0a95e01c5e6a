// Piecewise-planar textured scenes: every plane is a textured rectangle in 3-D with an id
// (1..N; 0 means nothing, the sky). Built procedurally and deterministically from the seed.
#pragma once

#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "devices/sim/scenario.h"
#include "devices/sim/texture.h"

namespace autocal {

// A rectangle {origin + a axis_u + b axis_v : 0 <= a < width_m, 0 <= b < height_m}. It is
// seen from the side its normal points to, where u runs to the right and v down, like an
// image on a wall; texture columns follow u, rows follow v.
struct Plane {
  int id = 0;                                         // 1..N, the value in plane-label images.
  std::string name;                                   // "floor", "wall_north", "box1_top", ...
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();   // World position of (a, b) = (0, 0).
  Eigen::Vector3d axis_u = Eigen::Vector3d::UnitX();  // Unit vector.
  Eigen::Vector3d axis_v = Eigen::Vector3d::UnitY();  // Unit vector, orthogonal to axis_u.
  double width_m = 1.0;                               // Extent along axis_u.
  double height_m = 1.0;                              // Extent along axis_v.
  int texture = 0;                                    // Index into Scene::textures.
  float shade = 1.0f;                                 // Lighting: factor on the texture's colour.
  // A moving plane (a side of a walking person): at t seconds after the first frame its
  // origin is origin + velocity_mps * t, and it is in the scene only for from_s <= t < until_s.
  Eigen::Vector3d velocity_mps = Eigen::Vector3d::Zero();
  double from_s = -std::numeric_limits<double>::infinity();
  double until_s = std::numeric_limits<double>::infinity();

  // Unit normal toward the side the plane is seen from.
  Eigen::Vector3d normal() const { return axis_v.cross(axis_u); }
  // At t = 0 for a moving plane.
  Eigen::Vector3d Point(double a, double b) const { return origin + a * axis_u + b * axis_v; }
  bool moves() const { return !velocity_mps.isZero(); }
  bool PresentAt(double t_s) const { return t_s >= from_s && t_s < until_s; }
  Eigen::Vector3d OriginAt(double t_s) const { return origin + velocity_mps * t_s; }
};

struct Scene {
  std::string name;
  std::vector<Plane> planes;  // Plane i has id i + 1.
  std::vector<Texture> textures;
  cv::Vec3f background{0.f, 0.f, 0.f};  // BGR where no plane is hit (the sky outdoors).
};

// "office", "corridor", "outdoor", "checkerboard".
std::vector<std::string> SceneNames();

// The scenario's scene, with its people (Scenario::people) after the scene's own planes.
// Scenes are cached by their parameters, so sequences of the same scene share textures.
// Throws Error for an unknown scene.
std::shared_ptr<const Scene> BuildScene(const Scenario& scenario);

// The checkerboard scene: the board lies in the plane x = kCheckerboardDistanceM facing the
// origin, centred at height 1 m, with a white margin of one square; square (i, j) covers
// plane coordinates [(i + 1) s, (i + 2) s) x [(j + 1) s, (j + 2) s), s = square_m, and is
// black when i + j is even. Inner corner (i, j), i < squares_x - 1, j < squares_y - 1, is
// at ((i + 2) s, (j + 2) s).
inline constexpr double kCheckerboardDistanceM = 0.5;

}  // namespace autocal
