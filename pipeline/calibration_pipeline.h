// Boxes 1-10 frame by frame: the lens stage (1-3), the motion stage (4-6), the
// accelerometer (7), the window of material (9), the self-calibrating solve (10) with the
// virtual boards it places (8), and the history that judges every attempt. Each frame gives
// an immutable snapshot of everything found in it. Boxes 1-3 (LensHalf) and 4-10
// (MotionHalf) are separate objects that share nothing but what they hand each other, so
// that they can run on two threads joined by frame timestamps (devices/runtime.h).
//
// Boxes 4-6 track the raw image (its equalized green channel), not a rectified one, so the
// track positions box 10 measures are raw pixels whatever the current calibration: that
// calibration only decides which tracks belong together on a plane.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "pipeline/calibration_history.h"
#include "pipeline/camera_model.h"
#include "pipeline/image_quality.h"
#include "pipeline/inertial.h"
#include "pipeline/lens_stage.h"
#include "pipeline/material_window.h"
#include "pipeline/motion_stage.h"
#include "pipeline/rectifier.h"
#include "pipeline/self_calibration.h"
#include "pipeline/virtual_board.h"

namespace autocal {

struct PipelineOptions {
  LensOptions lens;                     // Boxes 1-3.
  MotionStageOptions motion;            // Boxes 4-6.
  InertialOptions inertial;             // Box 7.
  VirtualBoardOptions board;            // Box 8.
  MaterialOptions material;             // Box 9.
  SelfCalibrationOptions calibration;   // Box 10.
  AcceptanceOptions acceptance;         // The history.

  // Checks this struct and every nested one; the message names the field.
  bool Check(std::string* error) const;
};

// Milliseconds each box took on one frame (0 for a box that did not run).
struct BoxTimings {
  double lines_ms = 0.0;        // Box 1: lines and snakes.
  double distortion_ms = 0.0;   // Box 2: the plumb-line estimate.
  double rectify_ms = 0.0;      // Box 3: green channel, equalized.
  double features_ms = 0.0;     // Box 4.
  double flow_ms = 0.0;         // Box 5.
  double planes_ms = 0.0;       // Box 6.
  double refind_ms = 0.0;       // Box 6: lost planes re-found by box 4's keypoints.
  double inertial_ms = 0.0;     // Box 7.
  double material_ms = 0.0;     // Box 9: the window, and the material when an attempt is due.
  double calibration_ms = 0.0;  // Box 10: the solve.
  double history_ms = 0.0;      // Judging the attempt; placing the boards (box 8).

  // (name, milliseconds) for every box, in box order: "lines", "distortion", ...
  std::vector<std::pair<std::string, double>> Named() const;
};

// What box 10 is handed: the window's material, the calibration to start from (and to
// hold weakly to), and when the window ended.
struct CalibrationJob {
  int64_t t_ns = 0;
  CalibrationMaterial material;
  CameraIntrinsics prior;
  std::vector<int64_t> view_times;  // Frame i of the material was taken at view_times[i].
};

// One judged attempt, with the virtual boards it placed.
struct AttemptOutcome {
  AttemptRecord record;
  std::vector<int64_t> view_times;
  // Box 10's pose of each view (empty for views it left out), and a board on each plane.
  std::vector<std::optional<Eigen::Isometry3d>> cam_from_world;
  std::vector<VirtualBoard> boards;
};

struct FrameSnapshot {
  int64_t t_ns = 0;
  int64_t index = 0;  // Frames processed before this one.
  // The calibration boxes 1-6 worked with on this frame: the filtered one, with the
  // plumb-line distortion of box 2 until the history has accepted a distortion.
  CameraIntrinsics working;
  LensSnapshot lens;
  MotionSnapshot motion;
  InertialSnapshot inertial;
  ImageQuality quality;  // Of the raw frame.
  // Why the frame is unfit to measure from (fog, noise), compared with the recent good
  // frames; empty when it is fit. An unfit frame is no view, and no update is made from a
  // window that held one.
  std::string degraded;
  bool view = false;  // The frame joined the window of material.
  // The attempt judged on this frame, if one was.
  std::shared_ptr<const AttemptOutcome> attempt;
  FilteredCalibration calibration;  // The output: in effect after this frame.
  BoxTimings timing;
};

// What boxes 8-10 and the history hand back to boxes 1-3 after a frame: the calibration
// the lens half works with on later frames.
struct CalibrationState {
  FilteredCalibration filtered;
  bool distortion_accepted = false;  // The history holds an estimated distortion.
};

// Boxes 1-3 on one frame: everything the motion half needs of it.
struct LensFrame {
  int64_t t_ns = 0;
  // The calibration boxes 1-6 work with on this frame (FrameSnapshot::working).
  CameraIntrinsics working;
  LensSnapshot lens;
  cv::Mat gray;  // Box 3: the equalized green channel that boxes 4-6 track.
  ImageQuality quality;  // Of the raw frame, before equalization hides its fading.
  double rectify_ms = 0.0;  // Box 3 and the quality measure.
  // Box 1's snake shapes pooled so far, shared between frames while the pool is unchanged
  // (box 10's plumb-line material).
  std::shared_ptr<const std::vector<LineObservation>> pooled_shapes;
};

// Boxes 1-3. Runs on its own thread in the runtime: it owns the lens stage and box 2's
// newest estimate, and learns the calibration only through the CalibrationState it is given.
class LensHalf {
 public:
  // `live`: box 2's estimates take effect once ended, never waited for
  // (LensStage::set_wait_for_estimates).
  explicit LensHalf(const PipelineOptions& options = {}, bool live = false);

  // `state`: the calibration after the latest frame the motion half has finished.
  LensFrame Process(int64_t t_ns, const cv::Mat& raw, const CalibrationState& state);
  void set_options(const PipelineOptions& options);

 private:
  LensStage lens_;
  Rectifier rectifier_;
  std::optional<PlumbLineResult> plumb_line_;  // Box 2's newest usable estimate.
  std::shared_ptr<const std::vector<LineObservation>> pooled_;
  std::optional<uint64_t> pooled_version_;
};

// Boxes 4-9, box 10's jobs and their judgement. Frames come in from the lens half in time
// order; the accelerometer joins them by timestamp.
class MotionHalf {
 public:
  // Throws Error when the options or the calibration are not valid.
  MotionHalf(const CameraIntrinsics& premission, const AccelCalibration& accel,
             const PipelineOptions& options = {});

  void AddAccel(std::span<const SpecificForceSample> samples);
  // Boxes 4-9 on a frame from the lens half, with box 10's job when an attempt is due (and
  // `job` is not null). No new job is handed out while one is pending.
  FrameSnapshot Process(LensFrame frame, std::optional<CalibrationJob>* job);
  // Judges a job's result (jobs in order); the output changes from the next frame on.
  std::shared_ptr<const AttemptOutcome> Judge(const CalibrationJob& job,
                                              const SelfCalibrationResult& result);
  CalibrationState state() const { return {filtered_, distortion_accepted_}; }

  const CalibrationHistory& history() const { return history_; }
  const PipelineOptions& options() const { return options_; }
  void set_options(const PipelineOptions& options);

 private:
  std::optional<VisualMotion> VisionBetweenFrames(const MotionSnapshot& motion);

  PipelineOptions options_;
  MotionStage motion_;
  InertialStage inertial_;
  MaterialWindow material_;
  CalibrationHistory history_;
  FilteredCalibration filtered_;
  bool distortion_accepted_ = false;
  // Per plane: its reference frame and decomposed rotation in the previous frame.
  std::vector<std::pair<int, std::pair<int64_t, Eigen::Matrix3d>>> previous_rotations_;
  std::optional<int64_t> last_attempt_ns_;
  ImageQualityGate quality_gate_;
  std::optional<int64_t> last_degraded_ns_;
  std::string last_degraded_;  // Why the newest unfit frame was.
  bool job_pending_ = false;
  int64_t frames_ = 0;
  // The newest attempt the history took (accepted, or founding a regime) and its views'
  // times: where the next solve starts. Not one it rejected: the attempts that confirm a
  // jump must each reach it on their own (docs/calibration.md, "Outdoors", session 26).
  std::optional<std::pair<std::vector<int64_t>, SelfCalibrationResult>> last_solved_;
};

// Boxes 1-10 on one thread: the two halves in turn, the lens half always seeing the
// calibration after the previous frame. devices/runtime.h runs them on threads.
class CalibrationPipeline {
 public:
  // `premission`: the calibration to start from and to judge the first attempts against.
  // Throws Error when the options or the calibration are not valid.
  CalibrationPipeline(const CameraIntrinsics& premission, const AccelCalibration& accel,
                      const PipelineOptions& options = {});

  // Accelerometer readings in time order. For box 7's windows centred on a frame, they
  // should run half a quasi-static window ahead of the frames.
  void AddAccel(std::span<const SpecificForceSample> samples);

  // Boxes 1-10 on one raw frame (8-bit BGR or grey), the solve included.
  FrameSnapshot Process(int64_t t_ns, const cv::Mat& raw);

  // The same in two halves, for a solve on another thread: boxes 1-9, with box 10's job
  // when an attempt is due; then the job's result judged. Judge results in job order; no
  // new job is handed out while one is pending.
  FrameSnapshot ProcessFrame(int64_t t_ns, const cv::Mat& raw, std::optional<CalibrationJob>* job);
  std::shared_ptr<const AttemptOutcome> Judge(const CalibrationJob& job,
                                              const SelfCalibrationResult& result);

  const CalibrationHistory& history() const { return motion_.history(); }
  const PipelineOptions& options() const { return motion_.options(); }
  // Takes effect on the next frame. Throws Error when not valid.
  void set_options(const PipelineOptions& options);

 private:
  LensHalf lens_;
  MotionHalf motion_;
};

}  // namespace autocal
