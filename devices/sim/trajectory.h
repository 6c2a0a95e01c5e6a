// The camera's path through the scene: a walking vest wearer (a closed Fourier-series path
// with step bob, sway, head scanning, pitch and roll) or a camera at rest. Positions are
// analytic, so velocity and acceleration are exact, not differentiated numerically.
// The accelerometer sits at the camera's optical centre.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "devices/sim/scenario.h"

namespace autocal {

// Camera state at one moment, world frame (z up).
struct BodyState {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();      // Optical centre, m.
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();      // m/s.
  Eigen::Vector3d acceleration = Eigen::Vector3d::Zero();  // m/s^2.
  Eigen::Matrix3d world_from_cam = Eigen::Matrix3d::Identity();
};

// The nominal body frame is x forward, y left, z up; the camera frame is OpenCV's
// (x right, y down, z forward). This rotation takes camera vectors to body vectors.
Eigen::Matrix3d BodyFromCam();

class Trajectory {
 public:
  // The walk or rest pose of `motion` in the named scene. Throws Error when the motion
  // does not exist for that scene.
  Trajectory(const MotionOptions& motion, const std::string& scene);

  // Everything at `t_s` seconds after the first frame (any real t, also negative).
  BodyState At(double t_s) const;
  Eigen::Vector3d PositionAt(double t_s) const;
  Eigen::Matrix3d WorldFromCamAt(double t_s) const;

  // Duration of one loop of the closed path (0 when at rest).
  double loop_period_s() const;

 private:
  struct Harmonic {
    int k;
    double ax, bx, ay, by;  // x += ax cos(k phi) + bx sin(k phi); y likewise.
  };

  template <typename T>
  void Evaluate(const T& t, T* x, T* y, T* z) const;
  double HeadingAt(double t_s) const;

  MotionOptions motion_;
  bool walking_ = false;
  // Walk: phase phi(t) = omega t + warp sin(2 omega t), path in the horizontal plane.
  Eigen::Vector2d centre_ = Eigen::Vector2d::Zero();
  std::vector<Harmonic> harmonics_;
  double omega_ = 0.0;
  double warp_ = 0.0;
  // Rest: fixed pose.
  Eigen::Vector3d rest_position_ = Eigen::Vector3d::Zero();
  double rest_yaw_deg_ = 0.0;
  double rest_pitch_deg_ = 0.0;
};

}  // namespace autocal
