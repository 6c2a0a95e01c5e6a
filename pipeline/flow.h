// Box 5, optical flow: pyramidal Lucas-Kanade tracks, forward-backward checked, each with
// a stable id and its recent history; box 4's corners fill the cells where tracks are
// missing.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "pipeline/features.h"

namespace autocal {

struct FlowOptions {
  // Side of the Lucas-Kanade window (odd). A translation-only window drifts as the view
  // of its patch changes (a zoom of 2% a frame: 0.18 px in 20 frames at 7 px, 0.45 px at
  // 15 px), and a small one straddles fewer plane boundaries; a large one is surer.
  int window_px = 11;
  int pyramid_levels = 3;        // Levels above the full image; reach ~window * 2^levels.
  int max_iterations = 20;       // Lucas-Kanade iterations per level.
  double epsilon_px = 0.01;      // ...or until a step is shorter than this.
  double min_eigen = 1e-4;       // Windows flatter than this (OpenCV's minEigThreshold) fail.
  double max_fb_error_px = 0.5;  // Tracked back, a point must land this close to its start.
  bool predict = true;           // Start each search at the point's previous velocity.
  // Tracks lost with the whole pyramid are searched again with this many levels from
  // where they were heading (-1: not): a region that changes, such as an occluder coming
  // in, spoils the coarse levels for every track far around it.
  int retry_levels = 1;
  int border_px = 4;        // Tracks closer than this to the border are dropped.
  int target_tracks = 300;  // New corners fill empty cells up to this many tracks.
  int history_frames = 30;  // Positions kept per track (the window of frames).
  FeatureOptions features;  // Where new tracks start (box 4).

  // Checks this struct and the nested one; the message names the field.
  bool Check(std::string* error) const;
};

// Where a track was in one frame (pixels of the image tracked, centres at integers).
struct TrackPoint {
  int64_t t_ns = 0;
  cv::Point2f pixel;
};

struct Track {
  int id = 0;                       // Unique over the tracker's life, never reused.
  int age = 0;                      // Frames tracked since it started (0 in its first frame).
  std::vector<TrackPoint> history;  // Oldest first, the last is now; at most history_frames.

  const cv::Point2f& current() const { return history.back().pixel; }
  // Where it was `frames` frames ago, if its history reaches back that far.
  const TrackPoint* FramesAgo(int frames) const;
  // Where it was in the frame taken at `t_ns`, if its history holds that frame.
  const TrackPoint* At(int64_t t_ns) const;
};

class FlowTracker {
 public:
  explicit FlowTracker(const FlowOptions& options = {});

  // Follows every track into `gray` (8-bit, one channel): Lucas-Kanade forward, then
  // back; a track dies where either fails, where it does not come back to its start, or
  // where it leaves the image. A change of image size starts afresh.
  void Advance(int64_t t_ns, const cv::Mat& gray);
  // Starts tracks at new corners of the latest frame (box 4) where cells lack them, up to
  // target_tracks. Returns how many started.
  int Replenish();
  // Advance, then Replenish.
  void Update(int64_t t_ns, const cv::Mat& gray);

  // Live tracks, oldest first.
  const std::vector<Track>& tracks() const { return tracks_; }
  // Tracks that died in the latest Advance.
  int died() const { return died_; }

  void set_options(const FlowOptions& options);
  const FlowOptions& options() const { return options_; }

 private:
  // Lucas-Kanade from the previous frame's pyramid to `pyramid` with `levels` levels above
  // the image, starting at `end`, then back; `found` says which came back to `start`.
  void ForwardBackward(const std::vector<cv::Mat>& pyramid, const std::vector<cv::Point2f>& start,
                       int levels, std::vector<cv::Point2f>* end, std::vector<uchar>* found) const;

  FlowOptions options_;
  std::vector<Track> tracks_;
  // The latest frame's pyramid (with derivatives; level 0 is the frame itself).
  std::vector<cv::Mat> pyramid_;
  int64_t t_ns_ = 0;  // The latest frame's time.
  int next_id_ = 1;
  int died_ = 0;
};

}  // namespace autocal
