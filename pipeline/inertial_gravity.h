// Box 7: gravity, and with it the camera's tilt (roll and pitch), whenever the body is
// quasi-static (docs/inertial.md).
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include <Eigen/Core>

#include "pipeline/inertial_integration.h"

namespace autocal {

struct QuasiStaticOptions {
  double window_s = 0.2;                 // Readings within half of this of the moment tested.
  double max_norm_deviation_m_s2 = 0.2;  // | |mean specific force| - gravity_m_s2 | at most this.
  double max_variance_m2_s4 = 0.005;     // Variance of the readings, per axis, at most this.
  int min_readings = 10;                 // Fewer readings in the window: not tested.
  double min_rest_s = 0.2;               // Gravity is measured once a rest lasts this long...
  double rest_average_s = 2.0;           // ...as the mean of the windows over this much of it...
  double rest_max_turn_deg = 1.0;        // ...restarted when vision sees it turn more.
  double gravity_m_s2 = 9.81;            // Local gravity.
  // Tilt uncertainty from an unknown accelerometer bias (its part across gravity, m/s^2),
  // added to the noise-driven part when the tilt's sigma is reported.
  double bias_uncertainty_m_s2 = 0.1;

  bool Check(std::string* error) const;
};

// The test of one window and, when it passes, gravity measured in it.
struct QuasiStaticTest {
  bool quasi_static = false;
  int readings = 0;
  AccelFaults faults;           // Faulty readings in the window fail the test.
  double norm_deviation = 0.0;  // |mean specific force| - gravity, m/s^2.
  double max_variance = 0.0;    // Largest per-axis variance, (m/s^2)^2.
  // Gravity ("down", magnitude |mean specific force|) in the camera frame, m/s^2: at rest
  // the accelerometer feels the floor push up, so gravity is minus the mean reading.
  Eigen::Vector3d gravity_cam = Eigen::Vector3d::Zero();
  double sigma_deg = 0.0;  // One-sigma uncertainty of its direction.
};

// Tests the readings within window_s / 2 of `t_ns`. For a centred window, readings must
// have arrived up to window_s / 2 after t_ns; otherwise the window is cut there.
QuasiStaticTest TestQuasiStatic(std::span<const SpecificForceSample> samples, int64_t t_ns,
                                const AccelCalibration& calibration,
                                const AccelScreenOptions& screen,
                                const QuasiStaticOptions& options);

// The camera's tilt relative to the horizontal, from gravity in its frame (OpenCV axes:
// x right, y down, z forward). Yaw is not observable from gravity.
struct Tilt {
  double roll_rad = 0.0;   // About the optical axis; positive when image right (x) dips.
  double pitch_rad = 0.0;  // Of the optical axis; positive when it points below horizontal.
};
Tilt TiltFromGravity(const Eigen::Vector3d& gravity_cam);

}  // namespace autocal
