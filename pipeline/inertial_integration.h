// Box 7, first half: accelerometer readings screened for faults, resampled to frame times
// and integrated between frames (docs/inertial.md).
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace autocal {

// One accelerometer reading: specific force (acceleration minus gravity, so about +9.81
// m/s^2 up at rest) in the accelerometer's own frame, m/s^2.
struct SpecificForceSample {
  int64_t t_ns = 0;
  Eigen::Vector3d specific_force = Eigen::Vector3d::Zero();
};

// What is known about the accelerometer before any estimation.
struct AccelCalibration {
  // Rotation taking accelerometer-frame vectors to camera-frame vectors.
  Eigen::Matrix3d cam_from_accel = Eigen::Matrix3d::Identity();
  // Known bias, accelerometer frame, m/s^2: subtracted from every reading.
  Eigen::Vector3d bias = Eigen::Vector3d::Zero();
};

struct AccelScreenOptions {
  double range_m_s2 = 3.0 * 9.81;        // The sensor's full scale: readings clip at +-range.
  double saturation_margin_m_s2 = 0.05;  // An axis this close to full scale is saturated.
  double max_gap_s = 0.02;               // Readings further apart than this leave a gap.

  bool Check(std::string* error) const;
};

// Faults met in a stretch of readings; any of them stops it from being integrated.
struct AccelFaults {
  int non_finite = 0;        // Readings with NaN or infinity on an axis.
  int saturated = 0;         // Readings at full scale on an axis (the true value is beyond).
  int gaps = 0;              // Spacings longer than max_gap_s between consecutive readings.
  double longest_gap_s = 0;  // The longest of them.
  int out_of_order = 0;      // Readings whose time was not after the previous one (dropped).
  bool no_data = false;      // No reading at or beyond one end of the stretch.

  bool Any() const {
    return non_finite > 0 || saturated > 0 || gaps > 0 || out_of_order > 0 || no_data;
  }
  // "2 saturated readings, a gap of 0.050 s"; empty when there is no fault.
  std::string Describe() const;
  void Add(const AccelFaults& other);
};

// Whether one reading is usable: finite and inside the range on every axis.
bool ReadingUsable(const SpecificForceSample& sample, const AccelScreenOptions& options,
                   AccelFaults* faults = nullptr);

// The integral of specific force over one frame interval [t0, t1], expressed in the camera
// frame at t0 (camera "0"). The readings are resampled (linear interpolation) at t0 and t1;
// between the nodes t0, every reading inside and t1 specific force is taken as linear in
// time, so both integrals are exact for it. Gravity is not removed: it is not known in
// this frame, and the callers add it (a_cam = f_cam + g_cam).
struct IntervalIntegral {
  int64_t t0_ns = 0;
  int64_t t1_ns = 0;
  int readings = 0;  // Readings strictly inside the interval.
  AccelFaults faults;
  // Specific force resampled at t0 and t1, each in its own camera frame, m/s^2.
  Eigen::Vector3d force_t0 = Eigen::Vector3d::Zero();
  Eigen::Vector3d force_t1 = Eigen::Vector3d::Zero();
  Eigen::Vector3d delta_velocity = Eigen::Vector3d::Zero();  // Integral of f over [t0, t1], m/s.
  // Double integral: the displacement the specific force alone makes, starting at rest, m.
  Eigen::Vector3d delta_position = Eigen::Vector3d::Zero();
  // How both change with an extra accelerometer bias b (accelerometer frame): the true
  // integrals are delta + d_delta_d_bias * b.
  Eigen::Matrix3d d_velocity_d_bias = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d d_position_d_bias = Eigen::Matrix3d::Zero();

  double dt_s() const { return 1e-9 * static_cast<double>(t1_ns - t0_ns); }
  bool usable() const { return !faults.Any(); }
};

// Integrates `samples` (sorted by time) over [t0_ns, t1_ns]. `cam0_from_cam1` is the
// camera's rotation over the interval where vision knows it (readings in between are
// turned by the slerp of it); identity assumes no rotation. Faulty readings in the
// interval, or used to resample its ends, are reported in `faults` and the integrals are
// then left at zero: bad data is never integrated.
IntervalIntegral IntegrateInterval(
    std::span<const SpecificForceSample> samples, int64_t t0_ns, int64_t t1_ns,
    const AccelCalibration& calibration, const AccelScreenOptions& options,
    const Eigen::Quaterniond& cam0_from_cam1 = Eigen::Quaterniond::Identity());

}  // namespace autocal
