#include "pipeline/plane_point_cost.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <string>
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
// turns, of both the frame and the plane's reference view.
TEST(PlanePointCost, JacobianAgreesWithCentralDifferences) {
  const std::vector<std::array<double, 6>> poses = {
      {1e-7, -2e-7, 5e-8, 0.05, -0.02, 0.1},
      {0.1, -0.25, 0.05, 0.2, 0.1, 0.3},
      {-0.6, 1.1, 0.4, -0.3, 0.2, 0.5},
  };
  const std::vector<std::array<double, 3>> planes = {
      {0.05, -0.02, 0.5}, {0.3, -0.2, 0.4}, {-0.1, 0.45, 0.2}};
  int checked = 0;
  for (std::array<double, 6> cam : poses) {
    for (std::array<double, 6> reference : poses) {
      for (std::array<double, 3> plane : planes) {
        std::array<double, kNumIntrinsics> intrinsics = Intrinsics();
        std::array<double, 2> ray = {0.31, -0.22};
        const PlanePointCost cost(Eigen::Vector2d(300.0, 250.0));
        std::ostringstream where;
        where << "camera " << cam[0] << " " << cam[1] << " " << cam[2] << ", reference "
              << reference[0] << " " << reference[1] << " " << reference[2] << ", plane "
              << plane[0] << " " << plane[1] << " " << plane[2];
        // Poses that put the point behind the camera are left out.
        if (test::ExpectJacobianMatchesCentralDifferences(
                cost, {intrinsics.data(), cam.data(), reference.data(), plane.data(), ray.data()},
                where.str())) {
          ++checked;
        }
      }
    }
  }
  EXPECT_GE(checked, 15) << "most poses must see the point";
}

TEST(ReferenceRayCost, JacobianAgreesWithCentralDifferences) {
  std::array<double, kNumIntrinsics> intrinsics = Intrinsics();
  for (std::array<double, 2> ray :
       {std::array{0.0, 0.0}, std::array{0.31, -0.22}, std::array{-0.6, 0.45}}) {
    EXPECT_TRUE(test::ExpectJacobianMatchesCentralDifferences(
        ReferenceRayCost(Eigen::Vector2d(300.0, 250.0)), {intrinsics.data(), ray.data()},
        "ray " + std::to_string(ray[0]) + " " + std::to_string(ray[1])));
  }
}

// The residual by hand: the plane z = 2 (m = (0, 0, 0.5)) in view k puts the ray
// (0.25, -0.125) at (0.5, -0.25, 2) there; with no distortion the pixel is f x + c.
TEST(PlanePointCost, ResidualIsThePinholeProjectionWithoutDistortion) {
  std::array<double, kNumIntrinsics> intrinsics{};
  intrinsics[kFx] = 400.0;
  intrinsics[kFy] = 410.0;
  intrinsics[kCx] = 320.0;
  intrinsics[kCy] = 240.0;
  const std::array<double, 6> identity = {0, 0, 0, 0, 0, 0};
  const std::array<double, 3> plane = {0.0, 0.0, 0.5};
  const std::array<double, 2> ray = {0.25, -0.125};
  const PlanePointCost cost(Eigen::Vector2d(100.0, 100.0));
  double residual[2];
  ASSERT_TRUE(cost.Residual(intrinsics.data(), identity.data(), identity.data(), plane.data(),
                            ray.data(), residual));
  EXPECT_NEAR(residual[0], 400.0 * 0.25 + 320.0 - 100.0, 1e-12);
  EXPECT_NEAR(residual[1], 410.0 * -0.125 + 240.0 - 100.0, 1e-12);
  // The camera half a unit to the right of the world: the point at (0, -0.25, 2) in it.
  const std::array<double, 6> right = {0, 0, 0, -0.5, 0, 0};
  ASSERT_TRUE(cost.Residual(intrinsics.data(), right.data(), identity.data(), plane.data(),
                            ray.data(), residual));
  EXPECT_NEAR(residual[0], 320.0 - 100.0, 1e-12);
  EXPECT_NEAR(residual[1], 410.0 * -0.125 + 240.0 - 100.0, 1e-12);
  // View k half a unit to the left of the world instead: the point's world is the same.
  const std::array<double, 6> left = {0, 0, 0, 0.5, 0, 0};
  ASSERT_TRUE(cost.Residual(intrinsics.data(), identity.data(), left.data(), plane.data(),
                            ray.data(), residual));
  EXPECT_NEAR(residual[0], 320.0 - 100.0, 1e-12);
  // Behind the camera, or on the ray's horizon: no residual.
  const std::array<double, 6> beyond = {0, 0, 0, 0, 0, -3.0};
  EXPECT_FALSE(cost.Residual(intrinsics.data(), beyond.data(), identity.data(), plane.data(),
                             ray.data(), residual));
  const std::array<double, 3> edge_on = {0.0, 0.5, 0.0625};  // m . (a, b, 1) = 0.
  EXPECT_FALSE(cost.Residual(intrinsics.data(), identity.data(), identity.data(), edge_on.data(),
                             ray.data(), residual));
}

}  // namespace
}  // namespace autocal
