// Box 7: metric scale of a visual trajectory, by matching the accelerometer's displacement
// to the visual translation over a short window (docs/inertial.md).
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "pipeline/inertial_integration.h"

namespace autocal {

// A camera pose from vision (boxes 6, 10): orientation and position in a world frame of
// vision's own choosing (not gravity-aligned), position known up to one unknown scale.
struct VisualPose {
  int64_t t_ns = 0;
  Eigen::Quaterniond world_from_cam = Eigen::Quaterniond::Identity();
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // Camera centre, visual units.
};

struct ScaleOptions {
  int min_poses = 10;  // Fewer poses in the window: no estimate.
  // Also an accelerometer bias: turned by the camera it is the largest error otherwise. Only
  // its part across the axes the camera turned about is seen (along gravity, through
  // gravity's known length).
  bool estimate_bias = true;
  bool known_gravity_norm = true;  // Hold |gravity| at gravity_m_s2, leaving its direction.
  double gravity_m_s2 = 9.81;      // Local gravity.
  int gravity_iterations = 4;      // Gauss-Newton steps on gravity's direction.
  // Noise that integrates into the displacements, weighting the solve and setting its sigma:
  // the accelerometer's white noise, (m/s^2)/sqrt(Hz), and the noise of vision's
  // orientations, per pose (it turns gravity into a false horizontal force).
  double accel_noise_density = 0.002;
  double visual_rotation_sigma_deg = 0.05;
  double max_relative_sigma = 0.015;  // Scale less certain (1 sigma, relative): not usable.

  bool Check(std::string* error) const;
};

struct ScaleEstimate {
  bool usable = false;
  std::string message;       // What was estimated, or why nothing usable was.
  double scale = 0.0;        // Metres per visual unit: metric position = scale * position.
  double scale_sigma = 0.0;  // One sigma, metres per visual unit.
  Eigen::Vector3d velocity_world = Eigen::Vector3d::Zero();  // At the first pose, m/s.
  Eigen::Vector3d gravity_world = Eigen::Vector3d::Zero();   // m/s^2, vision's world axes.
  // Bias beyond the calibration's, accelerometer frame, m/s^2 (when estimated).
  Eigen::Vector3d bias = Eigen::Vector3d::Zero();
  Eigen::Matrix3d bias_covariance = Eigen::Matrix3d::Zero();  // (m/s^2)^2.
  double rms_m = 0.0;                                         // RMS position residual, metres.
  int poses = 0;
  AccelFaults faults;  // Faults met in the window (an estimate needs none).
};

// Solves, by linear least squares over the poses of a window (sorted by time),
//   scale * (c_k - c_0) = v_0 t_k + g t_k^2 / 2 + D_k + B_k b
// for the scale, the velocity v_0 at the first pose, gravity g (both in vision's world
// frame) and optionally a bias b: D_k is the specific force double-integrated from the
// first pose, each reading turned into vision's world frame by the interpolated visual
// orientation, and B_k its derivative in b. The rows are weighted by the scatter of the
// visual positions and the correlated noise that integrates into D_k (generalized least
// squares). With known_gravity_norm, Gauss-Newton steps then hold |g| fixed. The window
// must be free of accelerometer faults and must accelerate: at constant velocity, scale
// and v_0 cannot be told apart.
ScaleEstimate EstimateMetricScale(std::span<const SpecificForceSample> samples,
                                  const AccelCalibration& calibration,
                                  std::span<const VisualPose> poses,
                                  const AccelScreenOptions& screen, const ScaleOptions& options);

}  // namespace autocal
