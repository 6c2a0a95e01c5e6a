// Box 2 on real footage it has never seen: OpenCV's sample calibration shots (opencv-doc,
// left01..left14.jpg, a 640x480 camera with strong barrel distortion). The reference is a
// target-based calibration of the same shots with cv::calibrateCamera; our estimate uses
// only straight lines in the images (the board's grid, the room's edges), and must explain
// the real board corners about as well as the target-based distortion does.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

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
  LensStage stage;
  const PlumbLineResult result = stage.EstimateFromStills(images, start).distortion;
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

// A 640x480 camera of about 75 deg across whose barrel bends a line at the corner by
// about 30% of its radius (some 175 px): a drone's or a body camera's lens.
CameraIntrinsics StrongBarrel() {
  CameraIntrinsics lens;
  lens.width = 640;
  lens.height = 480;
  lens.fx = lens.fy = 420.0;
  lens.cx = 322.0;
  lens.cy = 236.0;
  lens.k1 = -0.35;
  lens.k2 = 0.1;
  return lens;
}

// Barrel of about 15% at the corner, on a narrower lens.
CameraIntrinsics ModerateBarrel() {
  CameraIntrinsics lens = StrongBarrel();
  lens.fx = lens.fy = 500.0;
  lens.k1 = -0.17;
  lens.k2 = 0.0;
  return lens;
}

cv::Mat Photograph(const std::string& name) {
  const cv::Mat photo = cv::imread(std::string(kSampleData) + "/" + name, cv::IMREAD_COLOR);
  if (photo.empty()) ADD_FAILURE() << name << " is missing: apt-get install opencv-doc";
  return photo;
}

// Boxes 1-2 on still images, from the lens's own focal length and principal point but no
// distortion.
PlumbLineResult EstimateFromStills(const std::vector<cv::Mat>& images, const CameraIntrinsics& lens) {
  CameraIntrinsics start = lens;
  start.k1 = start.k2 = start.k3 = start.p1 = start.p2 = 0.0;
  LensStage stage;
  return stage.EstimateFromStills(images, start).distortion;
}

struct WarpedLens {
  CameraIntrinsics (*lens)();
  const char* name;
};

class DistortionWarped : public testing::TestWithParam<WarpedLens> {};

// Four real photographs (real texture, real edges that are not straight, JPEG noise) as
// one camera with a known strong barrel would take them, three shots each: the lines the lens bends into
// arcs are found, and the distortion that straightens them is the lens's, out to 80% of
// the half-diagonal.
TEST_P(DistortionWarped, ArcsOfRealPhotographsGiveTheLensDistortion) {
  const CameraIntrinsics truth = GetParam().lens();
  std::vector<cv::Mat> images;
  for (const char* name : {"building.jpg", "home.jpg", "box_in_scene.png", "leuvenA.jpg"}) {
    const cv::Mat photo = Photograph(name);
    ASSERT_FALSE(photo.empty());
    // Three shots of each scene, the camera turned a little between them.
    for (const auto& [yaw, pitch] : {std::pair{0.0, 0.0}, {8.0, 5.0}, {-8.0, -5.0}}) {
      images.push_back(test::WarpThroughLens(photo, truth, yaw, pitch));
    }
  }
  const PlumbLineResult result = EstimateFromStills(images, truth);
  const DistortionObservability& o = result.observability;
  CameraIntrinsics pinhole = truth;
  pinhole.k1 = pinhole.k2 = 0.0;
  const double corner_shift = MaxDistortionDifference(pinhole, truth, 1.0);
  const double error = MaxDistortionDifference(result.solved, truth, 0.8);
  std::printf("%s barrel (%.0f px at the corners): %s\nwithin 80%% of the half-diagonal %.2f px "
              "off the truth\n",
              GetParam().name, corner_shift, result.message.c_str(), error);
  ASSERT_TRUE(result.usable) << result.message;
  EXPECT_GE(result.lines_used, 50);
  EXPECT_GE(o.covered_radius, 0.7) << "the lines reach the outer image";
  EXPECT_LT(error, 1.0) << "px within 80% of the half-diagonal";
  EXPECT_LT(error, 3 * o.shift_sigma_px + 0.2) << "px: the error is within what the sigma says";
  // What the workbench shows: the shift and its sigma, how far out, from how many lines.
  char verdict[160];
  std::snprintf(verdict, sizeof verdict, "lens: %.1f \u00b1 %.2f px to %.0f%% (%d lines)",
                o.max_shift_px, o.shift_sigma_px, 100 * o.covered_radius, result.lines_used);
  EXPECT_EQ(LensVerdict(result), verdict);
}

INSTANTIATE_TEST_SUITE_P(RealPhotographs, DistortionWarped,
                         testing::Values(WarpedLens{StrongBarrel, "strong"},
                                         WarpedLens{ModerateBarrel, "moderate"}),
                         [](const testing::TestParamInfo<WarpedLens>& param) {
                           return std::string(param.param.name);
                         });

// Only the middle of the photograph has texture, faded to grey from 30% to 40% of the
// half-diagonal: its lines are short and central, where the lens hardly bends them, so
// the distortion is not observable and no number is given.
TEST(DistortionReal, LinesOnlyNearTheCentreAreNotObservable) {
  const CameraIntrinsics truth = StrongBarrel();
  const cv::Mat photo = Photograph("building.jpg");
  ASSERT_FALSE(photo.empty());
  cv::Mat image = test::WarpThroughLens(photo, truth);
  const double half_diagonal = 0.5 * std::hypot(image.cols, image.rows);
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const double r = std::hypot(x - truth.cx, y - truth.cy) / half_diagonal;
      const double keep = std::clamp((0.4 - r) / 0.1, 0.0, 1.0);
      cv::Vec3b& pixel = image.at<cv::Vec3b>(y, x);
      for (int k = 0; k < 3; ++k) pixel[k] = cv::saturate_cast<uchar>(128 + keep * (pixel[k] - 128));
    }
  }
  const PlumbLineResult result = EstimateFromStills({image}, truth);
  std::printf("%s\n", result.message.c_str());
  EXPECT_FALSE(result.usable);
  EXPECT_CONTAINS(result.message, "not observable: the lines reach only");
  EXPECT_EQ(result.estimate.k1, 0.0) << "the initial distortion is kept";
  EXPECT_LT(result.observability.covered_radius, 0.5);
  EXPECT_EQ(LensVerdict(result).rfind("lens not observable: lines reach only ", 0), 0u)
      << LensVerdict(result);
}

// The photograph smeared along its columns keeps only its upright edges: every line runs
// one way, and the estimate is refused for it.
TEST(DistortionReal, LinesInOneDirectionAreNotObservable) {
  const CameraIntrinsics truth = ModerateBarrel();
  const cv::Mat photo = Photograph("building.jpg");
  ASSERT_FALSE(photo.empty());
  cv::Mat smeared;
  cv::blur(photo, smeared, {1, 61});
  const PlumbLineResult result = EstimateFromStills({test::WarpThroughLens(smeared, truth)}, truth);
  std::printf("%s\n", result.message.c_str());
  EXPECT_FALSE(result.usable);
  EXPECT_CONTAINS(result.message, "not observable");
  EXPECT_EQ(result.estimate.k1, 0.0) << "the initial distortion is kept";
  EXPECT_EQ(LensVerdict(result), "lens not observable: lines in one direction only");
}

}  // namespace
}  // namespace autocal
