// Boxes 4-6 as one per-frame stage: corners, their flow, and the dominant planes the flow
// reveals. Box 7 (the accelerometer) fills its part of the snapshot afterwards.
#pragma once

#include <cstdint>
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
  std::vector<DominantPlane> planes;
  int tracks_started = 0;     // New tracks in this frame (box 4).
  int tracks_died = 0;        // Tracks lost in this frame (box 5).
  double features_ms = 0.0;   // Box 4.
  double flow_ms = 0.0;       // Box 5.
  double planes_ms = 0.0;     // Box 6.
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
  MotionStageOptions options_;
  FlowTracker flow_;
  PlaneTracker planes_;
};

}  // namespace autocal
