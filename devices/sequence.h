// What every recorded or simulated source delivers: frames with timestamps, the
// accelerometer stream, the session description and, for the simulator, ground truth.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "pipeline/camera_model.h"

namespace autocal {

// One accelerometer reading: specific force in the accelerometer's own frame, m/s^2.
struct AccelSample {
  int64_t t_ns = 0;
  Eigen::Vector3d specific_force = Eigen::Vector3d::Zero();
};

// What session.json holds.
struct SessionInfo {
  static constexpr int kFormatVersion = 1;
  int format_version = kFormatVersion;
  std::string camera_device;         // Free text: model, serial, "simulator".
  std::string accelerometer_device;  // Free text.
  int width = 0;                     // Frame size in pixels.
  int height = 0;
  double frame_rate_hz = 0.0;        // Nominal; measured rates come from the timestamps.
  double accel_rate_hz = 0.0;        // Nominal accelerometer rate.
  // A rolling shutter's readout: rows read top to bottom over this time, the middle row at
  // the frame's timestamp. 0: a global shutter, or not known.
  double readout_ms = 0.0;
  std::optional<CameraIntrinsics> premission_calibration;
  // Rotation taking accelerometer-frame vectors to camera-frame vectors.
  Eigen::Matrix3d cam_from_accel = Eigen::Matrix3d::Identity();
  std::string notes;
};

// Per-frame truth written by the simulator (ground_truth/ in a recording).
struct GroundTruthFrame {
  int64_t t_ns = 0;
  CameraIntrinsics intrinsics;
  Eigen::Vector3d world_from_cam_translation = Eigen::Vector3d::Zero();
  Eigen::Quaterniond world_from_cam_rotation = Eigen::Quaterniond::Identity();
};

struct ReadOptions {
  // false: the first fault in any file is an Error naming file, line and what was
  // expected. true: everything up to the first fault is kept, the fault is reported in
  // warnings(), and frames after the last good accelerometer sample (or vice versa) stay.
  bool truncate_at_fault = false;
  // The source's own accelerometer is not read (`--accel none`): a video then needs no CSV
  // beside it, and without a timestamps file its frames count from 0 at the container's
  // frame rate.
  bool without_accel = false;
  // An accelerometer CSV read instead of the source's own (`--accel FILE.csv`). A video
  // then needs none beside it, and without a timestamps file its frames count from this
  // CSV's first sample, as they would from the CSV beside it.
  std::string accel_csv;
};

// A finite, random-access sequence of frames plus its accelerometer stream.
// LoadFrame is const and safe to call from several threads at once.
class Sequence {
 public:
  virtual ~Sequence() = default;

  // Human-readable kind and location ("native recording /data/walk1").
  virtual std::string Describe() const = 0;
  virtual const SessionInfo& session() const = 0;
  virtual size_t frame_count() const = 0;
  virtual int64_t frame_time_ns(size_t index) const = 0;
  // 8-bit BGR frame. Throws Error (naming the file) when it cannot be read.
  virtual cv::Mat LoadFrame(size_t index) const = 0;
  // Where a frame comes from, for a message about it: its file where it has one.
  virtual std::string FrameName(size_t index) const { return "frame " + std::to_string(index + 1); }
  // Sorted by time.
  virtual const std::vector<AccelSample>& accel() const = 0;
  // Faults skipped because ReadOptions::truncate_at_fault was set.
  virtual const std::vector<std::string>& warnings() const = 0;

  // Ground truth, where the source has it (one entry per frame).
  virtual const std::vector<GroundTruthFrame>* ground_truth() const { return nullptr; }
  // Id of the scene plane each pixel sees (CV_16U, 0 = none), where the source has it.
  virtual std::optional<cv::Mat> LoadPlaneLabels(size_t /*index*/) const { return std::nullopt; }
  // The scene description (YAML, ground_truth/scene.yaml in a recording), where the source
  // has one, so that copying a sequence keeps it.
  virtual std::optional<std::string> SceneDescription() const { return std::nullopt; }
};

// Opens a native recording, a EuRoC folder (mav0/ or its parent), a TUM RGB-D folder,
// a video file with an accelerometer CSV beside it, or "sim:SCENARIO[,key=value...]"
// (the simulator). Throws Error saying what was found and what was expected.
std::unique_ptr<Sequence> OpenSequence(const std::string& path, const ReadOptions& options = {});

}  // namespace autocal
