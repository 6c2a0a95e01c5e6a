// The simulated accelerometer: specific force in its own frame, with white noise, bias,
// saturation and quantization, all drawn deterministically from the scenario's seed.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "devices/sequence.h"
#include "devices/sim/scenario.h"
#include "devices/sim/trajectory.h"

namespace autocal {

// Standard gravity used throughout the simulator, m/s^2.
inline constexpr double kGravity = 9.81;
// Gravity in the world frame (z up).
inline const Eigen::Vector3d kGravityWorld(0.0, 0.0, -kGravity);

// Rotation taking accelerometer vectors to camera vectors: the nominal axes (x forward,
// y left, z up when the camera looks forward) turned by the mounting misalignment.
Eigen::Matrix3d CamFromAccel(const AccelerometerOptions& options);

// Noise-free specific force f = R_accel_from_world (a - g) in the accelerometer frame.
Eigen::Vector3d TrueSpecificForce(const BodyState& state, const Eigen::Matrix3d& cam_from_accel);

// Seconds of accelerometer samples before the first frame and after the last.
inline constexpr double kAccelMarginS = 0.5;

// Samples at start_ns - margin + llround(k * 1e9 / rate) until margin after the last
// frame, with the scenario's noise, bias, range and quantization.
std::vector<AccelSample> SimulateAccelerometer(const Scenario& scenario,
                                               const Trajectory& trajectory);

}  // namespace autocal
