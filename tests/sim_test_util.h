// Poses and images for tests that render the simulator's scenes.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

namespace autocal::test {

Eigen::Isometry3d Pose(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation);

// World-from-camera pose of a camera `distance_m` from `target`, looking at it along world
// +x turned by yaw (about z, left positive), pitch (down positive) and roll (about the
// optical axis, clockwise in the image positive).
Eigen::Isometry3d LookingAt(const Eigen::Vector3d& target, double distance_m, double yaw_deg,
                            double pitch_deg, double roll_deg = 0.0);

// The green channel of the simulated office walk's first frame (640x480): a textured
// image to warp in known ways. Rendered once.
const cv::Mat& OfficeGreen();

}  // namespace autocal::test
