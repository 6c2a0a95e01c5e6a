#include "pipeline/inertial_integration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace autocal {

bool AccelScreenOptions::Check(std::string* error) const {
  std::string why;
  if (!(range_m_s2 > 0)) {
    why = "range_m_s2 must be positive";
  } else if (!(saturation_margin_m_s2 >= 0 && saturation_margin_m_s2 < range_m_s2)) {
    why = "saturation_margin_m_s2 must be in [0, range_m_s2)";
  } else if (!(max_gap_s > 0)) {
    why = "max_gap_s must be positive";
  }
  if (why.empty()) return true;
  if (error) *error = why;
  return false;
}

std::string AccelFaults::Describe() const {
  std::string text;
  char part[96];
  const auto add = [&](const char* piece) {
    if (!text.empty()) text += ", ";
    text += piece;
  };
  const auto readings = [&](int count, const char* what) {
    std::snprintf(part, sizeof(part), "%d %s %s", count, count == 1 ? "reading" : "readings", what);
    add(part);
  };
  if (non_finite > 0) readings(non_finite, "not finite");
  if (saturated > 0) readings(saturated, "saturated");
  if (gaps == 1) {
    std::snprintf(part, sizeof(part), "a gap of %.3f s", longest_gap_s);
    add(part);
  } else if (gaps > 1) {
    std::snprintf(part, sizeof(part), "%d gaps (longest %.3f s)", gaps, longest_gap_s);
    add(part);
  }
  if (out_of_order > 0) readings(out_of_order, "out of time order");
  if (no_data) add("no readings cover it");
  return text;
}

void AccelFaults::Add(const AccelFaults& other) {
  non_finite += other.non_finite;
  saturated += other.saturated;
  gaps += other.gaps;
  longest_gap_s = std::max(longest_gap_s, other.longest_gap_s);
  out_of_order += other.out_of_order;
  no_data = no_data || other.no_data;
}

bool ReadingUsable(const SpecificForceSample& sample, const AccelScreenOptions& options,
                   AccelFaults* faults) {
  if (!sample.specific_force.allFinite()) {
    if (faults) ++faults->non_finite;
    return false;
  }
  if (sample.specific_force.cwiseAbs().maxCoeff() >=
      options.range_m_s2 - options.saturation_margin_m_s2) {
    if (faults) ++faults->saturated;
    return false;
  }
  return true;
}

IntervalIntegral IntegrateInterval(std::span<const SpecificForceSample> samples, int64_t t0_ns,
                                   int64_t t1_ns, const AccelCalibration& calibration,
                                   const AccelScreenOptions& options,
                                   const Eigen::Quaterniond& cam0_from_cam1) {
  IntervalIntegral out;
  out.t0_ns = t0_ns;
  out.t1_ns = t1_ns;
  if (t1_ns <= t0_ns) {
    out.faults.out_of_order = 1;
    return out;
  }
  // The reading at or before t0 and the one at or after t1 bracket the interval.
  const auto after_t0 =
      std::upper_bound(samples.begin(), samples.end(), t0_ns,
                       [](int64_t t, const SpecificForceSample& s) { return t < s.t_ns; });
  const auto at_t1 =
      std::lower_bound(samples.begin(), samples.end(), t1_ns,
                       [](const SpecificForceSample& s, int64_t t) { return s.t_ns < t; });
  if (after_t0 == samples.begin() || at_t1 == samples.end()) {
    out.faults.no_data = true;
    return out;
  }
  const size_t first = static_cast<size_t>(after_t0 - samples.begin()) - 1;
  const size_t last = static_cast<size_t>(at_t1 - samples.begin());
  for (size_t k = first; k <= last; ++k) {
    ReadingUsable(samples[k], options, &out.faults);
    if (k == first) continue;
    const int64_t spacing = samples[k].t_ns - samples[k - 1].t_ns;
    if (spacing <= 0) {
      ++out.faults.out_of_order;
    } else if (1e-9 * static_cast<double>(spacing) > options.max_gap_s) {
      ++out.faults.gaps;
      out.faults.longest_gap_s = std::max(out.faults.longest_gap_s, 1e-9 * spacing);
    }
  }
  if (out.faults.Any()) return out;

  const auto resample = [&](size_t k, int64_t t_ns) -> Eigen::Vector3d {
    const SpecificForceSample& a = samples[k];
    const SpecificForceSample& b = samples[k + 1];
    const double w = static_cast<double>(t_ns - a.t_ns) / static_cast<double>(b.t_ns - a.t_ns);
    return (1.0 - w) * a.specific_force + w * b.specific_force - calibration.bias;
  };
  const Eigen::Vector3d f0 = resample(first, t0_ns);
  const Eigen::Vector3d f1 = resample(last - 1, t1_ns);
  out.force_t0 = calibration.cam_from_accel * f0;
  out.force_t1 = calibration.cam_from_accel * f1;
  out.readings = static_cast<int>(last - first) - 1;

  // Nodes in camera-0 coordinates: the reading turned by the camera's rotation so far.
  const double duration_s = out.dt_s();
  const Eigen::Quaterniond identity = Eigen::Quaterniond::Identity();
  const auto cam0_from_accel = [&](double t_s) -> Eigen::Matrix3d {
    return identity.slerp(t_s / duration_s, cam0_from_cam1).toRotationMatrix() *
           calibration.cam_from_accel;
  };
  double t_prev = 0.0;
  Eigen::Matrix3d rotation_prev = calibration.cam_from_accel;
  Eigen::Vector3d force_prev = out.force_t0;
  const auto step = [&](double t_s, const Eigen::Vector3d& force_accel) {
    const Eigen::Matrix3d rotation = cam0_from_accel(t_s);
    const Eigen::Vector3d force = rotation * force_accel;
    const double h = t_s - t_prev;
    // Exact for specific force linear over the step: v += h (a + b) / 2,
    // p += v h + h^2 (2 a + b) / 6 (with v before the step).
    out.delta_position += out.delta_velocity * h + h * h / 6.0 * (2.0 * force_prev + force);
    out.delta_velocity += 0.5 * h * (force_prev + force);
    // The same for a bias b, which enters every node as -rotation * b.
    out.d_position_d_bias +=
        out.d_velocity_d_bias * h - h * h / 6.0 * (2.0 * rotation_prev + rotation);
    out.d_velocity_d_bias -= 0.5 * h * (rotation_prev + rotation);
    t_prev = t_s;
    rotation_prev = rotation;
    force_prev = force;
  };
  for (size_t k = first + 1; k < last; ++k) {
    step(1e-9 * static_cast<double>(samples[k].t_ns - t0_ns),
         samples[k].specific_force - calibration.bias);
  }
  step(duration_s, f1);
  return out;
}

}  // namespace autocal
