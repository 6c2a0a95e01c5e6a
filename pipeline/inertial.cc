#include "pipeline/inertial.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "pipeline/stopwatch.h"

namespace autocal {

bool InertialOptions::Check(std::string* error) const {
  std::string nested;
  const auto fail = [&](const std::string& why) {
    if (error) *error = why;
    return false;
  };
  if (!screen.Check(&nested)) return fail("screen." + nested);
  if (!quasi_static.Check(&nested)) return fail("quasi_static." + nested);
  if (!motion.Check(&nested)) return fail("motion." + nested);
  if (!scale.Check(&nested)) return fail("scale." + nested);
  if (!(velocity_horizon_s > 0)) return fail("velocity_horizon_s must be positive");
  if (!(history_s >= quasi_static.window_s)) {
    return fail("history_s must be at least quasi_static.window_s");
  }
  if (!(max_bias_sigma_m_s2 > 0)) return fail("max_bias_sigma_m_s2 must be positive");
  if (!(bias_gate_chi2 > 0)) return fail("bias_gate_chi2 must be positive");
  return true;
}

InertialStage::InertialStage(const AccelCalibration& calibration, const InertialOptions& options)
    : calibration_(calibration), options_(options), effective_(calibration) {
  // The learned bias's prior: zero, with the uncertainty of a bias nobody measured.
  const double prior = std::max(options.quasi_static.bias_uncertainty_m_s2, 1e-6);
  bias_information_ = Eigen::Matrix3d::Identity() / (prior * prior);
}

void InertialStage::AddSamples(std::span<const SpecificForceSample> samples) {
  for (const SpecificForceSample& sample : samples) {
    if (!samples_.empty() && sample.t_ns <= samples_.back().t_ns) {
      dropped_ns_.push_back(samples_.back().t_ns);
      continue;
    }
    samples_.push_back(sample);
  }
}

InertialSnapshot InertialStage::Process(int64_t t_ns, const std::optional<VisualMotion>& visual) {
  const auto start = std::chrono::steady_clock::now();
  InertialSnapshot snapshot;
  snapshot.t_ns = t_ns;
  const Eigen::Matrix3d cam1_from_cam0 =
      visual ? visual->cam1_from_cam0.toRotationMatrix() : Eigen::Matrix3d::Identity();

  int64_t window_centre_ns = t_ns;
  if (previous_t_ns_) {
    snapshot.previous_t_ns = *previous_t_ns_;
    window_centre_ns = *previous_t_ns_ + (t_ns - *previous_t_ns_) / 2;
    IntervalIntegral interval = IntegrateInterval(
        samples_, *previous_t_ns_, t_ns, effective_, options_.screen,
        visual ? visual->cam1_from_cam0.conjugate() : Eigen::Quaterniond::Identity());
    const auto dropped = std::count_if(dropped_ns_.begin(), dropped_ns_.end(), [&](int64_t t) {
      return t >= *previous_t_ns_ && t <= t_ns;
    });
    if (dropped > 0) {
      // Integrated across the hole the dropped readings left: undone.
      AccelFaults faults = interval.faults;
      faults.out_of_order += static_cast<int>(dropped);
      interval = IntervalIntegral{};
      interval.t0_ns = *previous_t_ns_;
      interval.t1_ns = t_ns;
      interval.faults = faults;
    }
    // Velocity over the interval: a = f + g in the camera frame at its start, then turned
    // into the camera frame at its end.
    if (!interval.usable()) {
      velocity_cam_.reset();
    } else if (velocity_cam_ && gravity_cam_) {
      velocity_cam_ = cam1_from_cam0 *
                      (*velocity_cam_ + interval.delta_velocity + interval.dt_s() * *gravity_cam_);
    }
    snapshot.interval = interval;
  }
  if (velocity_cam_ && 1e-9 * static_cast<double>(t_ns - still_ns_) > options_.velocity_horizon_s) {
    velocity_cam_.reset();
  }

  // The tilt's sigma counts the bias as far as it is still unknown.
  QuasiStaticOptions quasi_static = options_.quasi_static;
  quasi_static.bias_uncertainty_m_s2 = std::sqrt(
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(bias_covariance()).eigenvalues().maxCoeff());
  const QuasiStaticTest test =
      TestQuasiStatic(samples_, window_centre_ns, effective_, options_.screen, quasi_static);
  snapshot.quasi_static = test.quasi_static;
  // The accelerometer cannot feel a turn about itself: at rest only if vision, when there,
  // sees no turn either (gravity would have moved within the window).
  const bool at_rest = test.quasi_static &&
                       (!visual || !snapshot.interval ||
                        Eigen::AngleAxisd(visual->cam1_from_cam0).angle() * 180.0 / M_PI <=
                            options_.motion.still_max_rotation_deg_s * snapshot.interval->dt_s());
  const bool measured = UpdateGravity(t_ns, at_rest, test, visual);
  if (gravity_cam_ && gravity_tracked_) {
    snapshot.gravity_source = measured ? GravitySource::kMeasured : GravitySource::kPropagated;
    snapshot.gravity_cam = gravity_cam_;
    snapshot.gravity_sigma_deg = gravity_sigma_deg_;
    snapshot.tilt = TiltFromGravity(*gravity_cam_);
  }
  snapshot.velocity_cam = velocity_cam_;

  MotionEvidence evidence;
  evidence.dt_s = snapshot.interval ? snapshot.interval->dt_s() : 0.0;
  evidence.quasi_static = test.quasi_static;
  evidence.visual = visual;
  evidence.gravity_cam = gravity_cam_;
  evidence.velocity_cam = velocity_cam_;
  snapshot.motion =
      snapshot.skipped() ? MotionClass::kUnknown : ClassifyMotion(evidence, options_.motion);

  // Forget what no window will reach again.
  previous_t_ns_ = t_ns;
  const int64_t keep_from = t_ns - static_cast<int64_t>(1e9 * options_.history_s);
  const auto keep =
      std::lower_bound(samples_.begin(), samples_.end(), keep_from,
                       [](const SpecificForceSample& s, int64_t t) { return s.t_ns < t; });
  // One reading before the kept span still brackets the oldest interval.
  if (keep - samples_.begin() > 1) samples_.erase(samples_.begin(), keep - 1);
  std::erase_if(dropped_ns_, [&](int64_t t) { return t < keep_from; });
  snapshot.process_ms = MillisecondsSince(start);
  return snapshot;
}

bool InertialStage::UpdateGravity(int64_t t_ns, bool at_rest, const QuasiStaticTest& test,
                                  const std::optional<VisualMotion>& visual) {
  const QuasiStaticOptions& options = options_.quasi_static;
  if (!at_rest) {
    rest_since_ns_.reset();
    // Carried by vision's rotations; without vision the camera may have turned unseen, and
    // gravity is kept only to remove it from the readings, not reported.
    if (gravity_cam_ && visual) gravity_cam_ = visual->cam1_from_cam0 * *gravity_cam_;
    if (!visual) gravity_tracked_ = false;
    return false;
  }
  velocity_cam_ = Eigen::Vector3d::Zero();
  still_ns_ = t_ns;
  if (!rest_since_ns_) {
    rest_since_ns_ = t_ns;
    rest_gravity_.clear();
  }
  // The first windows of a rest often hold the end of a motion, too gentle to fail the
  // test but enough to tilt gravity: until the rest has lasted, they are left out and
  // gravity tracked by vision stays as it is.
  if (1e-9 * static_cast<double>(t_ns - *rest_since_ns_) < options.min_rest_s) {
    if (gravity_tracked_ && visual) {
      gravity_cam_ = visual->cam1_from_cam0 * *gravity_cam_;
    } else {
      gravity_cam_ = test.gravity_cam;
      gravity_tracked_ = false;
    }
    return false;
  }
  // Then averaged over the rest so far, for less noise than one window has. Vision's frame
  // to frame rotations are mostly noise at rest: the windows are not turned by them, but
  // when they add up to a real turn the average starts again.
  if (rest_gravity_.empty()) {
    rest_turn_.setIdentity();
  } else if (visual) {
    rest_turn_ = visual->cam1_from_cam0 * rest_turn_;
  }
  if (Eigen::AngleAxisd(rest_turn_).angle() * 180.0 / M_PI > options.rest_max_turn_deg) {
    rest_gravity_.clear();
    rest_turn_.setIdentity();
  }
  rest_gravity_.emplace_back(t_ns, test.gravity_cam);
  const int64_t oldest = t_ns - static_cast<int64_t>(1e9 * options.rest_average_s);
  std::erase_if(rest_gravity_, [&](const auto& entry) { return entry.first < oldest; });
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& [t, gravity] : rest_gravity_) mean += gravity;
  mean /= static_cast<double>(rest_gravity_.size());
  gravity_cam_ = mean;
  gravity_sigma_deg_ = test.sigma_deg;
  gravity_tracked_ = true;
  return true;
}

ScaleEstimate InertialStage::EstimateScale(std::span<const VisualPose> poses) {
  ScaleEstimate estimate =
      EstimateMetricScale(samples_, effective_, poses, options_.screen, options_.scale);
  if (!options_.learn_bias || !options_.scale.estimate_bias || !estimate.usable) return estimate;
  const double largest_variance =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(estimate.bias_covariance)
          .eigenvalues()
          .maxCoeff();
  if (!(largest_variance <= options_.max_bias_sigma_m_s2 * options_.max_bias_sigma_m_s2)) {
    return estimate;  // Too little turning to see the bias.
  }
  // The window saw the bias left after the learned one: fuse learned + that, unless it is
  // too far from what was learned to be the same bias.
  const Eigen::Matrix3d disagreement = estimate.bias_covariance + bias_covariance();
  if (estimate.bias.dot(disagreement.ldlt().solve(estimate.bias)) > options_.bias_gate_chi2) {
    estimate.message += "; bias not learned (disagrees with the bias learned so far)";
    return estimate;
  }
  const Eigen::Vector3d seen = effective_.bias - calibration_.bias + estimate.bias;
  const Eigen::Matrix3d information = estimate.bias_covariance.inverse();
  bias_information_ += information;
  bias_information_vector_ += information * seen;
  effective_.bias = calibration_.bias + bias_information_.ldlt().solve(bias_information_vector_);
  return estimate;
}

}  // namespace autocal
