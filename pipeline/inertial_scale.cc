#include "pipeline/inertial_scale.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include <Eigen/Dense>

namespace autocal {
namespace {

// The accelerometer side of the window, in vision's world frame, at each pose k.
struct WindowIntegrals {
  std::vector<double> t_s;                    // Time since the first pose.
  std::vector<Eigen::Vector3d> displacement;  // D_k.
  std::vector<Eigen::Matrix3d> d_bias;        // B_k.
};

// Two unit vectors orthogonal to `n` (unit): a basis of its tangent plane.
Eigen::Matrix<double, 3, 2> TangentBasis(const Eigen::Vector3d& n) {
  const Eigen::Vector3d helper =
      std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  Eigen::Matrix<double, 3, 2> basis;
  basis.col(0) = n.cross(helper).normalized();
  basis.col(1) = n.cross(basis.col(0));
  return basis;
}

struct LinearSolution {
  Eigen::VectorXd x;
  Eigen::MatrixXd covariance;  // Meaningful when the system was whitened.
  double rss = 0.0;            // Of the residuals in metres (not whitened).
  bool ok = false;
};

// Least squares on the system whitened by `whitening` (the Cholesky factor of the noise
// covariance of b; none: unweighted), columns scaled to unit norm so that metres, seconds
// and bias columns of very different sizes condition alike.
LinearSolution Solve(const Eigen::MatrixXd& a, const Eigen::VectorXd& b,
                     const Eigen::LLT<Eigen::MatrixXd>* whitening) {
  LinearSolution solution;
  const Eigen::MatrixXd a_white = whitening ? whitening->matrixL().solve(a) : a;
  const Eigen::VectorXd b_white = whitening ? whitening->matrixL().solve(b) : b;
  const Eigen::VectorXd norms = a_white.colwise().norm().transpose();
  if ((norms.array() <= 0).any() || a.rows() <= a.cols()) return solution;
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(a_white * norms.cwiseInverse().asDiagonal(),
                                              Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& singular = svd.singularValues();
  if (singular(singular.size() - 1) < 1e-9 * singular(0)) return solution;
  solution.x = norms.cwiseInverse().asDiagonal() * svd.solve(b_white);
  solution.rss = (a * solution.x - b).squaredNorm();
  const Eigen::MatrixXd half =
      norms.cwiseInverse().asDiagonal() * svd.matrixV() * singular.cwiseInverse().asDiagonal();
  solution.covariance = half * half.transpose();
  solution.ok = true;
  return solution;
}

}  // namespace

bool ScaleOptions::Check(std::string* error) const {
  std::string why;
  if (min_poses < 4) {
    why = "min_poses must be at least 4";
  } else if (!(gravity_m_s2 > 0)) {
    why = "gravity_m_s2 must be positive";
  } else if (gravity_iterations < 1) {
    why = "gravity_iterations must be at least 1";
  } else if (!(accel_noise_density >= 0)) {
    why = "accel_noise_density must not be negative";
  } else if (!(visual_rotation_sigma_deg >= 0)) {
    why = "visual_rotation_sigma_deg must not be negative";
  } else if (!(max_relative_sigma > 0)) {
    why = "max_relative_sigma must be positive";
  }
  if (why.empty()) return true;
  if (error) *error = why;
  return false;
}

ScaleEstimate EstimateMetricScale(std::span<const SpecificForceSample> samples,
                                  const AccelCalibration& calibration,
                                  std::span<const VisualPose> poses,
                                  const AccelScreenOptions& screen, const ScaleOptions& options) {
  ScaleEstimate estimate;
  const int n = static_cast<int>(poses.size());
  estimate.poses = n;
  if (n < options.min_poses) {
    estimate.message = "too few poses (" + std::to_string(n) + ")";
    return estimate;
  }

  // Integrate between consecutive poses and chain the pieces in vision's world frame.
  WindowIntegrals window;
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  Eigen::Matrix3d velocity_d_bias = Eigen::Matrix3d::Zero();
  window.t_s.push_back(0.0);
  window.displacement.push_back(Eigen::Vector3d::Zero());
  window.d_bias.push_back(Eigen::Matrix3d::Zero());
  for (int k = 0; k + 1 < n; ++k) {
    const Eigen::Quaterniond cam0_from_cam1 =
        poses[k].world_from_cam.conjugate() * poses[k + 1].world_from_cam;
    const IntervalIntegral piece = IntegrateInterval(samples, poses[k].t_ns, poses[k + 1].t_ns,
                                                     calibration, screen, cam0_from_cam1);
    estimate.faults.Add(piece.faults);
    if (!piece.usable()) continue;
    const Eigen::Matrix3d world_from_cam = poses[k].world_from_cam.toRotationMatrix();
    const double dt = piece.dt_s();
    window.t_s.push_back(window.t_s.back() + dt);
    window.displacement.push_back(window.displacement.back() + velocity * dt +
                                  world_from_cam * piece.delta_position);
    window.d_bias.push_back(window.d_bias.back() + velocity_d_bias * dt +
                            world_from_cam * piece.d_position_d_bias);
    velocity += world_from_cam * piece.delta_velocity;
    velocity_d_bias += world_from_cam * piece.d_velocity_d_bias;
  }
  if (estimate.faults.Any()) {
    estimate.message = "accelerometer faults in the window: " + estimate.faults.Describe();
    return estimate;
  }

  // Noise that integrates twice into D_k: the accelerometer's own, and vision's orientation
  // error turning gravity into a false horizontal force, both taken as white and isotropic.
  // Double-integrated white noise of density q has Cov(D(s), D(t)) = q^2 s^2 (3t - s) / 6
  // for s <= t.
  const double turn_noise = options.visual_rotation_sigma_deg * M_PI / 180.0 * options.gravity_m_s2;
  const double density2 = options.accel_noise_density * options.accel_noise_density +
                          turn_noise * turn_noise * window.t_s.back() / (n - 1);
  Eigen::MatrixXd integrated_noise = Eigen::MatrixXd::Zero(3 * (n - 1), 3 * (n - 1));
  for (int j = 1; j < n; ++j) {
    for (int k = 1; k < n; ++k) {
      const double s = std::min(window.t_s[j], window.t_s[k]);
      const double t = std::max(window.t_s[j], window.t_s[k]);
      integrated_noise.block<3, 3>(3 * (j - 1), 3 * (k - 1))
          .diagonal()
          .setConstant(density2 * s * s * (3.0 * t - s) / 6.0);
    }
  }

  // Unknowns: scale, v_0 (3), gravity (3 free, or 2 for its direction), bias (0 or 3).
  const int bias_columns = options.estimate_bias ? 3 : 0;
  const int rows = 3 * (n - 1);
  const auto build = [&](const Eigen::Matrix<double, 3, Eigen::Dynamic>& gravity_block,
                         const Eigen::Vector3d& gravity_fixed, Eigen::MatrixXd* a,
                         Eigen::VectorXd* b) {
    const int gravity_cols = static_cast<int>(gravity_block.cols());
    a->setZero(rows, 4 + gravity_cols + bias_columns);
    b->resize(rows);
    for (int k = 1; k < n; ++k) {
      const int r = 3 * (k - 1);
      const double t = window.t_s[k];
      a->block<3, 1>(r, 0) = poses[k].position - poses[0].position;
      a->block<3, 3>(r, 1) = -t * Eigen::Matrix3d::Identity();
      a->block(r, 4, 3, gravity_cols) = -0.5 * t * t * gravity_block;
      if (bias_columns > 0) a->block<3, 3>(r, 4 + gravity_cols) = -window.d_bias[k];
      b->segment<3>(r) = window.displacement[k] + 0.5 * t * t * gravity_fixed;
    }
  };
  Eigen::MatrixXd a;
  Eigen::VectorXd b;
  build(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), &a, &b);
  // Unweighted first, for the scatter of the visual positions (white); then weighted by it
  // and the integrated noise together (generalized least squares).
  const auto degenerate = [&] {
    estimate.message = "degenerate window (no acceleration to compare)";
    return estimate;
  };
  LinearSolution solution = Solve(a, b, nullptr);
  if (!solution.ok) return degenerate();
  // A micrometre floor keeps noise-free data solvable.
  Eigen::MatrixXd noise = integrated_noise;
  noise.diagonal().array() += solution.rss / static_cast<double>(a.rows() - a.cols()) + 1e-12;
  const Eigen::LLT<Eigen::MatrixXd> whitening(noise);
  if (whitening.info() != Eigen::Success) return degenerate();
  solution = Solve(a, b, &whitening);
  if (!solution.ok) return degenerate();
  Eigen::Vector3d gravity = solution.x.segment<3>(4);
  if (options.known_gravity_norm) {
    if (!(gravity.norm() > 0)) return degenerate();
    // g = |g| * direction; each step solves for a turn of the direction in its tangent
    // plane, the other unknowns with it.
    Eigen::Vector3d direction = gravity.normalized();
    for (int iteration = 0; iteration < options.gravity_iterations; ++iteration) {
      const Eigen::Matrix<double, 3, 2> tangent = TangentBasis(direction);
      build(options.gravity_m_s2 * tangent, options.gravity_m_s2 * direction, &a, &b);
      solution = Solve(a, b, &whitening);
      if (!solution.ok) return degenerate();
      direction = (direction + tangent * solution.x.segment<2>(4)).normalized();
    }
    gravity = options.gravity_m_s2 * direction;
  }
  const int bias_at = static_cast<int>(solution.x.size()) - bias_columns;
  estimate.scale = solution.x(0);
  estimate.scale_sigma = std::sqrt(std::max(solution.covariance(0, 0), 0.0));
  estimate.velocity_world = solution.x.segment<3>(1);
  estimate.gravity_world = gravity;
  if (bias_columns > 0) {
    estimate.bias = solution.x.segment<3>(bias_at);
    estimate.bias_covariance = solution.covariance.block<3, 3>(bias_at, bias_at);
  }
  estimate.rms_m = std::sqrt(solution.rss / static_cast<double>(rows));
  char text[160];
  const double relative = estimate.scale_sigma / std::abs(estimate.scale);
  std::snprintf(text, sizeof(text),
                "scale %.4g m/unit +- %.1f%% from %d poses over %.2f s (rms %.1f mm)",
                estimate.scale, 100.0 * relative, n, window.t_s.back(), 1e3 * estimate.rms_m);
  estimate.message = text;
  if (!(estimate.scale > 0)) {
    estimate.message += ": not positive";
  } else if (!(relative <= options.max_relative_sigma)) {
    estimate.message += ": too uncertain (too little acceleration)";
  } else {
    estimate.usable = true;
  }
  return estimate;
}

}  // namespace autocal
