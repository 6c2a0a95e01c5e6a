// Box 10: self-calibrating Levenberg-Marquardt. Intrinsics, distortion, every dominant
// plane, every frame's pose and every tracked point (on its ray in the plane's reference
// view), estimated jointly from the REAL tracks of the planes (box 9), with plumb-line residuals
// from box 2, gravity residuals where the body is at rest, and a weak prior from the last
// accepted calibration. A plane seen from several orientations fixes the intrinsics
// (Triggs 1998, Zhang 2000); nothing here is measured on anything rendered with the
// current calibration, so a wrong start converges to the truth instead of staying put.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "pipeline/camera_model.h"
#include "pipeline/plumb_line.h"

namespace autocal {

// One tracked point of a plane, seen in one frame (pixels, distorted image).
struct PlaneObservation {
  int frame = 0;  // 0 .. CalibrationMaterial::frame_count - 1.
  int point = 0;  // Track id, unique within the plane.
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
};

// A dominant plane and the real tracks on it.
struct PlaneTrack {
  int id = 0;
  std::vector<PlaneObservation> observations;
};

// The direction of gravity ("down") in a frame's camera frame, from the accelerometer
// while the body is at rest.
struct GravityObservation {
  int frame = 0;
  Eigen::Vector3d down_cam = Eigen::Vector3d::UnitY();  // Unit vector.
  double sigma_deg = 0.5;
};

// A plane as the calibration placed it: its frame in the window's world (x, y in the plane,
// z its normal), and its tracked points' coordinates in that frame.
struct PlaneEstimate {
  int id = 0;
  Eigen::Isometry3d world_from_plane = Eigen::Isometry3d::Identity();
  std::vector<std::pair<int, Eigen::Vector2d>> points;  // (track id, (u, v)).
};

// A solution to start from: an earlier attempt's, on views this window shares with it.
struct CalibrationStart {
  CameraIntrinsics intrinsics;
  // Per frame of the material: the earlier attempt's pose of that view, in its world.
  std::vector<std::optional<Eigen::Isometry3d>> cam_from_world;
  std::vector<PlaneEstimate> planes;  // In the same world.
};

// How far the camera moved over a window of frames, as its images and its accelerometer saw
// it: an attempt that makes no update names it when the camera barely moved.
struct WindowMotion {
  double span_s = 0.0;
  // The largest median displacement (px) of the tracked features two views share: the
  // image motion every plane's parallax and view change come from.
  double image_px = 0.0;
  std::optional<double> tilt_deg;  // Largest angle between two views' measured gravity.
};

// Everything one calibration attempt draws on, over a window of frames.
struct CalibrationMaterial {
  // Why images in the window were unfit to measure from (box 9's quality gate); when set,
  // the attempt makes no update.
  std::string degraded;
  int frame_count = 0;
  std::vector<int64_t> frame_t_ns;  // Each frame's time; empty: unknown.
  std::vector<PlaneTrack> planes;
  std::vector<LineObservation> lines;  // Snake shapes: straight world lines.
  std::vector<GravityObservation> gravity;
  std::optional<WindowMotion> motion;  // Unset where not measured (still shots).
  // Windows overlap: the previous attempt's solution, when there is one, is where the solve
  // starts (SelfCalibrationOptions::warm_start).
  std::optional<CalibrationStart> start;
};

// A camera's rolling-shutter readout (ms): 0 (a global shutter) to this, a frame period at
// 1 frame/s; every place that takes one holds it to this range.
inline constexpr double kMaxReadoutMs = 1000.0;
inline bool IsReadoutMs(double ms) { return ms >= 0 && ms <= kMaxReadoutMs; }

struct SelfCalibrationOptions {
  bool estimate_principal_point = true;  // cx, cy free.
  bool estimate_distortion = true;       // k1, k2 free.
  bool estimate_k3 = false;              // k3 free too.
  bool estimate_tangential = false;      // p1, p2 free too.
  double loss_px = 1.0;                  // Cauchy loss scale on reprojection errors.
  double prior_focal_fraction = 0.1;     // Prior sigma of fx, fy as a fraction of them.
  double prior_principal_px = 30.0;      // Prior sigma of cx, cy.
  double prior_distortion = 0.2;         // Prior sigma of each distortion coefficient.
  // The plane tracks' noise (px) the prior is weighed against: the pixel residuals come at
  // unit weight, so (value - prior) / sigma is scaled by this. At 1 px the prior holds 5-20
  // times harder than its sigmas say (the tracks are good to 0.05-0.25 px) and holds a
  // wrong start back; 0.15 px converges twice as fast on the 320x240 walks but is not the
  // default yet (docs/calibration.md, "The prior is stronger than its sigmas say").
  double prior_track_noise_px = 1.0;
  int min_frames = 6;                    // Fewer frames with a pose: no update.
  int min_points_per_plane = 12;         // Planes with fewer tracked points are left out.
  double min_rotation_deg = 8.0;         // Views must differ by this much in orientation.
  // An attempt that makes no update over a window whose image moved less than this (px,
  // CalibrationMaterial::motion) puts it down to the camera barely moving, with the figures:
  // a plane is told apart by its parallax (PlaneOptions::min_parallax_px, 16 px), and 8 deg
  // of turn moves the image by 40-140 px at the fields of view of body cameras. A plane is
  // solved in its own world only if its image moved this much.
  double barely_moved_px = 20.0;
  double max_focal_sigma = 0.01;         // No update when sigma(fx) / fx exceeds this.
  // Levenberg-Marquardt iterations a pass; a last pass still descending after them makes no
  // update (it was crawling along a nearly flat valley, and stopped anywhere on it).
  int max_iterations = 100;
  // From an earlier attempt's solution, the first pass (the one that tells the points that
  // fit badly apart) stops after this many iterations at most.
  int warm_first_pass_iterations = 3;
  // Converged when an iteration lowers the cost by less than this fraction: Ceres' 1e-6
  // took one or two more iterations in seven, moving fx by 0.01% at most.
  double function_tolerance = 1e-5;
  // The last pass also ends once two successful iterations in a row have each moved the
  // image of the calibration by less than this (px: the largest shift of a 3 x 3 grid of
  // points spanning the image), the cost falling by less than 0.1% in each
  // (IntrinsicsStandStill); 0: only by the cost. The outdoor walk's long solves spent their
  // last 4-6 iterations with the cost falling 1-3e-5 an iteration and the calibration
  // moving by 0.01-0.015 px.
  double still_intrinsics_px = 0.02;
  bool warm_start = true;                // Start from CalibrationMaterial::start if set.
  // A warm start whose plane points reproject with a median error above this (px) is
  // dropped for a cold one. Most fit within 0.2-0.3 px; one off by 7-28 px (a short
  // window's solution carried into the next ones) took 60-100 iterations each of four
  // windows in a row and ended with every plane an outlier.
  double warm_start_max_median_px = 2.0;
  // After the solve, a point whose reprojection RMS over its views exceeds this many times
  // the median point's is left out and the solve goes on without it; 0: none left out.
  // They are mostly tracks held by the wrong plane (ceiling tracks by a wall's plane, by
  // the corner where the two meet) and tracks whose patch the walk deformed: 2-8% of the
  // points on the 320x240 walks. With them the attempts' fx scattered by 0.5-0.9% (RMS
  // against the truth), without them by 0.35-0.55% (docs/calibration.md). Straight lines
  // likewise, by their RMS distance from straight against the median line's
  // (StraightLines): world lines that are not quite straight.
  double max_point_rms_ratio = 3.0;
  // The camera's rolling shutter: rows are read top to bottom over this time, the middle
  // row at the frame's time; 0: a global shutter. Each tracked point is then measured as
  // the camera saw it from its row's pose, moved by the turn and travel that the poses of
  // the neighbouring views give (needs CalibrationMaterial::frame_t_ns).
  double readout_ms = 0.0;

  bool Check(std::string* error) const;
};

struct SelfCalibrationResult {
  bool usable = false;
  std::string reason;  // Why not ("no update: insufficient rotation ..."), or a report.
  CameraIntrinsics estimate;
  // Covariance of the free intrinsics, in the order of `free_parameters` (IntrinsicIndex),
  // each point's views one cluster of errors (MarginalCovariance's `clustered`).
  Eigen::MatrixXd covariance;
  std::vector<int> free_parameters;
  double rms_px = 0.0;               // Reprojection RMS of the plane tracks.
  double rotation_spread_deg = 0.0;  // Largest angle between two views' orientations.
  // No update because the views' orientations differ by less than min_rotation_deg.
  bool too_little_view_change = false;
  // No update because the solve fitted most observations and missed a few by far: a view
  // or a plane torn from the rest.
  bool came_apart = false;
  // Non-zero: the views differed too little relative to the scene as a whole (or the scene
  // came apart as one world), and this
  // plane, solved alone in its own world (the poses are relative to it), gave the update:
  // a plane that moved before the camera, as a board before a fixed one.
  int own_world_plane = 0;
  int frames_used = 0;
  int planes_used = 0;
  int points_used = 0;
  int observations_used = 0;
  int lines_used = 0;
  int iterations = 0;  // Levenberg-Marquardt iterations the solve took.
  // Per frame: the camera pose in the window's world (the reference camera), scale set by
  // the first plane's first point at depth 1; empty for frames left out.
  std::vector<std::optional<Eigen::Isometry3d>> cam_from_world;
  std::vector<PlaneEstimate> planes;
};

// The scene is first taken as one rigid world; when its views differ too little in
// orientation or it comes apart, each plane with enough points whose image moved is tried
// alone in its own world, and the one
// whose focal length is surest gives the result (SelfCalibrationResult::own_world_plane).
SelfCalibrationResult SelfCalibrate(const CalibrationMaterial& material,
                                    const CameraIntrinsics& prior,
                                    const SelfCalibrationOptions& options);

// The largest, over pairs of views, of the median displacement (px) of the points both
// see (each view: point id -> pixel), skipping pairs that share fewer than 8: how far the
// image moved (CalibrationMaterial::motion, a plane's own motion).
double LargestMedianDisplacementPx(const std::vector<std::map<int, Eigen::Vector2d>>& views);

// Every reason of an attempt that makes no update reads "no update: <cause>", then its
// figures in parentheses or its details after a colon; the cause names what was missing
// in words alone, so that the causes of many attempts can be counted.
std::string NoUpdateCause(const std::string& reason);
inline constexpr std::string_view kBarelyMovedCause = "the camera barely moved";

// The start `solved` (on views taken at `solved_views`) gives an attempt on views taken at
// `views`: the intrinsics, the planes and the poses of the views both have.
CalibrationStart StartFrom(const SelfCalibrationResult& solved,
                           const std::vector<int64_t>& solved_views,
                           const std::vector<int64_t>& views);

// Ceres logs each trial step its linear solver refuses ("Linear solver failure ... Matrix
// not positive definite") as a warning on stderr, though the solve goes on and its outcome
// is reported; programs call this once at start so their output is not drowned in them.
// Errors still show.
void QuietSolverWarnings();

}  // namespace autocal
