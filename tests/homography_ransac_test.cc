// Box 6's homographies, RANSAC and least squares, against OpenCV's own
// (cv::findHomography with cv::RANSAC and with method 0) and against the homography the
// points were made with.
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "pipeline/homography_ransac.h"

namespace autocal {
namespace {

constexpr double kThresholdPx = 1.0;

cv::Point2f Transfer(const cv::Matx33d& h, const cv::Point2f& p) {
  const cv::Vec3d q = h * cv::Vec3d(p.x, p.y, 1.0);
  return {float(q[0] / q[2]), float(q[1] / q[2])};
}

// A wall 3 m ahead, tilted 30 deg, seen by a 320x240 camera (fx = 250) before and after
// it turns 4 deg and moves 0.2 m: H = K (R + t n^T / d) K^-1.
cv::Matx33d WallHomography() {
  const cv::Matx33d k(250, 0, 160, 0, 250, 120, 0, 0, 1);
  cv::Matx33d r;
  cv::Rodrigues(cv::Vec3d(0.02, 0.065, 0.01), r);
  const cv::Vec3d t(0.15, -0.05, 0.12);
  const double tilt = 30.0 * M_PI / 180.0;
  const cv::Vec3d n(std::sin(tilt), 0.0, -std::cos(tilt));
  return k * (r + t * n.t() * (1.0 / 3.0)) * k.inv();
}

struct Correspondences {
  std::vector<cv::Point2f> from, to;
  std::vector<bool> on_plane;
};

// `planar` points on the wall with 0.1 px of noise, `others` moved 3-30 px off it.
Correspondences Make(const cv::Matx33d& h, int planar, int others, std::mt19937* random) {
  std::uniform_real_distribution<float> x(0, 320), y(0, 240), offset(3, 30), angle(0, 2 * M_PI);
  std::normal_distribution<float> noise(0, 0.1f);
  Correspondences c;
  for (int i = 0; i < planar + others; ++i) {
    const cv::Point2f p(x(*random), y(*random));
    cv::Point2f q = Transfer(h, p);
    const bool on_plane = i < planar;
    if (on_plane) {
      q += cv::Point2f(noise(*random), noise(*random));
    } else {
      const float a = angle(*random), d = offset(*random);
      q += cv::Point2f(d * std::cos(a), d * std::sin(a));
    }
    c.from.push_back(p);
    c.to.push_back(q);
    c.on_plane.push_back(on_plane);
  }
  return c;
}

// The largest distance between where two homographies send a grid over the image.
double LargestTransferGap(const cv::Matx33d& a, const cv::Matx33d& b) {
  double gap = 0.0;
  for (float x = 0; x <= 320; x += 16) {
    for (float y = 0; y <= 240; y += 16) {
      gap = std::max(gap, cv::norm(Transfer(a, {x, y}) - Transfer(b, {x, y})));
    }
  }
  return gap;
}

TEST(HomographyRansac, FindsThePlaneAmongOutliersAsOpenCvDoes) {
  std::mt19937 random(7);
  const cv::Matx33d truth = WallHomography();
  for (const auto& [planar, others] : {std::pair{60, 40}, std::pair{40, 60}, std::pair{100, 10}}) {
    SCOPED_TRACE(testing::Message() << planar << " on the plane, " << others << " off it");
    const Correspondences c = Make(truth, planar, others, &random);
    std::vector<uchar> inliers;
    const auto h =
        FitHomographyRansac(c.from, c.to, kThresholdPx, 500, kRansacConfidence, &inliers);
    ASSERT_TRUE(h.has_value());
    // The consensus of the best 4-point sample: none off the plane, most on it (a model
    // through four noisy points strays toward the image's far side).
    int on_plane = 0;
    for (size_t i = 0; i < c.from.size(); ++i) {
      if (!inliers[i]) continue;
      EXPECT_TRUE(c.on_plane[i]) << i;
      ++on_plane;
    }
    EXPECT_GE(on_plane, 0.9 * planar);
    EXPECT_LT(LargestTransferGap(*h, truth), 0.2);

    cv::Mat opencv_mask;
    const cv::Mat opencv = cv::findHomography(c.from, c.to, cv::RANSAC, kThresholdPx, opencv_mask,
                                              500, kRansacConfidence);
    ASSERT_FALSE(opencv.empty());
    EXPECT_EQ(cv::countNonZero(opencv_mask != cv::Mat(inliers)), 0);
    // The same consensus, fitted the same way.
    EXPECT_LT(LargestTransferGap(*h, cv::Matx33d(opencv)), 1e-6);
  }
}

TEST(HomographyRansac, SamplesUntilConfidentOfTheBestConsensus) {
  // A third of the points on the plane: a clean sample comes one draw in 80, and with
  // 500 draws one is found with near certainty.
  std::mt19937 random(11);
  const cv::Matx33d truth = WallHomography();
  const Correspondences c = Make(truth, 40, 80, &random);
  std::vector<uchar> inliers;
  const auto h = FitHomographyRansac(c.from, c.to, kThresholdPx, 500, kRansacConfidence, &inliers);
  ASSERT_TRUE(h.has_value());
  EXPECT_EQ(std::count(inliers.begin(), inliers.end(), 1), 40);
  EXPECT_LT(LargestTransferGap(*h, truth), 0.3);
  // Ten draws are not enough to be confident, and do not find it.
  std::vector<uchar> few;
  const auto hurried = FitHomographyRansac(c.from, c.to, kThresholdPx, 10, kRansacConfidence, &few);
  EXPECT_TRUE(!hurried || std::count(few.begin(), few.end(), 1) < 40);
}

TEST(HomographyRansac, GivesTheSameResultEveryTime) {
  std::mt19937 random(3);
  const Correspondences c = Make(WallHomography(), 30, 70, &random);
  std::vector<uchar> first, second;
  const auto a = FitHomographyRansac(c.from, c.to, kThresholdPx, 300, kRansacConfidence, &first);
  const auto b = FitHomographyRansac(c.from, c.to, kThresholdPx, 300, kRansacConfidence, &second);
  ASSERT_TRUE(a && b);
  EXPECT_EQ(first, second);
  EXPECT_EQ(cv::norm(*a - *b), 0.0);
}

TEST(HomographyRansac, RefusesTooFewOrCollinearPoints) {
  std::vector<uchar> inliers;
  const std::vector<cv::Point2f> three = {{0, 0}, {10, 0}, {0, 10}};
  EXPECT_FALSE(FitHomographyRansac(three, three, kThresholdPx, 100, kRansacConfidence, &inliers));
  EXPECT_EQ(inliers.size(), 3u);
  std::vector<cv::Point2f> line;
  for (int i = 0; i < 20; ++i) line.emplace_back(5.0f * i, 2.0f * i + 1.0f);
  EXPECT_FALSE(FitHomographyRansac(line, line, kThresholdPx, 100, kRansacConfidence, &inliers));
  EXPECT_EQ(std::count(inliers.begin(), inliers.end(), 1), 0);
}

double RmsTransferError(const cv::Matx33d& h, const Correspondences& c) {
  double sum = 0.0;
  for (size_t i = 0; i < c.from.size(); ++i) {
    const cv::Point2f miss = Transfer(h, c.from[i]) - c.to[i];
    sum += miss.dot(miss);
  }
  return std::sqrt(sum / double(c.from.size()));
}

TEST(FitHomography, FitsAsWellAsOpenCvLeastSquares) {
  std::mt19937 random(5);
  const cv::Matx33d wall = WallHomography();
  // The same view at 1280x960: pixel coordinates four times larger.
  const cv::Matx33d four(4, 0, 0, 0, 4, 0, 0, 0, 1);
  for (const double scale : {1.0, 4.0}) {
    const cv::Matx33d truth = scale == 1.0 ? wall : four * wall * four.inv();
    for (const int count : {5, 12, 40, 150}) {
      for (const float noise_px : {0.1f, 1.0f, 3.0f}) {
        SCOPED_TRACE(testing::Message()
                     << count << " points, " << noise_px << " px noise, x" << scale);
        std::normal_distribution<float> noise(0, noise_px);
        Correspondences c = Make(wall, count, 0, &random);
        for (size_t i = 0; i < c.from.size(); ++i) {
          c.from[i] *= float(scale);
          c.to[i] = Transfer(truth, c.from[i]) + cv::Point2f(noise(random), noise(random));
        }
        const auto ours = FitHomography(c.from, c.to);
        ASSERT_TRUE(ours.has_value());
        const cv::Mat opencv = cv::findHomography(c.from, c.to, 0);
        ASSERT_FALSE(opencv.empty());
        // Both minimize the same error: ours is no worse, and lands on OpenCV's homography
        // unless OpenCV's 10 steps stopped short (once here: 5 points, 3 px, rms 2.023 px
        // against our 2.021, a homography 5 px apart at the corners with so few points).
        const double ours_rms = RmsTransferError(*ours, c);
        const double opencv_rms = RmsTransferError(cv::Matx33d(opencv), c);
        EXPECT_LE(ours_rms, opencv_rms * (1 + 1e-6));
        if (opencv_rms <= ours_rms * (1 + 1e-6)) {
          EXPECT_LT(LargestTransferGap(*ours, cv::Matx33d(opencv)), 1e-3 * scale);
        }
      }
    }
  }
}

TEST(FitHomography, PassesThroughFourPointsExactly) {
  std::mt19937 random(9);
  const Correspondences c = Make(WallHomography(), 4, 0, &random);
  const cv::Matx33d truth = WallHomography();
  std::vector<cv::Point2f> exact;
  for (const cv::Point2f& p : c.from) exact.push_back(Transfer(truth, p));
  const auto h = FitHomography(c.from, exact);
  ASSERT_TRUE(h.has_value());
  for (size_t i = 0; i < exact.size(); ++i) {
    EXPECT_LT(cv::norm(Transfer(*h, c.from[i]) - exact[i]), 1e-3);
  }
  EXPECT_LT(LargestTransferGap(*h, truth), 1e-2);
}

TEST(FitHomography, RefusesTooFewOrCollinearPoints) {
  const std::vector<cv::Point2f> three = {{0, 0}, {10, 0}, {0, 10}};
  EXPECT_FALSE(FitHomography(three, three));
  std::vector<cv::Point2f> line;
  for (int i = 0; i < 20; ++i) line.emplace_back(5.0f * i, 2.0f * i + 1.0f);
  EXPECT_FALSE(FitHomography(line, line));
}

}  // namespace
}  // namespace autocal
