// The live camera's capture loop (devices/live_camera.h), driven through the real
// cv::VideoCapture on a real video file: the file's end is the camera going away, and
// moving the file out of the way and back is unplugging it and plugging it back. No
// camera is needed; the V4L2-only parts (driver timestamps, enumeration of a real node)
// are not exercised here.
#include "devices/live_camera.h"

#include <chrono>
#include <filesystem>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/videoio.hpp>

#include "devices/usb/usb_accelerometer.h"
#include "pipeline/error.h"
#include "tests/test_util.h"

namespace fs = std::filesystem;
using namespace std::chrono_literals;

namespace autocal {
namespace {

constexpr int kFileFrames = 12;

// An MJPEG AVI (OpenCV's own writer and reader, always built in) whose frame i is grey
// level 20 * i, so that a decoded frame tells which one it is.
void WriteVideo(const std::string& path) {
  cv::VideoWriter writer(path, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                         30.0, cv::Size(64, 48));
  ASSERT_TRUE(writer.isOpened());
  for (int i = 0; i < kFileFrames; ++i)
    writer.write(cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(20 * i)));
}

int FrameIndex(const cv::Mat& image) {
  return static_cast<int>(std::lround(cv::mean(image)[0] / 20.0));
}

// Polls `condition` until it holds or 10 s pass.
template <typename Condition>
bool WaitUntil(Condition condition) {
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(5ms);
  }
  return true;
}

TEST(LiveCameraTest, UnplugAndReplugKeepTheSessionAndRecordTheGap) {
  test::TempDir dir;
  const std::string path = dir / "camera.avi";
  WriteVideo(path);
  LiveCameraOptions options;
  options.device = path;
  options.queue_capacity = 10000;
  options.reconnect_interval = 100ms;
  LiveCamera camera(options);
  const int64_t before_start = MonotonicNowNs();
  camera.Start();
  fs::rename(path, dir / "away.avi");  // Unplugged: reopening fails from now on.

  ASSERT_TRUE(WaitUntil([&] {
    const LiveCameraStats s = camera.stats();
    return s.disconnections >= 1 && !s.connected && s.reconnect_attempts >= 3;
  }));
  const LiveCameraStats unplugged = camera.stats();
  EXPECT_EQ(unplugged.width, 64);
  EXPECT_EQ(unplugged.height, 48);
  std::this_thread::sleep_for(300ms);
  EXPECT_EQ(camera.stats().frames, unplugged.frames) << "no frames while unplugged";
  EXPECT_GT(camera.stats().reconnect_attempts, unplugged.reconnect_attempts) << "still trying";

  fs::rename(dir / "away.avi", path);  // Plugged back.
  ASSERT_TRUE(WaitUntil([&] {
    const LiveCameraStats s = camera.stats();
    return s.frames >= unplugged.frames + kFileFrames;
  })) << "frames "
      << camera.stats().frames << " (" << unplugged.frames << " before), gaps "
      << camera.stats().gaps.size() << ", disconnections " << camera.stats().disconnections
      << ", attempts " << camera.stats().reconnect_attempts;
  camera.Stop();
  const LiveCameraStats stats = camera.stats();

  const std::vector<CameraFrame> frames = camera.Drain();
  ASSERT_EQ(frames.size(), stats.frames);
  EXPECT_GE(frames.front().t_ns, before_start);
  EXPECT_LE(frames.back().t_ns, MonotonicNowNs());
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].number, i);
    if (i > 0) {
      EXPECT_GT(frames[i].t_ns, frames[i - 1].t_ns) << "frame " << i;
    }
    // Each connection plays the file from its start.
    EXPECT_EQ(FrameIndex(frames[i].image), static_cast<int>(i % kFileFrames)) << "frame " << i;
  }

  // The long gap is the unplug: from the last frame before it to the first after it.
  ASSERT_FALSE(stats.gaps.empty());
  const TimeGap& gap = stats.gaps[unplugged.disconnections - 1];
  EXPECT_GE(gap.seconds(), 0.3);
  const size_t last_before = unplugged.frames - 1;
  EXPECT_EQ(gap.start_ns, frames[last_before].t_ns);
  EXPECT_EQ(gap.end_ns, frames[last_before + 1].t_ns);

  // Events alternate, starting with the first opening.
  const std::vector<CameraEvent> events = camera.TakeEvents();
  ASSERT_GE(events.size(), 3u);
  for (size_t i = 0; i < events.size(); ++i) {
    EXPECT_EQ(events[i].kind,
              i % 2 == 0 ? CameraEvent::Kind::kConnected : CameraEvent::Kind::kDisconnected)
        << "event " << i << ": " << events[i].message;
    if (i > 0) {
      EXPECT_GE(events[i].t_ns, events[i - 1].t_ns);
    }
  }
  EXPECT_EQ(stats.connections, stats.disconnections + (events.size() % 2 == 1 ? 1 : 0));
}

TEST(LiveCameraTest, SlowConsumerLosesTheOldestFramesNotTheCamera) {
  test::TempDir dir;
  const std::string path = dir / "camera.avi";
  WriteVideo(path);
  LiveCameraOptions options;
  options.device = path;
  options.queue_capacity = 4;
  options.reconnect_interval = 1000ms;  // One pass of the file, then a pause.
  LiveCamera camera(options);
  camera.Start();
  ASSERT_TRUE(WaitUntil([&] { return camera.stats().frames >= kFileFrames; }));
  const std::vector<CameraFrame> frames = camera.Drain();
  ASSERT_EQ(frames.size(), 4u);
  EXPECT_EQ(camera.stats().queue_dropped, camera.stats().frames - 4);
  // The newest frames are the ones kept.
  EXPECT_EQ(frames.back().number, camera.stats().frames - 1);
  EXPECT_EQ(FrameIndex(frames.back().image), kFileFrames - 1);
}

TEST(LiveCameraTest, StartSaysWhatIsWrong) {
  LiveCameraOptions missing;
  missing.device = "/dev/video987";
  try {
    LiveCamera(missing).Start();
    FAIL();
  } catch (const Error& e) {
    EXPECT_TRUE(std::string(e.what()).starts_with("no camera at /dev/video987; found: "))
        << e.what();
  }

  test::TempDir dir;
  WriteVideo(dir / "camera.avi");
  LiveCameraOptions wrong_size;
  wrong_size.device = dir / "camera.avi";
  wrong_size.width = 32;
  wrong_size.height = 24;
  try {
    LiveCamera(wrong_size).Start();
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("gives 64x48, not the 32x24 asked for"), std::string::npos)
        << e.what();
  }

  LiveCameraOptions bad;
  bad.width = 640;  // Without a height.
  std::string why;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("height"), std::string::npos);
  EXPECT_THROW(LiveCamera(bad).Start(), Error);
  EXPECT_TRUE(LiveCameraOptions().Check(&why)) << why;
}

}  // namespace
}  // namespace autocal
