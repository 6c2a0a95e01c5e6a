#include "tests/sim_test_util.h"

#include <cmath>

#include <opencv2/core.hpp>

#include "devices/sim/simulator.h"
#include "devices/sim/trajectory.h"

namespace autocal::test {

Eigen::Isometry3d Pose(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation;
  pose.translation() = translation;
  return pose;
}

Eigen::Isometry3d LookingAt(const Eigen::Vector3d& target, double distance_m, double yaw_deg,
                            double pitch_deg, double roll_deg) {
  const Eigen::Matrix3d world_from_body =
      (Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()) *
       Eigen::AngleAxisd(pitch_deg * M_PI / 180.0, Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(roll_deg * M_PI / 180.0, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  return Pose(world_from_body * BodyFromCam(), target - distance_m * world_from_body.col(0));
}

const cv::Mat& OfficeGreen() {
  static const cv::Mat green = [] {
    Scenario scenario = LoadScenario("office");
    ApplyScenarioOverride(&scenario, "seconds", "0.1");
    cv::Mat channel;
    cv::extractChannel(MakeSimulatedSequence(scenario)->LoadFrame(0), channel, 1);
    return channel;
  }();
  return green;
}

}  // namespace autocal::test
