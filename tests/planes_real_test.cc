// Boxes 4 and 6 on real footage they have never seen: two shots of a painted wall (OpenCV's
// sample graf1.png and graf3.png, from the Oxford affine-covariant-regions set, 30-40 deg
// apart) and the homography measured between them for that set (H1to3p.xml).
#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core/persistence.hpp>
#include <opencv2/imgcodecs.hpp>

#include "pipeline/features.h"
#include "pipeline/planes.h"

namespace autocal {
namespace {

// Installed by tools/bootstrap.sh (Debian package opencv-doc).
const std::string kSampleData = "/usr/share/doc/opencv-doc/examples/data";

cv::Point2f Transfer(const cv::Matx33d& h, const cv::Point2f& p) {
  const cv::Vec3d q = h * cv::Vec3d(p.x, p.y, 1.0);
  return {float(q[0] / q[2]), float(q[1] / q[2])};
}

class PlanesReal : public testing::TestWithParam<DescriptorType> {};

TEST_P(PlanesReal, TheWallBetweenTwoShotsIsTheMeasuredHomography) {
  ASSERT_TRUE(std::filesystem::exists(kSampleData + "/graf1.png"))
      << "OpenCV's sample images are missing: apt-get install opencv-doc";
  const cv::Mat a = cv::imread(kSampleData + "/graf1.png", cv::IMREAD_GRAYSCALE);
  const cv::Mat b = cv::imread(kSampleData + "/graf3.png", cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(a.empty() || b.empty());
  cv::Mat measured;
  cv::FileStorage(kSampleData + "/H1to3p.xml", cv::FileStorage::READ)["H13"] >> measured;
  ASSERT_EQ(measured.size(), cv::Size(3, 3));
  const cv::Matx33d truth(measured);

  FeatureOptions features;
  features.descriptor = GetParam();
  const KeypointSet keypoints_a = DetectKeypoints(a, features);
  const KeypointSet keypoints_b = DetectKeypoints(b, features);
  // The lens is unknown and barely distorts: no distortion, a 60 deg field of view.
  const CameraIntrinsics camera = CameraIntrinsics::FromFieldOfView(a.cols, a.rows, 60.0);
  const std::vector<ShotPlane> planes =
      FindPlanesBetweenShots(keypoints_a, keypoints_b, camera, PlaneOptions{}, features);
  ASSERT_FALSE(planes.empty());
  // The wall is the scene: the first plane, and the only large one.
  const ShotPlane& wall = planes.front();
  EXPECT_GE(wall.matches.size(), 100u);
  for (size_t k = 1; k < planes.size(); ++k) {
    EXPECT_LT(planes[k].matches.size(), wall.matches.size() / 5) << "plane " << k;
  }
  // Along the bottom of graf1 (the lowest 80 px, left half) the matches lie 3-8 px off the
  // measured homography, all the same way: another surface, or the measurement's own error
  // there. They fit the wall's own consensus within the 3 px that keypoints placed at their
  // octave's scale need (58 of its 236 first SIFT matches), and its fit follows them there
  // by up to 6 px at the outline's corner; elsewhere the two homographies agree within the
  // keypoints' own scatter.
  int on_measured = 0;
  std::vector<double> gaps;
  for (const cv::DMatch& m : wall.matches) {
    const cv::Point2f p = keypoints_a.keypoints[m.queryIdx].pt;
    const cv::Point2f q = keypoints_b.keypoints[m.trainIdx].pt;
    on_measured += cv::norm(Transfer(truth, p) - q) <= PlaneOptions{}.shot_inlier_threshold_px;
    gaps.push_back(cv::norm(Transfer(wall.homography, p) - Transfer(truth, p)));
  }
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  const double median_gap = gaps[gaps.size() / 2];
  std::printf("%s: %zu planes, the wall on %zu matches, %d of them within 3 px of the measured "
              "homography; the two homographies %.2f px apart there (median)\n",
              GetParam() == DescriptorType::kSift ? "SIFT" : "ORB", planes.size(),
              wall.matches.size(), on_measured, median_gap);
  EXPECT_GE(on_measured, 0.7 * wall.matches.size());
  EXPECT_LT(median_gap, 2.0);
}

INSTANTIATE_TEST_SUITE_P(Descriptors, PlanesReal,
                         testing::Values(DescriptorType::kSift, DescriptorType::kOrb),
                         [](const testing::TestParamInfo<DescriptorType>& param) {
                           return param.param == DescriptorType::kSift ? "Sift" : "Orb";
                         });

}  // namespace
}  // namespace autocal
