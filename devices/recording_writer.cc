#include "devices/recording_writer.h"

#include <algorithm>
#include <exception>
#include <filesystem>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include "devices/csv.h"
#include "devices/session_io.h"
#include "pipeline/error.h"

namespace fs = std::filesystem;

namespace autocal {
namespace {

// Frames copied per round of parallel encoding; their rows are then appended in order.
constexpr size_t kFramesPerBatch = 8;

fs::path FramePath(const std::string& dir, int64_t t_ns) {
  return fs::path(dir) / "cam0" / "data" / (std::to_string(t_ns) + ".png");
}

fs::path PlaneLabelPath(const std::string& dir, int64_t t_ns) {
  return fs::path(dir) / "ground_truth" / "planes" / (std::to_string(t_ns) + ".png");
}

void CreateFolder(const fs::path& path) {
  std::error_code error;
  fs::create_directories(path, error);
  if (error) throw Error(path.string(), 0, "cannot create the folder: " + error.message());
}

void OpenCsv(const fs::path& path, const char* header, std::ofstream* out) {
  out->open(path, std::ios::binary | std::ios::trunc);
  *out << header << '\n';
  out->flush();
  if (!*out) throw Error(path.string(), 0, "cannot be written");
}

// Flushes each row so that a killed process leaves every row it reported written.
void AppendRow(std::ofstream* out, const std::string& row, const std::string& dir,
               const char* name) {
  *out << row << '\n';
  out->flush();
  if (!*out) throw Error((fs::path(dir) / name).string(), 0, "cannot be written");
}

void RequireAfter(const std::optional<int64_t>& last, int64_t t_ns, const std::string& dir,
                  const char* name) {
  if (last && t_ns <= *last) {
    throw Error((fs::path(dir) / name).string(), 0,
                "timestamp " + std::to_string(t_ns) + " is not after the previous one " +
                    std::to_string(*last));
  }
}

// Encodes to a temporary name and renames, so that a killed process never leaves a
// half-written PNG under the name a CSV row refers to.
void WritePng(const fs::path& path, const cv::Mat& image) {
  fs::path temporary = path;
  temporary.replace_extension(".tmp.png");
  bool written = false;
  try {
    written = cv::imwrite(temporary.string(), image, {cv::IMWRITE_PNG_COMPRESSION, 1});
  } catch (const cv::Exception& e) {
    throw Error(path.string(), 0, "cannot be written: " + e.err);
  }
  if (!written) throw Error(path.string(), 0, "cannot be written");
  std::error_code error;
  fs::rename(temporary, path, error);
  if (error) throw Error(path.string(), 0, "cannot be written: " + error.message());
}

void WriteTextFile(const fs::path& path, const std::string& contents) {
  const fs::path temporary = fs::path(path).concat(".tmp");
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out << contents;
    out.flush();
    if (!out) throw Error(path.string(), 0, "cannot be written");
  }
  std::error_code error;
  fs::rename(temporary, path, error);
  if (error) throw Error(path.string(), 0, "cannot be written: " + error.message());
}

}  // namespace

RecordingWriter::RecordingWriter(const std::string& dir, const SessionInfo& session) : dir_(dir) {
  std::error_code error;
  if (fs::exists(dir_, error) && !fs::is_empty(dir_, error)) {
    throw Error(dir_, 0, "already exists and is not empty: a recording needs a new folder");
  }
  CreateFolder(fs::path(dir_) / "cam0" / "data");
  CreateFolder(fs::path(dir_) / "accel0");
  WriteSessionFile((fs::path(dir_) / "session.json").string(), session);
  OpenCsv(fs::path(dir_) / "cam0" / "data.csv", "#timestamp [ns],filename", &frames_csv_);
  OpenCsv(fs::path(dir_) / "accel0" / "data.csv",
          "#timestamp [ns],a_x [m s^-2],a_y [m s^-2],a_z [m s^-2]", &accel_csv_);
}

void RecordingWriter::AddFrame(int64_t t_ns, const cv::Mat& image) {
  RequireAfter(last_frame_ns_, t_ns, dir_, "cam0/data.csv");  // Before writing the image.
  WriteFrameImage(t_ns, image);
  AppendFrameRow(t_ns);
}

void RecordingWriter::WriteFrameImage(int64_t t_ns, const cv::Mat& image) const {
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
    throw Error(FramePath(dir_, t_ns).string(), 0, "a frame must be an 8-bit gray or BGR image");
  }
  WritePng(FramePath(dir_, t_ns), image);
}

void RecordingWriter::AppendFrameRow(int64_t t_ns) {
  const fs::path image = FramePath(dir_, t_ns);
  std::error_code error;
  if (!fs::is_regular_file(image, error)) {
    throw Error(image.string(), 0, "a frame row was added before its image was written");
  }
  RequireAfter(last_frame_ns_, t_ns, dir_, "cam0/data.csv");
  AppendRow(&frames_csv_, std::to_string(t_ns) + "," + image.filename().string(), dir_,
            "cam0/data.csv");
  last_frame_ns_ = t_ns;
}

void RecordingWriter::AddAccel(const AccelSample& sample) {
  RequireAfter(last_accel_ns_, sample.t_ns, dir_, "accel0/data.csv");
  const Eigen::Vector3d& f = sample.specific_force;
  AppendRow(&accel_csv_,
            std::to_string(sample.t_ns) + "," + FormatDouble(f.x()) + "," + FormatDouble(f.y()) +
                "," + FormatDouble(f.z()),
            dir_, "accel0/data.csv");
  last_accel_ns_ = sample.t_ns;
}

void RecordingWriter::OpenGroundTruth() {
  if (intrinsics_csv_.is_open()) return;
  const fs::path dir = fs::path(dir_) / "ground_truth";
  CreateFolder(dir);
  OpenCsv(dir / "intrinsics.csv", "#timestamp [ns],fx,fy,cx,cy,k1,k2,p1,p2,k3", &intrinsics_csv_);
  OpenCsv(dir / "poses.csv", "#timestamp [ns],p_x,p_y,p_z,q_w,q_x,q_y,q_z", &poses_csv_);
}

void RecordingWriter::AddGroundTruth(const GroundTruthFrame& truth, const cv::Mat& plane_labels) {
  RequireAfter(last_truth_ns_, truth.t_ns, dir_, "ground_truth/intrinsics.csv");
  if (!plane_labels.empty()) WritePlaneLabels(truth.t_ns, plane_labels);
  AppendGroundTruthRows(truth);
}

void RecordingWriter::WritePlaneLabels(int64_t t_ns, const cv::Mat& plane_labels) const {
  if (plane_labels.type() != CV_16UC1) {
    throw Error(PlaneLabelPath(dir_, t_ns).string(), 0,
                "plane labels must be a 16-bit single-channel image");
  }
  const fs::path path = PlaneLabelPath(dir_, t_ns);
  CreateFolder(path.parent_path());  // Safe to repeat, and from several threads.
  WritePng(path, plane_labels);
}

void RecordingWriter::AppendGroundTruthRows(const GroundTruthFrame& truth) {
  OpenGroundTruth();
  RequireAfter(last_truth_ns_, truth.t_ns, dir_, "ground_truth/intrinsics.csv");
  const CameraIntrinsics& c = truth.intrinsics;
  std::string intrinsics = std::to_string(truth.t_ns);
  for (const double value : c.Packed()) intrinsics += "," + FormatDouble(value);
  AppendRow(&intrinsics_csv_, intrinsics, dir_, "ground_truth/intrinsics.csv");

  const Eigen::Vector3d& p = truth.world_from_cam_translation;
  const Eigen::Quaterniond& q = truth.world_from_cam_rotation;
  std::string pose = std::to_string(truth.t_ns);
  for (const double value : {p.x(), p.y(), p.z(), q.w(), q.x(), q.y(), q.z()}) {
    pose += "," + FormatDouble(value);
  }
  AppendRow(&poses_csv_, pose, dir_, "ground_truth/poses.csv");
  last_truth_ns_ = truth.t_ns;
}

void RecordingWriter::AddGroundTruthFile(const std::string& name, const std::string& contents) {
  OpenGroundTruth();
  WriteTextFile(fs::path(dir_) / "ground_truth" / name, contents);
}

bool WriteSequence(const Sequence& sequence, const std::string& dir,
                   const ProgressCallback& progress) {
  const size_t count = sequence.frame_count();
  const std::vector<GroundTruthFrame>* truth = sequence.ground_truth();
  if (truth && truth->size() != count) {
    throw Error(sequence.Describe() + ": ground truth has " + std::to_string(truth->size()) +
                " entries for " + std::to_string(count) + " frames");
  }
  for (size_t i = 0; truth && i < count; ++i) {
    if ((*truth)[i].t_ns != sequence.frame_time_ns(i)) {
      throw Error(sequence.Describe() + ": the ground truth of frame " + std::to_string(i + 1) +
                  " is not at the frame's time");
    }
  }

  RecordingWriter writer(dir, sequence.session());
  for (const AccelSample& sample : sequence.accel()) writer.AddAccel(sample);
  if (const std::optional<std::string> scene = sequence.SceneDescription()) {
    writer.AddGroundTruthFile("scene.yaml", *scene);
  }

  for (size_t begin = 0; begin < count; begin += kFramesPerBatch) {
    const size_t end = std::min(count, begin + kFramesPerBatch);
    // Loading (rendering, for the simulator) and encoding run in parallel; exceptions are
    // carried out of the workers and rethrown in frame order.
    std::vector<std::exception_ptr> failures(end - begin);
    cv::parallel_for_(
        cv::Range(static_cast<int>(begin), static_cast<int>(end)),
        [&](const cv::Range& range) {
          for (int i = range.start; i < range.end; ++i) {
            try {
              const int64_t t_ns = sequence.frame_time_ns(i);
              writer.WriteFrameImage(t_ns, sequence.LoadFrame(i));
              if (truth) {
                const std::optional<cv::Mat> labels = sequence.LoadPlaneLabels(i);
                if (labels && !labels->empty()) writer.WritePlaneLabels(t_ns, *labels);
              }
            } catch (...) {
              failures[i - begin] = std::current_exception();
            }
          }
        },
        static_cast<double>(end - begin));

    for (size_t i = begin; i < end; ++i) {
      if (failures[i - begin]) std::rethrow_exception(failures[i - begin]);
      writer.AppendFrameRow(sequence.frame_time_ns(i));
      if (truth) writer.AppendGroundTruthRows((*truth)[i]);
      if (progress && !progress(i + 1, count)) return false;
    }
  }
  return true;
}

}  // namespace autocal
