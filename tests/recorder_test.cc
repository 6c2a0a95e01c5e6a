// The recorder (devices/recorder.h) on a recorded source (every frame kept, pixel for
// pixel) and on a live one: a camera that is a real video file, whose end is an unplug
// and whose reopening a re-plug, so that the recording goes on across the gap and
// events.csv says what happened.
#include "devices/recorder.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/videoio.hpp>

#include "pipeline/error.h"
#include "tests/test_util.h"

namespace fs = std::filesystem;

namespace autocal {
namespace {

constexpr char kSmallSim[] = "sim:office,seconds=2,resolution=160x120,accel_rate=200";

TEST(RecorderTest, RecordsTheRequestedSecondsOfARecordedSource) {
  test::TempDir dir;
  const std::unique_ptr<FrameSource> source = OpenSource(kSmallSim);
  RecorderOptions options;
  options.seconds = 0.5;
  int reports = 0;
  const RecorderProgress result =
      Record(*source, dir / "rec", options, [&](const RecorderProgress&) { ++reports; });
  EXPECT_GE(reports, 1);
  EXPECT_EQ(result.frames_written, 15u);  // [0, 0.5 s) at 30 Hz.
  EXPECT_EQ(result.frames_dropped, 0u);

  const std::unique_ptr<Sequence> recorded = OpenSequence(dir / "rec");
  const std::unique_ptr<Sequence> simulated = OpenSequence(kSmallSim);
  ASSERT_EQ(recorded->frame_count(), 15u);
  for (size_t i = 0; i < recorded->frame_count(); ++i) {
    EXPECT_EQ(recorded->frame_time_ns(i), simulated->frame_time_ns(i));
    EXPECT_EQ(cv::norm(recorded->LoadFrame(i), simulated->LoadFrame(i), cv::NORM_INF), 0.0);
  }
  // Every sample before the end time, the lead-in before the first frame included.
  const int64_t end_ns = simulated->frame_time_ns(0) + 500'000'000;
  size_t expected_samples = 0;
  for (const AccelSample& s : simulated->accel()) expected_samples += s.t_ns < end_ns;
  EXPECT_EQ(recorded->accel().size(), expected_samples);
  EXPECT_EQ(result.accel_written, expected_samples);
  EXPECT_EQ(recorded->accel().front().t_ns, simulated->accel().front().t_ns);
  EXPECT_EQ(recorded->session().width, 160);
  EXPECT_EQ(recorded->session().readout_ms, 0.0) << "the simulator's global shutter";
}

// A camera cannot tell its rolling shutter's readout: the recording states the one given.
TEST(RecorderTest, StatesTheReadoutGiven) {
  test::TempDir dir;
  const std::unique_ptr<FrameSource> source = OpenSource(kSmallSim);
  RecorderOptions options;
  options.seconds = 0.2;
  options.readout_ms = 27.5;
  Record(*source, dir / "rec", options);
  EXPECT_EQ(OpenSequence(dir / "rec")->session().readout_ms, 27.5);
  options.readout_ms = -1.0;
  EXPECT_THROW(Record(*OpenSource(kSmallSim), dir / "bad", options), Error);
  EXPECT_FALSE(fs::exists(dir / "bad"));
}

TEST(RecorderTest, StopFlagEndsTheRecording) {
  test::TempDir dir;
  const std::unique_ptr<FrameSource> source = OpenSource(kSmallSim);
  const std::atomic<bool> stop{true};
  const RecorderProgress result = Record(*source, dir / "rec", {}, {}, &stop);
  EXPECT_EQ(result.frames_written, 0u);
  EXPECT_TRUE(fs::is_regular_file(dir / "rec/session.json"));
}

TEST(RecorderTest, NothingIsCreatedWhenTheSourceCannotStart) {
  test::TempDir dir;
  const std::unique_ptr<FrameSource> source = OpenSource("camera:/dev/video987");
  EXPECT_THROW(Record(*source, dir / "rec", {}), Error);
  EXPECT_FALSE(fs::exists(dir / "rec"));

  test::WriteTextFile(dir / "full/something", "x");
  const std::unique_ptr<FrameSource> sim = OpenSource(kSmallSim);
  EXPECT_THROW(Record(*sim, dir / "full", {}), Error);
}

TEST(RecorderTest, LiveRecordingGoesOnAcrossAnUnplug) {
  test::TempDir dir;
  const std::string video = dir / "camera.avi";
  {
    cv::VideoWriter writer(video, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                           30.0, cv::Size(64, 48));
    ASSERT_TRUE(writer.isOpened());
    for (int i = 0; i < 10; ++i) writer.write(cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(20 * i)));
  }
  // Each pass of the file ends in an "unplug"; the camera is reopened every 500 ms.
  // The file gives its frames in a burst, not at 30 Hz: the queue holds a whole pass.
  SourceOptions source_options;
  source_options.frame_queue = 64;
  const std::unique_ptr<FrameSource> source = OpenSource("camera:" + video, "", source_options);
  ASSERT_TRUE(source->live());
  RecorderOptions options;
  options.seconds = 1.2;
  options.progress_interval_s = 0.1;
  const RecorderProgress result = Record(*source, dir / "rec", options);

  EXPECT_GE(result.elapsed_s, 1.2);
  EXPECT_GE(result.frames_written, 20u) << "at least two passes: the recording went on";
  EXPECT_EQ(result.source.frames_dropped + result.frames_dropped, 0u);
  ASSERT_GE(result.source.camera_gaps.size(), 1u);
  EXPECT_GE(result.source.camera_gaps.front().seconds(), 0.4);

  const std::unique_ptr<Sequence> recorded = OpenSequence(dir / "rec");
  ASSERT_EQ(recorded->frame_count(), result.frames_written);
  EXPECT_EQ(recorded->session().width, 64);
  EXPECT_EQ(recorded->session().height, 48);
  EXPECT_NE(recorded->session().camera_device.find("camera.avi"), std::string::npos);
  // The gap is in the frame times: the first frame of the second pass comes at least the
  // reconnect interval after the last of the first.
  EXPECT_GE(recorded->frame_time_ns(10) - recorded->frame_time_ns(9), 400'000'000);

  std::ifstream events(dir / "rec/events.csv");
  std::string line;
  std::vector<std::string> lines;
  while (std::getline(events, line)) lines.push_back(line);
  ASSERT_GE(lines.size(), 4u) << "header, connected, disconnected, connected";
  EXPECT_EQ(lines[0], "#timestamp [ns],device,event,message");
  EXPECT_NE(lines[1].find(",camera,connected,opened "), std::string::npos) << lines[1];
  EXPECT_NE(lines[2].find(",camera,disconnected,lost "), std::string::npos) << lines[2];
  EXPECT_NE(lines[3].find(",camera,connected,reopened "), std::string::npos) << lines[3];
  ASSERT_EQ(result.events.size(), lines.size() - 1);
}

}  // namespace
}  // namespace autocal
