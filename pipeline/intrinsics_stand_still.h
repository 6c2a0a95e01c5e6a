// Box 10's stop on the calibration itself, beside Ceres' own on the cost.
#pragma once

#include <array>
#include <vector>

#include <ceres/iteration_callback.h>
#include <Eigen/Core>

#include "pipeline/camera_model.h"

namespace autocal {

// Ends a pass once two successful iterations in a row have each moved the calibration by
// less than `px`: the largest shift, between the intrinsics before and after the step, of
// the image of a 3 x 3 grid of points spanning the image. The cost can go on falling for a
// while after that (the views and the points settling along a valley of their own, 1-3e-5
// of it an iteration on the outdoor walk), while the calibration, which is what an attempt
// hands on, moves by hundredths of a pixel. Only once the cost falls by less than
// kSettledFall an iteration, though: from a wrong start the intrinsics can hold still for
// an iteration or two while the views and the points, still far off, take the cost down by
// percents (stopped there, a synthetic room's solve had not placed its views, and its
// covariance was singular). Needs Solver::Options::update_state_every_iteration.
class IntrinsicsStandStill final : public ceres::IterationCallback {
 public:
  static constexpr double kSettledFall = 1e-3;

  // `intrinsics`: the problem's packed block, read after each iteration; `image`: the
  // calibration whose image the grid spans.
  IntrinsicsStandStill(const double* intrinsics, const CameraIntrinsics& image, double px);

  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override;

 private:
  const double* intrinsics_;
  double px_;
  std::vector<Eigen::Vector2d> grid_;  // Ideal normalized coordinates.
  std::array<double, kNumIntrinsics> last_;
  int still_ = 0;  // Successful iterations in a row that moved it less than px_.
};

}  // namespace autocal
