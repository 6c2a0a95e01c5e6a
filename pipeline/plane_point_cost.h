// Box 10's main residual, with its Jacobian worked out by hand: a tracked point of a plane,
// on the ray through (a, b, 1) of the plane's reference view k, where that ray meets the
// plane m . X = 1 (m in view k's camera), carried into a frame's camera and through the lens
// into pixels, against where it was tracked. A plane and its points so given are the
// homography of view k's image onto the plane: far more nearly linear in the image than a
// plane's pose and points in its own frame (u, v), along which the solves crawled (the
// outdoor walk's ground seen to the horizon: docs/calibration.md, "Outdoors", session 25).
// Thousands of these make up a window's problem, and automatic differentiation made their
// evaluation half of box 10's time.
#pragma once

#include <optional>

#include <ceres/sized_cost_function.h>
#include <Eigen/Core>

#include "pipeline/camera_model.h"

namespace autocal {

// Parameters: packed intrinsics (IntrinsicIndex order); the frame's cam_from_world and
// view k's, each an angle-axis rotation then a translation; m; the point's (a, b).
// Evaluation fails for a point on or behind the frame's camera, or on the ray's horizon.
class PlanePointCost final : public ceres::SizedCostFunction<2, kNumIntrinsics, 6, 6, 3, 2> {
 public:
  explicit PlanePointCost(const Eigen::Vector2d& pixel) : pixel_(pixel) {}
  void set_pixel(const Eigen::Vector2d& pixel) { pixel_ = pixel; }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  // The residual alone (pixels), false where Evaluate fails.
  bool Residual(const double* intrinsics, const double* cam_from_world,
                const double* reference_from_world, const double* plane, const double* ray,
                double* residual) const;

 private:
  Eigen::Vector2d pixel_;
};

// The same point seen from view k itself: the pixel of (a, b), whatever the plane.
class ReferenceRayCost final : public ceres::SizedCostFunction<2, kNumIntrinsics, 2> {
 public:
  explicit ReferenceRayCost(const Eigen::Vector2d& pixel) : pixel_(pixel) {}
  void set_pixel(const Eigen::Vector2d& pixel) { pixel_ = pixel; }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector2d pixel_;
};

// The point of ray (a, b) on plane m, in view k's camera; nullopt on the ray's horizon.
std::optional<Eigen::Vector3d> PointOnRay(const double* plane, const double* ray);

}  // namespace autocal
