// The streaming source interface (devices/source.h): what a recorded sequence streams is
// exactly what Sequence::LoadFrame gives, in time order; image folders; --accel and
// camera: specs; the no-camera message; the time-order merger of live streams; V4L2
// enumeration on a folder that holds no V4L2 device.
#include "devices/source.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "devices/recording_writer.h"
#include "devices/sim/simulator.h"
#include "devices/video_devices.h"
#include "pipeline/error.h"
#include "tests/test_util.h"

namespace fs = std::filesystem;

namespace autocal {
namespace {

constexpr char kSmallSim[] = "sim:office,seconds=1,resolution=160x120,accel_rate=200";

struct Streamed {
  std::vector<SourceItem> frames;
  std::vector<AccelSample> accel;
  std::vector<int64_t> times;  // Every item's, in delivery order.
};

Streamed StreamAll(FrameSource& source) {
  Streamed out;
  source.Start();
  SourceItem item;
  while (true) {
    const FrameSource::Status status = source.Next(&item, std::chrono::seconds(30));
    if (status == FrameSource::Status::kEnd) break;
    EXPECT_EQ(status, FrameSource::Status::kItem) << "a recorded source never times out here";
    if (status != FrameSource::Status::kItem) break;
    out.times.push_back(item.t_ns);
    if (item.kind == SourceItem::Kind::kFrame) out.frames.push_back(item);
    if (item.kind == SourceItem::Kind::kAccel) out.accel.push_back(item.accel);
  }
  return out;
}

// The stream holds every frame of `sequence`, pixel for pixel, at its time, and every
// accelerometer sample, all in time order with samples before a frame at the same time.
void ExpectSameAsSequence(const Streamed& streamed, const Sequence& sequence) {
  ASSERT_EQ(streamed.frames.size(), sequence.frame_count());
  for (size_t i = 0; i < streamed.frames.size(); ++i) {
    const SourceItem& frame = streamed.frames[i];
    ASSERT_EQ(frame.frame_number, i);
    EXPECT_EQ(frame.t_ns, sequence.frame_time_ns(i));
    const cv::Mat expected = sequence.LoadFrame(i);
    ASSERT_EQ(frame.image.size(), expected.size());
    ASSERT_EQ(frame.image.type(), expected.type());
    EXPECT_EQ(cv::norm(frame.image, expected, cv::NORM_INF), 0.0) << "frame " << i;
  }
  ASSERT_EQ(streamed.accel.size(), sequence.accel().size());
  for (size_t i = 0; i < streamed.accel.size(); ++i) {
    EXPECT_EQ(streamed.accel[i].t_ns, sequence.accel()[i].t_ns);
    EXPECT_EQ(streamed.accel[i].specific_force, sequence.accel()[i].specific_force);
  }
  EXPECT_TRUE(std::is_sorted(streamed.times.begin(), streamed.times.end()));
}

TEST(SourcesTest, SimulatorStreamsWhatLoadFrameRenders) {
  const std::unique_ptr<FrameSource> source = OpenSource(kSmallSim);
  EXPECT_FALSE(source->live());
  ASSERT_NE(source->sequence(), nullptr);
  const Streamed streamed = StreamAll(*source);
  EXPECT_EQ(streamed.frames.size(), 30u);
  EXPECT_GT(streamed.accel.size(), 200u);  // 1 s of frames plus the margins, at 200 Hz.
  const std::unique_ptr<Sequence> reference = OpenSequence(kSmallSim);
  ExpectSameAsSequence(streamed, *reference);
  EXPECT_EQ(source->stats().frames, 30u);
  EXPECT_EQ(source->stats().accel_samples, reference->accel().size());
  EXPECT_EQ(source->stats().frames_dropped, 0u);
}

TEST(SourcesTest, NativeRecordingStreamsWhatLoadFrameReads) {
  test::TempDir dir;
  ASSERT_TRUE(WriteSequence(*OpenSequence(kSmallSim), dir / "rec"));
  const std::unique_ptr<FrameSource> source = OpenSource(dir / "rec");
  const Streamed streamed = StreamAll(*source);
  const std::unique_ptr<Sequence> reference = OpenSequence(dir / "rec");
  ExpectSameAsSequence(streamed, *reference);
  EXPECT_EQ(streamed.frames.size(), 30u);
  // Samples up to the first frame's time come before it.
  size_t before_first_frame = 0;
  for (const AccelSample& s : reference->accel())
    before_first_frame += s.t_ns <= reference->frame_time_ns(0);
  EXPECT_GT(before_first_frame, 0u);
  EXPECT_EQ(streamed.times[before_first_frame], reference->frame_time_ns(0));
}

TEST(SourcesTest, VideoWithCsvStreamsWhatLoadFrameDecodes) {
  test::TempDir dir;
  {
    cv::VideoWriter writer(dir / "walk.avi", cv::CAP_OPENCV_MJPEG,
                           cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30.0, cv::Size(64, 48));
    ASSERT_TRUE(writer.isOpened());
    for (int i = 0; i < 20; ++i) {
      cv::Mat frame(48, 64, CV_8UC3, cv::Scalar::all(10 * i));
      cv::circle(frame, {3 * i, 24}, 5, cv::Scalar(255, 0, 0), -1);
      writer.write(frame);
    }
  }
  std::string csv = "#timestamp [ns],a_x [m s^-2],a_y [m s^-2],a_z [m s^-2]\n";
  for (int k = 0; k < 200; ++k) csv += std::to_string(k * 5'000'000) + ",0,0,9.81\n";
  test::WriteTextFile(dir / "walk.csv", csv);

  const Streamed streamed = StreamAll(*OpenSource(dir / "walk.avi"));
  const std::unique_ptr<Sequence> reference = OpenSequence(dir / "walk.avi");
  ExpectSameAsSequence(streamed, *reference);
  EXPECT_EQ(streamed.frames.size(), 20u);
}

// 10 frames at 25 per second, frame i all grey 20 i, and no accelerometer CSV beside.
void WriteGreyVideo(const fs::path& path) {
  cv::VideoWriter writer(path, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                         25.0, cv::Size(64, 48));
  ASSERT_TRUE(writer.isOpened());
  for (int i = 0; i < 10; ++i) writer.write(cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(20 * i)));
}

// A video without its accelerometer CSV, read with --accel none: its frames alone, timed
// from 0 at the container's rate.
TEST(SourcesTest, VideoAloneWithAccelNone) {
  test::TempDir dir;
  WriteGreyVideo(dir / "walk.avi");
  EXPECT_THROW(OpenSource(dir / "walk.avi"), Error);  // Its own accelerometer is missing.
  const Streamed streamed = StreamAll(*OpenSource(dir / "walk.avi", "none"));
  ASSERT_EQ(streamed.frames.size(), 10u);
  EXPECT_TRUE(streamed.accel.empty());
  for (size_t i = 0; i < streamed.frames.size(); ++i) {
    EXPECT_EQ(streamed.frames[i].t_ns, static_cast<int64_t>(i) * 40'000'000);
    EXPECT_NEAR(cv::mean(streamed.frames[i].image)[0], 20.0 * double(i), 2.0);
  }
}

// A video with an accelerometer logged apart (`--accel FILE.csv`): the given CSV is read
// as the video's own, beside it or not, and the frames are timed from its first sample.
TEST(SourcesTest, VideoWithAnAccelerometerCsvGivenApart) {
  test::TempDir dir;
  WriteGreyVideo(dir / "walk.avi");
  const int64_t first_ns = 1'700'000'000'000'000'000;
  std::string logged = "#timestamp [ns],a_x [m s^-2],a_y [m s^-2],a_z [m s^-2]\n";
  for (int k = 0; k < 100; ++k) logged += std::to_string(first_ns + k * 5'000'000) + ",0,1,9.8\n";
  fs::create_directories(dir / "imu");
  test::WriteTextFile(dir / "imu/log.csv", logged);
  const auto expect_logged = [&](const Streamed& streamed) {
    ASSERT_EQ(streamed.frames.size(), 10u);
    for (size_t i = 0; i < streamed.frames.size(); ++i) {
      EXPECT_EQ(streamed.frames[i].t_ns, first_ns + static_cast<int64_t>(i) * 40'000'000);
    }
    ASSERT_FALSE(streamed.accel.empty());
    EXPECT_EQ(streamed.accel.front().t_ns, first_ns);
    for (const AccelSample& sample : streamed.accel) EXPECT_EQ(sample.specific_force.y(), 1.0);
  };
  expect_logged(StreamAll(*OpenSource(dir / "walk.avi", dir / "imu/log.csv")));
  // A CSV beside the video, on another clock, is not the one read.
  test::WriteTextFile(dir / "walk.csv",
                      "#timestamp [ns],a_x,a_y,a_z\n0,0,0,9.8\n5000000,0,0,9.8\n");
  expect_logged(StreamAll(*OpenSource(dir / "walk.avi", dir / "imu/log.csv")));
}

TEST(SourcesTest, StopEndsARecordedStream) {
  const std::unique_ptr<FrameSource> source = OpenSource(kSmallSim);
  source->Start();
  SourceItem item;
  ASSERT_EQ(source->Next(&item, std::chrono::seconds(30)), FrameSource::Status::kItem);
  source->Stop();
  EXPECT_EQ(source->Next(&item, std::chrono::seconds(1)), FrameSource::Status::kEnd);
}

TEST(SourcesTest, ImageFolderTimedByNamesOrByRate) {
  test::TempDir dir;
  // Names that are times, which sort differently as text ("1000" < "900").
  fs::create_directories(dir / "timed");
  for (const int t : {900, 1000, 1100}) {
    const cv::Mat image(12, 16, CV_8UC3, cv::Scalar(t % 256, 0, 0));
    ASSERT_TRUE(cv::imwrite(dir / ("timed/" + std::to_string(t) + ".png"), image));
  }
  const std::unique_ptr<FrameSource> timed = OpenSource(dir / "timed");
  const Streamed streamed = StreamAll(*timed);
  ASSERT_EQ(streamed.frames.size(), 3u);
  EXPECT_EQ(streamed.frames[0].t_ns, 900);
  EXPECT_EQ(streamed.frames[1].t_ns, 1000);
  EXPECT_EQ(streamed.frames[2].t_ns, 1100);
  EXPECT_EQ(streamed.frames[0].image.at<cv::Vec3b>(0, 0)[0], 900 % 256);
  EXPECT_EQ(timed->session().width, 16);
  EXPECT_EQ(timed->session().height, 12);

  fs::create_directories(dir / "named");
  for (const char* name : {"b.jpg", "a.png", "c.bmp"}) {
    ASSERT_TRUE(cv::imwrite(dir / (std::string("named/") + name),
                            cv::Mat(12, 16, CV_8UC3, cv::Scalar::all(128))));
  }
  test::WriteTextFile(dir / "named/notes.txt", "not an image");
  // With an accelerometer CSV given beside.
  test::WriteTextFile(dir / "accel.csv",
                      "#timestamp [ns],a_x [m s^-2],a_y [m s^-2],a_z [m s^-2]\n"
                      "0,0,0,9.81\n"
                      "40000000,0,0,9.8\n");
  const std::unique_ptr<FrameSource> named = OpenSource(dir / "named", dir / "accel.csv");
  const Streamed by_rate = StreamAll(*named);
  ASSERT_EQ(by_rate.frames.size(), 3u);
  EXPECT_EQ(by_rate.frames[1].t_ns, 33333333);  // 30 Hz assumed.
  ASSERT_EQ(by_rate.accel.size(), 2u);
  EXPECT_EQ(by_rate.accel[1].specific_force.z(), 9.8);
  EXPECT_EQ(by_rate.times, (std::vector<int64_t>{0, 0, 33333333, 40000000, 66666667}));
}

TEST(SourcesTest, AccelNoneDropsTheInputsSamples) {
  const Streamed streamed = StreamAll(*OpenSource(kSmallSim, "none"));
  EXPECT_EQ(streamed.frames.size(), 30u);
  EXPECT_TRUE(streamed.accel.empty());
}

TEST(SourcesTest, ParsesAccelSpecs) {
  EXPECT_EQ(ParseAccelSpec("").kind, AccelSpec::Kind::kInput);
  EXPECT_EQ(ParseAccelSpec("none").kind, AccelSpec::Kind::kNone);
  EXPECT_EQ(ParseAccelSpec("usb").kind, AccelSpec::Kind::kUsb);
  const AccelSpec ids = ParseAccelSpec("usb:1a2B:00ff");
  EXPECT_EQ(ids.kind, AccelSpec::Kind::kUsb);
  EXPECT_EQ(ids.vendor_id, 0x1a2b);
  EXPECT_EQ(ids.product_id, 0x00ff);
  EXPECT_EQ(ParseAccelSpec("usb:mapping=/x/y.yaml").mapping_file, "/x/y.yaml");
  for (const char* bad : {"usb:12345:1", "usb:zz:1", "usb:1234", "usb:mapping=", "/no/such.csv"}) {
    EXPECT_THROW(ParseAccelSpec(bad), Error) << bad;
  }
}

TEST(SourcesTest, ParsesCameraSpecs) {
  EXPECT_FALSE(ParseCameraSpec("sim:office"));
  EXPECT_EQ(ParseCameraSpec("camera:2")->device, "/dev/video2");
  const CameraSpec full = *ParseCameraSpec("camera:/dev/video4,size=1280x720,fps=60,format=MJPG");
  EXPECT_EQ(full.device, "/dev/video4");
  EXPECT_EQ(full.width, 1280);
  EXPECT_EQ(full.height, 720);
  EXPECT_EQ(full.fps, 60.0);
  EXPECT_EQ(full.fourcc, "MJPG");
  for (const char* bad : {"camera:", "camera:front", "camera:0,size=1280", "camera:0,fps=-1",
                          "camera:0,format=MJPEG", "camera:0,zoom=2"}) {
    EXPECT_THROW(ParseCameraSpec(bad), Error) << bad;
  }
}

TEST(SourcesTest, MissingCameraSaysWhatWasFound) {
  const std::unique_ptr<FrameSource> source = OpenSource("camera:/dev/video987");
  EXPECT_TRUE(source->live());
  try {
    source->Start();
    FAIL() << "started a camera that does not exist";
  } catch (const Error& e) {
    const std::string expected =
        "no camera at /dev/video987; found: " + SummarizeVideoDevices(ListVideoDevices());
    EXPECT_EQ(std::string(e.what()), expected);
  }
}

TEST(SourcesTest, RefusesClocksThatDoNotMix) {
  test::TempDir dir;
  test::WriteTextFile(dir / "accel.csv",
                      "#timestamp [ns],a_x [m s^-2],a_y [m s^-2],a_z [m s^-2]\n");
  try {
    OpenSource(kSmallSim, "usb");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("needs a live camera input"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(OpenSource("camera:0", dir / "accel.csv"), Error);
  EXPECT_THROW(OpenSource(dir / "nothing-here"), Error);
}

// --live: a recording played as a live source keeps to its own timestamps in real time
// (twice as fast here), keeps its times and ground truth, and drops what a consumer that
// stalls leaves beyond the queue, counted.
TEST(SourcesTest, RealTimePlaybackPacesAndDropsForASlowConsumer) {
  SourceOptions options;
  options.real_time = true;
  options.real_time_speed = 2.0;
  options.frame_queue = 3;
  const std::unique_ptr<FrameSource> source =
      OpenSource("sim:static,seconds=1,resolution=64x48,fps=30", "", options);
  ASSERT_TRUE(source->live());
  ASSERT_NE(source->sequence(), nullptr);
  const Sequence& recorded = *source->sequence();
  ASSERT_NE(recorded.ground_truth(), nullptr);
  source->Start();
  std::vector<int64_t> frames;
  std::vector<std::chrono::steady_clock::time_point> taken;
  SourceItem item;
  while (source->Next(&item, std::chrono::seconds(5)) == FrameSource::Status::kItem) {
    if (item.kind != SourceItem::Kind::kFrame) continue;
    EXPECT_EQ(item.t_ns, recorded.frame_time_ns(item.frame_number)) << "the recording's times";
    frames.push_back(item.t_ns);
    taken.push_back(std::chrono::steady_clock::now());
    // Stalls for half of the playback after the first frame, then takes everything.
    if (frames.size() == 1) std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
  const SourceStats stats = source->stats();
  EXPECT_GT(stats.frames_dropped, 0u) << "the stall overflowed the queue of 3";
  EXPECT_EQ(frames.size() + stats.frames_dropped, recorded.frame_count());
  EXPECT_EQ(stats.frames, frames.size());
  EXPECT_TRUE(std::is_sorted(frames.begin(), frames.end()));
  // Paced: the last frame comes no earlier than its time at twice real time (~0.5 s).
  const double last_s = 1e-9 * double(frames.back() - frames.front()) / 2.0;
  EXPECT_GE(std::chrono::duration<double>(taken.back() - taken.front()).count(), last_s - 0.02);
  EXPECT_GT(stats.camera_rate_hz, 35.0) << "30 frames/s played twice as fast";
  EXPECT_LT(stats.camera_rate_hz, 70.0);
}

TEST(DroppingItemQueueTest, DropsTheOldestOfAKindAndNeverAnEvent) {
  DroppingItemQueue queue(2, 1);
  for (int i = 0; i < 4; ++i) {
    SourceItem item;
    item.kind = i == 1 ? SourceItem::Kind::kEvent : SourceItem::Kind::kFrame;
    item.t_ns = i;
    queue.Push(item);
  }
  SourceItem sample;
  sample.kind = SourceItem::Kind::kAccel;
  sample.t_ns = 10;
  queue.Push(sample);
  sample.t_ns = 11;
  queue.Push(sample);
  queue.Close();
  EXPECT_EQ(queue.frames_dropped(), 1u);
  EXPECT_EQ(queue.accel_dropped(), 1u);
  std::vector<int64_t> left;
  SourceItem item;
  while (queue.Pop(&item, std::chrono::milliseconds(0)) == FrameSource::Status::kItem) {
    left.push_back(item.t_ns);
  }
  EXPECT_EQ(left, (std::vector<int64_t>{1, 2, 3, 11}));  // Frame 0 and sample 10 dropped.
}

TEST(TimeOrderMergerTest, HoldsAFrameUntilTheAccelerometerPassesIt) {
  TimeOrderMerger merger(/*window_ns=*/100, true, true);
  merger.AddFrame(1000, 0, cv::Mat());
  EXPECT_FALSE(merger.Pop(1050)) << "samples up to the frame's time may still come";
  merger.AddAccel({990, {}});
  merger.AddAccel({1000, {}});
  std::optional<SourceItem> item = merger.Pop(1050);
  ASSERT_TRUE(item);
  EXPECT_EQ(item->kind, SourceItem::Kind::kAccel);
  EXPECT_EQ(item->t_ns, 990);
  item = merger.Pop(1050);
  ASSERT_TRUE(item);
  EXPECT_EQ(item->t_ns, 1000);
  EXPECT_EQ(item->kind, SourceItem::Kind::kAccel) << "a sample at the frame's time goes first";
  item = merger.Pop(1050);
  ASSERT_TRUE(item);
  EXPECT_EQ(item->kind, SourceItem::Kind::kFrame);
  EXPECT_FALSE(merger.Pop(1050));
  EXPECT_EQ(merger.out_of_order(), 0u);
}

TEST(TimeOrderMergerTest, ReleasesAfterTheWindowAndCountsLateItems) {
  TimeOrderMerger merger(/*window_ns=*/100, true, true);
  merger.AddFrame(1000, 0, cv::Mat());
  EXPECT_FALSE(merger.Pop(1099));
  ASSERT_TRUE(merger.Pop(1100)) << "the accelerometer is silent: the frame waited long enough";
  merger.AddAccel({950, {}});  // Arrived after the frame left.
  merger.AddFrame(1033, 1, cv::Mat());
  std::optional<SourceItem> late = merger.Pop(1100);
  ASSERT_TRUE(late);
  EXPECT_EQ(late->t_ns, 950);
  EXPECT_EQ(merger.out_of_order(), 1u);
  EXPECT_FALSE(merger.Pop(1100)) << "a sample up to 1033 may still come";
  const std::vector<SourceItem> rest = merger.Flush();
  ASSERT_EQ(rest.size(), 1u);
  EXPECT_EQ(rest[0].t_ns, 1033);
}

TEST(TimeOrderMergerTest, FramesAloneLeaveAtOnce) {
  TimeOrderMerger merger(/*window_ns=*/1'000'000'000, true, false);
  merger.AddFrame(5, 0, cv::Mat());
  ASSERT_TRUE(merger.Pop(5));
}

TEST(VideoDevicesTest, ListsNodesInNumericOrderAndSaysWhatTheyAre) {
  test::TempDir dir;
  for (const char* name : {"video10", "video2", "video0", "videox", "vide0", "video"}) {
    test::WriteTextFile(dir / name, "");
  }
  const std::vector<VideoDeviceInfo> devices = ListVideoDevices(dir.path().string());
  ASSERT_EQ(devices.size(), 3u);
  EXPECT_EQ(devices[0].path, dir / "video0");
  EXPECT_EQ(devices[1].path, dir / "video2");
  EXPECT_EQ(devices[2].path, dir / "video10");
  EXPECT_EQ(devices[0].error, "not a V4L2 device");
  EXPECT_FALSE(devices[0].can_capture);
  EXPECT_EQ(SummarizeVideoDevices({}), "none");
  EXPECT_EQ(SummarizeVideoDevices({devices[0]}), dir / "video0" + " (not a V4L2 device)");
  EXPECT_TRUE(ListVideoDevices(dir / "missing").empty());
}

}  // namespace
}  // namespace autocal
