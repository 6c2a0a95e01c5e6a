// Pinhole + Brown-Conrady camera model in OpenCV's convention (DESIGN.md section 2).
//
// The forward model maps ideal normalized coordinates (X/Z, Y/Z) to distorted pixels;
// pixel centres sit at integer coordinates. The templated functions are what Ceres
// differentiates; the double-typed ones are for everyday use.
#pragma once

#include <array>
#include <optional>
#include <string>

#include <Eigen/Core>

namespace autocal {

// Parameter order of the packed intrinsics vector used by the solvers.
enum IntrinsicIndex { kFx = 0, kFy, kCx, kCy, kK1, kK2, kP1, kP2, kK3, kNumIntrinsics };

struct CameraIntrinsics {
  int width = 0;              // Image width in pixels.
  int height = 0;             // Image height in pixels.
  double fx = 0.0, fy = 0.0;  // Focal lengths in pixels.
  double cx = 0.0, cy = 0.0;  // Principal point in pixels (pixel centres at integers).
  double k1 = 0.0, k2 = 0.0, p1 = 0.0, p2 = 0.0, k3 = 0.0;  // Brown-Conrady, OpenCV order.

  // fx, fy, cx, cy, k1, k2, p1, p2, k3.
  std::array<double, kNumIntrinsics> Packed() const;
  static CameraIntrinsics FromPacked(const std::array<double, kNumIntrinsics>& packed, int width,
                                     int height);
  // k1, k2, p1, p2, k3 (OpenCV's distortion vector).
  std::array<double, 5> Distortion() const { return {k1, k2, p1, p2, k3}; }
  Eigen::Matrix3d CameraMatrix() const;

  // A focal length and image size that make sense; says which field is wrong.
  bool Check(std::string* error) const;

  // A lens with the given horizontal field of view, principal point at the image centre.
  static CameraIntrinsics FromFieldOfView(int width, int height, double horizontal_fov_deg);

  bool operator==(const CameraIntrinsics&) const = default;
};

// Applies radial-tangential distortion to ideal normalized coordinates (x, y).
// dist = {k1, k2, p1, p2, k3}.
template <typename T>
void DistortNormalized(const T* dist, const T& x, const T& y, T* xd, T* yd) {
  const T x2 = x * x, y2 = y * y, xy = x * y;
  const T r2 = x2 + y2;
  const T radial = T(1.0) + r2 * (dist[0] + r2 * (dist[1] + r2 * dist[4]));
  *xd = x * radial + T(2.0) * dist[2] * xy + dist[3] * (r2 + T(2.0) * x2);
  *yd = y * radial + dist[2] * (r2 + T(2.0) * y2) + T(2.0) * dist[3] * xy;
}

// Jacobian of DistortNormalized with respect to (x, y), row-major: d(xd, yd)/d(x, y).
template <typename T>
void DistortionJacobian(const T* dist, const T& x, const T& y, T* jacobian) {
  const T r2 = x * x + y * y;
  const T radial = T(1.0) + r2 * (dist[0] + r2 * (dist[1] + r2 * dist[4]));
  const T dradial_dr2 = dist[0] + r2 * (T(2.0) * dist[1] + T(3.0) * r2 * dist[4]);
  const T cross = T(2.0) * x * y * dradial_dr2 + T(2.0) * dist[2] * x + T(2.0) * dist[3] * y;
  jacobian[0] = radial + T(2.0) * x * x * dradial_dr2 + T(2.0) * dist[2] * y + T(6.0) * dist[3] * x;
  jacobian[1] = cross;
  jacobian[2] = cross;
  jacobian[3] = radial + T(2.0) * y * y * dradial_dr2 + T(6.0) * dist[2] * y + T(2.0) * dist[3] * x;
}

// Inverse distortion by a fixed number of Newton steps from (xd, yd), for solvers that
// differentiate through it: once converged, the derivatives carried by Ceres' jets are
// those of the exact inverse (implicit function theorem). Enough steps for the lenses
// we meet converge to machine precision (see UndistortNormalized for a checked version).
template <typename T>
void UndistortNormalizedNewton(const T* dist, const T& xd, const T& yd, int steps, T* x, T* y) {
  *x = xd;
  *y = yd;
  for (int i = 0; i < steps; ++i) {
    T rx, ry, j[4];
    DistortNormalized(dist, *x, *y, &rx, &ry);
    DistortionJacobian(dist, *x, *y, j);
    rx -= xd;
    ry -= yd;
    const T det = j[0] * j[3] - j[1] * j[2];
    *x -= (j[3] * rx - j[1] * ry) / det;
    *y -= (j[0] * ry - j[2] * rx) / det;
  }
}

// Projects a point given in the camera frame to pixels with the packed intrinsics
// (IntrinsicIndex order). Points at or behind the camera centre are still projected;
// callers that care test the depth themselves.
template <typename T>
void ProjectPoint(const T* intrinsics, const T* point_cam, T* pixel) {
  const T x = point_cam[0] / point_cam[2];
  const T y = point_cam[1] / point_cam[2];
  T xd, yd;
  DistortNormalized(intrinsics + kK1, x, y, &xd, &yd);
  pixel[0] = intrinsics[kFx] * xd + intrinsics[kCx];
  pixel[1] = intrinsics[kFy] * yd + intrinsics[kCy];
}

// The pixel of ideal normalized coordinates (x, y) through the packed intrinsics, with its
// derivatives by hand for the solvers' residuals: by the intrinsics (2 x kNumIntrinsics,
// row-major) and by (x, y) (2 x 2, row-major); either may be null.
void ProjectNormalized(const double* intrinsics, double x, double y, double* pixel,
                       double* by_intrinsics, double* by_normalized);

// Pixel of a point in the camera frame.
Eigen::Vector2d Project(const CameraIntrinsics& camera, const Eigen::Vector3d& point_cam);

// Ideal normalized coordinates whose distorted image is (xd, yd): Newton's method, run
// until the distorted point is reproduced to `tolerance` (normalized units). Returns
// nothing where the distortion cannot be inverted (beyond the fold of a strong barrel).
// `initial` may carry a nearby solution (the previous frame's) to start from.
std::optional<Eigen::Vector2d> UndistortNormalized(
    const std::array<double, 5>& dist, const Eigen::Vector2d& distorted, double tolerance = 1e-12,
    const std::optional<Eigen::Vector2d>& initial = std::nullopt);

// Ideal normalized coordinates (x, y), i.e. the ray (x, y, 1), seen by a pixel.
std::optional<Eigen::Vector2d> Unproject(const CameraIntrinsics& camera,
                                         const Eigen::Vector2d& pixel);

// The undistorted pixel of a raw one: where the camera matrix alone would image its ray
// (the rectified image's pixel). Nothing beyond the fold of a strong barrel.
std::optional<Eigen::Vector2d> UndistortPixel(const CameraIntrinsics& camera,
                                              const Eigen::Vector2d& raw);

}  // namespace autocal
