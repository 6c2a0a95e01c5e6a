#include "devices/recording_reader.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <utility>

#include <opencv2/imgcodecs.hpp>

#include "devices/csv.h"
#include "devices/session_io.h"
#include "pipeline/error.h"

namespace fs = std::filesystem;

namespace autocal {
namespace {

constexpr char kLayout[] =
    "a native recording has session.json, cam0/data.csv, cam0/data/ and accel0/data.csv";

void RequireExists(const fs::path& path, bool folder) {
  std::error_code ignored;
  if (folder ? fs::is_directory(path, ignored) : fs::is_regular_file(path, ignored)) return;
  throw Error(path.string(), 0,
              std::string(folder ? "folder" : "file") + " does not exist: " + kLayout);
}

// Whether a ground-truth row is kept: row `index` must be that of frame `index`. Rows past
// the last frame are an error, or, when truncating (the frames may have been cut at a
// fault), skipped.
bool CheckGroundTruthTime(CsvReader& reader, int64_t t_ns, size_t index,
                          const std::vector<int64_t>& frame_times_ns, const ReadOptions& options) {
  if (index >= frame_times_ns.size()) {
    if (options.truncate_at_fault) return false;
    reader.Fail("more rows than cam0/data.csv has frames (" +
                std::to_string(frame_times_ns.size()) + ")");
  }
  if (t_ns != frame_times_ns[index]) {
    reader.Fail("timestamp " + std::to_string(t_ns) + " is not that of frame " +
                std::to_string(index + 1) + " in cam0/data.csv, " +
                std::to_string(frame_times_ns[index]));
  }
  return true;
}

std::vector<CameraIntrinsics> ReadGroundTruthIntrinsics(const fs::path& csv,
                                                        const ImageFileSequence::Contents& in,
                                                        const ReadOptions& options,
                                                        std::vector<std::string>* warnings) {
  CsvReader reader(csv, CsvReader::Separator::kComma,
                   {"timestamp [ns]", "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"});
  std::vector<CameraIntrinsics> rows;
  ReadRows(reader, options.truncate_at_fault, warnings, [&](CsvReader& row) {
    if (!CheckGroundTruthTime(row, row.Int64(0), rows.size(), in.frame_times_ns, options)) return;
    CameraIntrinsics c;
    c.width = in.session.width;
    c.height = in.session.height;
    c.fx = row.Double(1);
    c.fy = row.Double(2);
    c.cx = row.Double(3);
    c.cy = row.Double(4);
    c.k1 = row.Double(5);
    c.k2 = row.Double(6);
    c.p1 = row.Double(7);
    c.p2 = row.Double(8);
    c.k3 = row.Double(9);
    std::string why;
    if (!c.Check(&why)) row.Fail(why);
    rows.push_back(c);
  });
  return rows;
}

struct Pose {
  Eigen::Vector3d translation;
  Eigen::Quaterniond rotation;
};

std::vector<Pose> ReadGroundTruthPoses(const fs::path& csv, const ImageFileSequence::Contents& in,
                                       const ReadOptions& options,
                                       std::vector<std::string>* warnings) {
  CsvReader reader(csv, CsvReader::Separator::kComma,
                   {"timestamp [ns]", "p_x", "p_y", "p_z", "q_w", "q_x", "q_y", "q_z"});
  std::vector<Pose> rows;
  ReadRows(reader, options.truncate_at_fault, warnings, [&](CsvReader& row) {
    if (!CheckGroundTruthTime(row, row.Int64(0), rows.size(), in.frame_times_ns, options)) return;
    Pose pose;
    pose.translation = {row.Double(1), row.Double(2), row.Double(3)};
    pose.rotation = Eigen::Quaterniond(row.Double(4), row.Double(5), row.Double(6), row.Double(7));
    if (std::abs(pose.rotation.norm() - 1.0) > 1e-6) {
      row.Fail("quaternion (q_w, q_x, q_y, q_z) is not of unit length");
    }
    rows.push_back(pose);
  });
  return rows;
}

// Reads ground_truth/ into `contents`. Every frame needs ground truth: when the files end
// early (a recording cut off between a frame and its truth) the frames are cut to match,
// or it is an error.
void ReadGroundTruth(const fs::path& dir, const ReadOptions& options,
                     ImageFileSequence::Contents* contents) {
  const fs::path intrinsics_csv = dir / "intrinsics.csv";
  const fs::path poses_csv = dir / "poses.csv";
  const std::vector<CameraIntrinsics> intrinsics =
      ReadGroundTruthIntrinsics(intrinsics_csv, *contents, options, &contents->warnings);
  const std::vector<Pose> poses =
      ReadGroundTruthPoses(poses_csv, *contents, options, &contents->warnings);

  const size_t frames = contents->frame_times_ns.size();
  for (const auto& [csv, rows] :
       {std::pair{intrinsics_csv, intrinsics.size()}, std::pair{poses_csv, poses.size()}}) {
    if (rows == frames) continue;
    const std::string what = "ends after " + std::to_string(rows) + " rows but cam0/data.csv has " +
                             std::to_string(frames) + " frames: every frame needs ground truth";
    if (!options.truncate_at_fault) throw Error(csv.string(), 0, what);
    contents->warnings.push_back(csv.string() + ": " + what + " (frames cut to match)");
  }
  const size_t kept = std::min({frames, intrinsics.size(), poses.size()});
  contents->frame_times_ns.resize(kept);
  contents->frame_paths.resize(kept);

  std::vector<GroundTruthFrame> truth(kept);
  contents->plane_label_paths.resize(kept);
  for (size_t i = 0; i < kept; ++i) {
    truth[i].t_ns = contents->frame_times_ns[i];
    truth[i].intrinsics = intrinsics[i];
    truth[i].world_from_cam_translation = poses[i].translation;
    truth[i].world_from_cam_rotation = poses[i].rotation;
    const fs::path labels = dir / "planes" / (std::to_string(truth[i].t_ns) + ".png");
    std::error_code ignored;
    if (fs::is_regular_file(labels, ignored)) contents->plane_label_paths[i] = labels;
  }
  contents->ground_truth = std::move(truth);

  const fs::path scene = dir / "scene.yaml";
  if (std::ifstream in(scene, std::ios::binary); in) {
    std::ostringstream text;
    text << in.rdbuf();
    contents->scene_description = text.str();
  }
}

}  // namespace

ImageFileSequence::ImageFileSequence(Contents contents) : contents_(std::move(contents)) {}

cv::Mat ImageFileSequence::LoadFrame(size_t index) const {
  const fs::path& path = contents_.frame_paths.at(index);
  cv::Mat image = cv::imread(path.string(), cv::IMREAD_COLOR);
  if (image.empty()) {
    std::error_code ignored;
    throw Error(path.string(), 0,
                fs::exists(path, ignored) ? "cannot be decoded as an image (truncated or corrupt)"
                                          : "frame file does not exist");
  }
  return image;
}

const std::vector<GroundTruthFrame>* ImageFileSequence::ground_truth() const {
  return contents_.ground_truth ? &*contents_.ground_truth : nullptr;
}

std::optional<cv::Mat> ImageFileSequence::LoadPlaneLabels(size_t index) const {
  if (index >= contents_.plane_label_paths.size() || contents_.plane_label_paths[index].empty()) {
    return std::nullopt;
  }
  const std::string path = contents_.plane_label_paths[index].string();
  cv::Mat labels = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (labels.empty()) throw Error(path, 0, "cannot be decoded as an image (truncated or corrupt)");
  if (labels.type() != CV_16UC1) {
    throw Error(path, 0, "expected a 16-bit single-channel plane-label image");
  }
  return labels;
}

void ReadFrameList(const fs::path& csv, const fs::path& image_dir, const ReadOptions& options,
                   ImageFileSequence::Contents* contents) {
  CsvReader reader(csv, CsvReader::Separator::kComma, {"timestamp [ns]", "filename"});
  ReadRows(reader, options.truncate_at_fault, &contents->warnings, [&](CsvReader& row) {
    const int64_t t_ns = row.Int64(0);
    row.CheckIncreasing(t_ns);
    const std::string_view name = row.Text(1);
    if (name.empty()) row.Fail("field 2 (filename) is empty");
    fs::path frame = image_dir / name;
    std::error_code ignored;
    if (!fs::is_regular_file(frame, ignored)) {
      row.Fail("frame file " + frame.string() + " does not exist");
    }
    contents->frame_times_ns.push_back(t_ns);
    contents->frame_paths.push_back(std::move(frame));
  });
}

std::vector<AccelSample> ReadAccelCsv(const fs::path& csv, const ReadOptions& options,
                                      std::vector<std::string>* warnings) {
  CsvReader reader(csv, CsvReader::Separator::kComma, {"timestamp [ns]", "a_x", "a_y", "a_z"});
  std::vector<AccelSample> samples;
  ReadRows(reader, options.truncate_at_fault, warnings, [&](CsvReader& row) {
    AccelSample sample;
    sample.t_ns = row.Int64(0);
    sample.specific_force = {row.Double(1), row.Double(2), row.Double(3)};
    row.CheckIncreasing(sample.t_ns);
    samples.push_back(sample);
  });
  return samples;
}

bool LooksLikeRecording(const fs::path& dir) {
  std::error_code ignored;
  return fs::exists(dir / "session.json", ignored) || fs::is_directory(dir / "cam0", ignored) ||
         fs::is_directory(dir / "accel0", ignored);
}

std::unique_ptr<Sequence> OpenRecording(const std::string& dir_name, const ReadOptions& options) {
  const fs::path dir(dir_name);
  RequireExists(dir, /*folder=*/true);
  RequireExists(dir / "session.json", /*folder=*/false);
  RequireExists(dir / "cam0", /*folder=*/true);
  RequireExists(dir / "cam0" / "data.csv", /*folder=*/false);
  RequireExists(dir / "accel0" / "data.csv", /*folder=*/false);

  ImageFileSequence::Contents contents;
  contents.description = "native recording " + dir.string();
  contents.session = ReadSessionFile((dir / "session.json").string());
  ReadFrameList(dir / "cam0" / "data.csv", dir / "cam0" / "data", options, &contents);
  contents.accel = ReadAccelCsv(dir / "accel0" / "data.csv", options, &contents.warnings);
  std::error_code ignored;
  if (fs::is_directory(dir / "ground_truth", ignored)) {
    ReadGroundTruth(dir / "ground_truth", options, &contents);
  }
  return std::make_unique<ImageFileSequence>(std::move(contents));
}

}  // namespace autocal
