// Reads the native recording folder (DESIGN.md section 4, docs/recordings.md) and holds
// what every image-file dataset reads into: timestamps, frame paths, accelerometer
// samples and, for recordings of the simulator, ground truth.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "devices/sequence.h"

namespace autocal {

// A sequence of frames stored as image files, decoded only when asked for.
class ImageFileSequence : public Sequence {
 public:
  struct Contents {
    std::string description;  // What Describe() returns.
    SessionInfo session;
    std::vector<int64_t> frame_times_ns;             // Increasing.
    std::vector<std::filesystem::path> frame_paths;  // One per frame time.
    std::vector<AccelSample> accel;                  // Increasing in time.
    std::vector<std::string> warnings;
    // Either none or one entry per frame, as are the plane-label paths (an empty path:
    // that frame has no plane labels).
    std::optional<std::vector<GroundTruthFrame>> ground_truth;
    std::vector<std::filesystem::path> plane_label_paths;
    std::optional<std::string> scene_description;
  };

  explicit ImageFileSequence(Contents contents);

  std::string Describe() const override { return contents_.description; }
  const SessionInfo& session() const override { return contents_.session; }
  size_t frame_count() const override { return contents_.frame_times_ns.size(); }
  int64_t frame_time_ns(size_t index) const override { return contents_.frame_times_ns.at(index); }
  cv::Mat LoadFrame(size_t index) const override;
  std::string FrameName(size_t index) const override {
    return contents_.frame_paths.at(index).string();
  }
  const std::vector<AccelSample>& accel() const override { return contents_.accel; }
  const std::vector<std::string>& warnings() const override { return contents_.warnings; }
  const std::vector<GroundTruthFrame>* ground_truth() const override;
  std::optional<cv::Mat> LoadPlaneLabels(size_t index) const override;
  std::optional<std::string> SceneDescription() const override {
    return contents_.scene_description;
  }

 private:
  Contents contents_;
};

// Reads a frame list in EuRoC's layout (`#timestamp [ns],filename`, the files in
// `image_dir`) into `contents`, checking that every frame file exists.
void ReadFrameList(const std::filesystem::path& csv, const std::filesystem::path& image_dir,
                   const ReadOptions& options, ImageFileSequence::Contents* contents);

// Reads accelerometer samples in the native layout
// (`#timestamp [ns],a_x [m s^-2],a_y [m s^-2],a_z [m s^-2]`).
std::vector<AccelSample> ReadAccelCsv(const std::filesystem::path& csv, const ReadOptions& options,
                                      std::vector<std::string>* warnings);

// True when `dir` has any part of a native recording (session.json, cam0/ or accel0/), so
// that OpenRecording's error, rather than "unknown format", says what is missing.
bool LooksLikeRecording(const std::filesystem::path& dir);

// Opens a native recording folder. Throws Error naming the missing or faulty file (and
// line) and what was expected.
std::unique_ptr<Sequence> OpenRecording(const std::string& dir, const ReadOptions& options = {});

}  // namespace autocal
