// The report behind `autocal info`, on recordings whose numbers are worked out by hand.
#include "devices/inspect.h"

#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "devices/recording_reader.h"
#include "devices/recording_writer.h"
#include "tests/test_util.h"

namespace autocal {
namespace {

constexpr int64_t kT0 = 1'000'000'000'000;
constexpr int64_t kMs = 1'000'000;

struct Layout {
  std::vector<int64_t> frame_times;
  std::vector<int64_t> accel_times;
  cv::Size frame_size{64, 48};
};

// Frames every 100 ms from kT0 with the one at 500 ms missing (10 frames over 1 s, a
// 200 ms gap at 400 ms); accelerometer every 5 ms from 50 ms to 850 ms (161 samples).
Layout HandWorked() {
  Layout layout;
  for (int k = 0; k <= 10; ++k) {
    if (k != 5) layout.frame_times.push_back(kT0 + 100 * kMs * k);
  }
  for (int j = 0; j <= 160; ++j) layout.accel_times.push_back(kT0 + 50 * kMs + 5 * kMs * j);
  return layout;
}

std::unique_ptr<Sequence> Record(const test::TempDir& tmp, const Layout& layout) {
  SessionInfo session;
  session.width = 64;
  session.height = 48;
  session.premission_calibration = CameraIntrinsics::FromFieldOfView(64, 48, 70.0);
  {
    RecordingWriter writer(tmp / "rec", session);
    for (const int64_t t : layout.frame_times) {
      writer.AddFrame(t, cv::Mat(layout.frame_size, CV_8UC3, cv::Scalar::all(128)));
    }
    for (const int64_t t : layout.accel_times) writer.AddAccel({t, Eigen::Vector3d(0, 0, 9.81)});
  }
  return OpenRecording(tmp / "rec");
}

bool HasFinding(const SequenceReport& report, Severity severity, const std::string& part) {
  for (const Finding& finding : report.findings) {
    if (finding.severity == severity && finding.message.find(part) != std::string::npos) {
      return true;
    }
  }
  return false;
}

std::string Findings(const SequenceReport& report) {
  std::string text;
  for (const Finding& f : report.findings)
    text += SeverityName(f.severity) + (": " + f.message) + "\n";
  return text;
}

TEST(InspectTest, MedianRateOfIntervals) {
  EXPECT_EQ(MedianRateHz({}), 0.0);
  EXPECT_EQ(MedianRateHz({7}), 0.0);
  EXPECT_DOUBLE_EQ(MedianRateHz({0, 10, 20, 40}), 1e8);     // Intervals 10, 10, 20.
  EXPECT_DOUBLE_EQ(MedianRateHz({0, 10, 30}), 1e9 / 15.0);  // Intervals 10, 20.
}

TEST(InspectTest, HandWorkedRecording) {
  test::TempDir tmp;
  const auto sequence = Record(tmp, HandWorked());
  const SequenceReport report = InspectSequence(*sequence);

  EXPECT_EQ(report.width, 64);
  EXPECT_EQ(report.height, 48);
  EXPECT_EQ(report.frames.count, 10u);
  EXPECT_DOUBLE_EQ(report.frames.duration_s, 1.0);
  EXPECT_DOUBLE_EQ(report.frames.median_rate_hz, 10.0);  // Eight 100 ms, one 200 ms interval.
  ASSERT_EQ(report.frames.gaps.size(), 1u);              // 200 ms > 1.5 x 100 ms.
  EXPECT_EQ(report.frames.gaps[0].start_ns, kT0 + 400 * kMs);
  EXPECT_EQ(report.frames.gaps[0].end_ns, kT0 + 600 * kMs);

  EXPECT_EQ(report.accel.count, 161u);
  EXPECT_DOUBLE_EQ(report.accel.duration_s, 0.8);
  EXPECT_DOUBLE_EQ(report.accel.median_rate_hz, 200.0);
  EXPECT_TRUE(report.accel.gaps.empty());

  // The accelerometer covers 50..850 ms of the frames' 0..1000 ms.
  EXPECT_TRUE(report.has_overlap);
  EXPECT_EQ(report.overlap_start_ns, kT0 + 50 * kMs);
  EXPECT_EQ(report.overlap_end_ns, kT0 + 850 * kMs);
  EXPECT_DOUBLE_EQ(report.overlap_fraction, 0.8);

  EXPECT_FALSE(report.has_ground_truth);
  EXPECT_TRUE(report.premission_calibration.has_value());
  EXPECT_FALSE(HasErrors(report)) << Findings(report);
  EXPECT_TRUE(HasFinding(report, Severity::kWarning, "1 frame gap(s)")) << Findings(report);
  EXPECT_TRUE(HasFinding(report, Severity::kWarning, "0.200 s at 0.400 s")) << Findings(report);
  EXPECT_TRUE(HasFinding(report, Severity::kWarning, "covers only 80.0% of the frame span"))
      << Findings(report);

  const std::string text = FormatReport(report);
  EXPECT_CONTAINS(text, "native recording");
  EXPECT_CONTAINS(text, "10 frames over 1.000 s, median rate 10.00 Hz");
  EXPECT_CONTAINS(text, "frame gaps       1: 0.200 s at 0.400 s");
  EXPECT_CONTAINS(text, "161 samples over 0.800 s, median rate 200.0 Hz");
  EXPECT_CONTAINS(text, "0.050 to 0.850 s, 80.0% of the frame span");

  cv::FileStorage json(ReportToJson(report), cv::FileStorage::READ | cv::FileStorage::MEMORY |
                                                 cv::FileStorage::FORMAT_JSON);
  EXPECT_EQ(static_cast<int>(json["frames"]["count"]), 10);
  EXPECT_DOUBLE_EQ(static_cast<double>(json["frames"]["median_rate_hz"]), 10.0);
  ASSERT_EQ(json["frames"]["gaps"].size(), 1u);
  EXPECT_NEAR(static_cast<double>(json["frames"]["gaps"][0]["start_s"]), 0.4, 1e-12);
  EXPECT_NEAR(static_cast<double>(json["frames"]["gaps"][0]["length_s"]), 0.2, 1e-12);
  EXPECT_DOUBLE_EQ(static_cast<double>(json["overlap"]["fraction"]), 0.8);
  EXPECT_EQ(static_cast<int>(json["errors"]), 0);
  EXPECT_EQ(static_cast<std::string>(json["findings"][0]["severity"]), "warning");
}

TEST(InspectTest, SlowAccelerometerIsAnError) {
  test::TempDir tmp;
  Layout layout = HandWorked();
  layout.accel_times.clear();
  for (int j = 0; j <= 50; ++j) layout.accel_times.push_back(kT0 + 20 * kMs * j);  // 50 Hz.
  const SequenceReport report = InspectSequence(*Record(tmp, layout));
  EXPECT_DOUBLE_EQ(report.accel.median_rate_hz, 50.0);
  EXPECT_TRUE(HasErrors(report));
  EXPECT_TRUE(HasFinding(report, Severity::kError, "accelerometer rate 50.0 Hz is below 100.0 Hz"))
      << Findings(report);
  EXPECT_EQ(report.findings.front().severity, Severity::kError);  // Worst first.
}

TEST(InspectTest, NoOverlapIsAnError) {
  test::TempDir tmp;
  Layout layout = HandWorked();
  for (int64_t& t : layout.accel_times) t += 2'000 * kMs;  // 2.05 .. 2.85 s.
  const SequenceReport report = InspectSequence(*Record(tmp, layout));
  EXPECT_FALSE(report.has_overlap);
  EXPECT_EQ(report.overlap_fraction, 0.0);
  EXPECT_TRUE(HasFinding(report, Severity::kError,
                         "do not overlap in time: frames 0.000 to 1.000 s, accelerometer 2.050 to "
                         "2.850 s"))
      << Findings(report);
  EXPECT_CONTAINS(FormatReport(report), "overlap          none");
  cv::FileStorage json(ReportToJson(report), cv::FileStorage::READ | cv::FileStorage::MEMORY |
                                                 cv::FileStorage::FORMAT_JSON);
  EXPECT_EQ(static_cast<int>(json["errors"]), 1);
}

TEST(InspectTest, LongGapsAreErrors) {
  test::TempDir tmp;
  Layout layout = HandWorked();
  // Frames 100 ms apart but none from 300 to 900 ms; accelerometer silent 400 to 700 ms.
  layout.frame_times = {kT0,
                        kT0 + 100 * kMs,
                        kT0 + 200 * kMs,
                        kT0 + 300 * kMs,
                        kT0 + 900 * kMs,
                        kT0 + 1000 * kMs,
                        kT0 + 1100 * kMs};
  std::erase_if(layout.accel_times,
                [](int64_t t) { return t > kT0 + 400 * kMs && t < kT0 + 700 * kMs; });
  const SequenceReport report = InspectSequence(*Record(tmp, layout));
  ASSERT_EQ(report.frames.gaps.size(), 1u);
  EXPECT_DOUBLE_EQ(report.frames.gaps[0].seconds(), 0.6);
  EXPECT_TRUE(HasFinding(report, Severity::kError, "0.600 s at 0.300 s, is longer than 0.500 s"))
      << Findings(report);
  ASSERT_EQ(report.accel.gaps.size(), 1u);
  EXPECT_EQ(report.accel.gaps[0].start_ns, kT0 + 400 * kMs);
  EXPECT_EQ(report.accel.gaps[0].end_ns, kT0 + 700 * kMs);
  EXPECT_TRUE(HasFinding(report, Severity::kWarning, "1 accelerometer gap(s)")) << Findings(report);
}

TEST(InspectTest, FramesOfAnotherSizeThanTheSessionAreAnError) {
  test::TempDir tmp;
  Layout layout = HandWorked();
  layout.frame_size = cv::Size(32, 24);
  const SequenceReport report = InspectSequence(*Record(tmp, layout));
  EXPECT_TRUE(HasFinding(report, Severity::kError, "frame 1 is 32x24 but the session says 64x48"))
      << Findings(report);
}

TEST(InspectTest, ReaderWarningsAndUnreadableFramesAreFindings) {
  test::TempDir tmp;
  Record(tmp, HandWorked());
  const std::filesystem::path csv = tmp.path() / "rec" / "accel0" / "data.csv";
  test::WriteTextFile(csv, test::ReadTextFile(csv) + "1000900000000,1,2");
  const std::filesystem::path last_frame =
      tmp.path() / "rec" / "cam0" / "data" / (std::to_string(kT0 + 1000 * kMs) + ".png");
  test::WriteTextFile(last_frame, "not a png");

  ReadOptions options;
  options.truncate_at_fault = true;
  const SequenceReport report = InspectSequence(*OpenRecording(tmp / "rec", options));
  ASSERT_EQ(report.warnings.size(), 1u);
  EXPECT_TRUE(HasFinding(report, Severity::kWarning, "read only up to a fault: "))
      << Findings(report);
  EXPECT_TRUE(HasFinding(report, Severity::kError, "frame 10 cannot be read: "))
      << Findings(report);
}

TEST(InspectTest, OptionsAreChecked) {
  EXPECT_TRUE(InspectOptions().Check(nullptr));
  InspectOptions options;
  options.gap_factor = 0.5;
  std::string why;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_CONTAINS(why, "gap_factor");
}

}  // namespace
}  // namespace autocal
