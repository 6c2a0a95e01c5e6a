#include "devices/session_io.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <utility>

#include <opencv2/core.hpp>

#include "pipeline/error.h"
#include "pipeline/text_format.h"

namespace autocal {
namespace {

constexpr int kJsonWrite =
    cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_JSON;
constexpr int kJsonRead =
    cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_JSON;
// A rolling shutter's readout, at most (the slowest frame rate's period).
constexpr double kMaxReadoutMs = 1000.0;

// Field access that names the file and the field when something is wrong.
class JsonFields {
 public:
  JsonFields(const cv::FileNode& node, std::string source, std::string prefix)
      : node_(node), source_(std::move(source)), prefix_(std::move(prefix)) {}

  bool Has(const std::string& key) const { return !node_[key].isNone(); }

  cv::FileNode Get(const std::string& key) const {
    const cv::FileNode field = node_[key];
    if (field.isNone()) Fail(key, "is missing");
    return field;
  }

  int Int(const std::string& key) const {
    const cv::FileNode field = Get(key);
    if (!field.isInt()) Fail(key, "must be an integer");
    return static_cast<int>(field);
  }

  double Double(const std::string& key) const {
    const cv::FileNode field = Get(key);
    if (!field.isInt() && !field.isReal()) Fail(key, "must be a number");
    return static_cast<double>(field);
  }

  // Optional text fields default to empty.
  std::string String(const std::string& key) const {
    if (!Has(key)) return {};
    const cv::FileNode field = node_[key];
    if (!field.isString()) Fail(key, "must be a string");
    return static_cast<std::string>(field);
  }

  [[noreturn]] void Fail(const std::string& key, const std::string& what) const {
    throw Error(source_, 0, prefix_ + key + " " + what);
  }

 private:
  cv::FileNode node_;
  std::string source_;
  std::string prefix_;
};

CameraIntrinsics ReadIntrinsics(const JsonFields& fields) {
  CameraIntrinsics c;
  c.width = fields.Int("width");
  c.height = fields.Int("height");
  c.fx = fields.Double("fx");
  c.fy = fields.Double("fy");
  c.cx = fields.Double("cx");
  c.cy = fields.Double("cy");
  c.k1 = fields.Double("k1");
  c.k2 = fields.Double("k2");
  c.p1 = fields.Double("p1");
  c.p2 = fields.Double("p2");
  c.k3 = fields.Double("k3");
  return c;
}

}  // namespace

void WriteJsonText(cv::FileStorage& fs, const std::string& key, const std::string& text) {
  // cv::FileStorage writes such text without quotes, and cannot read it back.
  const bool quoted =
      !text.empty() && (text.front() == '"' || text.front() == '\'') && text.back() == text.front();
  if (quoted) {
    throw Error("\"" + key + "\" cannot be stored: it starts and ends with a quote character");
  }
  // FileStorage's limit on one string (CV_FS_MAX_LEN).
  constexpr size_t kMaxLength = 4096;
  if (text.size() > kMaxLength) {
    throw Error("\"" + key + "\" cannot be stored: longer than " + std::to_string(kMaxLength) +
                " bytes");
  }
  cv::write(fs, key, text);
}

void WriteJsonIntrinsics(cv::FileStorage& fs, const std::string& key, const CameraIntrinsics& c) {
  fs << key << "{";
  cv::write(fs, "width", c.width);
  cv::write(fs, "height", c.height);
  const std::pair<const char*, double> values[] = {{"fx", c.fx}, {"fy", c.fy}, {"cx", c.cx},
                                                   {"cy", c.cy}, {"k1", c.k1}, {"k2", c.k2},
                                                   {"p1", c.p1}, {"p2", c.p2}, {"k3", c.k3}};
  for (const auto& [name, value] : values) cv::write(fs, name, value);
  fs << "}";
}

std::string SessionToJson(const SessionInfo& session) {
  // FileStorage would write non-finite numbers in a form that is not JSON.
  if (!std::isfinite(session.frame_rate_hz) || !std::isfinite(session.accel_rate_hz) ||
      !session.cam_from_accel.allFinite()) {
    throw Error("session: frame_rate_hz, accel_rate_hz and cam_from_accel must be finite");
  }
  if (!(session.readout_ms >= 0 && session.readout_ms <= kMaxReadoutMs)) {
    throw Error("session: readout_ms must be in [0, " + std::to_string(int(kMaxReadoutMs)) + "]");
  }
  if (const auto& c = session.premission_calibration) {
    std::string why;
    if (!c->Check(&why)) throw Error("session: premission_calibration: " + why);
  }
  cv::FileStorage fs(".json", kJsonWrite);
  cv::write(fs, "format_version", session.format_version);
  WriteJsonText(fs, "camera_device", session.camera_device);
  WriteJsonText(fs, "accelerometer_device", session.accelerometer_device);
  cv::write(fs, "width", session.width);
  cv::write(fs, "height", session.height);
  cv::write(fs, "frame_rate_hz", session.frame_rate_hz);
  cv::write(fs, "accel_rate_hz", session.accel_rate_hz);
  cv::write(fs, "readout_ms", session.readout_ms);
  if (const auto& c = session.premission_calibration) {
    WriteJsonIntrinsics(fs, "premission_calibration", *c);
  }
  fs << "cam_from_accel"
     << "[";
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) cv::write(fs, cv::String(), session.cam_from_accel(row, col));
  }
  fs << "]";
  WriteJsonText(fs, "notes", session.notes);
  return fs.releaseAndGetString();
}

SessionInfo SessionFromJson(const std::string& json, const std::string& source) {
  cv::FileStorage fs;
  try {
    fs.open(json, kJsonRead);
  } catch (const cv::Exception& e) {
    throw Error(source, 0, "is not valid JSON (" + e.err + ")");
  }
  if (!fs.isOpened() || !fs.root().isMap()) throw Error(source, 0, "expected a JSON object");
  const JsonFields fields(fs.root(), source, "");

  SessionInfo session;
  session.format_version = fields.Int("format_version");
  if (session.format_version != SessionInfo::kFormatVersion) {
    throw Error(source, 0,
                "format_version " + std::to_string(session.format_version) +
                    " is not supported: this build reads format_version " +
                    std::to_string(SessionInfo::kFormatVersion));
  }
  session.camera_device = fields.String("camera_device");
  session.accelerometer_device = fields.String("accelerometer_device");
  session.width = fields.Int("width");
  session.height = fields.Int("height");
  if (session.width <= 0 || session.height <= 0) {
    fields.Fail("width and height", "must be positive");
  }
  session.frame_rate_hz = fields.Has("frame_rate_hz") ? fields.Double("frame_rate_hz") : 0.0;
  session.accel_rate_hz = fields.Has("accel_rate_hz") ? fields.Double("accel_rate_hz") : 0.0;
  session.readout_ms = fields.Has("readout_ms") ? fields.Double("readout_ms") : 0.0;
  if (!(session.readout_ms >= 0 && session.readout_ms <= kMaxReadoutMs)) {
    fields.Fail("readout_ms", "must be in [0, " + std::to_string(int(kMaxReadoutMs)) +
                                  "] ms (0: a global shutter)");
  }
  if (fields.Has("premission_calibration")) {
    const cv::FileNode node = fields.Get("premission_calibration");
    if (!node.isMap()) fields.Fail("premission_calibration", "must be an object");
    const CameraIntrinsics calibration =
        ReadIntrinsics(JsonFields(node, source, "premission_calibration."));
    std::string why;
    if (!calibration.Check(&why)) throw Error(source, 0, "premission_calibration: " + why);
    session.premission_calibration = calibration;
  }

  if (fields.Has("cam_from_accel")) {
    const cv::FileNode node = fields.Get("cam_from_accel");
    if (!node.isSeq() || node.size() != 9) {
      fields.Fail("cam_from_accel", "must be an array of 9 numbers (3x3, row-major)");
    }
    for (int i = 0; i < 9; ++i) {
      const cv::FileNode value = node[i];
      if (!value.isInt() && !value.isReal()) {
        fields.Fail("cam_from_accel", "must be an array of 9 numbers (3x3, row-major)");
      }
      session.cam_from_accel(i / 3, i % 3) = static_cast<double>(value);
    }
    const Eigen::Matrix3d& r = session.cam_from_accel;
    if (!(r.transpose() * r).isIdentity(1e-6) || std::abs(r.determinant() - 1.0) > 1e-6) {
      fields.Fail("cam_from_accel", "is not a rotation matrix (orthonormal, determinant +1)");
    }
  }
  session.notes = fields.String("notes");
  return session;
}

SessionInfo ReadSessionFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw Error(
        path, 0,
        std::filesystem::exists(path) ? "cannot be opened for reading" : "file does not exist");
  }
  std::ostringstream text;
  text << in.rdbuf();
  return SessionFromJson(text.str(), path);
}

void WriteSessionFile(const std::string& path, const SessionInfo& session) {
  WriteTextFile(path, SessionToJson(session));
}

}  // namespace autocal
