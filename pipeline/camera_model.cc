#include "pipeline/camera_model.h"

#include <cmath>
#include <sstream>

#include <Eigen/LU>

namespace autocal {

std::array<double, kNumIntrinsics> CameraIntrinsics::Packed() const {
  return {fx, fy, cx, cy, k1, k2, p1, p2, k3};
}

CameraIntrinsics CameraIntrinsics::FromPacked(const std::array<double, kNumIntrinsics>& p,
                                              int width, int height) {
  CameraIntrinsics c;
  c.width = width;
  c.height = height;
  c.fx = p[kFx];
  c.fy = p[kFy];
  c.cx = p[kCx];
  c.cy = p[kCy];
  c.k1 = p[kK1];
  c.k2 = p[kK2];
  c.p1 = p[kP1];
  c.p2 = p[kP2];
  c.k3 = p[kK3];
  return c;
}

Eigen::Matrix3d CameraIntrinsics::CameraMatrix() const {
  Eigen::Matrix3d k;
  k << fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0;
  return k;
}

bool CameraIntrinsics::Check(std::string* error) const {
  std::ostringstream why;
  if (width <= 0 || height <= 0) {
    why << "image size must be positive, got " << width << "x" << height;
  } else if (!(fx > 0.0) || !(fy > 0.0) || !std::isfinite(fx) || !std::isfinite(fy)) {
    why << "focal lengths must be positive and finite, got fx=" << fx << " fy=" << fy;
  } else if (!std::isfinite(cx) || !std::isfinite(cy)) {
    why << "principal point must be finite";
  } else if (!std::isfinite(k1) || !std::isfinite(k2) || !std::isfinite(p1) || !std::isfinite(p2) ||
             !std::isfinite(k3)) {
    why << "distortion coefficients must be finite";
  }
  if (why.str().empty()) return true;
  if (error) *error = why.str();
  return false;
}

CameraIntrinsics CameraIntrinsics::FromFieldOfView(int width, int height,
                                                   double horizontal_fov_deg) {
  CameraIntrinsics c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = 0.5 * width / std::tan(0.5 * horizontal_fov_deg * M_PI / 180.0);
  c.cx = 0.5 * (width - 1);
  c.cy = 0.5 * (height - 1);
  return c;
}

Eigen::Vector2d Project(const CameraIntrinsics& camera, const Eigen::Vector3d& point_cam) {
  const auto packed = camera.Packed();
  Eigen::Vector2d pixel;
  ProjectPoint(packed.data(), point_cam.data(), pixel.data());
  return pixel;
}

std::optional<Eigen::Vector2d> UndistortNormalized(const std::array<double, 5>& dist,
                                                   const Eigen::Vector2d& distorted,
                                                   double tolerance,
                                                   const std::optional<Eigen::Vector2d>& initial) {
  constexpr int kMaxIterations = 50;
  Eigen::Vector2d x = initial.value_or(distorted);
  for (int i = 0; i < kMaxIterations; ++i) {
    Eigen::Vector2d reproduced;
    DistortNormalized(dist.data(), x.x(), x.y(), &reproduced.x(), &reproduced.y());
    const Eigen::Vector2d residual = reproduced - distorted;
    if (residual.norm() <= tolerance) return x;
    Eigen::Matrix<double, 2, 2, Eigen::RowMajor> j;
    DistortionJacobian(dist.data(), x.x(), x.y(), j.data());
    const double det = j.determinant();
    // A vanishing or negative determinant means we crossed the fold of the lens: there
    // the model is not invertible and no ray maps to this pixel.
    if (!(det > 1e-12)) return std::nullopt;
    Eigen::Vector2d step = j.inverse() * residual;
    // Keep Newton from leaping across the fold from a poor start.
    const double max_step = 0.5 * (1.0 + x.norm());
    if (step.norm() > max_step) step *= max_step / step.norm();
    x -= step;
    if (!x.allFinite()) return std::nullopt;
  }
  return std::nullopt;
}

std::optional<Eigen::Vector2d> Unproject(const CameraIntrinsics& camera,
                                         const Eigen::Vector2d& pixel) {
  const Eigen::Vector2d distorted((pixel.x() - camera.cx) / camera.fx,
                                  (pixel.y() - camera.cy) / camera.fy);
  return UndistortNormalized(camera.Distortion(), distorted);
}

}  // namespace autocal
