// Helpers shared by the tests.
#pragma once

#include <filesystem>
#include <future>
#include <string>
#include <vector>

#include <ceres/cost_function.h>

#include <opencv2/core.hpp>

#include "pipeline/camera_model.h"

// Fails the test, and goes on, unless the string `text` contains `part` (both printed).
#define EXPECT_CONTAINS(text, part) EXPECT_PRED_FORMAT2(::testing::IsSubstring, part, text)

namespace autocal::test {

// A fresh empty folder for this test, removed when the object goes out of scope.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// A 640x480 camera like the simulator's sonnar lens (about 85 deg across), its principal
// point a little off centre and fx, fy slightly unequal so swapped fields show; barrel
// distortion k1, k2.
CameraIntrinsics SonnarLikeCamera(double k1 = -0.3, double k2 = 0.1);

// The calibration issue's wrong start from `truth`: fx, fy 5% too large, cx +15 px,
// cy -10 px, no distortion.
CameraIntrinsics WrongStart(const CameraIntrinsics& truth);

// OpenCV's camera matrix and distortion vector (k1, k2, p1, p2[, k3]), as cv::calibrateCamera
// returns them, for an image of `size`.
CameraIntrinsics FromOpenCv(const cv::Mat& camera_matrix, const cv::Mat& distortion,
                            cv::Size size);

// A real photograph as `lens` would see its scene: each pixel of the result (the lens's
// image size) takes the photograph's colour where a pinhole camera with the photograph's
// centre images that pixel's ray, turned by `yaw_deg` (about the image's vertical) and
// `pitch_deg` (about its horizontal), with the focal length that just fits the whole frame
// inside the photograph; then JPEG at `jpeg_quality`, as a camera would store it. The
// photograph's own lens is taken for a pinhole: its distortion is part of the texture.
cv::Mat WarpThroughLens(const cv::Mat& photo, const CameraIntrinsics& lens, double yaw_deg = 0.0,
                        double pitch_deg = 0.0, int jpeg_quality = 90);

// Checks every column of the Jacobian `cost` gives at `parameters` against central
// differences of its residual (within 1e-5, relative beyond 1), naming `where` in
// failures. False, with nothing checked, where the cost cannot be evaluated there.
// (Ceres' GradientChecker gave garbage numeric columns for our costs.)
bool ExpectJacobianMatchesCentralDifferences(const ceres::CostFunction& cost,
                                             const std::vector<double*>& parameters,
                                             const std::string& where);

// Writes `contents` to `path`, creating parent folders.
void WriteTextFile(const std::filesystem::path& path, const std::string& contents);
std::string ReadTextFile(const std::filesystem::path& path);

// Takes the write lock of the SQLite file `path` on a connection of its own, as another
// program (a backup, sqlite3 in a shell) may, and holds it until `release` is ready. The
// future returned is ready once the lock is held.
std::future<void> HoldSqliteWriteLock(const std::string& path, std::shared_future<void> release);

}  // namespace autocal::test
