// Boxes 1-3 as one per-frame stage: lines, snakes, the distortion estimated from the
// snakes gathered over time, and the rectified geometry image for boxes 4-10.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "pipeline/camera_model.h"
#include "pipeline/line_detector.h"
#include "pipeline/plumb_line.h"
#include "pipeline/radon_snake.h"
#include "pipeline/rectifier.h"

namespace autocal {

struct LensOptions {
  LineDetectorOptions lines;
  SnakeOptions snakes;
  PlumbLineOptions plumb_line;
  RectifyOptions rectify;
  int observe_every_frames = 3;           // A snake's shape joins the pool this often...
  double min_observation_shift_px = 4.0;  // ...if it moved this much since its last one.
  // Shapes are kept per cell of a grid over the image and per orientation (4 bins), the
  // newest `pool_per_cell` in each, so the corners, where distortion shows most, are not
  // crowded out by the many shapes near the centre.
  int pool_grid = 8;               // Cells across the image (rows by aspect).
  int pool_per_cell = 8;           // Newest shapes kept per cell and orientation.
  int estimate_every_frames = 30;  // Distortion re-estimated this often (frames).
  // Box 2 runs on a worker of its own, so that the frames behind it do not wait for it (49
  // ms at 640x480, 89 at 1280x720; live at 640x480 that wait put 15-20 ms on the median
  // update latency). Its estimate takes effect this many frames after it was begun,
  // waiting for it then if it has not ended, so that what each frame sees does not depend
  // on thread timing; 0: on the frame it was begun, as if inline. At 8 the tessar drift
  // walk ended 0.91% off in fy (the end-to-end test allows 0.75).
  int estimate_lag_frames = 4;
  // Box 2's estimate takes the newest this many of each cell and orientation (box 10 takes
  // the whole pool). Its solve's time grows faster than the number of shapes: 4 halves it,
  // but the tessar drift walk then ends 0.93% off in fy (the end-to-end test allows 0.75).
  int estimate_per_cell = 8;
  // Still images (EstimateFromStills): rounds of boxes 1-2, each next one finding lines in
  // the images undistorted by the estimate so far, and how many lines and snakes an image
  // may give (no frame rate to keep up with).
  int still_rounds = 4;
  int still_max_lines = 200;
  int still_max_snakes = 200;

  // Checks this struct and every nested one; the message names the field.
  bool Check(std::string* error) const;
};

// What boxes 1-3 found in one frame: immutable, for the overlays and the summary.
struct LensSnapshot {
  int64_t t_ns = 0;
  std::vector<LineSegment> lines;
  std::vector<RadonSnake> snakes;
  // The newest distortion estimate, if one took effect on or before this frame.
  std::optional<PlumbLineResult> distortion;
  int pooled_shapes = 0;  // Snake shapes the estimate draws on.
  double lines_ms = 0.0;  // Box 1 (lines and snakes).
  // Box 2, on its worker: on the frame its estimate takes effect, the time it took (0 on
  // the others).
  double distortion_ms = 0.0;
  double rectify_ms = 0.0;  // Box 3.
};

class LensStage {
 public:
  explicit LensStage(const LensOptions& options = {});

  // Runs boxes 1-3 on a raw frame (8-bit BGR or grey). Lines and snakes are found in the
  // raw image, whose distortion they measure; `calibration` gives the principal point
  // near which snakes are seeded and the undistortion of `rectified` (if not null).
  LensSnapshot Process(int64_t t_ns, const cv::Mat& raw, const CameraIntrinsics& calibration,
                       cv::Mat* rectified = nullptr);

  // Estimates the distortion from every snake shape pooled so far, now.
  PlumbLineResult EstimateNow(const CameraIntrinsics& initial) const;

  // For still images: seeds snakes from the lines of one image and lets them grow along
  // its curved edges, then pools their shapes. Snakes do not carry over between images.
  LensSnapshot ProcessStill(const cv::Mat& raw, const CameraIntrinsics& calibration);

  // For a set of still images of one camera: boxes 1-2 in rounds. The first seeds snakes
  // from the straight lines near the principal point of each raw image (ProcessStill), as
  // only there does a strong lens leave them straight enough for the Radon transform. Each
  // next round undistorts the images by the distortion the round before estimated, finds
  // the lines that have become straight anywhere in them, carries them back into the raw
  // images and follows them there with snakes, so that the arcs far out, which constrain
  // the lens most, join in; the rounds end when they add no line and move the lens by
  // under 0.1 px, or when a round's estimate is not taken or departs from the one before by
  // more than three times their sigmas, and that round is dropped. The pool then holds the
  // last kept round's shapes, and the result is its estimate from `initial`. `stop` is
  // asked between images.
  struct StillsResult {
    PlumbLineResult distortion;
    std::vector<LensSnapshot> snapshots;  // Per image, the last round's lines and snakes.
    int rounds = 0;
  };
  StillsResult EstimateFromStills(const std::vector<cv::Mat>& raws,
                                  const CameraIntrinsics& initial,
                                  const std::function<bool()>& stop = {});

  void set_options(const LensOptions& options);
  const LensOptions& options() const { return options_; }
  // The camera's rolling shutter (SelfCalibrationOptions::readout_ms; 0: a global one): a
  // snake's shape is then pooled as the frame's time saw it, each hinge moved back by its
  // edge's motion across the line since the previous frame over its row's delay.
  void set_readout_ms(double readout_ms) { readout_ms_ = readout_ms; }
  // Whether box 2 begins estimates (it does by default). An estimate under way still takes
  // effect when due.
  void set_estimating(bool estimating) { begin_estimates_ = estimating; }
  // Whether the frame an estimate is due on waits for it (the default, so that what each
  // frame sees is fixed by frame counts). Live it should not: the estimate then takes
  // effect on the first frame from its due one on where it has ended, and the camera's
  // frames never wait for box 2 (68 ms at 1280x720 on an idle machine, longer under load).
  void set_wait_for_estimates(bool wait) { wait_for_estimates_ = wait; }
  size_t pooled_shapes() const;
  // The snake shapes pooled so far (raw pixels), bin by bin over the image.
  std::vector<LineObservation> PooledShapes() const;
  // The newest `per_bin` shapes of every bin of the pool (box 2's periodic estimate takes
  // `estimate_per_cell` of them).
  std::vector<LineObservation> NewestShapes(int per_bin) const;
  // Changes whenever a shape joins the pool: a copy of the pool stays current until then.
  uint64_t pool_version() const { return pool_version_; }

 private:
  void Pool(const RadonSnake& snake, cv::Size image_size, int64_t t_ns);
  // One still image's snakes seeded along the lines of `undistorted` (the raw image seen
  // through `lens` by a pinhole camera `pinhole`), grown to their ends and pooled.
  LensSnapshot ProcessStillThrough(const cv::Mat& raw, const CameraIntrinsics& lens,
                                   const cv::Mat& map1, const cv::Mat& map2,
                                   const CameraIntrinsics& pinhole);
  // Snakes grown along their edges on a still image until they stop growing.
  void GrowStill(SnakeTracker* tracker, const Gradients& gradients, cv::Size size) const;
  SnakeOptions StillSnakes() const;
  LineDetectorOptions StillLines() const;
  // `capped`: the bin keeps its newest pool_per_cell shapes (a video's); still images keep
  // every shape, as they are all the material there is.
  void AddShape(std::vector<Eigen::Vector2d> points, cv::Size image_size, bool capped = true);

  LensOptions options_;
  Rectifier rectifier_;
  SnakeTracker tracker_;
  std::map<int, std::deque<LineObservation>> pool_;  // By cell and orientation bin.
  // Where each snake's last pooled shape was (by snake id), to pool only new views.
  std::vector<std::pair<int, Eigen::Vector2d>> last_pooled_;
  double readout_ms_ = 0.0;
  bool begin_estimates_ = true;
  bool wait_for_estimates_ = true;
  // The snakes of the frame before and its time: with a rolling shutter, their motion.
  std::vector<RadonSnake> previous_snakes_;
  int64_t previous_t_ns_ = 0;
  std::optional<PlumbLineResult> latest_;
  struct TimedEstimate {
    PlumbLineResult result;
    double ms = 0.0;
  };
  std::future<TimedEstimate> estimating_;  // Box 2 on its worker...
  int64_t estimate_due_ = 0;               // ...taking effect on this frame.
  int64_t frames_ = 0;
  uint64_t pool_version_ = 0;
};

}  // namespace autocal
