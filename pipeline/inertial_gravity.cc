#include "pipeline/inertial_gravity.h"

#include <algorithm>
#include <cmath>

namespace autocal {

bool QuasiStaticOptions::Check(std::string* error) const {
  std::string why;
  if (!(window_s > 0)) {
    why = "window_s must be positive";
  } else if (!(max_norm_deviation_m_s2 > 0)) {
    why = "max_norm_deviation_m_s2 must be positive";
  } else if (!(max_variance_m2_s4 > 0)) {
    why = "max_variance_m2_s4 must be positive";
  } else if (min_readings < 2) {
    why = "min_readings must be at least 2";
  } else if (!(min_rest_s >= 0)) {
    why = "min_rest_s must not be negative";
  } else if (!(rest_average_s >= 0)) {
    why = "rest_average_s must not be negative";
  } else if (!(rest_max_turn_deg > 0)) {
    why = "rest_max_turn_deg must be positive";
  } else if (!(gravity_m_s2 > 0)) {
    why = "gravity_m_s2 must be positive";
  } else if (!(bias_uncertainty_m_s2 >= 0)) {
    why = "bias_uncertainty_m_s2 must not be negative";
  }
  if (why.empty()) return true;
  if (error) *error = why;
  return false;
}

QuasiStaticTest TestQuasiStatic(std::span<const SpecificForceSample> samples, int64_t t_ns,
                                const AccelCalibration& calibration,
                                const AccelScreenOptions& screen,
                                const QuasiStaticOptions& options) {
  QuasiStaticTest test;
  const auto half = static_cast<int64_t>(std::llround(0.5e9 * options.window_s));
  const auto begin =
      std::lower_bound(samples.begin(), samples.end(), t_ns - half,
                       [](const SpecificForceSample& s, int64_t t) { return s.t_ns < t; });
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Vector3d sum_squares = Eigen::Vector3d::Zero();
  int64_t previous_ns = 0;
  for (auto it = begin; it != samples.end() && it->t_ns <= t_ns + half; ++it) {
    if (it != begin) {
      const int64_t spacing = it->t_ns - previous_ns;
      if (spacing <= 0) {
        ++test.faults.out_of_order;
      } else if (1e-9 * static_cast<double>(spacing) > screen.max_gap_s) {
        ++test.faults.gaps;
        test.faults.longest_gap_s = std::max(test.faults.longest_gap_s, 1e-9 * spacing);
      }
    }
    previous_ns = it->t_ns;
    if (!ReadingUsable(*it, screen, &test.faults)) continue;
    const Eigen::Vector3d f = it->specific_force - calibration.bias;
    sum += f;
    sum_squares += f.cwiseProduct(f);
    ++test.readings;
  }
  if (test.readings < options.min_readings || test.faults.Any()) return test;
  const double n = test.readings;
  const Eigen::Vector3d mean = sum / n;
  const Eigen::Vector3d variance =
      ((sum_squares - n * mean.cwiseProduct(mean)) / (n - 1.0)).cwiseMax(0.0);
  test.norm_deviation = mean.norm() - options.gravity_m_s2;
  test.max_variance = variance.maxCoeff();
  test.quasi_static = std::abs(test.norm_deviation) <= options.max_norm_deviation_m_s2 &&
                      test.max_variance <= options.max_variance_m2_s4;
  if (!test.quasi_static) return test;
  test.gravity_cam = -(calibration.cam_from_accel * mean);
  // Noise of the mean across gravity, and the bias we cannot see, as angles.
  const double noise = std::sqrt(variance.sum() / (3.0 * n));
  test.sigma_deg = std::hypot(noise, options.bias_uncertainty_m_s2) / mean.norm() * 180.0 / M_PI;
  return test;
}

Tilt TiltFromGravity(const Eigen::Vector3d& gravity_cam) {
  const Eigen::Vector3d down = gravity_cam.normalized();
  return {std::atan2(down.x(), down.y()), std::asin(std::clamp(down.z(), -1.0, 1.0))};
}

}  // namespace autocal
