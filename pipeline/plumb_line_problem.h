// What the Ceres problems of the distortion estimate (box 2) and the calibration (box 10)
// share: plumb-line residuals, parameter storage, and the covariance of the intrinsics.
#pragma once

#include <cstddef>
#include <optional>
#include <span>
#include <vector>

#include <ceres/ordered_groups.h>
#include <ceres/problem.h>
#include <ceres/sized_cost_function.h>
#include <Eigen/Core>

#include "pipeline/camera_model.h"
#include "pipeline/plumb_line.h"

namespace autocal {

// A point of a straight world line, against where it was observed. The line is
// x cos(t) + y sin(t) = rho in ideal normalized coordinates, and the lens model carries it
// into the image: the residual runs from the observed pixel to the nearest point of the
// line's image, measured where the noise is, in pixels of the distorted image, with no
// inverse of the lens (which a trial distortion may not have). The point's position along
// the line is not a parameter: each evaluation finds it by Gauss-Newton from `position`
// (variable projection), and the Jacobian is the projection's, less its component along
// the line's image (Kaufman's), the position's Schur complement. A window's lines have
// a thousand or more points, and carried as parameters of their own their positions and
// lines made nearly half of box 10's linear solver time. Parameters: packed intrinsics
// (IntrinsicIndex order) and the line (t, rho). The Jacobian is worked by hand (automatic
// differentiation once took half of box 10's solve at 640x480).
class LinePointCost final : public ceres::SizedCostFunction<2, kNumIntrinsics, 2> {
 public:
  LinePointCost(const Eigen::Vector2d& pixel, double position)
      : pixel_(pixel), position_(position) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector2d pixel_;
  double position_;  // Along the line, where the search starts.
};

// Options for a problem whose residuals share one loss the caller owns (a loss object per
// residual costs an allocation and an entry in Ceres' ownership table each).
inline ceres::Problem::Options UnownedLosses() {
  ceres::Problem::Options options;
  options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return options;
}

// Every parameter block of one problem in a single allocation, handed out in the order
// asked for. Ceres orders the blocks of an elimination group by address; within one
// allocation that is this order, so two solves of the same material agree to the last
// digit (blocks in separate allocations would be ordered by heap addresses, which differ
// between runs).
class ParameterArena {
 public:
  explicit ParameterArena(size_t capacity) { values_.reserve(capacity); }
  ParameterArena(const ParameterArena&) = delete;
  ParameterArena& operator=(const ParameterArena&) = delete;

  // A block holding a copy of `initial`, valid as long as the arena. Throws
  // std::logic_error beyond the capacity (the blocks handed out would move).
  double* Add(std::span<const double> initial);

 private:
  std::vector<double> values_;
};

// Which of `lines` are straight under `camera`: those whose undistorted points lie within
// `factor` times the median line's RMS distance of their own best straight line. The rest
// are curved in the world (a kerb, a roofline turning a corner, the horizon over a
// ground's corner) or mistracked, and would bend the distortion toward their shape.
std::vector<bool> StraightLines(const std::vector<const LineObservation*>& lines,
                                const CameraIntrinsics& camera, double factor);

// The values AddPlumbLineResiduals takes from the arena for `lines`.
size_t PlumbLineParameterCount(const std::vector<const LineObservation*>& lines);

// Adds one residual per point of every line, on `intrinsics` (packed, owned by the
// caller), with the lines taken from `arena` and initialized from `start`. Every residual
// takes `loss` (the problem's options say who owns it; Ceres deletes a shared one once).
// The lines go in elimination group 0 of `ordering`. Returns each line's parameter block,
// in order.
std::vector<double*> AddPlumbLineResiduals(const std::vector<const LineObservation*>& lines,
                                           const CameraIntrinsics& start, ceres::LossFunction* loss,
                                           double* intrinsics, ceres::Problem* problem,
                                           ceres::ParameterBlockOrdering* ordering,
                                           ParameterArena* arena);

// The covariance of `intrinsics` at the solution, in its tangent space (the free
// parameters, in order), for unit residual variance: the Gauss-Newton Hessian J^T J with
// every other parameter marginalized out by the Schur complement. `ordering` must hold
// every non-constant block, the intrinsics in group 1 and in group 0 only blocks seen by
// no residual together with another group-0 block (points, lines); std::logic_error if
// not. Empty when the intrinsics are not constrained.
//
// With `clustered`, also the covariance that does not take the residuals for independent:
// the sandwich H^-1 (sum over clusters of g g^T) H^-1, g a cluster's gradient J^T r, each
// group-0 block's residuals one cluster (a point's views, a line's points) and every other
// residual its own. A tracked point's errors carry over from view to view (Lucas-Kanade's
// drift), so its views say less than as many independent ones; this counts them as what
// they scatter by together. Its scale is the residuals' own (not unit variance), with the
// small-sample factor n / (n - 1) over n clusters.
std::optional<Eigen::MatrixXd> MarginalCovariance(ceres::Problem* problem,
                                                  const ceres::ParameterBlockOrdering& ordering,
                                                  double* intrinsics,
                                                  Eigen::MatrixXd* clustered = nullptr);

}  // namespace autocal
