#include "pipeline/plane_point_cost.h"

#include <cmath>

#include <ceres/rotation.h>
#include <Eigen/Core>

namespace autocal {
namespace {

using RowMajor2x3 = Eigen::Matrix<double, 2, 3, Eigen::RowMajor>;

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

Eigen::Matrix3d Rotation(const double* angle_axis) {
  Eigen::Matrix3d r;  // Column-major, as Ceres writes it.
  ceres::AngleAxisToRotationMatrix(angle_axis, r.data());
  return r;
}

// d(R(w) p) / dw = -[R(w) p]x J(w), J the left Jacobian of SO(3): R(w + dw) is
// Exp(J(w) dw) R(w) to first order.
Eigen::Matrix3d DerivativeOfTurnedPoint(const double* angle_axis, const Eigen::Vector3d& rotated) {
  const Eigen::Vector3d w(angle_axis[0], angle_axis[1], angle_axis[2]);
  const Eigen::Matrix3d wx = Skew(w);
  const double theta2 = w.squaredNorm();
  double a, b;  // J = I + a [w]x + b [w]x^2.
  if (theta2 < 1e-8) {
    a = 0.5 - theta2 / 24.0;
    b = 1.0 / 6.0 - theta2 / 120.0;
  } else {
    const double theta = std::sqrt(theta2);
    a = (1.0 - std::cos(theta)) / theta2;
    b = (theta - std::sin(theta)) / (theta2 * theta);
  }
  const Eigen::Matrix3d left_jacobian = Eigen::Matrix3d::Identity() + a * wx + b * wx * wx;
  return -Skew(rotated) * left_jacobian;
}

}  // namespace

bool PlanePointCost::Residual(const double* intrinsics, const double* cam_from_world,
                              const double* world_from_plane, const double* uv,
                              double* residual) const {
  const double* const parameters[] = {intrinsics, cam_from_world, world_from_plane, uv};
  return Evaluate(parameters, residual, nullptr);
}

bool PlanePointCost::Evaluate(double const* const* parameters, double* residuals,
                              double** jacobians) const {
  const double* intrinsics = parameters[0];
  const double* cam = parameters[1];
  const double* plane = parameters[2];
  const double* uv = parameters[3];

  const Eigen::Matrix3d plane_rotation = Rotation(plane);
  const Eigen::Matrix3d cam_rotation = Rotation(cam);
  const Eigen::Vector3d in_world_turned = plane_rotation.leftCols<2>() * Eigen::Vector2d(uv[0], uv[1]);
  const Eigen::Vector3d world = in_world_turned + Eigen::Vector3d(plane[3], plane[4], plane[5]);
  const Eigen::Vector3d cam_turned = cam_rotation * world;
  const Eigen::Vector3d point = cam_turned + Eigen::Vector3d(cam[3], cam[4], cam[5]);
  if (!(point.z() > 0.0)) return false;

  const double inv_z = 1.0 / point.z();
  const double x = point.x() * inv_z, y = point.y() * inv_z;
  const double* dist = intrinsics + kK1;  // k1, k2, p1, p2, k3.
  double xd, yd;
  DistortNormalized(dist, x, y, &xd, &yd);
  const double fx = intrinsics[kFx], fy = intrinsics[kFy];
  residuals[0] = fx * xd + intrinsics[kCx] - pixel_.x();
  residuals[1] = fy * yd + intrinsics[kCy] - pixel_.y();
  if (!jacobians) return true;

  if (double* j = jacobians[0]) {
    const double r2 = x * x + y * y, r4 = r2 * r2, xy2 = 2.0 * x * y;
    Eigen::Map<Eigen::Matrix<double, 2, kNumIntrinsics, Eigen::RowMajor>> d(j);
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
  if (!jacobians[1] && !jacobians[2] && !jacobians[3]) return true;

  // Pixels by the point in the camera: focal lengths, lens, perspective division.
  double lens[4];
  DistortionJacobian(dist, x, y, lens);
  Eigen::Matrix2d by_normalized;
  by_normalized << fx * lens[0], fx * lens[1], fy * lens[2], fy * lens[3];
  RowMajor2x3 division;
  division << inv_z, 0.0, -x * inv_z, 0.0, inv_z, -y * inv_z;
  const RowMajor2x3 by_point = by_normalized * division;

  if (double* j = jacobians[1]) {
    Eigen::Map<Eigen::Matrix<double, 2, 6, Eigen::RowMajor>> d(j);
    d.leftCols<3>() = by_point * DerivativeOfTurnedPoint(cam, cam_turned);
    d.rightCols<3>() = by_point;
  }
  const RowMajor2x3 by_world = by_point * cam_rotation;
  if (double* j = jacobians[2]) {
    Eigen::Map<Eigen::Matrix<double, 2, 6, Eigen::RowMajor>> d(j);
    d.leftCols<3>() = by_world * DerivativeOfTurnedPoint(plane, in_world_turned);
    d.rightCols<3>() = by_world;
  }
  if (double* j = jacobians[3]) {
    Eigen::Map<Eigen::Matrix<double, 2, 2, Eigen::RowMajor>> d(j);
    d = by_world * plane_rotation.leftCols<2>();
  }
  return true;
}

}  // namespace autocal
