#include "devices/sim/accelerometer.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "devices/sim/random.h"

namespace autocal {

Eigen::Matrix3d CamFromAccel(const AccelerometerOptions& options) {
  const Eigen::Vector3d rotation_vector = options.misalignment_deg * (M_PI / 180.0);
  Eigen::Matrix3d body_from_accel = Eigen::Matrix3d::Identity();
  if (rotation_vector.norm() > 0.0) {
    body_from_accel =
        Eigen::AngleAxisd(rotation_vector.norm(), rotation_vector.normalized()).toRotationMatrix();
  }
  return BodyFromCam().transpose() * body_from_accel;
}

Eigen::Vector3d TrueSpecificForce(const BodyState& state, const Eigen::Matrix3d& cam_from_accel) {
  const Eigen::Matrix3d world_from_accel = state.world_from_cam * cam_from_accel;
  return world_from_accel.transpose() * (state.acceleration - kGravityWorld);
}

std::vector<AccelSample> SimulateAccelerometer(const Scenario& scenario,
                                               const Trajectory& trajectory) {
  const AccelerometerOptions& options = scenario.accelerometer;
  const Eigen::Matrix3d cam_from_accel = CamFromAccel(options);
  const int64_t first_ns = scenario.start_ns - static_cast<int64_t>(kAccelMarginS * 1e9);
  const int64_t last_ns = scenario.frame_time_ns(scenario.frame_count() - 1) +
                          static_cast<int64_t>(kAccelMarginS * 1e9);
  const double range = options.range_g * kGravity;
  // Discrete white noise of a continuous density: sigma = density * sqrt(rate).
  const double sigma = options.noise_density * std::sqrt(options.rate_hz);
  const double lsb = options.bits > 0 ? 2.0 * range / std::ldexp(1.0, options.bits) : 0.0;
  const double max_code = options.bits > 0 ? std::ldexp(1.0, options.bits - 1) - 1.0 : 0.0;

  cv::RNG rng(MixSeed(scenario.seed, kAccelerometerStream));
  std::vector<AccelSample> samples;
  for (int64_t k = 0;; ++k) {
    const int64_t t_ns = first_ns + std::llround(k * 1e9 / options.rate_hz);
    if (t_ns > last_ns) break;
    const BodyState state = trajectory.At(scenario.SecondsAt(t_ns));
    Eigen::Vector3d f = TrueSpecificForce(state, cam_from_accel) + options.bias;
    for (int axis = 0; axis < 3; ++axis) {
      double value = f[axis] + (sigma > 0.0 ? rng.gaussian(sigma) : 0.0);
      value = std::clamp(value, -range, range);
      if (lsb > 0.0) value = std::clamp(std::round(value / lsb), -max_code - 1.0, max_code) * lsb;
      f[axis] = value;
    }
    samples.push_back({t_ns, f});
  }
  return samples;
}

}  // namespace autocal
