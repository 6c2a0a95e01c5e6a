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

// R(w + dw) is Exp(J(w) dw) R(w) to first order, J the left Jacobian of SO(3).
Eigen::Matrix3d LeftJacobian(const double* angle_axis) {
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
  return Eigen::Matrix3d::Identity() + a * wx + b * wx * wx;
}

// A ray parallel to the plane within this meets it nowhere usable.
constexpr double kHorizon = 1e-12;

}  // namespace

std::optional<Eigen::Vector3d> PointOnRay(const double* plane, const double* ray) {
  const Eigen::Vector3d d(ray[0], ray[1], 1.0);
  const double s = Eigen::Vector3d(plane[0], plane[1], plane[2]).dot(d);
  if (!(std::abs(s) > kHorizon)) return std::nullopt;
  return d / s;
}

bool PlanePointCost::Residual(const double* intrinsics, const double* cam_from_world,
                              const double* reference_from_world, const double* plane,
                              const double* ray, double* residual) const {
  const double* const parameters[] = {intrinsics, cam_from_world, reference_from_world, plane, ray};
  return Evaluate(parameters, residual, nullptr);
}

bool PlanePointCost::Evaluate(double const* const* parameters, double* residuals,
                              double** jacobians) const {
  const double* intrinsics = parameters[0];
  const double* cam = parameters[1];
  const double* reference = parameters[2];
  const double* plane = parameters[3];
  const double* ray = parameters[4];

  const std::optional<Eigen::Vector3d> in_reference = PointOnRay(plane, ray);
  if (!in_reference) return false;
  const Eigen::Matrix3d reference_rotation = Rotation(reference);
  const Eigen::Matrix3d cam_rotation = Rotation(cam);
  // World = R_k^T (X_k - t_k).
  const Eigen::Vector3d offset =
      *in_reference - Eigen::Vector3d(reference[3], reference[4], reference[5]);
  const Eigen::Vector3d world = reference_rotation.transpose() * offset;
  const Eigen::Vector3d cam_turned = cam_rotation * world;
  const Eigen::Vector3d point = cam_turned + Eigen::Vector3d(cam[3], cam[4], cam[5]);
  if (!(point.z() > 0.0)) return false;

  const double inv_z = 1.0 / point.z();
  const double x = point.x() * inv_z, y = point.y() * inv_z;
  const bool by_pose = jacobians && (jacobians[1] || jacobians[2] || jacobians[3] || jacobians[4]);
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
    d.leftCols<3>() = -by_point * Skew(cam_turned) * LeftJacobian(cam);
    d.rightCols<3>() = by_point;
  }
  // By the point in view k's camera.
  const RowMajor2x3 by_reference = by_point * cam_rotation * reference_rotation.transpose();
  if (double* j = jacobians[2]) {
    // R(w + dw)^T y = R^T (I - [J dw]x) y = R^T y + R^T [y]x J dw.
    Eigen::Map<Eigen::Matrix<double, 2, 6, Eigen::RowMajor>> d(j);
    d.leftCols<3>() = by_reference * Skew(offset) * LeftJacobian(reference);
    d.rightCols<3>() = -by_reference;
  }
  // X_k = d / (m . d): by m, -X_k X_k^T; by d, (I - X_k m^T) / (m . d).
  const Eigen::Vector3d& xk = *in_reference;
  if (double* j = jacobians[3]) {
    Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> d(j);
    d = -by_reference * (xk * xk.transpose());
  }
  if (double* j = jacobians[4]) {
    const Eigen::Vector3d m(plane[0], plane[1], plane[2]);
    const Eigen::Matrix3d by_direction =
        (Eigen::Matrix3d::Identity() - xk * m.transpose()) * xk.z();  // 1 / (m . d) = X_k.z.
    Eigen::Map<Eigen::Matrix<double, 2, 2, Eigen::RowMajor>> d(j);
    d = by_reference * by_direction.leftCols<2>();
  }
  return true;
}

bool ReferenceRayCost::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  const double* ray = parameters[1];
  ProjectNormalized(parameters[0], ray[0], ray[1], residuals, jacobians ? jacobians[0] : nullptr,
                    jacobians ? jacobians[1] : nullptr);
  residuals[0] -= pixel_.x();
  residuals[1] -= pixel_.y();
  return true;
}

}  // namespace autocal
