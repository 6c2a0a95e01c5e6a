// EuRoC, TUM RGB-D and video+CSV folders written in their real layouts, and OpenSequence
// telling the formats apart.
#include "devices/dataset_readers.h"

#include <cmath>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "devices/recording_writer.h"
#include "devices/sequence.h"
#include "devices/session_io.h"
#include "pipeline/error.h"
#include "tests/test_util.h"

namespace autocal {
namespace {

namespace fs = std::filesystem;

std::string ErrorOf(const std::function<void()>& action) {
  try {
    action();
  } catch (const Error& error) {
    return error.what();
  }
  ADD_FAILURE() << "no autocal::Error thrown";
  return {};
}

ReadOptions Truncating() {
  ReadOptions options;
  options.truncate_at_fault = true;
  return options;
}

// An image whose pixels all have the value `level`, so that lossy codecs keep it.
cv::Mat Uniform(int level, int type = CV_8UC3) {
  return cv::Mat(48, 64, type, cv::Scalar::all(level));
}

double MeanLevel(const cv::Mat& image) { return cv::mean(image)[0]; }

// --- EuRoC ---------------------------------------------------------------------------------

constexpr int64_t kEurocT0 = 1403636579763555584;  // A real MH_01 timestamp.

// cam0/sensor.yaml as EuRoC ships it: no "%YAML" line, comments, flow sequences.
constexpr char kEurocCamYaml[] = R"(# General sensor definitions.
sensor_type: camera
comment: VI-Sensor cam0 (MT9M034)

# Sensor extrinsics wrt. the body-frame.
T_BS:
  cols: 4
  rows: 4
  data: [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,
         0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,
        -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,
         0.0, 0.0, 0.0, 1.0]

# Camera specific definitions.
rate_hz: 20
resolution: [64, 48]
camera_model: pinhole
intrinsics: [458.654, 457.296, 367.215, 248.375] #fu, fv, cu, cv
distortion_model: radial-tangential
distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
)";

constexpr char kEurocImuYaml[] = R"(#Default imu sensor yaml file
sensor_type: imu
comment: VI-Sensor IMU (ADIS16448)

# Sensor extrinsics wrt. the body-frame.
T_BS:
  cols: 4
  rows: 4
  data: [1.0, 0.0, 0.0, 0.0,
         0.0, 1.0, 0.0, 0.0,
         0.0, 0.0, 1.0, 0.0,
         0.0, 0.0, 0.0, 1.0]
rate_hz: 200

# inertial sensor noise model parameters (static)
gyroscope_noise_density: 1.6968e-04     # [ rad / s / sqrt(Hz) ]   ( gyro "white noise" )
accelerometer_noise_density: 2.0000e-3  # [ m / s^2 / sqrt(Hz) ]   ( accel "white noise" )
)";

// Writes `frames` gray frames at 20 Hz and 10 IMU rows per frame (200 Hz) under root/mav0.
void WriteEuroc(const fs::path& root, int frames, bool with_yaml) {
  const fs::path mav0 = root / "mav0";
  std::string cam_csv = "#timestamp [ns],filename\n";
  for (int i = 0; i < frames; ++i) {
    const std::string t = std::to_string(kEurocT0 + i * 50'000'000LL);
    cam_csv += t + "," + t + ".png\n";
    fs::create_directories(mav0 / "cam0" / "data");
    cv::imwrite((mav0 / "cam0" / "data" / (t + ".png")).string(), Uniform(10 * i, CV_8UC1));
  }
  test::WriteTextFile(mav0 / "cam0" / "data.csv", cam_csv);
  std::string imu_csv =
      "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
      "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n";
  for (int i = 0; i < 10 * frames; ++i) {
    // Gyroscope columns hold values that must not be mistaken for the accelerometer's.
    imu_csv += std::to_string(kEurocT0 - 2'000'000 + i * 5'000'000LL) +
               ",-0.099134701513277898,0.14730578886832138,0.02722713633111154," +
               std::to_string(8 + i) + ".5,0.25," + std::to_string(-i) + ".125\n";
  }
  test::WriteTextFile(mav0 / "imu0" / "data.csv", imu_csv);
  if (with_yaml) {
    test::WriteTextFile(mav0 / "cam0" / "sensor.yaml", kEurocCamYaml);
    test::WriteTextFile(mav0 / "imu0" / "sensor.yaml", kEurocImuYaml);
  }
}

TEST(EurocTest, ReadsFramesAccelerometerColumnsAndSensorYaml) {
  test::TempDir tmp;
  WriteEuroc(tmp.path(), 4, /*with_yaml=*/true);
  for (const fs::path& dir : {tmp.path(), tmp.path() / "mav0"}) {
    const auto sequence = OpenEuroc(dir.string());
    ASSERT_EQ(sequence->frame_count(), 4u) << dir;
    EXPECT_EQ(sequence->frame_time_ns(3), kEurocT0 + 150'000'000);
    const cv::Mat frame = sequence->LoadFrame(2);
    EXPECT_EQ(frame.type(), CV_8UC3);  // Gray PNGs come out as BGR.
    EXPECT_EQ(MeanLevel(frame), 20.0);

    ASSERT_EQ(sequence->accel().size(), 40u);
    const AccelSample& sample = sequence->accel()[7];
    EXPECT_EQ(sample.t_ns, kEurocT0 - 2'000'000 + 35'000'000);
    EXPECT_EQ(sample.specific_force, Eigen::Vector3d(15.5, 0.25, -7.125));

    const SessionInfo& session = sequence->session();
    EXPECT_EQ(session.camera_device, "VI-Sensor cam0 (MT9M034)");
    EXPECT_EQ(session.accelerometer_device, "VI-Sensor IMU (ADIS16448)");
    EXPECT_EQ(session.width, 64);
    EXPECT_EQ(session.height, 48);
    EXPECT_EQ(session.frame_rate_hz, 20.0);
    EXPECT_EQ(session.accel_rate_hz, 200.0);
    ASSERT_TRUE(session.premission_calibration.has_value());
    const CameraIntrinsics& c = *session.premission_calibration;
    EXPECT_EQ(c.fx, 458.654);
    EXPECT_EQ(c.fy, 457.296);
    EXPECT_EQ(c.cx, 367.215);
    EXPECT_EQ(c.cy, 248.375);
    EXPECT_EQ(c.k1, -0.28340811);
    EXPECT_EQ(c.k2, 0.07395907);
    EXPECT_EQ(c.p1, 0.00019359);
    EXPECT_EQ(c.p2, 1.76187114e-05);
    EXPECT_EQ(c.k3, 0.0);
    // cam <- accel = (body <- cam)^T (body <- imu); here body <- imu is the identity.
    Eigen::Matrix3d body_from_cam;
    body_from_cam << 0.0148655429818, -0.999880929698, 0.00414029679422, 0.999557249008,
        0.0149672133247, 0.025715529948, -0.0257744366974, 0.00375618835797, 0.999660727178;
    EXPECT_TRUE(session.cam_from_accel.isApprox(body_from_cam.transpose(), 1e-15));
    EXPECT_TRUE(sequence->warnings().empty());
    EXPECT_EQ(sequence->ground_truth(), nullptr);
  }
}

TEST(EurocTest, WithoutSensorYamlSizeAndRatesComeFromTheData) {
  test::TempDir tmp;
  WriteEuroc(tmp.path(), 3, /*with_yaml=*/false);
  const auto sequence = OpenEuroc(tmp.path().string());
  const SessionInfo& session = sequence->session();
  EXPECT_EQ(session.width, 64);
  EXPECT_EQ(session.height, 48);
  EXPECT_DOUBLE_EQ(session.frame_rate_hz, 20.0);
  EXPECT_DOUBLE_EQ(session.accel_rate_hz, 200.0);
  EXPECT_FALSE(session.premission_calibration.has_value());
  EXPECT_EQ(session.cam_from_accel, Eigen::Matrix3d::Identity());
}

TEST(EurocTest, FaultsNameTheFileAndLine) {
  test::TempDir tmp;
  WriteEuroc(tmp.path(), 3, /*with_yaml=*/false);
  const fs::path imu = tmp.path() / "mav0" / "imu0" / "data.csv";
  std::string text = test::ReadTextFile(imu);
  text += "1403636580000000000,0,0,0,9.8,0.1\n";  // Line 32: one column short.
  test::WriteTextFile(imu, text);
  const std::string message = ErrorOf([&] { OpenEuroc(tmp.path().string()); });
  EXPECT_CONTAINS(message, imu.string() + ":32: expected 7 comma-separated fields");
  EXPECT_EQ(OpenEuroc(tmp.path().string(), Truncating())->accel().size(), 30u);

  fs::remove_all(tmp.path() / "mav0" / "imu0");
  EXPECT_CONTAINS(ErrorOf([&] { OpenEuroc(tmp.path().string()); }), "imu0");
}

// --- TUM RGB-D -----------------------------------------------------------------------------

void WriteTum(const fs::path& dir) {
  std::string rgb =
      "# color images\n# file: 'rgbd_dataset_freiburg1_xyz.bag'\n# timestamp filename\n";
  const char* times[] = {"1305031102.175304", "1305031102.211214", "1305031102.243211"};
  for (int i = 0; i < 3; ++i) {
    const std::string name = std::string("rgb/") + times[i] + ".png";
    rgb += std::string(times[i]) + " " + name + "\n";
    fs::create_directories(dir / "rgb");
    cv::imwrite((dir / name).string(), Uniform(40 + i));
  }
  test::WriteTextFile(dir / "rgb.txt", rgb);
  test::WriteTextFile(dir / "accelerometer.txt",
                      "# accelerometer data\n# file: 'rgbd_dataset_freiburg1_xyz.bag'\n"
                      "# timestamp ax ay az\n"
                      "1305031098.6659 -0.0196 9.7908 0.6671\n"
                      "1305031098.6758 -0.0098 9.7712 0.6573\n"
                      "1305031102.2 0.0 9.81 0.5\n");
}

TEST(TumTest, ReadsSecondsAsExactNanoseconds) {
  test::TempDir tmp;
  WriteTum(tmp.path());
  const auto sequence = OpenTum(tmp.path().string());
  ASSERT_EQ(sequence->frame_count(), 3u);
  EXPECT_EQ(sequence->frame_time_ns(0), 1305031102175304000);
  EXPECT_EQ(sequence->frame_time_ns(1), 1305031102211214000);
  EXPECT_EQ(MeanLevel(sequence->LoadFrame(1)), 41.0);
  ASSERT_EQ(sequence->accel().size(), 3u);
  EXPECT_EQ(sequence->accel()[0].t_ns, 1305031098665900000);
  EXPECT_EQ(sequence->accel()[1].t_ns, 1305031098675800000);
  EXPECT_EQ(sequence->accel()[2].t_ns, 1305031102200000000);
  EXPECT_EQ(sequence->accel()[1].specific_force, Eigen::Vector3d(-0.0098, 9.7712, 0.6573));
  EXPECT_EQ(sequence->session().width, 64);
  EXPECT_EQ(sequence->session().height, 48);
  EXPECT_FALSE(sequence->session().premission_calibration.has_value());
}

TEST(TumTest, SessionJsonBesideGivesThePremissionCalibration) {
  test::TempDir tmp;
  WriteTum(tmp.path());
  SessionInfo session;
  session.width = 64;
  session.height = 48;
  CameraIntrinsics c = CameraIntrinsics::FromFieldOfView(64, 48, 60.0);
  c.k1 = 0.2624;
  session.premission_calibration = c;
  WriteSessionFile((tmp.path() / "session.json").string(), session);
  const auto sequence = OpenSequence(tmp.path().string());
  EXPECT_EQ(sequence->Describe(), "TUM RGB-D folder " + tmp.path().string());
  EXPECT_EQ(sequence->session().premission_calibration, c);
}

TEST(TumTest, FaultsNameTheFileAndLine) {
  test::TempDir tmp;
  WriteTum(tmp.path());
  test::WriteTextFile(tmp.path() / "accelerometer.txt",
                      "# timestamp ax ay az\n1305031098.6659 -0.0196 9.7908 0.6671\n"
                      "1305031098.6659x 1 2 3\n");
  const std::string message = ErrorOf([&] { OpenTum(tmp.path().string()); });
  EXPECT_CONTAINS(message, "accelerometer.txt:3: field 1 (timestamp [s]) is not a time in seconds");

  test::WriteTextFile(tmp.path() / "accelerometer.txt", "1305031098.6659 -0.0196 9.7908\n");
  EXPECT_CONTAINS(ErrorOf([&] { OpenTum(tmp.path().string()); }),
                  "accelerometer.txt:1: expected 4 space-separated fields: timestamp [s], ax, "
                  "ay, az; got 3");

  // Truncating, both faults are skipped: frames stop before the missing one.
  fs::remove(tmp.path() / "rgb" / "1305031102.211214.png");
  const auto sequence = OpenTum(tmp.path().string(), Truncating());
  EXPECT_EQ(sequence->frame_count(), 1u);
  EXPECT_EQ(sequence->accel().size(), 0u);
  ASSERT_EQ(sequence->warnings().size(), 2u);
  EXPECT_CONTAINS(sequence->warnings()[0], "rgb.txt:5: frame file");
  EXPECT_CONTAINS(sequence->warnings()[0], "1305031102.211214.png does not exist");
}

// --- Video ---------------------------------------------------------------------------------

constexpr int64_t kVideoT0 = 1'700'000'000'000'000'007;

// Writes dir/walk.avi (MJPG, 20 fps), frame i uniformly 30 * i, and dir/<csv_name>.
void WriteVideo(const fs::path& dir, int frames, const std::string& csv_name = "walk.csv") {
  cv::VideoWriter writer((dir / "walk.avi").string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                         20.0, cv::Size(64, 48));
  ASSERT_TRUE(writer.isOpened());
  for (int i = 0; i < frames; ++i) writer.write(Uniform(30 * i));
  writer.release();
  std::string csv = "#timestamp [ns],a_x [m s^-2],a_y [m s^-2],a_z [m s^-2]\n";
  for (int i = 0; i < 100; ++i) {
    csv += std::to_string(kVideoT0 + i * 2'500'000LL) + ",0.5,-9.75," + std::to_string(i) + "\n";
  }
  test::WriteTextFile(dir / csv_name, csv);
}

TEST(VideoTest, FramesAreTimedFromTheFrameRateAndReadInAnyOrder) {
  test::TempDir tmp;
  WriteVideo(tmp.path(), 6);
  const auto sequence = OpenVideo((tmp.path() / "walk.avi").string());
  ASSERT_EQ(sequence->frame_count(), 6u);
  for (size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(sequence->frame_time_ns(i), kVideoT0 + static_cast<int64_t>(i) * 50'000'000);
  }
  EXPECT_EQ(sequence->session().width, 64);
  EXPECT_EQ(sequence->session().height, 48);
  ASSERT_EQ(sequence->accel().size(), 100u);
  EXPECT_EQ(sequence->accel()[99].specific_force, Eigen::Vector3d(0.5, -9.75, 99.0));
  for (const size_t i : {0u, 1u, 4u, 2u, 5u, 3u, 3u}) {
    const cv::Mat frame = sequence->LoadFrame(i);
    EXPECT_EQ(frame.size(), cv::Size(64, 48));
    EXPECT_NEAR(MeanLevel(frame), 30.0 * i, 2.0) << "frame " << i;
  }
  EXPECT_CONTAINS(ErrorOf([&] { sequence->LoadFrame(6); }), "beyond the last frame");
}

TEST(VideoTest, FramesCanBeLoadedFromSeveralThreadsAtOnce) {
  test::TempDir tmp;
  WriteVideo(tmp.path(), 8);
  const auto sequence = OpenVideo((tmp.path() / "walk.avi").string());
  // One thread reads forwards, the other in strides: nearly every read races with a seek.
  const auto read_many = [&](int stride, int* wrong) {
    for (int n = 0; n < 400; ++n) {
      const int i = (n * stride) % 8;
      if (std::abs(MeanLevel(sequence->LoadFrame(i)) - 30.0 * i) > 2.0) ++*wrong;
    }
  };
  int wrong_here = 0, wrong_there = 0;
  std::thread other(read_many, 3, &wrong_there);
  read_many(1, &wrong_here);
  other.join();
  EXPECT_EQ(wrong_here, 0);
  EXPECT_EQ(wrong_there, 0);
}

TEST(VideoTest, TimestampsFileAndAccelCsvFallback) {
  test::TempDir tmp;
  WriteVideo(tmp.path(), 3, "accel.csv");
  test::WriteTextFile(tmp.path() / "walk.timestamps.csv",
                      "#timestamp [ns]\n1000000000000000001\n1000000000040000000\n"
                      "1000000000090000003\n");
  const auto sequence = OpenSequence((tmp.path() / "walk.avi").string());
  ASSERT_EQ(sequence->frame_count(), 3u);
  EXPECT_EQ(sequence->frame_time_ns(0), 1000000000000000001);
  EXPECT_EQ(sequence->frame_time_ns(2), 1000000000090000003);
  EXPECT_EQ(sequence->accel().size(), 100u);

  test::WriteTextFile(tmp.path() / "walk.timestamps.csv",
                      "#timestamp [ns]\n1000000000000000001\n1000000000040000000\n");
  EXPECT_CONTAINS(ErrorOf([&] { OpenVideo((tmp.path() / "walk.avi").string()); }),
                  "walk.timestamps.csv: has 2 timestamps but the video has 3 frames");
  EXPECT_EQ(OpenVideo((tmp.path() / "walk.avi").string(), Truncating())->frame_count(), 2u);
}

TEST(VideoTest, MissingCsvListsWhereItLooked) {
  test::TempDir tmp;
  WriteVideo(tmp.path(), 2);
  fs::remove(tmp.path() / "walk.csv");
  const std::string message = ErrorOf([&] { OpenVideo((tmp.path() / "walk.avi").string()); });
  EXPECT_CONTAINS(message, "walk.csv");
  EXPECT_CONTAINS(message, "accel.csv");

  test::WriteTextFile(tmp.path() / "notvideo.avi", "not a video");
  test::WriteTextFile(tmp.path() / "notvideo.csv", "#timestamp [ns],a_x,a_y,a_z\n");
  EXPECT_CONTAINS(ErrorOf([&] { OpenVideo((tmp.path() / "notvideo.avi").string()); }),
                  "cannot be opened as a video");
}

// --- OpenSequence --------------------------------------------------------------------------

TEST(OpenSequenceTest, DetectsEachFormat) {
  test::TempDir tmp;
  {
    SessionInfo session;
    session.width = 64;
    session.height = 48;
    RecordingWriter writer(tmp / "native", session);
    writer.AddFrame(5, Uniform(1));
    writer.AddAccel({4, Eigen::Vector3d(0, 0, 9.81)});
  }
  WriteEuroc(tmp.path() / "euroc", 2, true);
  WriteTum(tmp.path() / "tum");
  fs::create_directories(tmp.path() / "video");
  WriteVideo(tmp.path() / "video", 2);

  EXPECT_EQ(OpenSequence(tmp / "native")->Describe(), "native recording " + (tmp / "native"));
  EXPECT_EQ(OpenSequence(tmp / "euroc")->Describe(), "EuRoC folder " + (tmp / "euroc"));
  EXPECT_EQ(OpenSequence(tmp / "euroc/mav0")->Describe(), "EuRoC folder " + (tmp / "euroc/mav0"));
  EXPECT_EQ(OpenSequence(tmp / "tum")->Describe(), "TUM RGB-D folder " + (tmp / "tum"));
  EXPECT_EQ(OpenSequence(tmp / "video/walk.avi")->Describe(), "video " + (tmp / "video/walk.avi"));
  EXPECT_EQ(OpenSequence(tmp / "native")->frame_count(), 1u);

  // A broken native recording is reported as such, not as an unknown folder.
  fs::remove(tmp.path() / "native" / "session.json");
  EXPECT_CONTAINS(ErrorOf([&] { OpenSequence(tmp / "native"); }),
                  "session.json: file does not exist");
}

TEST(OpenSequenceTest, SimSpecOpensTheSimulatorAndItsCopyKeepsTheTruth) {
  test::TempDir tmp;
  const auto simulated = OpenSequence("sim:office,seconds=0.3,fps=10,resolution=64x48");
  ASSERT_GE(simulated->frame_count(), 3u);
  EXPECT_EQ(simulated->session().width, 64);
  ASSERT_NE(simulated->ground_truth(), nullptr);

  ASSERT_TRUE(WriteSequence(*simulated, tmp / "sim"));
  const auto copy = OpenSequence(tmp / "sim");
  ASSERT_EQ(copy->frame_count(), simulated->frame_count());
  ASSERT_NE(copy->ground_truth(), nullptr);
  for (size_t i = 0; i < copy->frame_count(); ++i) {
    EXPECT_EQ(copy->frame_time_ns(i), simulated->frame_time_ns(i));
    EXPECT_EQ(cv::norm(copy->LoadFrame(i), simulated->LoadFrame(i), cv::NORM_INF), 0.0);
    EXPECT_EQ((*copy->ground_truth())[i].intrinsics, (*simulated->ground_truth())[i].intrinsics);
    const std::optional<cv::Mat> labels = simulated->LoadPlaneLabels(i);
    ASSERT_EQ(copy->LoadPlaneLabels(i).has_value(), labels.has_value());
    if (labels) {
      EXPECT_EQ(cv::norm(*copy->LoadPlaneLabels(i), *labels, cv::NORM_INF), 0.0);
    }
  }
  ASSERT_EQ(copy->accel().size(), simulated->accel().size());
  EXPECT_EQ(copy->accel().back().specific_force, simulated->accel().back().specific_force);
  EXPECT_EQ(copy->SceneDescription(), simulated->SceneDescription());

  EXPECT_CONTAINS(ErrorOf([] { OpenSequence("sim:office,lens"); }), "key=value");
}

TEST(OpenSequenceTest, UnknownFolderListsTheLayoutsLookedFor) {
  test::TempDir tmp;
  test::WriteTextFile(tmp.path() / "photos" / "a.png", "");
  const std::string message = ErrorOf([&] { OpenSequence(tmp / "photos"); });
  EXPECT_CONTAINS(message, "photos: is not a recording folder of a known layout");
  for (const char* layout : {"native recording (session.json", "EuRoC folder (mav0/cam0/",
                             "TUM RGB-D folder (rgb.txt", "video file", "sim:SCENARIO"}) {
    EXPECT_CONTAINS(message, layout);
  }
  EXPECT_CONTAINS(ErrorOf([&] { OpenSequence(tmp / "missing"); }), "no such file or folder");
}

}  // namespace
}  // namespace autocal
