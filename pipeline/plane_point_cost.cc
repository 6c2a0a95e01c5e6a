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
  const bool by_pose = jacobians && (jacobians[1] || jacobians[2] || jacobians[3]);
  Eigen::Matrix<double, 2, 2, Eigen::RowMajor> by_normalized;
  ProjectNormalized(intrinsics, x, y, residuals, jacobians ? jacobians[0] : nullptr,
                    by_pose ? by_normalized.data() : nullptr);
  residuals[0] -= pixel_.x();
  residuals[1] -= pixel_.y();
  if (!by_pose) return true;

  // Pixels by the point in the camera: lens and focal lengths, perspective division.
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
