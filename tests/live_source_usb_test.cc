// The whole live path without hardware: a camera (a real video file read through
// cv::VideoCapture) and a USB HID Sensor accelerometer (emulated with umockdev, see
// tests/usb/emulated_usb.h) opened as one source with OpenSource("camera:...", "usb:...")
// and recorded with Record(): samples decoded right and merged with the frames on one
// clock, the accelerometer unplugged and plugged back mid-recording, events.csv and
// session.json saying so. ctest runs this binary through umockdev-wrapper; without it the
// test skips.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/videoio.hpp>

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

TEST(LiveSourceUsb, CameraAndUsbAccelerometerRecordedTogether) {
  if (!test::RunningUnderUmockdevWrapper())
    GTEST_SKIP() << "needs umockdev-wrapper (ctest runs it so)";
  test::UsbTestbed bed;  // Before libusb_init, which the source's Start() calls.
  const int first = bed.Plug(test::HidSensorHub());
  test::TempDir dir;
  const std::string video = dir / "camera.avi";
  {
    cv::VideoWriter writer(video, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                           30.0, cv::Size(64, 48));
    ASSERT_TRUE(writer.isOpened());
    for (int i = 0; i < 10; ++i) writer.write(cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(20 * i)));
  }
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

}  // namespace
}  // namespace autocal
