// Box 10's main residual, with its Jacobian worked out by hand: a tracked point of a plane,
// at (u, v) in the plane's own frame, carried into the world by the plane's pose, into a
// frame's camera by that frame's pose, and through the lens into pixels, against where it
// was tracked. Thousands of these make up a window's problem, and automatic
// differentiation of all 23 parameters at once made their evaluation half of box 10's time.
#pragma once

#include <ceres/sized_cost_function.h>
#include <Eigen/Core>

#include "pipeline/camera_model.h"

namespace autocal {

// Parameters: packed intrinsics (IntrinsicIndex order); cam_from_world and
// world_from_plane, each an angle-axis rotation then a translation; the point's (u, v).
// Evaluation fails for a point on or behind the camera.
class PlanePointCost final : public ceres::SizedCostFunction<2, kNumIntrinsics, 6, 6, 2> {
 public:
  explicit PlanePointCost(const Eigen::Vector2d& pixel) : pixel_(pixel) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  // The residual alone (pixels), false where Evaluate fails.
  bool Residual(const double* intrinsics, const double* cam_from_world,
                const double* world_from_plane, const double* uv, double* residual) const;

 private:
  Eigen::Vector2d pixel_;
};

}  // namespace autocal
