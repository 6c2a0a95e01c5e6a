// Box 2 on real footage it has never seen: OpenCV's sample calibration shots (opencv-doc,
// left01..left14.jpg, a 640x480 camera with strong barrel distortion). The reference is a
// target-based calibration of the same shots with cv::calibrateCamera; our estimate uses
// only straight lines in the images (the board's grid, the room's edges), and must explain
// the real board corners about as well as the target-based distortion does.
#include <cstdio>
#include <filesystem>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "pipeline/lens_stage.h"
#include "tests/test_util.h"

namespace autocal {
namespace {

// Installed by tools/bootstrap.sh (Debian package opencv-doc).
const char* kSampleData = "/usr/share/doc/opencv-doc/examples/data";

TEST(DistortionReal, StraightLinesInOpenCvSampleShotsGiveTheTargetBasedDistortion) {
  ASSERT_TRUE(std::filesystem::exists(std::string(kSampleData) + "/left01.jpg"))
      << "OpenCV's sample images are missing: apt-get install opencv-doc";
  std::vector<cv::Mat> images;
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<std::vector<cv::Point3f>> board;
  for (int i : {1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14}) {
    char name[512];
    std::snprintf(name, sizeof name, "%s/left%02d.jpg", kSampleData, i);
    const cv::Mat image = cv::imread(name, cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(image.empty()) << name;
    images.push_back(image);
    std::vector<cv::Point2f> found;
    ASSERT_TRUE(cv::findChessboardCornersSB(image, {9, 6}, found, cv::CALIB_CB_ACCURACY)) << name;
    corners.push_back(found);
    std::vector<cv::Point3f> squares;
    for (int y = 0; y < 6; ++y) {
      for (int x = 0; x < 9; ++x) squares.emplace_back(float(x), float(y), 0.0f);
    }
    board.push_back(squares);
  }

  // The target-based reference (k1, k2, like our default model).
  const int model = cv::CALIB_FIX_K3 | cv::CALIB_ZERO_TANGENT_DIST;
  cv::Mat k, d;
  std::vector<cv::Mat> rvecs, tvecs;
  const double rms_reference =
      cv::calibrateCamera(board, corners, {640, 480}, k, d, rvecs, tvecs, model);
  const CameraIntrinsics reference = test::FromOpenCv(k, d, {640, 480});

  // Ours, from the same focal length and principal point but no distortion.
  CameraIntrinsics start = reference;
  start.k1 = start.k2 = 0.0;
  LensOptions options;
  options.pool_per_cell = 1000;  // Still shots: keep every line.
  LensStage stage(options);
  for (const cv::Mat& image : images) stage.ProcessStill(image, start);
  const PlumbLineResult result = stage.EstimateNow(start);
  ASSERT_TRUE(result.usable) << result.message;

  // How well each distortion explains the real board corners: calibrate everything else
  // with the distortion held.
  auto corner_rms = [&](const CameraIntrinsics& lens) {
    cv::Mat k_held = k.clone();
    cv::Mat d_held = (cv::Mat_<double>(1, 5) << lens.k1, lens.k2, 0, 0, 0);
    return cv::calibrateCamera(
        board, corners, {640, 480}, k_held, d_held, rvecs, tvecs,
        model | cv::CALIB_FIX_K1 | cv::CALIB_FIX_K2 | cv::CALIB_USE_INTRINSIC_GUESS);
  };
  const double rms_ours = corner_rms(result.estimate);
  const double rms_none = corner_rms(start);
  const double difference = MaxDistortionDifference(result.estimate, reference, 0.8);
  const double size = MaxDistortionDifference(start, reference, 0.8);
  std::printf(
      "%s\nboard corners RMS: target-based %.3f px, ours %.3f px, no distortion %.3f px; "
      "ours vs target-based within 80%% of the half-diagonal: %.2f px of %.1f px\n",
      result.message.c_str(), rms_reference, rms_ours, rms_none, difference, size);
  EXPECT_GE(result.lines_used, 50);
  EXPECT_LT(rms_ours, 1.15 * rms_reference) << "px: ours explains the real corners";
  EXPECT_GT(rms_none, 4 * rms_reference) << "the lens distorts: without a model corners miss";
  // The reference is itself uncertain where no board corner was seen (the corners).
  EXPECT_LT(difference, 2.0) << "px, where the distortion itself reaches " << size << " px";
}

}  // namespace
}  // namespace autocal
