#include "pipeline/plane_point_cost.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <vector>

#include <gtest/gtest.h>

#include "tests/test_util.h"

namespace autocal {
namespace {

// A strong barrel with tangential terms, so that every distortion column is exercised.
std::array<double, kNumIntrinsics> Intrinsics() {
  std::array<double, kNumIntrinsics> in{};
  in[kFx] = 431.0;
  in[kFy] = 428.5;
  in[kCx] = 322.0;
  in[kCy] = 236.0;
  in[kK1] = -0.31;
  in[kK2] = 0.12;
  in[kP1] = 0.002;
  in[kP2] = -0.0015;
  in[kK3] = -0.02;
  return in;
}

// The hand-worked Jacobian against central differences of the residual, for poses from
// nearly the identity (where the rotation's derivative takes its series form) to large
// turns.
TEST(PlanePointCost, JacobianAgreesWithCentralDifferences) {
  const std::vector<std::array<double, 6>> cams = {
      {1e-7, -2e-7, 5e-8, 0.05, -0.02, 0.1},
      {0.1, -0.25, 0.05, 0.2, 0.1, 0.3},
      {-0.6, 1.1, 0.4, -0.3, 0.2, 0.5},
  };
  const std::vector<std::array<double, 6>> planes = {
      {0.0, 0.0, 0.0, -0.2, 0.1, 2.0},
      {0.3, -0.2, 0.9, 0.1, -0.3, 2.5},
      {1.4, 0.2, -0.3, 0.4, 0.2, 1.8},
  };
  int checked = 0;
  for (std::array<double, 6> cam : cams) {
    for (std::array<double, 6> plane : planes) {
      std::array<double, kNumIntrinsics> intrinsics = Intrinsics();
      std::array<double, 2> uv = {0.31, -0.22};
      const PlanePointCost cost(Eigen::Vector2d(300.0, 250.0));
      std::ostringstream where;
      where << "camera " << cam[0] << " " << cam[1] << " " << cam[2] << ", plane " << plane[0]
            << " " << plane[1] << " " << plane[2];
      // Poses that put the point behind the camera are left out.
      if (test::ExpectJacobianMatchesCentralDifferences(
              cost, {intrinsics.data(), cam.data(), plane.data(), uv.data()}, where.str())) {
        ++checked;
      }
    }
  }
  EXPECT_GE(checked, 6) << "most poses must see the point";
}

// The residual by hand: a fronto-parallel plane at depth 2 seen by an identity camera puts
// (u, v) at normalized (u / 2, v / 2); with no distortion the pixel is f x + c.
TEST(PlanePointCost, ResidualIsThePinholeProjectionWithoutDistortion) {
  std::array<double, kNumIntrinsics> intrinsics{};
  intrinsics[kFx] = 400.0;
  intrinsics[kFy] = 410.0;
  intrinsics[kCx] = 320.0;
  intrinsics[kCy] = 240.0;
  const std::array<double, 6> cam = {0, 0, 0, 0, 0, 0};
  const std::array<double, 6> plane = {0, 0, 0, 0, 0, 2.0};
  const std::array<double, 2> uv = {0.5, -0.25};
  const PlanePointCost cost(Eigen::Vector2d(100.0, 100.0));
  double residual[2];
  ASSERT_TRUE(cost.Residual(intrinsics.data(), cam.data(), plane.data(), uv.data(), residual));
  EXPECT_NEAR(residual[0], 400.0 * 0.25 + 320.0 - 100.0, 1e-12);
  EXPECT_NEAR(residual[1], 410.0 * -0.125 + 240.0 - 100.0, 1e-12);
  // Behind the camera: no residual.
  const std::array<double, 6> behind = {0, 0, 0, 0, 0, -2.0};
  EXPECT_FALSE(cost.Residual(intrinsics.data(), cam.data(), behind.data(), uv.data(), residual));
}

}  // namespace
}  // namespace autocal
