#include "devices/dataset_readers.h"

#include <cmath>
#include <fstream>
#include <sstream>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "devices/csv.h"
#include "devices/decoder_pool.h"
#include "devices/inspect.h"
#include "devices/recording_reader.h"
#include "devices/session_io.h"
#include "pipeline/error.h"

namespace fs = std::filesystem;

namespace autocal {
namespace {

void RequireFile(const fs::path& path, const std::string& layout) {
  std::error_code ignored;
  if (!fs::is_regular_file(path, ignored)) {
    throw Error(path.string(), 0, "file does not exist: " + layout);
  }
}

std::vector<int64_t> AccelTimes(const std::vector<AccelSample>& accel) {
  std::vector<int64_t> times;
  times.reserve(accel.size());
  for (const auto& sample : accel) times.push_back(sample.t_ns);
  return times;
}

// Size of the first frame, for datasets that do not state it; 0x0 without frames.
cv::Size FirstFrameSize(const ImageFileSequence::Contents& contents) {
  if (contents.frame_paths.empty()) return {};
  const std::string path = contents.frame_paths.front().string();
  const cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (image.empty()) throw Error(path, 0, "cannot be decoded as an image (truncated or corrupt)");
  return image.size();
}

// Nominal rates that the dataset does not state are taken from the timestamps.
void FillMissingRates(const ImageFileSequence::Contents& contents, SessionInfo* session) {
  if (session->frame_rate_hz <= 0.0) session->frame_rate_hz = MedianRateHz(contents.frame_times_ns);
  if (session->accel_rate_hz <= 0.0)
    session->accel_rate_hz = MedianRateHz(AccelTimes(contents.accel));
}

// --- EuRoC ---------------------------------------------------------------------------------

constexpr char kEurocLayout[] =
    "a EuRoC folder has mav0/cam0/data.csv, mav0/cam0/data/ and mav0/imu0/data.csv";

// EuRoC's sensor.yaml files lack the "%YAML:1.0" line that cv::FileStorage requires.
cv::FileStorage ReadSensorYaml(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string(), 0, "cannot be opened for reading");
  std::ostringstream text;
  text << in.rdbuf();
  std::string yaml = text.str();
  if (!yaml.starts_with("%YAML")) yaml = "%YAML:1.0\n" + yaml;
  try {
    return cv::FileStorage(
        yaml, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  } catch (const cv::Exception& e) {
    throw Error(path.string(), 0, "is not valid YAML (" + e.err + ")");
  }
}

std::vector<double> Numbers(const cv::FileNode& node, size_t min_count, size_t max_count,
                            const fs::path& file, const std::string& key) {
  std::vector<double> numbers;
  if (node.isSeq()) {
    for (const auto& item : node) {
      if (!item.isInt() && !item.isReal()) break;
      numbers.push_back(static_cast<double>(item));
    }
  }
  if (numbers.size() != node.size() || numbers.size() < min_count || numbers.size() > max_count) {
    const std::string count = min_count == max_count
                                  ? std::to_string(min_count)
                                  : std::to_string(min_count) + " to " + std::to_string(max_count);
    throw Error(file.string(), 0, key + ": expected a list of " + count + " numbers");
  }
  return numbers;
}

// Rotation of T_BS (body from sensor), the 4x4 row-major matrix of a EuRoC sensor.yaml.
std::optional<Eigen::Matrix3d> BodyFromSensorRotation(const cv::FileStorage& yaml,
                                                      const fs::path& file) {
  const cv::FileNode t_bs = yaml["T_BS"];
  if (t_bs.isNone()) return std::nullopt;
  const std::vector<double> data = Numbers(t_bs["data"], 16, 16, file, "T_BS.data");
  Eigen::Matrix3d rotation;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) rotation(row, col) = data[row * 4 + col];
  }
  return rotation;
}

std::string Comment(const cv::FileStorage& yaml, const std::string& fallback) {
  const cv::FileNode comment = yaml["comment"];
  return comment.isString() ? static_cast<std::string>(comment) : fallback;
}

double Rate(const cv::FileStorage& yaml) {
  const cv::FileNode rate = yaml["rate_hz"];
  return rate.isInt() || rate.isReal() ? static_cast<double>(rate) : 0.0;
}

// Reads what mav0/cam0/sensor.yaml and mav0/imu0/sensor.yaml say into `session`.
void ReadEurocSensors(const fs::path& mav0, SessionInfo* session) {
  std::error_code ignored;
  const fs::path cam_yaml_path = mav0 / "cam0" / "sensor.yaml";
  const fs::path imu_yaml_path = mav0 / "imu0" / "sensor.yaml";
  std::optional<Eigen::Matrix3d> body_from_cam, body_from_imu;

  if (fs::is_regular_file(cam_yaml_path, ignored)) {
    const cv::FileStorage yaml = ReadSensorYaml(cam_yaml_path);
    session->camera_device = Comment(yaml, session->camera_device);
    session->frame_rate_hz = Rate(yaml);
    if (!yaml["resolution"].isNone()) {
      const auto size = Numbers(yaml["resolution"], 2, 2, cam_yaml_path, "resolution");
      session->width = static_cast<int>(size[0]);
      session->height = static_cast<int>(size[1]);
    }
    const auto text = [&yaml](const char* key, const char* fallback) {
      return yaml[key].isString() ? static_cast<std::string>(yaml[key]) : std::string(fallback);
    };
    const std::string model = text("camera_model", "pinhole");
    const std::string distortion = text("distortion_model", "");
    if (!yaml["intrinsics"].isNone() && model == "pinhole" && distortion == "radial-tangential") {
      const auto k = Numbers(yaml["intrinsics"], 4, 4, cam_yaml_path, "intrinsics");
      const auto d =
          Numbers(yaml["distortion_coefficients"], 4, 5, cam_yaml_path, "distortion_coefficients");
      CameraIntrinsics c;
      c.width = session->width;
      c.height = session->height;
      c.fx = k[0];
      c.fy = k[1];
      c.cx = k[2];
      c.cy = k[3];
      c.k1 = d[0];
      c.k2 = d[1];
      c.p1 = d[2];
      c.p2 = d[3];
      c.k3 = d.size() == 5 ? d[4] : 0.0;
      std::string why;
      if (!c.Check(&why)) throw Error(cam_yaml_path.string(), 0, "intrinsics: " + why);
      session->premission_calibration = c;
    } else if (!yaml["intrinsics"].isNone()) {
      session->notes = "cam0 lens model " + model + "/" + distortion +
                       " is not pinhole radial-tangential: no pre-mission calibration taken";
    }
    body_from_cam = BodyFromSensorRotation(yaml, cam_yaml_path);
  }
  if (fs::is_regular_file(imu_yaml_path, ignored)) {
    const cv::FileStorage yaml = ReadSensorYaml(imu_yaml_path);
    session->accelerometer_device = Comment(yaml, session->accelerometer_device);
    session->accel_rate_hz = Rate(yaml);
    body_from_imu = BodyFromSensorRotation(yaml, imu_yaml_path);
  }
  if (body_from_cam && body_from_imu) {
    session->cam_from_accel = body_from_cam->transpose() * *body_from_imu;
  }
}

// --- Video ---------------------------------------------------------------------------------

// Frames decoded from a video file, by a few decoders so that each reader keeps its own
// place (devices/decoder_pool.h).
class VideoSequence : public Sequence {
 public:
  VideoSequence(std::string path, std::string description, SessionInfo session,
                std::vector<int64_t> frame_times_ns, std::vector<AccelSample> accel,
                std::vector<std::string> warnings)
      : path_(std::move(path)),
        description_(std::move(description)),
        session_(std::move(session)),
        frame_times_ns_(std::move(frame_times_ns)),
        accel_(std::move(accel)),
        warnings_(std::move(warnings)),
        captures_(kMaxDecoders),
        pool_(kMaxDecoders, kMaxFramesReadOn) {
    if (!captures_[0].open(path_)) {
      throw Error(path_, 0, "cannot be opened as a video any more");
    }
    pool_.Release(0, 0);
  }

  std::string Describe() const override { return description_; }
  const SessionInfo& session() const override { return session_; }
  size_t frame_count() const override { return frame_times_ns_.size(); }
  int64_t frame_time_ns(size_t index) const override { return frame_times_ns_.at(index); }
  const std::vector<AccelSample>& accel() const override { return accel_; }
  const std::vector<std::string>& warnings() const override { return warnings_; }

  cv::Mat LoadFrame(size_t index) const override {
    if (index >= frame_times_ns_.size()) {
      throw Error(path_, 0, "frame " + std::to_string(index) + " is beyond the last frame");
    }
    const DecoderPool::Lease lease = pool_.Acquire(index);
    cv::VideoCapture& capture = captures_[lease.slot];
    size_t next = lease.next;
    if (!capture.isOpened() && capture.open(path_)) next = 0;
    bool read = capture.isOpened();
    if (read && next != index) {
      if (next < index && index - next <= kMaxFramesReadOn) {
        for (; read && next < index; ++next) read = capture.grab();
      } else {
        read = capture.set(cv::CAP_PROP_POS_FRAMES, static_cast<double>(index));
      }
    }
    cv::Mat frame;
    read = read && capture.read(frame) && !frame.empty();
    pool_.Release(lease.slot, read ? index + 1 : DecoderPool::kUnknown);
    if (!read) throw Error(path_, 0, "frame " + std::to_string(index) + " cannot be decoded");
    if (frame.channels() == 1) cv::cvtColor(frame, frame, cv::COLOR_GRAY2BGR);
    return frame;
  }

 private:
  // The pipeline, the display and one more reader.
  static constexpr size_t kMaxDecoders = 3;
  // Frames decoded and dropped rather than seeking: a second of video at 30 frames/s.
  static constexpr size_t kMaxFramesReadOn = 30;

  std::string path_;
  std::string description_;
  SessionInfo session_;
  std::vector<int64_t> frame_times_ns_;
  std::vector<AccelSample> accel_;
  std::vector<std::string> warnings_;
  mutable std::vector<cv::VideoCapture> captures_;  // Each used by its pool lease alone.
  mutable DecoderPool pool_;
};

}  // namespace

std::optional<fs::path> FindEurocMav0(const fs::path& dir) {
  std::error_code ignored;
  if (fs::is_directory(dir / "cam0", ignored) && fs::is_directory(dir / "imu0", ignored)) {
    return dir;
  }
  if (fs::is_directory(dir / "mav0", ignored)) return dir / "mav0";
  return std::nullopt;
}

namespace {

// What a dataset does not state: the frame size from its first frame, the rates from
// its timestamps.
std::unique_ptr<Sequence> FinishDataset(ImageFileSequence::Contents contents) {
  if (contents.session.width <= 0 || contents.session.height <= 0) {
    const cv::Size size = FirstFrameSize(contents);
    contents.session.width = size.width;
    contents.session.height = size.height;
  }
  FillMissingRates(contents, &contents.session);
  return std::make_unique<ImageFileSequence>(std::move(contents));
}

}  // namespace

std::unique_ptr<Sequence> OpenEuroc(const std::string& dir, const ReadOptions& options) {
  const std::optional<fs::path> mav0 = FindEurocMav0(dir);
  if (!mav0) throw Error(dir, 0, std::string("is not a EuRoC folder: ") + kEurocLayout);
  RequireFile(*mav0 / "cam0" / "data.csv", kEurocLayout);
  RequireFile(*mav0 / "imu0" / "data.csv", kEurocLayout);

  ImageFileSequence::Contents contents;
  contents.description = "EuRoC folder " + dir;
  contents.session.camera_device = "EuRoC cam0";
  contents.session.accelerometer_device = "EuRoC imu0";
  ReadEurocSensors(*mav0, &contents.session);
  ReadFrameList(*mav0 / "cam0" / "data.csv", *mav0 / "cam0" / "data", options, &contents);

  CsvReader reader(*mav0 / "imu0" / "data.csv", CsvReader::Separator::kComma,
                   {"timestamp [ns]", "w_x", "w_y", "w_z", "a_x", "a_y", "a_z"});
  ReadRows(reader, options.truncate_at_fault, &contents.warnings, [&](CsvReader& row) {
    AccelSample sample;
    sample.t_ns = row.Int64(0);
    for (int axis = 0; axis < 3; ++axis) row.Double(1 + axis);  // Gyroscope: checked, unused.
    sample.specific_force = {row.Double(4), row.Double(5), row.Double(6)};
    row.CheckIncreasing(sample.t_ns);
    contents.accel.push_back(sample);
  });

  return FinishDataset(std::move(contents));
}

bool IsTumFolder(const fs::path& dir) {
  std::error_code ignored;
  return fs::is_regular_file(dir / "rgb.txt", ignored) ||
         fs::is_regular_file(dir / "accelerometer.txt", ignored);
}

std::unique_ptr<Sequence> OpenTum(const std::string& dir_name, const ReadOptions& options) {
  const fs::path dir(dir_name);
  constexpr char kTumLayout[] = "a TUM RGB-D folder has rgb.txt, rgb/ and accelerometer.txt";
  RequireFile(dir / "rgb.txt", kTumLayout);
  RequireFile(dir / "accelerometer.txt", kTumLayout);

  ImageFileSequence::Contents contents;
  contents.description = "TUM RGB-D folder " + dir_name;
  std::error_code ignored;
  if (fs::is_regular_file(dir / "session.json", ignored)) {
    contents.session = ReadSessionFile((dir / "session.json").string());
  } else {
    contents.session.camera_device = "TUM RGB-D (Kinect)";
    contents.session.accelerometer_device = "TUM RGB-D (Kinect accelerometer)";
  }

  CsvReader frames(dir / "rgb.txt", CsvReader::Separator::kWhitespace,
                   {"timestamp [s]", "filename"});
  ReadRows(frames, options.truncate_at_fault, &contents.warnings, [&](CsvReader& row) {
    const int64_t t_ns = row.SecondsAsNs(0);
    row.CheckIncreasing(t_ns);
    fs::path frame = dir / row.Text(1);
    if (!fs::is_regular_file(frame, ignored)) {
      row.Fail("frame file " + frame.string() + " does not exist");
    }
    contents.frame_times_ns.push_back(t_ns);
    contents.frame_paths.push_back(std::move(frame));
  });

  CsvReader accel(dir / "accelerometer.txt", CsvReader::Separator::kWhitespace,
                  {"timestamp [s]", "ax", "ay", "az"});
  ReadRows(accel, options.truncate_at_fault, &contents.warnings, [&](CsvReader& row) {
    AccelSample sample;
    sample.t_ns = row.SecondsAsNs(0);
    sample.specific_force = {row.Double(1), row.Double(2), row.Double(3)};
    row.CheckIncreasing(sample.t_ns);
    contents.accel.push_back(sample);
  });

  return FinishDataset(std::move(contents));
}

std::unique_ptr<Sequence> OpenVideo(const std::string& path_name, const ReadOptions& options) {
  const fs::path path(path_name);
  const fs::path dir = path.parent_path();
  const std::string base = path.stem().string();

  std::error_code ignored;
  fs::path accel_csv = options.accel_csv;
  if (accel_csv.empty() && !options.without_accel) {
    accel_csv = dir / (base + ".csv");
    if (!fs::is_regular_file(accel_csv, ignored)) accel_csv = dir / "accel.csv";
    if (!fs::is_regular_file(accel_csv, ignored)) {
      throw Error(path_name, 0,
                  "no accelerometer CSV beside the video: looked for " +
                      (dir / (base + ".csv")).string() + " and " + accel_csv.string() +
                      " (--accel FILE.csv reads one kept elsewhere, --accel none the video "
                      "alone)");
    }
  }

  cv::VideoCapture capture(path_name);
  if (!capture.isOpened()) {
    throw Error(path_name, 0, "cannot be opened as a video (cv::VideoCapture)");
  }
  // CAP_PROP_FRAME_COUNT is an estimate from the container; counting is exact.
  size_t frame_count = 0;
  while (capture.grab()) ++frame_count;

  SessionInfo session;
  session.camera_device = "video file " + path.filename().string();
  session.accelerometer_device = accel_csv.empty() ? "" : "CSV " + accel_csv.filename().string();
  session.width = static_cast<int>(capture.get(cv::CAP_PROP_FRAME_WIDTH));
  session.height = static_cast<int>(capture.get(cv::CAP_PROP_FRAME_HEIGHT));
  session.frame_rate_hz = capture.get(cv::CAP_PROP_FPS);

  std::vector<std::string> warnings;
  std::vector<AccelSample> accel;
  if (!accel_csv.empty()) accel = ReadAccelCsv(accel_csv, options, &warnings);
  session.accel_rate_hz = MedianRateHz(AccelTimes(accel));

  std::vector<int64_t> frame_times_ns;
  const fs::path times_csv = dir / (base + ".timestamps.csv");
  if (fs::is_regular_file(times_csv, ignored)) {
    CsvReader reader(times_csv, CsvReader::Separator::kComma, {"timestamp [ns]"});
    ReadRows(reader, options.truncate_at_fault, &warnings, [&](CsvReader& row) {
      if (frame_times_ns.size() == frame_count) {
        row.Fail("more timestamps than the video has frames (" + std::to_string(frame_count) + ")");
      }
      const int64_t t_ns = row.Int64(0);
      row.CheckIncreasing(t_ns);
      frame_times_ns.push_back(t_ns);
    });
    if (frame_times_ns.size() < frame_count) {
      const std::string what = "has " + std::to_string(frame_times_ns.size()) +
                               " timestamps but the video has " + std::to_string(frame_count) +
                               " frames";
      if (!options.truncate_at_fault) throw Error(times_csv.string(), 0, what);
      warnings.push_back(times_csv.string() + ": " + what + " (frames cut to match)");
    }
  } else if (frame_count > 0) {
    if (!(session.frame_rate_hz > 0.0)) {
      throw Error(
          path_name, 0,
          "the container states no frame rate: give the frame times in " + times_csv.string());
    }
    if (accel.empty() && !accel_csv.empty()) {
      throw Error(accel_csv.string(), 0,
                  "has no samples to start the frame times from: give the frame times in " +
                      times_csv.string());
    }
    const int64_t start_ns = accel.empty() ? 0 : accel.front().t_ns;
    for (size_t i = 0; i < frame_count; ++i) {
      frame_times_ns.push_back(start_ns +
                               std::llround(static_cast<double>(i) * 1e9 / session.frame_rate_hz));
    }
  }
  return std::make_unique<VideoSequence>(path_name, "video " + path_name, std::move(session),
                                         std::move(frame_times_ns), std::move(accel),
                                         std::move(warnings));
}

}  // namespace autocal
