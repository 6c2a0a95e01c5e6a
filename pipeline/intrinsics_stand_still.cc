#include "pipeline/intrinsics_stand_still.h"

#include <algorithm>
#include <cmath>

namespace autocal {

IntrinsicsStandStill::IntrinsicsStandStill(const double* intrinsics, const CameraIntrinsics& image,
                                           double px)
    : intrinsics_(intrinsics), px_(px) {
  for (double u : {0.0, 0.5, 1.0}) {
    for (double v : {0.0, 0.5, 1.0}) {
      grid_.emplace_back((u * (image.width - 1) - image.cx) / image.fx,
                         (v * (image.height - 1) - image.cy) / image.fy);
    }
  }
  std::copy_n(intrinsics, kNumIntrinsics, last_.begin());
}

ceres::CallbackReturnType IntrinsicsStandStill::operator()(const ceres::IterationSummary& summary) {
  if (summary.iteration == 0 || !summary.step_is_successful) return ceres::SOLVER_CONTINUE;
  double shift = 0.0;
  for (const Eigen::Vector2d& x : grid_) {
    double before[2], after[2];
    ProjectNormalized(last_.data(), x.x(), x.y(), before, nullptr, nullptr);
    ProjectNormalized(intrinsics_, x.x(), x.y(), after, nullptr, nullptr);
    shift = std::max(shift, std::hypot(after[0] - before[0], after[1] - before[1]));
  }
  std::copy_n(intrinsics_, kNumIntrinsics, last_.begin());
  const double fall = summary.cost_change / (summary.cost + summary.cost_change);
  still_ = shift < px_ && fall < kSettledFall ? still_ + 1 : 0;
  return still_ >= 2 ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
}

}  // namespace autocal
