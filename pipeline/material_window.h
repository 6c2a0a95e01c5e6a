// Box 9, measurement: the material of a calibration attempt over a sliding window of views.
// Each plane's observations are the pixels of its REAL tracks in the raw image, measured
// against the patch each was first seen with (AnchoredTracks), never the virtual board
// rendered with the current calibration (DESIGN.md, "The one trap"): the patch is shaped
// by the plane's homography between the tracks, the calibration only linearizing it, so
// a wrong calibration bends the patch a little but does not move it (the walks from a
// wrong start converge). Straight lines are the snake shapes box 1 pooled; gravity is
// what box 7 measured at rest, not what it carried through vision's rotations.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "pipeline/anchored_tracks.h"
#include "pipeline/image_quality.h"
#include "pipeline/inertial.h"
#include "pipeline/motion_stage.h"
#include "pipeline/self_calibration.h"

namespace autocal {

struct MaterialOptions {
  // Views this far behind the newest one make up the window: long enough for the views to
  // turn (which fixes the focal length), short enough that a jolt of the lens leaves the
  // window soon (an alarm needs two attempts on windows after it).
  double window_s = 2.0;
  // One frame in this many is a view: neighbours add little but cost as much to solve.
  int view_every_frames = 3;
  double attempt_every_s = 0.5;  // Box 10 is tried this often.
  // Per plane, the tracks seen in the most views are handed on, at most this many: the
  // solve grows with them, its accuracy hardly beyond this.
  int max_points_per_plane = 120;
  int min_views_per_point = 4;  // Tracks seen in fewer views constrain too little.
  int max_lines = 150;          // Straight-line shapes handed on, spread over the pool.
  // Frames unfit to measure from (fog, noise bursts) are no views, and a window that held
  // one makes no update.
  ImageQualityOptions quality;
  // Plane tracks measured against the patch where each was first measured on its plane,
  // not where box 5's drifting window has it (pipeline/anchored_tracks.h).
  AnchorOptions anchor;

  bool Check(std::string* error) const;
};

class MaterialWindow {
 public:
  explicit MaterialWindow(const MaterialOptions& options = {});

  // Every frame, after boxes 4-7, with the image box 5 tracked and the calibration boxes
  // 4-6 worked with. Takes it as a view when one is due; returns whether it did.
  bool Add(const MotionSnapshot& motion, const InertialSnapshot& inertial, const cv::Mat& image,
           const CameraIntrinsics& camera);

  // The window as box 10's material, with `lines` thinned to max_lines.
  CalibrationMaterial Assemble(const std::vector<LineObservation>& lines) const;

  // Times of the views, oldest first (frame i of the material is view i).
  std::vector<int64_t> view_times() const;
  // The time span the views cover, seconds.
  double span_s() const;

  void set_options(const MaterialOptions& options) {
    options_ = options;
    anchors_.set_options(options.anchor);
  }
  const MaterialOptions& options() const { return options_; }

 private:
  struct View {
    int64_t t_ns = 0;
    // Plane id -> (track id, raw pixel) of its member tracks.
    std::map<int, std::vector<std::pair<int, Eigen::Vector2d>>> planes;
    std::optional<GravityObservation> gravity;  // Frame index filled in by Assemble.
    // Every live track's pixel by id: how far the image moved between views.
    std::map<int, Eigen::Vector2d> tracked;
  };
  // Assemble's CalibrationMaterial::motion over the views.
  WindowMotion Motion() const;

  MaterialOptions options_;
  std::deque<View> views_;
  AnchoredTracks anchors_;
  int64_t frames_seen_ = 0;
};

}  // namespace autocal
