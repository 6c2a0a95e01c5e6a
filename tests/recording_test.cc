// Native recordings: write -> read round trips, and every fault a reader must report.
#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "devices/recording_reader.h"
#include "devices/recording_writer.h"
#include "devices/sequence.h"
#include "devices/session_io.h"
#include "pipeline/error.h"
#include "tests/test_util.h"

namespace autocal {
namespace {

namespace fs = std::filesystem;

constexpr int64_t kT0 = 1'700'000'000'123'456'789;  // Beyond what a double holds exactly.
constexpr int64_t kFrameStep = 33'333'333;
constexpr int64_t kAccelStep = 1'250'000;  // 800 Hz.

SessionInfo MakeSession() {
  SessionInfo s;
  s.camera_device = "cam \"A\" [front] {left}";
  s.accelerometer_device = "adxl355 #7";
  s.width = 64;
  s.height = 48;
  s.frame_rate_hz = 30.000000000000004;
  s.accel_rate_hz = 800.0;
  s.readout_ms = 100.0 / 3.0 - 1e-14;
  CameraIntrinsics c;
  c.width = 64;
  c.height = 48;
  c.fx = 100.0 / 3.0;
  c.fy = 33.3333333333333357;
  c.cx = 31.5;
  c.cy = 23.499999999999996;
  c.k1 = -0.3 + 1e-17;
  c.k2 = 0.1;
  c.p1 = 1.2345678901234567e-4;
  c.p2 = -2e-5;
  c.k3 = -1.0 / 7.0;
  s.premission_calibration = c;
  s.cam_from_accel =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(1.0, -2.0, 0.5).normalized()).toRotationMatrix();
  s.notes = "walk 1\nline two, with 'quotes'";
  return s;
}

cv::Mat RandomImage(int type) {
  cv::Mat image(48, 64, type);
  cv::randu(image, 0, type == CV_16UC1 ? 65535 : 255);
  return image;
}

AccelSample Sample(int index) {
  AccelSample sample;
  sample.t_ns = kT0 - 5 * kAccelStep + index * kAccelStep;
  // Values whose shortest decimal form needs all 17 digits.
  sample.specific_force = {0.1 * index + 1.0 / 3.0, -9.81 + std::sqrt(2.0) * 1e-3 * index,
                           std::nextafter(0.2, 1.0) * index};
  return sample;
}

GroundTruthFrame Truth(int index) {
  GroundTruthFrame truth;
  truth.t_ns = kT0 + index * kFrameStep;
  truth.intrinsics = *MakeSession().premission_calibration;
  truth.intrinsics.fx += index / 7.0;
  truth.world_from_cam_translation = {index / 3.0, -0.1 * index, 1.6};
  truth.world_from_cam_rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * index + 0.01, Eigen::Vector3d::UnitY()));
  return truth;
}

struct Written {
  std::vector<cv::Mat> frames, labels;
  std::vector<AccelSample> accel;
  std::vector<GroundTruthFrame> truth;
};

// A recording as the simulator writes it: frames, accelerometer, ground truth.
Written WriteRecording(const std::string& dir, int frames, bool with_truth = true) {
  Written w;
  RecordingWriter writer(dir, MakeSession());
  for (int i = 0; i < 10 * frames; ++i) {
    w.accel.push_back(Sample(i));
    writer.AddAccel(w.accel.back());
  }
  if (with_truth) writer.AddGroundTruthFile("scene.yaml", "planes:\n  - {id: 1, name: floor}\n");
  for (int i = 0; i < frames; ++i) {
    w.frames.push_back(RandomImage(CV_8UC3));
    writer.AddFrame(kT0 + i * kFrameStep, w.frames.back());
    if (with_truth) {
      // Every other frame without plane labels: they are optional per frame.
      w.labels.push_back(i % 2 == 0 ? RandomImage(CV_16UC1) : cv::Mat());
      w.truth.push_back(Truth(i));
      writer.AddGroundTruth(w.truth.back(), w.labels.back());
    }
  }
  return w;
}

bool SameImage(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

void ExpectSameSession(const SessionInfo& expected, const SessionInfo& actual) {
  EXPECT_EQ(actual.format_version, expected.format_version);
  EXPECT_EQ(actual.camera_device, expected.camera_device);
  EXPECT_EQ(actual.accelerometer_device, expected.accelerometer_device);
  EXPECT_EQ(actual.width, expected.width);
  EXPECT_EQ(actual.height, expected.height);
  EXPECT_EQ(actual.frame_rate_hz, expected.frame_rate_hz);
  EXPECT_EQ(actual.accel_rate_hz, expected.accel_rate_hz);
  EXPECT_EQ(actual.readout_ms, expected.readout_ms);
  EXPECT_EQ(actual.premission_calibration, expected.premission_calibration);
  EXPECT_EQ(actual.cam_from_accel, expected.cam_from_accel);
  EXPECT_EQ(actual.notes, expected.notes);
}

void ExpectSameAsWritten(const Written& w, const Sequence& sequence) {
  ExpectSameSession(MakeSession(), sequence.session());
  ASSERT_EQ(sequence.frame_count(), w.frames.size());
  for (size_t i = 0; i < w.frames.size(); ++i) {
    EXPECT_EQ(sequence.frame_time_ns(i), kT0 + static_cast<int64_t>(i) * kFrameStep);
    EXPECT_TRUE(SameImage(sequence.LoadFrame(i), w.frames[i])) << "frame " << i;
  }
  ASSERT_EQ(sequence.accel().size(), w.accel.size());
  for (size_t i = 0; i < w.accel.size(); ++i) {
    EXPECT_EQ(sequence.accel()[i].t_ns, w.accel[i].t_ns);
    EXPECT_EQ(sequence.accel()[i].specific_force, w.accel[i].specific_force) << "sample " << i;
  }
  EXPECT_TRUE(sequence.warnings().empty());
  if (w.truth.empty()) {
    EXPECT_EQ(sequence.ground_truth(), nullptr);
    return;
  }
  ASSERT_NE(sequence.ground_truth(), nullptr);
  const std::vector<GroundTruthFrame>& truth = *sequence.ground_truth();
  ASSERT_EQ(truth.size(), w.truth.size());
  for (size_t i = 0; i < truth.size(); ++i) {
    EXPECT_EQ(truth[i].t_ns, w.truth[i].t_ns);
    EXPECT_EQ(truth[i].intrinsics, w.truth[i].intrinsics);
    EXPECT_EQ(truth[i].world_from_cam_translation, w.truth[i].world_from_cam_translation);
    EXPECT_EQ(truth[i].world_from_cam_rotation.coeffs(),
              w.truth[i].world_from_cam_rotation.coeffs());
    const std::optional<cv::Mat> labels = sequence.LoadPlaneLabels(i);
    if (w.labels[i].empty()) {
      EXPECT_FALSE(labels.has_value()) << "frame " << i;
    } else {
      ASSERT_TRUE(labels.has_value()) << "frame " << i;
      EXPECT_TRUE(SameImage(*labels, w.labels[i])) << "frame " << i;
    }
  }
  EXPECT_EQ(sequence.SceneDescription(), "planes:\n  - {id: 1, name: floor}\n");
}

// The message of the Error that `action` throws; a test failure if it throws none.
std::string ErrorOf(const std::function<void()>& action) {
  try {
    action();
  } catch (const Error& error) {
    return error.what();
  }
  ADD_FAILURE() << "no autocal::Error thrown";
  return {};
}

std::vector<std::string> Lines(const fs::path& path) {
  std::vector<std::string> lines;
  std::istringstream text(test::ReadTextFile(path));
  for (std::string line; std::getline(text, line);) lines.push_back(line);
  return lines;
}

void WriteLines(const fs::path& path, const std::vector<std::string>& lines) {
  std::string text;
  for (const auto& line : lines) text += line + "\n";
  test::WriteTextFile(path, text);
}

// Replaces line `number` (1-based) of a file.
void ReplaceLine(const fs::path& path, int number, const std::string& line) {
  std::vector<std::string> lines = Lines(path);
  lines.at(number - 1) = line;
  WriteLines(path, lines);
}

ReadOptions Truncating() {
  ReadOptions options;
  options.truncate_at_fault = true;
  return options;
}

TEST(RecordingTest, WriterThenReaderRoundTripsEverythingExactly) {
  test::TempDir tmp;
  const Written written = WriteRecording(tmp / "rec", 5);
  ExpectSameAsWritten(written, *OpenRecording(tmp / "rec"));
  EXPECT_EQ(OpenRecording(tmp / "rec")->Describe(), "native recording " + (tmp / "rec"));
}

TEST(RecordingTest, RecordingWithoutGroundTruthHasNone) {
  test::TempDir tmp;
  const Written written = WriteRecording(tmp / "rec", 3, /*with_truth=*/false);
  EXPECT_FALSE(fs::exists(tmp.path() / "rec" / "ground_truth"));
  const auto sequence = OpenRecording(tmp / "rec");
  ExpectSameAsWritten(written, *sequence);
  EXPECT_FALSE(sequence->SceneDescription().has_value());
  EXPECT_FALSE(sequence->LoadPlaneLabels(0).has_value());
}

TEST(RecordingTest, FilesHaveTheDocumentedLayout) {
  test::TempDir tmp;
  WriteRecording(tmp / "rec", 2);
  const fs::path rec = tmp.path() / "rec";
  EXPECT_EQ(
      Lines(rec / "cam0" / "data.csv"),
      (std::vector<std::string>{
          "#timestamp [ns],filename", std::to_string(kT0) + "," + std::to_string(kT0) + ".png",
          std::to_string(kT0 + kFrameStep) + "," + std::to_string(kT0 + kFrameStep) + ".png"}));
  EXPECT_EQ(Lines(rec / "accel0" / "data.csv").front(),
            "#timestamp [ns],a_x [m s^-2],a_y [m s^-2],a_z [m s^-2]");
  EXPECT_EQ(Lines(rec / "ground_truth" / "intrinsics.csv").front(),
            "#timestamp [ns],fx,fy,cx,cy,k1,k2,p1,p2,k3");
  EXPECT_EQ(Lines(rec / "ground_truth" / "poses.csv").front(),
            "#timestamp [ns],p_x,p_y,p_z,q_w,q_x,q_y,q_z");
  EXPECT_TRUE(fs::exists(rec / "ground_truth" / "planes" / (std::to_string(kT0) + ".png")));
  EXPECT_FALSE(
      fs::exists(rec / "ground_truth" / "planes" / (std::to_string(kT0 + kFrameStep) + ".png")));
  // No temporary files are left behind.
  for (const auto& entry : fs::recursive_directory_iterator(rec)) {
    EXPECT_EQ(entry.path().string().find(".tmp"), std::string::npos) << entry.path();
  }
  // session.json is JSON that FileStorage reads with the documented field names.
  cv::FileStorage json(test::ReadTextFile(rec / "session.json"), cv::FileStorage::READ |
                                                                     cv::FileStorage::MEMORY |
                                                                     cv::FileStorage::FORMAT_JSON);
  EXPECT_EQ(static_cast<int>(json["format_version"]), 1);
  EXPECT_EQ(static_cast<double>(json["premission_calibration"]["fx"]), 100.0 / 3.0);
  EXPECT_EQ(json["cam_from_accel"].size(), 9u);
}

TEST(RecordingTest, SessionJsonRoundTripsWithoutCalibration) {
  SessionInfo session = MakeSession();
  session.premission_calibration.reset();
  session.notes = "";
  const SessionInfo read = SessionFromJson(SessionToJson(session), "session.json");
  ExpectSameSession(session, read);
}

TEST(RecordingTest, WriterRefusesWhatReadersWouldReject) {
  test::TempDir tmp;
  test::WriteTextFile(tmp.path() / "full" / "x.txt", "x");
  EXPECT_CONTAINS(ErrorOf([&] { RecordingWriter(tmp / "full", MakeSession()); }), "not empty");

  RecordingWriter writer(tmp / "rec", MakeSession());
  writer.AddFrame(kT0, RandomImage(CV_8UC3));
  EXPECT_CONTAINS(ErrorOf([&] { writer.AddFrame(kT0, RandomImage(CV_8UC3)); }),
                  "is not after the previous one");
  EXPECT_CONTAINS(ErrorOf([&] { writer.AddFrame(kT0 + 1, RandomImage(CV_16UC1)); }), "8-bit");
  writer.AddAccel(Sample(3));
  EXPECT_CONTAINS(ErrorOf([&] { writer.AddAccel(Sample(2)); }), "accel0/data.csv");
  SessionInfo quoted = MakeSession();
  quoted.notes = "'quoted'";
  EXPECT_CONTAINS(ErrorOf([&] { SessionToJson(quoted); }), "notes");
}

TEST(RecordingTest, WriteSequenceCopiesEverythingInOrderWithProgress) {
  test::TempDir tmp;
  const Written written = WriteRecording(tmp / "a", 11);  // More than one parallel batch.
  std::vector<size_t> done;
  const auto source = OpenRecording(tmp / "a");
  EXPECT_TRUE(WriteSequence(*source, tmp / "b", [&](size_t n, size_t total) {
    EXPECT_EQ(total, 11u);
    done.push_back(n);
    return true;
  }));
  EXPECT_EQ(done, (std::vector<size_t>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11}));
  ExpectSameAsWritten(written, *OpenRecording(tmp / "b"));
  EXPECT_EQ(test::ReadTextFile(tmp.path() / "a" / "accel0" / "data.csv"),
            test::ReadTextFile(tmp.path() / "b" / "accel0" / "data.csv"));
}

TEST(RecordingTest, CancelledCopyIsAReadableShorterRecording) {
  test::TempDir tmp;
  WriteRecording(tmp / "a", 6);
  const auto source = OpenRecording(tmp / "a");
  EXPECT_FALSE(WriteSequence(*source, tmp / "b", [](size_t n, size_t) { return n < 3; }));
  const auto copy = OpenRecording(tmp / "b");
  EXPECT_EQ(copy->frame_count(), 3u);
  EXPECT_EQ(copy->ground_truth()->size(), 3u);
  EXPECT_TRUE(SameImage(copy->LoadFrame(2), source->LoadFrame(2)));
}

// --- Faults --------------------------------------------------------------------------------

class RecordingFaultTest : public ::testing::Test {
 protected:
  void SetUp() override { written_ = WriteRecording(dir(), 5); }
  std::string dir() const { return tmp_ / "rec"; }
  fs::path file(const std::string& name) const { return tmp_.path() / "rec" / name; }

  test::TempDir tmp_;
  Written written_;
};

TEST_F(RecordingFaultTest, MissingColumnNamesFileLineAndColumns) {
  ReplaceLine(file("accel0/data.csv"), 4, "1700000000100000000,1.0,2.0");
  const std::string message = ErrorOf([&] { OpenRecording(dir()); });
  EXPECT_CONTAINS(message, file("accel0/data.csv").string() + ":4: ");
  EXPECT_CONTAINS(message, ("expected 4 comma-separated fields: timestamp [ns], a_x, a_y, "
                            "a_z; got 3"));

  const auto sequence = OpenRecording(dir(), Truncating());
  ASSERT_EQ(sequence->accel().size(), 2u);  // Lines 2 and 3.
  EXPECT_EQ(sequence->accel()[1].specific_force, written_.accel[1].specific_force);
  EXPECT_EQ(sequence->frame_count(), 5u);  // Frames are not cut by an accelerometer fault.
  ASSERT_EQ(sequence->warnings().size(), 1u);
  EXPECT_CONTAINS(sequence->warnings()[0], "accel0/data.csv:4: expected 4");
}

TEST_F(RecordingFaultTest, NonNumericFieldNamesTheColumn) {
  ReplaceLine(file("accel0/data.csv"), 3, std::to_string(Sample(1).t_ns) + ",0.5,abc,1");
  const std::string message = ErrorOf([&] { OpenRecording(dir()); });
  EXPECT_CONTAINS(message, "accel0/data.csv:3: field 3 (a_y) is not a number: \"abc\"");
  EXPECT_EQ(OpenRecording(dir(), Truncating())->accel().size(), 1u);
}

TEST_F(RecordingFaultTest, NonFiniteValuesAreFaults) {
  for (const std::string value : {"nan", "inf", "-inf"}) {
    ReplaceLine(file("accel0/data.csv"), 5, std::to_string(Sample(3).t_ns) + ",0,0," + value);
    const std::string message = ErrorOf([&] { OpenRecording(dir()); });
    EXPECT_CONTAINS(message, "accel0/data.csv:5: field 4 (a_z) is not finite: \"" + value + "\"");
  }
  ReplaceLine(file("accel0/data.csv"), 5, std::to_string(Sample(3).t_ns) + ",0,0,1e999");
  EXPECT_CONTAINS(ErrorOf([&] { OpenRecording(dir()); }),
                  "accel0/data.csv:5: field 4 (a_z) is out of range: \"1e999\"");
}

TEST_F(RecordingFaultTest, NonIncreasingTimestampsNameBothLines) {
  const int64_t t2 = kT0 + 2 * kFrameStep;
  ReplaceLine(file("cam0/data.csv"), 5, std::to_string(t2) + "," + std::to_string(t2) + ".png");
  // Line 5 now repeats line 4's timestamp.
  const std::string message = ErrorOf([&] { OpenRecording(dir()); });
  EXPECT_CONTAINS(message, ("cam0/data.csv:5: timestamp " + std::to_string(t2) +
                            " is not after the previous one " + std::to_string(t2) + " on line 4"));
  // Truncated, the frames stop before the fault, and the ground truth with them.
  const auto sequence = OpenRecording(dir(), Truncating());
  EXPECT_EQ(sequence->frame_count(), 3u);
  EXPECT_EQ(sequence->ground_truth()->size(), 3u);
  EXPECT_EQ(sequence->accel().size(), written_.accel.size());
  ASSERT_FALSE(sequence->warnings().empty());
  EXPECT_CONTAINS(sequence->warnings()[0], "cam0/data.csv:5: timestamp");
}

TEST_F(RecordingFaultTest, MissingFrameFileNamesFileAndLine) {
  const std::string name = std::to_string(kT0 + 3 * kFrameStep) + ".png";
  fs::remove(file("cam0/data/" + name));
  const std::string message = ErrorOf([&] { OpenRecording(dir()); });
  EXPECT_CONTAINS(message, "cam0/data.csv:5: frame file ");
  EXPECT_CONTAINS(message, name + " does not exist");
  EXPECT_EQ(OpenRecording(dir(), Truncating())->frame_count(), 3u);
}

TEST_F(RecordingFaultTest, TruncatedLastLineIsReportedAsSuch) {
  // What a writer killed in the middle of a row leaves.
  std::string text = test::ReadTextFile(file("accel0/data.csv"));
  text += std::to_string(Sample(50).t_ns) + ",0.25";
  test::WriteTextFile(file("accel0/data.csv"), text);
  const int last_line = static_cast<int>(Lines(file("accel0/data.csv")).size());
  const std::string message = ErrorOf([&] { OpenRecording(dir()); });
  EXPECT_CONTAINS(message,
                  ("accel0/data.csv:" + std::to_string(last_line) + ": last line is truncated"));
  EXPECT_CONTAINS(message, "expected 4 comma-separated fields");

  const auto sequence = OpenRecording(dir(), Truncating());
  EXPECT_EQ(sequence->accel().size(), written_.accel.size());
  ASSERT_EQ(sequence->warnings().size(), 1u);
  EXPECT_CONTAINS(sequence->warnings()[0], "truncated");
}

TEST_F(RecordingFaultTest, FaultOnAnUnterminatedLastLineIsReportedAsTruncation) {
  std::string text = test::ReadTextFile(file("accel0/data.csv"));
  text += std::to_string(Sample(50).t_ns) + ",0.25,1.5,-";  // Cut inside the last number.
  test::WriteTextFile(file("accel0/data.csv"), text);
  EXPECT_CONTAINS(ErrorOf([&] { OpenRecording(dir()); }),
                  "last line is truncated (no newline at the end of the file): field 4 (a_z) is "
                  "not a number: \"-\"");
}

TEST_F(RecordingFaultTest, CompleteLastLineWithoutNewlineIsFine) {
  std::string text = test::ReadTextFile(file("accel0/data.csv"));
  text.pop_back();
  test::WriteTextFile(file("accel0/data.csv"), text);
  EXPECT_EQ(OpenRecording(dir())->accel().size(), written_.accel.size());
}

TEST_F(RecordingFaultTest, UndecodablePngIsNamedWhenLoaded) {
  const fs::path png = file("cam0/data/" + std::to_string(kT0 + kFrameStep) + ".png");
  const std::string bytes = test::ReadTextFile(png);
  test::WriteTextFile(png, bytes.substr(0, bytes.size() / 3));  // Cut off mid-file.
  const auto sequence = OpenRecording(dir());                   // Frames are decoded lazily.
  EXPECT_TRUE(SameImage(sequence->LoadFrame(0), written_.frames[0]));
  const std::string message = ErrorOf([&] { sequence->LoadFrame(1); });
  EXPECT_CONTAINS(message, png.string());
  EXPECT_CONTAINS(message, "cannot be decoded");
}

TEST_F(RecordingFaultTest, MissingSessionOrFoldersSayWhatARecordingHas) {
  fs::remove(file("session.json"));
  std::string message = ErrorOf([&] { OpenRecording(dir()); });
  EXPECT_CONTAINS(message, "session.json: file does not exist");
  EXPECT_CONTAINS(message, "cam0/data.csv");

  WriteSessionFile(file("session.json").string(), MakeSession());
  fs::remove_all(file("cam0"));
  message = ErrorOf([&] { OpenRecording(dir()); });
  EXPECT_CONTAINS(message, "cam0: folder does not exist");

  message = ErrorOf([&] { OpenRecording(tmp_ / "nowhere"); });
  EXPECT_CONTAINS(message, "nowhere: folder does not exist");
}

TEST_F(RecordingFaultTest, WrongFormatVersionIsRefused) {
  std::string json = test::ReadTextFile(file("session.json"));
  const std::string field = "\"format_version\": 1";
  ASSERT_NE(json.find(field), std::string::npos);
  json.replace(json.find(field), field.size(), "\"format_version\": 2");
  test::WriteTextFile(file("session.json"), json);
  const std::string message = ErrorOf([&] { OpenRecording(dir()); });
  EXPECT_CONTAINS(message, "session.json: format_version 2 is not supported");
  // Not a fault inside a table: truncating does not make it readable.
  EXPECT_CONTAINS(ErrorOf([&] { OpenRecording(dir(), Truncating()); }), "format_version");
}

TEST_F(RecordingFaultTest, BadSessionFieldsAreNamed) {
  SessionInfo session = MakeSession();
  session.cam_from_accel(0, 0) += 0.01;
  test::WriteTextFile(file("session.json"), SessionToJson(session));
  EXPECT_CONTAINS(ErrorOf([&] { OpenRecording(dir()); }),
                  "session.json: cam_from_accel is not a rotation");

  test::WriteTextFile(file("session.json"), "{ \"format_version\": 1, \"width\": \"wide\" }");
  EXPECT_CONTAINS(ErrorOf([&] { OpenRecording(dir()); }), "session.json: width must be an integer");

  session = MakeSession();
  session.readout_ms = -1.0;
  EXPECT_CONTAINS(ErrorOf([&] { SessionToJson(session); }), "readout_ms");
  session.readout_ms = 1.5;
  std::string json = SessionToJson(session);
  const std::string positive = "\"readout_ms\": 1.5";
  const size_t readout = json.find(positive);
  ASSERT_NE(readout, std::string::npos) << json;
  json.replace(readout, positive.size(), "\"readout_ms\": -1.5");
  test::WriteTextFile(file("session.json"), json);
  EXPECT_CONTAINS(ErrorOf([&] { OpenRecording(dir()); }), "session.json: readout_ms must be in");

  test::WriteTextFile(file("session.json"), "{ \"format_version\": 1, ");
  EXPECT_CONTAINS(ErrorOf([&] { OpenRecording(dir()); }), "session.json: is not valid JSON");
}

TEST_F(RecordingFaultTest, GroundTruthMustMatchTheFrames) {
  // A recording cut off after a frame and before its ground truth.
  std::vector<std::string> poses = Lines(file("ground_truth/poses.csv"));
  poses.pop_back();
  WriteLines(file("ground_truth/poses.csv"), poses);
  const std::string message = ErrorOf([&] { OpenRecording(dir()); });
  EXPECT_CONTAINS(message, "poses.csv: ends after 4 rows but cam0/data.csv has 5 frames");
  const auto sequence = OpenRecording(dir(), Truncating());
  EXPECT_EQ(sequence->frame_count(), 4u);
  EXPECT_EQ(sequence->ground_truth()->size(), 4u);
  EXPECT_EQ(sequence->warnings().size(), 1u);

  ReplaceLine(file("ground_truth/intrinsics.csv"), 3,
              "123,1,1,1,1,0,0,0,0,0");  // Not frame 2's time.
  EXPECT_CONTAINS(ErrorOf([&] { OpenRecording(dir()); }),
                  "intrinsics.csv:3: timestamp 123 is not that of frame 2");
}

}  // namespace
}  // namespace autocal
