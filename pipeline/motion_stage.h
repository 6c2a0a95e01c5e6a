// Boxes 4-6 as one per-frame stage: corners, their flow, and the dominant planes the flow
// reveals. Box 7 (the accelerometer) fills its part of the snapshot afterwards.
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
#include "pipeline/planes.h"

namespace autocal {

struct MotionStageOptions {
  FlowOptions flow;     // Boxes 4 (flow.features) and 5.
  PlaneOptions planes;  // Box 6.
  // A lost plane is remembered by box 4's keypoints around its tracks in the frame where
  // it filled most of the image; a new plane whose keypoints match a remembered one's by a
  // homography (within planes.shot_inlier_threshold_px) gets its id back. At most this
  // many are remembered, the latest (0: planes are not re-found).
  int lost_planes_kept = 16;
  int refind_min_matches = 20;  // Homography inliers to re-find a plane.
  // ORB: SIFT re-finds the same planes on the simulated walks but costs 10 times as much
  // each time a plane is lost or found (40 ms at 640x480), over the frame's budget.
  DescriptorType refind_descriptor = DescriptorType::kOrb;

  // Checks this struct and every nested one; the message names the field.
  bool Check(std::string* error) const;
};

// Box 7's findings for the frame, filled in by the caller from the accelerometer.
struct InertialFindings {
  std::optional<Eigen::Vector3d> gravity_cam;  // Gravity in the camera frame, when at rest.
  std::string motion_class;                    // "forward", "sidestep", "rotate", ...
  double inertial_ms = 0.0;                    // Box 7's time.
};

// What boxes 4-6 found in one frame: immutable once published, for the overlays, box 7
// and boxes 8-10.
struct MotionSnapshot {
  int64_t t_ns = 0;
  cv::Size image_size;
  CameraIntrinsics camera;  // The calibration the frame was processed with.
  // Live tracks with their recent history; a track's flow vector runs from FramesAgo(1)
  // to current() (tracks started in this frame have none).
  std::vector<Track> tracks;
  // Box 6's planes; one lost and seen again has the id it had before (see
  // MotionStageOptions::lost_planes_kept).
  std::vector<DominantPlane> planes;
  int tracks_started = 0;     // New tracks in this frame (box 4).
  int tracks_died = 0;        // Tracks lost in this frame (box 5).
  double features_ms = 0.0;   // Box 4.
  double flow_ms = 0.0;       // Box 5.
  double planes_ms = 0.0;     // Box 6.
  double refind_ms = 0.0;     // Lost planes remembered and re-found (box 4's keypoints).
  InertialFindings inertial;  // Box 7, filled by the caller.

  // The id of the plane holding a track, 0 for none.
  int PlaneOf(int track_id) const;
};

class MotionStage {
 public:
  explicit MotionStage(const MotionStageOptions& options = {});

  // Runs boxes 4-6 on one 8-bit grey frame. `camera` describes that image: for box 3's
  // rectified image, the calibration with its distortion set to zero; for a raw channel,
  // the full calibration, with which the track points are undistorted for box 6.
  MotionSnapshot Process(int64_t t_ns, const cv::Mat& gray, const CameraIntrinsics& camera);

  void set_options(const MotionStageOptions& options);
  const MotionStageOptions& options() const { return options_; }

 private:
  // Remembers the planes lost since the last frame, and gives new planes that are old
  // ones seen again their old ids. Returns the planes with the ids they are known by.
  std::vector<DominantPlane> Refind(const cv::Mat& gray, const CameraIntrinsics& camera);

  // A lost plane: its id and box 4's keypoints around its tracks.
  struct LostPlane {
    int id = 0;
    KeypointSet keypoints;
    std::vector<cv::Point2f> points;  // Undistorted keypoint positions.
  };

  MotionStageOptions options_;
  FlowTracker flow_;
  PlaneTracker planes_;
  // Each followed plane as seen where it filled most of the image, by box 6's id.
  struct View {
    DominantPlane plane;
    cv::Mat gray;
    CameraIntrinsics camera;
  };
  std::map<int, View> largest_;
  std::deque<LostPlane> lost_;   // Oldest first.
  std::map<int, int> known_as_;  // Box 6's id -> the id of the plane it re-found.
  int newest_id_ = 0;            // The newest id box 6 has given.
};

}  // namespace autocal
