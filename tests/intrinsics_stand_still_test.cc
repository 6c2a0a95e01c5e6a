#include "pipeline/intrinsics_stand_still.h"

#include <array>

#include <gtest/gtest.h>

#include "tests/test_util.h"

namespace autocal {
namespace {

// Drives the callback as Ceres would: each step moves the packed intrinsics, then reports
// whether it was taken and how much it took off the cost.
class StandStillDriver {
 public:
  explicit StandStillDriver(double px)
      : camera_(test::SonnarLikeCamera(-0.3, 0.1)),
        intrinsics_(camera_.Packed()),
        stop_(intrinsics_.data(), camera_, px) {
    ceres::IterationSummary start;
    start.iteration = 0;
    EXPECT_EQ(stop_(start), ceres::SOLVER_CONTINUE);
  }

  // A step that moves fx by `dfx` px and takes `fall` of the cost off.
  ceres::CallbackReturnType Step(double dfx, double fall, bool successful = true) {
    ceres::IterationSummary step;
    step.iteration = ++iteration_;
    step.step_is_successful = successful;
    if (successful) intrinsics_[kFx] += dfx;
    step.cost = 100.0 * (1.0 - fall);
    step.cost_change = 100.0 * fall;
    return stop_(step);
  }

 private:
  CameraIntrinsics camera_;
  std::array<double, kNumIntrinsics> intrinsics_;
  IntrinsicsStandStill stop_;
  int iteration_ = 0;
};

// fx moved by d px shifts the image's corner (0.75 in normalized x, the sonnar's barrel
// taking it to about 0.62) by about 0.62 d: 0.02 px of fx moves it 0.012 px, 0.05 px 0.031.
TEST(IntrinsicsStandStill, StopsAfterTwoStillIterationsInARow) {
  StandStillDriver driver(0.02);
  EXPECT_EQ(driver.Step(5.0, 0.2), ceres::SOLVER_CONTINUE);
  EXPECT_EQ(driver.Step(0.02, 1e-5), ceres::SOLVER_CONTINUE) << "one still iteration";
  EXPECT_EQ(driver.Step(0.02, 1e-5), ceres::SOLVER_TERMINATE_SUCCESSFULLY) << "two in a row";
}

TEST(IntrinsicsStandStill, AMoveInBetweenStartsTheCountAgain) {
  StandStillDriver driver(0.02);
  EXPECT_EQ(driver.Step(0.02, 1e-5), ceres::SOLVER_CONTINUE);
  EXPECT_EQ(driver.Step(0.05, 1e-5), ceres::SOLVER_CONTINUE) << "0.031 px at the corner";
  EXPECT_EQ(driver.Step(0.02, 1e-5), ceres::SOLVER_CONTINUE);
  EXPECT_EQ(driver.Step(0.02, 1e-5), ceres::SOLVER_TERMINATE_SUCCESSFULLY);
}

TEST(IntrinsicsStandStill, RejectedStepsNeitherCountNorBreakTheCount) {
  StandStillDriver driver(0.02);
  EXPECT_EQ(driver.Step(0.02, 1e-5), ceres::SOLVER_CONTINUE);
  EXPECT_EQ(driver.Step(0.0, -0.05, false), ceres::SOLVER_CONTINUE);
  EXPECT_EQ(driver.Step(0.0, -0.05, false), ceres::SOLVER_CONTINUE);
  EXPECT_EQ(driver.Step(0.02, 1e-5), ceres::SOLVER_TERMINATE_SUCCESSFULLY);
}

// From a wrong start the views and points can take the cost down while the intrinsics
// hold still: not a stop.
TEST(IntrinsicsStandStill, NoStopWhileTheCostStillFallsByMoreThanATenthOfAPercent) {
  StandStillDriver driver(0.02);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(driver.Step(0.0, 0.05), ceres::SOLVER_CONTINUE) << "iteration " << i;
  }
  EXPECT_EQ(driver.Step(0.0, 2e-3), ceres::SOLVER_CONTINUE);
  EXPECT_EQ(driver.Step(0.0, 5e-4), ceres::SOLVER_CONTINUE);
  EXPECT_EQ(driver.Step(0.0, 5e-4), ceres::SOLVER_TERMINATE_SUCCESSFULLY);
}

}  // namespace
}  // namespace autocal
