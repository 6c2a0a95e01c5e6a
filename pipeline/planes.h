// Box 6, dominant planes: the flow of points on one plane is a homography. Planes are
// found one after another by robust homography fits on the tracks that no plane holds
// yet, then followed from frame to frame with a stable id, their member tracks, their
// homography from a reference frame and the plane's orientation decomposed from it.
// Everything is fitted on undistorted points, where planes map by homographies.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "pipeline/camera_model.h"
#include "pipeline/features.h"
#include "pipeline/flow.h"

namespace autocal {

struct PlaneOptions {
  // Membership and new planes are judged on the flow over this many frames: long enough
  // for parallax to set planes apart, short enough that tracks do not drift (Lucas-Kanade
  // drifts about 0.5 px in 10 frames as the view of a patch changes).
  int baseline_frames = 10;
  // Tracks old enough are judged over this longer baseline too (0: not), with thresholds
  // larger by the square root of 2 (drift grows about as the square root of time): planes
  // twice as close in depth come apart there.
  int long_baseline_frames = 20;
  // Tracks younger than the baseline but this many frames old are judged over their own
  // life, through the plane's homographies of those frames (0: not): in a fast turn most
  // tracks live about two baselines, and a plane whose tracks could join only once a
  // baseline old starves.
  int young_frames = 5;
  double inlier_threshold_px = 0.6;  // Transfer error over the baseline to join a plane.
  double eject_threshold_px = 1.5;   // A member whose error exceeds this leaves its plane.
  // A plane whose tracks are noisier (a wall close by at a grazing angle, where patches
  // deform fast) has both thresholds scaled up by this times the median error of its
  // tracks over inlier_threshold_px, when that exceeds 1 (0: never).
  double noise_scale = 1.5;
  // At most this factor: a plane whose tracks turn noisy (a fast turn) would otherwise
  // widen its thresholds until it holds, and keeps out of new planes, tracks of the
  // plane beside it.
  double max_noise_scale = 1.5;
  // Planes are connected regions: a track joins one only this close to one of its tracks
  // (a fraction of the image diagonal); farther points that fit are more likely on
  // another plane that parallax does not yet set apart.
  double join_radius = 0.07;
  int ransac_iterations = 500;      // Most RANSAC samples per fit.
  int min_inliers = 20;             // Tracks a new plane needs...
  double min_area_fraction = 0.02;  // ...and the image fraction their convex hull covers.
  int min_tracks_to_keep = 8;       // A plane left with fewer live tracks is lost.
  // The camera must have moved over the baseline for a new plane (and for a vote on its
  // orientation) so that the translation alone moves the plane's image by this many
  // pixels (translation over the plane's distance, times the focal length): under less
  // parallax other planes fit its homography too.
  double min_parallax_px = 16.0;
  int max_planes = 8;             // Planes followed at once.
  int max_reference_frames = 60;  // The reference frame moves up after this many frames.
  double merge_fraction = 0.8;    // Two planes one homography fits this well are one.
  // A plane's orientation is decomposed only while its tracks spread this much across
  // their narrowest direction (standard deviation over the image diagonal): a thin strip
  // leaves the homography undetermined across it.
  double min_spread = 0.03;
  int normal_votes = 30;                  // Frames of decomposition candidates voted over.
  double normal_agreement_deg = 5.0;      // Candidates this close vote for each other.
  double shot_inlier_threshold_px = 3.0;  // Still shots: transfer error of matched keypoints.
  // Still shots: each plane's homography also matches the keypoints that Lowe's test
  // refused for looking alike (repetitive texture), where it brings them within the
  // threshold of each other.
  bool shot_guided_matching = true;

  bool Check(std::string* error) const;
};

// The camera motion and plane that a homography between two views decomposes into
// (X_current = rotation X_reference + translation_over_distance * distance).
struct PlaneMotion {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // Current from reference camera.
  Eigen::Vector3d translation_over_distance = Eigen::Vector3d::Zero();  // Over the reference
                                                                        // camera's distance.
  Eigen::Vector3d normal_reference = Eigen::Vector3d::UnitZ();          // Unit, toward the camera.
};

// The physically valid decompositions (points in front of both cameras) of a homography
// between undistorted pixels `reference` -> `current` of the camera matrix of `camera`.
// One or two solutions in general (one when the motion is along the normal).
std::vector<PlaneMotion> DecomposePlaneHomography(const cv::Matx33d& homography,
                                                  const CameraIntrinsics& camera,
                                                  const std::vector<cv::Point2f>& reference,
                                                  const std::vector<cv::Point2f>& current);

// Undistorted pixel coordinates (the camera matrix, no distortion) of image points.
std::vector<cv::Point2f> UndistortPixels(const std::vector<cv::Point2f>& points,
                                         const CameraIntrinsics& camera);

// One plane as seen now. Its homography maps the reference frame's undistorted pixels to
// the current frame's.
struct DominantPlane {
  int id = 0;                       // Stable while the plane is followed; never reused.
  int age = 0;                      // Frames since it was found.
  int64_t reference_t_ns = 0;       // The frame its homography starts from.
  std::vector<int> track_ids;       // Its live member tracks, ascending.
  std::vector<cv::Point2f> points;  // Their positions now, in the image tracked.
  // Their undistorted positions in the reference frame: measured there, or carried back
  // by the homography for tracks that started later (plane coordinates up to a
  // homography, for the virtual board).
  std::vector<cv::Point2f> reference_points;
  std::vector<cv::Point2f> outline;             // Convex hull of `points`.
  double area_fraction = 0.0;                   // Area of the outline over the image's.
  cv::Matx33d homography = cv::Matx33d::eye();  // Reference -> now, undistorted pixels.
  // The reference frame before this one (none: -1) and the homography from it to this
  // one, so that what was measured against the old reference carries over.
  int64_t previous_reference_t_ns = -1;
  cv::Matx33d previous_to_reference = cv::Matx33d::eye();
  // The decomposition chosen by the votes, once the camera has moved enough.
  std::optional<PlaneMotion> motion;
  // Unit normal in the current camera frame, pointing toward the camera.
  std::optional<Eigen::Vector3d> normal;
};

class PlaneTracker {
 public:
  explicit PlaneTracker(const PlaneOptions& options = {});

  // One frame: `tracks` are all live tracks at `t_ns` (positions in the image `camera`
  // describes; their histories reach back baseline_frames into the frames given before).
  // Follows the planes over the baseline, lets tracks join and leave them, merges planes
  // that turn out to be one, and fits new ones among the tracks left over.
  void Update(int64_t t_ns, const std::vector<Track>& tracks, const CameraIntrinsics& camera);

  const std::vector<DominantPlane>& planes() const { return planes_; }

  void set_options(const PlaneOptions& options) { options_ = options; }
  const PlaneOptions& options() const { return options_; }

 private:
  // A followed plane.
  struct State {
    int id = 0;
    int age = 0;
    int64_t reference_t_ns = 0;
    int64_t previous_reference_t_ns = -1;
    cv::Matx33d previous_to_reference = cv::Matx33d::eye();
    cv::Matx33d homography = cv::Matx33d::eye();  // Reference -> now.
    cv::Matx33d recent = cv::Matx33d::eye();      // Baseline frame -> now.
    std::optional<cv::Matx33d> longer;            // Long baseline frame -> now.
    double scale = 1.0;                           // On the thresholds, for its noise.
    std::map<int, cv::Point2f> members;           // Track id -> reference point.
    // Reference -> frame for every frame since the reference, oldest first, now last.
    std::deque<std::pair<int64_t, cv::Matx33d>> chain;
    // Per frame with enough parallax: the candidate normals, in the reference frame.
    std::deque<std::vector<Eigen::Vector3d>> votes;
    std::optional<Eigen::Vector3d> normal_reference;  // Chosen by the votes.
    std::optional<PlaneMotion> motion;                // This frame's, agreeing with it.

    // The chain's homography to the frame taken at `t_ns`, if it reaches that far.
    const cv::Matx33d* ChainAt(int64_t t_ns) const;
  };
  struct Frame;

  bool FollowRecent(State* state, const Frame& frame) const;
  // A track's transfer error by the plane, in pixels of the image tracked, over the
  // baseline or, for a young track, over its life; infinite when it cannot be judged.
  double Error(const State& state, const Frame& frame, int track) const;
  // Members that stray leave their plane; tracks that fit one plane alone are returned
  // as its joiners.
  std::vector<std::vector<int>> Assign(const Frame& frame);
  bool Near(const State& state, const Frame& frame, int track) const;
  // The factor on the thresholds for a plane whose tracks fit with these errors.
  double Scale(std::vector<double> errors) const;
  bool FollowReference(State* state, const Frame& frame, const std::vector<int>& joiners) const;
  void Merge(const Frame& frame);
  void Detect(const Frame& frame);
  void Reanchor(State* state, const Frame& frame) const;
  void Orient(State* state, const Frame& frame) const;
  DominantPlane Describe(const State& state, const Frame& frame) const;

  PlaneOptions options_;
  std::vector<State> states_;
  std::vector<DominantPlane> planes_;
  std::deque<int64_t> frame_times_;  // Recent frames, oldest first.
  // Undistorted history of each live track (aligned with Track::history), kept while the
  // calibration stays the same.
  std::map<int, std::vector<cv::Point2f>> ideal_;
  CameraIntrinsics ideal_camera_;
  int next_id_ = 1;
};

// Still shots: planes between two images from their matched keypoints, found one after
// another by robust homography fits.
struct ShotPlane {
  cv::Matx33d homography = cv::Matx33d::eye();  // Shot a -> shot b, undistorted pixels.
  std::vector<cv::DMatch> matches;              // Inlier matches (queryIdx in a, trainIdx in b).
  std::vector<cv::Point2f> outline_a;           // Convex hull of the inliers in a...
  std::vector<cv::Point2f> outline_b;           // ...and in b.
  // The decompositions left once every plane's must share one camera motion; one when
  // that settles it.
  std::vector<PlaneMotion> motions;
};

std::vector<ShotPlane> FindPlanesBetweenShots(const KeypointSet& a, const KeypointSet& b,
                                              const CameraIntrinsics& camera,
                                              const PlaneOptions& options,
                                              const FeatureOptions& features);

}  // namespace autocal
