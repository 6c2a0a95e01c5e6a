// The whole live path without hardware: a camera (a real video file read through
// cv::VideoCapture) and a USB HID Sensor accelerometer (emulated with umockdev, see
// tests/usb/emulated_usb.h) opened as one source with OpenSource("camera:...", "usb:...")
// and recorded with Record(): samples decoded right and merged with the frames on one
// clock, the accelerometer unplugged and plugged back mid-recording, events.csv and
// session.json saying so; and `autocal run`'s live path (RunSource) on the same devices.
// ctest runs this binary through umockdev-wrapper; without it the tests skip.
#include <atomic>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/videoio.hpp>

#include "devices/offline_runner.h"
#include "devices/recorder.h"
#include "devices/session_io.h"
#include "devices/source.h"
#include "devices/usb/usb_accelerometer.h"
#include "tests/test_util.h"
#include "tests/usb/emulated_usb.h"

namespace autocal {
namespace {

using namespace std::chrono_literals;
std::vector<std::string> ReadLines(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// The "camera": a 30 frames/s MJPEG video of `frames` (its end is an unplug).
bool WriteVideo(const std::string& path, const std::vector<cv::Mat>& frames) {
  cv::VideoWriter writer(path, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                         30.0, frames.front().size());
  if (!writer.isOpened()) return false;
  for (const cv::Mat& frame : frames) writer.write(frame);
  return true;
}

TEST(LiveSourceUsb, CameraAndUsbAccelerometerRecordedTogether) {
  if (!test::RunningUnderUmockdevWrapper())
    GTEST_SKIP() << "needs umockdev-wrapper (ctest runs it so)";
  test::UsbTestbed bed;  // Before libusb_init, which the source's Start() calls.
  const int first = bed.Plug(test::HidSensorHub());
  test::TempDir dir;
  const std::string video = dir / "camera.avi";
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 10; ++i) frames.emplace_back(48, 64, CV_8UC3, cv::Scalar::all(20 * i));
  ASSERT_TRUE(WriteVideo(video, frames));
  SourceOptions options;
  options.frame_queue = 64;  // The file gives its frames in a burst.
  const std::unique_ptr<FrameSource> source =
      OpenSource("camera:" + video, "usb:1234:5678", options);
  ASSERT_TRUE(source->live());
  source->Start();

  // Reports 0..39, the accelerometer pulled out and put back, reports 100..119.
  std::atomic<bool> fed{false};
  std::string feeder_error;
  std::thread feeder([&] {
    for (int i = 0; i < 40; ++i) {
      if (!bed.SendReport(first, test::HidSensorAccelReport(i, -i, 100)))
        feeder_error = "report " + std::to_string(i);
      std::this_thread::sleep_for(3ms);
    }
    bed.Unplug(first);
    std::this_thread::sleep_for(100ms);
    const int second = bed.Plug(test::HidSensorHub());
    for (int i = 100; i < 120; ++i) {
      if (!bed.SendReport(second, test::HidSensorAccelReport(i, -i, 100)))
        feeder_error = "report " + std::to_string(i);
      std::this_thread::sleep_for(3ms);
    }
    fed = true;
  });
  RecorderOptions recorder;
  recorder.seconds = 60;
  std::atomic<bool> stop{false};
  std::thread stopper([&] {
    // Record until every report is in, and longer than the merger holds an item (100 ms)
    // with room for a busy machine.
    while (!fed) std::this_thread::sleep_for(10ms);
    std::this_thread::sleep_for(1s);
    stop = true;
  });
  const RecorderProgress result = Record(*source, dir / "rec", recorder, {}, &stop);
  feeder.join();
  stopper.join();
  ASSERT_EQ(feeder_error, "");

  EXPECT_EQ(result.accel_written, 60u);
  EXPECT_GE(result.frames_written, 10u);
  EXPECT_EQ(result.source.accel_disconnections, 1);
  EXPECT_EQ(result.source.out_of_order, 0u);
  EXPECT_EQ(result.items_refused, 0u);

  const std::unique_ptr<Sequence> recorded = OpenSequence(dir / "rec");
  const std::vector<AccelSample>& accel = recorded->accel();
  ASSERT_EQ(accel.size(), 60u);
  const double g = 0.01 * 9.80665;  // One count, m/s^2.
  for (size_t k = 0; k < accel.size(); ++k) {
    const int i = k < 40 ? static_cast<int>(k) : static_cast<int>(k) + 60;
    EXPECT_NEAR(accel[k].specific_force.x(), i * g, 1e-9) << "sample " << k;
    EXPECT_NEAR(accel[k].specific_force.y(), -i * g, 1e-9) << "sample " << k;
    EXPECT_NEAR(accel[k].specific_force.z(), 100 * g, 1e-9) << "sample " << k;
  }
  // One clock: the accelerometer's samples fall among the camera's frames.
  ASSERT_GT(recorded->frame_count(), 0u);
  EXPECT_LT(recorded->frame_time_ns(0), accel.back().t_ns);
  EXPECT_GT(recorded->frame_time_ns(recorded->frame_count() - 1), accel.front().t_ns);

  const SessionInfo session = ReadSessionFile(dir / "rec/session.json");
  EXPECT_NE(session.accelerometer_device.find("1234:5678 Acme Sensor Hub"), std::string::npos)
      << session.accelerometer_device;
  EXPECT_GT(session.accel_rate_hz, 0.0) << "the measured rate, written at the end";
  EXPECT_EQ(session.width, 64);

  const std::vector<std::string> events = ReadLines(dir / "rec/events.csv");
  std::ostringstream all;
  for (const std::string& line : events) all << line << "\n";
  int accel_connected = 0, accel_lost = 0;
  for (const std::string& line : events) {
    accel_connected += line.find(",accelerometer,connected,") != std::string::npos;
    accel_lost += line.find(",accelerometer,disconnected,") != std::string::npos;
  }
  EXPECT_EQ(accel_connected, 2) << all.str();
  EXPECT_EQ(accel_lost, 1) << all.str();
  EXPECT_NE(all.str().find(",camera,connected,opened "), std::string::npos) << all.str();
}

// `autocal run --input camera:... --accel usb:1234:5678`: the run goes on across an
// accelerometer unplugged and plugged back and across the camera's own "unplugs" (the
// video file's end; it reopens), counts and reports both, and ends on --seconds.
TEST(LiveSourceUsb, LiveRunGoesOnAcrossUnplugs) {
  if (!test::RunningUnderUmockdevWrapper())
    GTEST_SKIP() << "needs umockdev-wrapper (ctest runs it so)";
  test::UsbTestbed bed;  // Before libusb_init, which the source's Start() calls.
  const int first = bed.Plug(test::HidSensorHub());
  test::TempDir dir;
  const std::string video = dir / "camera.avi";
  std::vector<cv::Mat> frames(10);
  for (cv::Mat& frame : frames) {
    frame.create(120, 160, CV_8UC3);
    cv::randu(frame, cv::Scalar::all(0), cv::Scalar::all(255));
  }
  ASSERT_TRUE(WriteVideo(video, frames));
  const std::unique_ptr<FrameSource> source = OpenSource("camera:" + video, "usb:1234:5678");
  RunSettings settings;
  CameraIntrinsics prior;
  prior.width = 160;
  prior.height = 120;
  prior.fx = prior.fy = 120.0;
  prior.cx = 79.5;
  prior.cy = 59.5;
  settings.prior = prior;
  settings.history_path = dir / "history.sqlite";

  std::atomic<bool> started{false};
  std::string feeder_error;
  std::thread feeder([&] {
    while (!started) std::this_thread::sleep_for(1ms);
    for (int i = 0; i < 40; ++i) {
      if (!bed.SendReport(first, test::HidSensorAccelReport(0, 0, 100)))
        feeder_error = "report " + std::to_string(i);
      std::this_thread::sleep_for(5ms);
    }
    bed.Unplug(first);
    std::this_thread::sleep_for(200ms);
    const int second = bed.Plug(test::HidSensorHub());
    for (int i = 0; i < 40; ++i) {
      if (!bed.SendReport(second, test::HidSensorAccelReport(0, 0, 100)))
        feeder_error = "report " + std::to_string(i);
      std::this_thread::sleep_for(5ms);
    }
  });
  LiveRunControl control;
  control.seconds = 3.0;
  control.progress_interval_s = 0.1;
  std::vector<std::string> events;
  control.on_event = [&](const SourceEvent& event) { events.push_back(FormatSourceEvent(event)); };
  control.progress = [&](const RunProgress&) { started = true; };
  const RunReport report = RunSource(*source, settings, control);
  started = true;
  feeder.join();
  ASSERT_EQ(feeder_error, "");

  ASSERT_TRUE(report.live);
  const LiveRunReport& live = *report.live;
  EXPECT_EQ(live.ended_by, "--seconds");
  EXPECT_EQ(live.accel_disconnections, 1);
  EXPECT_GE(live.camera_disconnections, 1) << "the file's end is an unplug";
  EXPECT_FALSE(live.camera_gaps.empty());
  EXPECT_GT(live.frames_received, 10u) << "the camera reopened after its unplug";
  EXPECT_GT(report.frames, 0u);
  // Every frame received was processed or dropped by the pipeline.
  EXPECT_EQ(report.frames + live.pipeline_dropped, live.frames_received);
  EXPECT_EQ(live.events.size(), events.size()) << "every event printed and reported";
  int accel_connected = 0, accel_lost = 0;
  for (const std::string& event : events) {
    accel_connected += event.starts_with("accelerometer connected: ");
    accel_lost += event.starts_with("accelerometer disconnected: ");
  }
  EXPECT_EQ(accel_connected, 2);
  EXPECT_EQ(accel_lost, 1);
  const std::string json = SummaryJson(report);
  EXPECT_NE(json.find("\"disconnections\": {\"camera\": "), std::string::npos) << json;
  EXPECT_NE(json.find("\"accelerometer\": 1}"), std::string::npos) << json;
  EXPECT_NE(json.find("accelerometer disconnected: "), std::string::npos) << json;
  EXPECT_TRUE(std::filesystem::exists(settings.history_path));
}

}  // namespace
}  // namespace autocal
