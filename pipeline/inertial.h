// Box 7, motion from the accelerometer, as one per-frame stage: readings screened and
// integrated between frames, gravity and tilt whenever the body is quasi-static, the kind
// of motion of each frame interval, and metric scale for a visual trajectory
// (docs/inertial.md). The pieces are in inertial_integration.h, inertial_gravity.h,
// inertial_motion.h and inertial_scale.h.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "pipeline/inertial_gravity.h"
#include "pipeline/inertial_integration.h"
#include "pipeline/inertial_motion.h"
#include "pipeline/inertial_scale.h"

namespace autocal {

struct InertialOptions {
  AccelScreenOptions screen;
  QuasiStaticOptions quasi_static;
  MotionClassOptions motion;
  ScaleOptions scale;
  // Velocity integrated since the last still moment drifts (noise, bias turned by the
  // camera): after this long without one it is forgotten.
  double velocity_horizon_s = 10.0;
  double history_s = 4.0;  // Readings kept this far behind the newest frame (scale windows).
  // The accelerometer bias that scale windows estimate is fused over windows and taken off
  // the readings: it sets the floor of the tilt's error otherwise. It starts from zero with
  // quasi_static.bias_uncertainty_m_s2. Only windows that turned enough to see it are
  // fused (without a turn, the bias across gravity looks like a tilt of gravity).
  bool learn_bias = true;
  double max_bias_sigma_m_s2 = 0.02;  // A window's bias less certain (any axis): not fused.
  double bias_gate_chi2 = 16.0;       // A window this far (chi-square) from what was learned:
                                      // not fused.

  // Checks this struct and every nested one; the message names the field.
  bool Check(std::string* error) const;
};

// Where a snapshot's gravity comes from.
enum class GravitySource {
  kNone,        // Not known: no still moment yet, or the camera turned unseen since.
  kMeasured,    // Quasi-static now: measured in this frame's window.
  kPropagated,  // The last measured gravity, carried through vision's rotations since.
};

// What box 7 found for one frame and the interval that ends at it: immutable, held by the
// per-frame snapshot of boxes 4-7.
struct InertialSnapshot {
  int64_t t_ns = 0;
  int64_t previous_t_ns = 0;  // Start of the interval (the previous frame); 0 on the first.
  MotionClass motion = MotionClass::kUnknown;
  bool quasi_static = false;  // The accelerometer's window around the interval is at rest.
  GravitySource gravity_source = GravitySource::kNone;
  // Gravity ("down") in the camera frame at t_ns, m/s^2, its direction's one-sigma
  // uncertainty, and the tilt it gives; set when gravity_source is not kNone.
  std::optional<Eigen::Vector3d> gravity_cam;
  double gravity_sigma_deg = 0.0;
  std::optional<Tilt> tilt;
  // Camera velocity from the accelerometer since the last still moment, camera frame at
  // t_ns, m/s (unknown before one, after a fault, or beyond velocity_horizon_s).
  std::optional<Eigen::Vector3d> velocity_cam;
  // The readings integrated over [previous_t_ns, t_ns]; absent on the first frame. When
  // it holds faults it was skipped, not integrated.
  std::optional<IntervalIntegral> interval;
  double process_ms = 0.0;

  bool skipped() const { return interval && !interval->usable(); }
  // Why the interval was skipped ("3 readings saturated"); empty when it was not.
  std::string skip_reason() const { return skipped() ? interval->faults.Describe() : ""; }
};

class InertialStage {
 public:
  explicit InertialStage(const AccelCalibration& calibration, const InertialOptions& options = {});

  // Appends readings in time order, any number at a time. A reading not after the previous
  // one is dropped and reported as a fault of the interval it falls in. For windows
  // centred on a frame, readings should run quasi_static.window_s / 2 ahead of frames.
  void AddSamples(std::span<const SpecificForceSample> samples);

  // The frame at `t_ns` (after the previous one), and what vision measured over the
  // interval since the previous frame, if anything.
  InertialSnapshot Process(int64_t t_ns, const std::optional<VisualMotion>& visual = std::nullopt);

  // Metric scale of the visual trajectory `poses` (within history_s of the newest frame).
  // A usable estimate's bias is learned (InertialOptions::learn_bias).
  ScaleEstimate EstimateScale(std::span<const VisualPose> poses);

  // What was learned is kept (its prior was set at construction).
  void set_options(const InertialOptions& options) { options_ = options; }
  const InertialOptions& options() const { return options_; }
  // The calibration given, its bias plus what was learned.
  const AccelCalibration& calibration() const { return calibration_; }
  const AccelCalibration& effective_calibration() const { return effective_; }
  // Covariance of the effective bias, (m/s^2)^2.
  Eigen::Matrix3d bias_covariance() const { return bias_information_.inverse(); }

 private:
  // Measures gravity at rest, else carries it through vision's rotation; true when it was
  // measured in this frame.
  bool UpdateGravity(int64_t t_ns, bool at_rest, const QuasiStaticTest& test,
                     const std::optional<VisualMotion>& visual);

  AccelCalibration calibration_;
  InertialOptions options_;
  // Learned bias (on top of calibration_.bias) in information form, and the calibration
  // with it.
  Eigen::Matrix3d bias_information_;
  Eigen::Vector3d bias_information_vector_ = Eigen::Vector3d::Zero();
  AccelCalibration effective_;
  std::vector<SpecificForceSample> samples_;  // Sorted by time.
  std::vector<int64_t> dropped_ns_;           // Where out-of-order readings were dropped.
  std::optional<int64_t> previous_t_ns_;
  // Gravity in the current camera frame, as last measured; `tracked` while vision's
  // rotations have carried it since, so it is still the truth.
  std::optional<Eigen::Vector3d> gravity_cam_;
  double gravity_sigma_deg_ = 0.0;
  bool gravity_tracked_ = false;
  std::optional<int64_t> rest_since_ns_;  // When the current rest began.
  // Gravity of each window of the current rest (newest rest_average_s of it).
  std::vector<std::pair<int64_t, Eigen::Vector3d>> rest_gravity_;
  Eigen::Quaterniond rest_turn_ = Eigen::Quaterniond::Identity();  // Vision's, since then.
  std::optional<Eigen::Vector3d> velocity_cam_;
  int64_t still_ns_ = 0;  // When the body was last still (velocity zero).
};

}  // namespace autocal
