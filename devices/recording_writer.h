// Writes the native recording folder (DESIGN.md section 4). Every row is flushed as it is
// written, so a killed process leaves a recording readable up to its last frame.
#pragma once

#include <cstdint>
#include <fstream>
#include <functional>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "devices/sequence.h"

namespace autocal {

class RecordingWriter {
 public:
  // Creates `dir` (which must not exist, or be empty) and writes session.json at once.
  // Throws Error when the folder cannot be created or written.
  RecordingWriter(const std::string& dir, const SessionInfo& session);

  // Appends a frame: cam0/data/<t_ns>.png and a row in cam0/data.csv.
  void AddFrame(int64_t t_ns, const cv::Mat& image);
  // Appends a row to accel0/data.csv.
  void AddAccel(const AccelSample& sample);
  // Appends ground truth for one frame: rows in ground_truth/intrinsics.csv and poses.csv
  // and, if not empty, the CV_16U plane-label image ground_truth/planes/<t_ns>.png.
  void AddGroundTruth(const GroundTruthFrame& truth, const cv::Mat& plane_labels);
  // Writes a file below ground_truth/ (e.g. the scene description).
  void AddGroundTruthFile(const std::string& name, const std::string& contents);

  // AddFrame and AddGroundTruth in two steps, for writers that encode several frames at
  // once: the Write* calls are safe from several threads at once, and the Append* calls
  // then add the rows, in time order, for images already written.
  void WriteFrameImage(int64_t t_ns, const cv::Mat& image) const;
  void WritePlaneLabels(int64_t t_ns, const cv::Mat& plane_labels) const;
  void AppendFrameRow(int64_t t_ns);
  void AppendGroundTruthRows(const GroundTruthFrame& truth);

  const std::string& dir() const { return dir_; }

 private:
  // Creates ground_truth/ and its CSV files with their headers, once.
  void OpenGroundTruth();

  std::string dir_;
  std::ofstream frames_csv_, accel_csv_, intrinsics_csv_, poses_csv_;
  // Last timestamps written, to refuse rows a reader would reject.
  std::optional<int64_t> last_frame_ns_, last_accel_ns_, last_truth_ns_;
};

// Reports progress (frames done, frames in all); returning false cancels.
using ProgressCallback = std::function<bool(size_t done, size_t total)>;

// Copies any sequence, with its ground truth where it has one, into a native recording.
// Returns false if cancelled. Throws Error on I/O failure.
bool WriteSequence(const Sequence& sequence, const std::string& dir,
                   const ProgressCallback& progress = {});

}  // namespace autocal
