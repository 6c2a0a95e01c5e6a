// Plumb-line residuals in a Ceres problem, shared by the distortion estimate (box 2) and
// the calibration (box 10).
#pragma once

#include <array>
#include <vector>

#include <ceres/ordered_groups.h>
#include <ceres/problem.h>
#include <Eigen/Core>

#include "pipeline/camera_model.h"
#include "pipeline/plumb_line.h"

namespace autocal {

// A point of a straight world line, against where it was observed. The line is
// x cos(t) + y sin(t) = rho in ideal normalized coordinates, the point sits at position s
// along it, and the lens model carries it into the image: the error is measured where the
// noise is, in pixels of the distorted image, and needs no inverse of the lens (which a
// trial distortion may not have). Parameters: packed intrinsics (IntrinsicIndex order),
// the line (t, rho), the position s.
struct LinePointCost {
  explicit LinePointCost(const Eigen::Vector2d& pixel) : pixel_(pixel) {}

  template <typename T>
  bool operator()(const T* intrinsics, const T* line, const T* position, T* residual) const {
    using std::cos;
    using std::sin;
    const T nx = cos(line[0]), ny = sin(line[0]);
    const T point[3] = {line[1] * nx - position[0] * ny, line[1] * ny + position[0] * nx, T(1.0)};
    T pixel[2];
    ProjectPoint(intrinsics, point, pixel);
    residual[0] = pixel[0] - T(pixel_.x());
    residual[1] = pixel[1] - T(pixel_.y());
    return true;
  }

  Eigen::Vector2d pixel_;
};

// The line and position parameters of the plumb-line residuals; must outlive the solve.
struct PlumbLineBlocks {
  std::vector<std::array<double, 2>> lines;
  std::vector<double> positions;
};

// Adds one residual per point of every line, on `intrinsics` (packed, owned by the
// caller), with the lines and positions initialized from `start`. Positions go in
// elimination group 0 of `ordering`, lines in group 1.
void AddPlumbLineResiduals(const std::vector<const LineObservation*>& lines,
                           const CameraIntrinsics& start, double loss_px, double* intrinsics,
                           ceres::Problem* problem, ceres::ParameterBlockOrdering* ordering,
                           PlumbLineBlocks* blocks);

}  // namespace autocal
