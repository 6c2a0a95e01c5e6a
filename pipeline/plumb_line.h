// Box 2, distortion by the plumb-line principle: the world lines behind the snakes are
// straight, so the distortion is what makes every undistorted snake straight. Solved
// with Ceres over all snakes gathered over time, robust to edges that are curved in the
// world.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "pipeline/camera_model.h"

namespace autocal {

struct PlumbLineOptions {
  bool estimate_k3 = false;          // Free k3 (wide lenses); k1, k2 are always free.
  bool estimate_tangential = false;  // Free p1, p2.
  bool estimate_centre = false;      // Free distortion centre (= principal point).
  double loss_scale_px = 0.5;        // Cauchy loss scale on point-to-line distances.
  double outlier_factor = 3.0;       // Lines with RMS above this times the median are dropped.
  int min_lines = 6;                 // Fewer lines: not observable.
  int min_points_per_line = 5;       // Shorter polylines are ignored.
  int max_iterations = 50;           // Levenberg-Marquardt iterations per solve.
  // What the lines must constrain for an estimate to be taken; short of it the result is
  // "not observable" and the initial distortion is kept, since lines that do not bend under
  // the lens leave it free to take any value (see DistortionObservability).
  double min_covered_radius = 0.5;  // Supporting points must reach this far (of the half-diagonal).
  double max_direction_share = 0.95;  // Most of the support allowed within 20 deg of one direction.
  double max_sigma_px = 1.0;          // Largest 1-sigma of the shift within the covered radius, px.
  // An estimate that moves a pixel within the covered radius by over max(2 px, 5 sigma) from
  // the initial lens must straighten the lines by at least this fraction of their residual.
  double min_straightening = 0.1;

  bool Check(std::string* error) const;
};

// Distorted pixel points that lie on one straight world line (a snake, a line segment).
struct LineObservation {
  std::vector<Eigen::Vector2d> points;
};

// What the lines behind an estimate constrain of the lens. Radii are from the principal
// point (the distortion centre), in fractions of the image's half-diagonal.
struct DistortionObservability {
  static constexpr int kRadialBins = 10;
  // Supporting points by radius, in tenths of the half-diagonal (the corners of an image
  // whose principal point is off centre fall in the last bin).
  std::array<int, kRadialBins> radial_points{};
  double covered_radius = 0.0;   // 95% of the supporting points lie within this radius.
  double direction_share = 0.0;  // Largest share of the points on lines within 20 deg of one direction.
  // The largest shift the estimated distortion gives a pixel within the covered radius, and
  // the largest 1-sigma of that shift there (from the covariance with a line's points taken
  // as one cluster, their errors being correlated along an edge), px.
  double max_shift_px = 0.0;
  double shift_sigma_px = 0.0;
  // The largest distance between the estimated and the initial lens within the covered
  // radius, px: how far the estimate moved the lens.
  double change_px = 0.0;
  bool observable = false;
  std::string reason;        // Why not observable; empty when it is.
  std::string brief_reason;  // The same in a few words, for a display.
};

struct PlumbLineResult {
  bool usable = false;        // False: not enough material or the solve failed.
  std::string message;        // Why not usable, or a one-line report.
  CameraIntrinsics estimate;  // The initial camera with the estimated distortion.
  // What the solve ended on, whether taken or not (not observable); the initial camera
  // when it failed.
  CameraIntrinsics solved;
  // RMS distance of the undistorted points to their best lines, px, with the initial and
  // the estimated distortion (all lines used for the estimate).
  double rms_before_px = 0.0;
  double rms_after_px = 0.0;
  int lines_used = 0;
  int lines_rejected = 0;  // Curved in the world (or mistracked): left out.
  int points_used = 0;
  // Covariance of the free distortion coefficients, in the order k1, k2[, p1, p2][, k3],
  // with a line's points as one cluster (MarginalCovariance's clustered one).
  Eigen::MatrixXd covariance;
  // Filled whenever a solve ended; `usable` needs `observable`. When the lines do not
  // constrain the lens, `estimate` is the initial camera and the message says why.
  DistortionObservability observability;
};

// A few words for a display: the largest shift box 2's estimate gives within the radius its
// lines reach, its 1-sigma, that radius and the lines ("lens: 12.3 ± 0.09 px to 78% (214
// lines)"), or, plainly, that the lines do not determine the lens and why ("lens not
// observable: lines reach only 36%"). PlumbLineResult::message says it in full.
std::string LensVerdict(const PlumbLineResult& result);

// The observability as a JSON object (the summaries' "observability" field).
std::string ObservabilityJson(const DistortionObservability& observability);

// Estimates the distortion (and, if asked, the distortion centre) starting from
// `initial`. Its focal lengths are held: the plumb-line constraint fixes the distortion
// in pixels, so the normalized coefficients are tied to the focal length they were
// estimated with (see ScaleDistortionToFocal).
PlumbLineResult EstimateDistortion(const std::vector<LineObservation>& lines,
                                   const CameraIntrinsics& initial,
                                   const PlumbLineOptions& options);

// The same distortion in pixels, expressed for another focal length: radial terms scale
// with powers of f_new / f_old, tangential ones linearly.
CameraIntrinsics ScaleDistortionToFocal(const CameraIntrinsics& camera, double fx, double fy);

// `pinhole`'s fx, fy, cx, cy with the distortion of `lens`, carried to those focal lengths.
CameraIntrinsics WithDistortionOf(const CameraIntrinsics& pinhole, const CameraIntrinsics& lens);

// How far apart two lenses put the same ray in the image, at worst (px): for every pixel
// p within `radius_fraction` of the half-diagonal from the image centre, the ray lens
// `reference` sees at p is projected through `lens`, and its distance to p taken. With
// equal pinhole parameters this compares the distortions where they are observed.
double MaxDistortionDifference(const CameraIntrinsics& lens, const CameraIntrinsics& reference,
                               double radius_fraction, int grid_step_px = 8);

}  // namespace autocal
