// Still shots: photographs of a scene from different viewpoints, with no accelerometer and
// no video rate between them. Boxes 1-2 find the straight lines of every shot and the
// distortion that straightens them; box 4's scale-invariant keypoints are matched between
// every pair of shots and box 6 splits each pair's matches into planes by robust
// homographies, one after another; the planes of all pairs are chained into planes with
// stable ids whose tracks run over the shots (a track is one scene point: the keypoints
// matched to each other on one plane), and box 10 calibrates from them. Nothing is
// rendered with the prior: a wrong start converges as it does on video.
#pragma once

#include <atomic>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "pipeline/camera_model.h"
#include "pipeline/features.h"
#include "pipeline/lens_stage.h"
#include "pipeline/planes.h"
#include "pipeline/self_calibration.h"

namespace autocal {

struct StillShotOptions {
  LensOptions lens;                    // Boxes 1-2 on every shot.
  FeatureOptions features;             // Box 4: keypoints per shot, matching between two.
  PlaneOptions planes;                 // Box 6 between two shots (the shot_* and fit fields).
  SelfCalibrationOptions calibration;  // Box 10; min_frames counts shots.
  // Planes of two pairs of shots that hold this many of the same keypoints are one plane.
  int min_shared_keypoints = 8;
  int min_shots_per_point = 2;  // Tracks seen in fewer shots are left out.
  // Per plane, the tracks seen in the most shots are kept, at most this many: box 10's
  // time grows with them, its accuracy little beyond this.
  int max_points_per_plane = 200;
  int max_lines = 150;  // Straight-line shapes handed to box 10, spread over the pool.
  // After a first solve over all the shots, tracks that miss their plane by more than this
  // (or 3 times the solve's RMS, if more) in some shot are left out: a point off the plane
  // (a box on the floor that the pairs' homographies could not set apart) or a wrong match.
  double outlier_px = 1.0;
  // Box 10 is tried on all the shots, then on all but one, each shot it placed left out in
  // turn (spread over them when there are more), at most this many attempts in all: the
  // history sees whether the shots agree, as it sees consecutive windows of a video.
  int max_attempts = 9;

  // Says which field is out of range; checks the nested options too.
  bool Check(std::string* error) const;
};

// One box-10 attempt over some of the shots.
struct StillShotAttempt {
  std::string shots;  // "all 8 shots", "all but shot 3" (counted from 1, in order).
  SelfCalibrationResult result;
};

struct StillShotCalibration {
  PlumbLineResult distortion;  // Box 2 over every shot (usable, or why not).
  // What the planes were fitted with: the prior, with box 2's distortion when it was usable.
  CameraIntrinsics working;
  // Every shot is a frame (its index); the planes' tracks and the straight lines.
  CalibrationMaterial material;
  int outlier_tracks = 0;  // Tracks left out after the first solve.
  int pairs = 0;              // Pairs of shots matched...
  int pairs_with_planes = 0;  // ...and those in which a plane was found.
  // The first is over all the shots; when box 10 can make nothing of them, it is the only one.
  std::vector<StillShotAttempt> attempts;
  bool stopped = false;  // A stop request ended the work early: the attempts are those made.
  // Milliseconds per box, each time it ran: "lines" and "features" per shot, "distortion"
  // once, "planes" per pair of shots (matching and fitting), "calibration" per attempt.
  std::map<std::string, std::vector<double>> timing_ms;
};

// What a caller of CalibrateStillShots is told while it works, and how it is stopped.
struct StillShotProgress {
  std::function<void(const std::string&)> step;              // What is being done.
  std::function<void(const StillShotAttempt&)> attempted;  // Each attempt, once made.
  // When it becomes true (from a signal handler, say), the work returns after the shot,
  // pair or attempt in hand, with what was done (StillShotCalibration::stopped).
  const std::atomic<bool>* stop = nullptr;
};

// Shots are 8-bit BGR or grey images of one size, the prior's; at least 3 of them (throws
// Error otherwise). Every attempt's SelfCalibrationResult says "no update" and why when the
// shots do not pin the intrinsics down; material.planes is empty when no plane was found
// (and no attempt is made).
StillShotCalibration CalibrateStillShots(const std::vector<cv::Mat>& shots,
                                         const CameraIntrinsics& prior,
                                         const StillShotOptions& options = {},
                                         const StillShotProgress& progress = {});

// The material of the attempts: all the shots, then each of the `placed` shots (ascending)
// left out in turn (spread over them, up to max_attempts in all), with its observations
// removed and the later shots renumbered. Names each subset.
std::vector<std::pair<std::string, CalibrationMaterial>> StillShotSubsets(
    const CalibrationMaterial& all, const std::vector<int>& placed, int max_attempts);

}  // namespace autocal
