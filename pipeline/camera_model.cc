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

void ProjectNormalized(const double* intrinsics, double x, double y, double* pixel,
                       double* by_intrinsics, double* by_normalized) {
  const double* dist = intrinsics + kK1;  // k1, k2, p1, p2, k3.
  const double fx = intrinsics[kFx], fy = intrinsics[kFy];
  double xd, yd;
  DistortNormalized(dist, x, y, &xd, &yd);
  pixel[0] = fx * xd + intrinsics[kCx];
  pixel[1] = fy * yd + intrinsics[kCy];
  if (by_intrinsics) {
    const double r2 = x * x + y * y, r4 = r2 * r2, xy2 = 2.0 * x * y;
    Eigen::Map<Eigen::Matrix<double, 2, kNumIntrinsics, Eigen::RowMajor>> d(by_intrinsics);
    d.setZero();
    d(0, kFx) = xd;
    d(1, kFy) = yd;
    d(0, kCx) = 1.0;
    d(1, kCy) = 1.0;
    d(0, kK1) = fx * x * r2;
    d(1, kK1) = fy * y * r2;
    d(0, kK2) = fx * x * r4;
    d(1, kK2) = fy * y * r4;
    d(0, kK3) = fx * x * r4 * r2;
    d(1, kK3) = fy * y * r4 * r2;
    d(0, kP1) = fx * xy2;
    d(1, kP1) = fy * (r2 + 2.0 * y * y);
    d(0, kP2) = fx * (r2 + 2.0 * x * x);
    d(1, kP2) = fy * xy2;
  }
  if (by_normalized) {
    double lens[4];
    DistortionJacobian(dist, x, y, lens);
    by_normalized[0] = fx * lens[0];
    by_normalized[1] = fx * lens[1];
    by_normalized[2] = fy * lens[2];
    by_normalized[3] = fy * lens[3];
  }
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

std::optional<Eigen::Vector2d> UndistortPixel(const CameraIntrinsics& camera,
                                              const Eigen::Vector2d& raw) {
  const std::optional<Eigen::Vector2d> ray = Unproject(camera, raw);
  if (!ray) return std::nullopt;
  return Eigen::Vector2d(camera.fx * ray->x() + camera.cx, camera.fy * ray->y() + camera.cy);
}

}  // namespace autocal
