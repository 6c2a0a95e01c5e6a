#include "pipeline/line_detector.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

namespace autocal {
namespace {

struct TrueLine {
  double rho, theta;
};

// A convex polygon (bright on dark) rendered with exact area coverage (16x16 samples per
// pixel, pixel centres at integers), plus Gaussian noise. Its edges are the true lines.
cv::Mat RenderPolygon(const std::vector<Eigen::Vector2d>& corners, cv::Size size, double noise,
                      std::vector<TrueLine>* lines) {
  const int n = static_cast<int>(corners.size());
  std::vector<Eigen::Vector3d> half_planes;  // a x + b y + c >= 0 inside.
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d& p = corners[i];
    const Eigen::Vector2d& q = corners[(i + 1) % n];
    const Eigen::Vector2d normal = Eigen::Vector2d(q.y() - p.y(), p.x() - q.x()).normalized();
    half_planes.emplace_back(normal.x(), normal.y(), -normal.dot(p));
    double theta = std::atan2(normal.y(), normal.x());
    double rho = normal.dot(p);
    if (theta < 0) {
      theta += M_PI;
      rho = -rho;
    }
    lines->push_back({rho, theta});
  }
  // The orientation of the corners decides which side is inside.
  const double sign =
      half_planes[0].dot(Eigen::Vector3d(corners[2].x(), corners[2].y(), 1)) > 0 ? 1.0 : -1.0;
  constexpr int kSub = 16;
  cv::Mat image(size, CV_32F);
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      int inside = 0;
      for (int i = 0; i < kSub; ++i) {
        for (int j = 0; j < kSub; ++j) {
          const Eigen::Vector3d sample(x - 0.5 + (j + 0.5) / kSub, y - 0.5 + (i + 0.5) / kSub, 1);
          bool in = true;
          for (const auto& h : half_planes) in = in && sign * h.dot(sample) >= 0;
          inside += in;
        }
      }
      image.at<float>(y, x) = 60.0f + 130.0f * inside / (kSub * kSub);
    }
  }
  cv::Mat noise_image(size, CV_32F);
  cv::randn(noise_image, 0.0, noise);
  image += noise_image;
  cv::Mat gray;
  image.convertTo(gray, CV_8U);
  return gray;
}

TEST(LineDetector, DefaultOptionsAreValid) {
  std::string error;
  EXPECT_TRUE(LineDetectorOptions().Check(&error)) << error;
  LineDetectorOptions bad;
  bad.min_fill = 1.5;
  EXPECT_FALSE(bad.Check(&error));
  EXPECT_NE(error.find("min_fill"), std::string::npos) << error;
}

TEST(LineDetector, FitLineRecoversAKnownLine) {
  // Points on x cos(t) + y sin(t) = 40 with t = 30 deg.
  const double theta = 30 * M_PI / 180;
  std::vector<Eigen::Vector2d> points;
  for (int i = -20; i <= 20; ++i) {
    points.push_back(40.0 * Eigen::Vector2d(std::cos(theta), std::sin(theta)) +
                     i * Eigen::Vector2d(-std::sin(theta), std::cos(theta)));
  }
  const LineFit fit = FitLine(points);
  EXPECT_NEAR(fit.theta, theta, 1e-12);
  EXPECT_NEAR(fit.rho, 40.0, 1e-9);
  EXPECT_NEAR(fit.rms, 0.0, 1e-6);
}

TEST(LineDetector, FindsPolygonEdgesToSubPixelAccuracy) {
  cv::RNG rng(7);
  double worst_rho = 0, worst_theta = 0;
  for (int trial = 0; trial < 4; ++trial) {
    // A random quadrilateral well inside a 320x240 image.
    const Eigen::Vector2d centre(160 + rng.uniform(-20.0, 20.0), 120 + rng.uniform(-15.0, 15.0));
    const double angle = rng.uniform(0.0, M_PI);
    std::vector<Eigen::Vector2d> corners;
    for (int k = 0; k < 4; ++k) {
      const double a = angle + k * M_PI / 2 + rng.uniform(-0.2, 0.2);
      const double r = rng.uniform(70.0, 95.0);
      corners.push_back(centre + r * Eigen::Vector2d(std::cos(a), std::sin(a)));
    }
    std::vector<TrueLine> truth;
    const cv::Mat image = RenderPolygon(corners, {320, 240}, 2.0, &truth);
    const std::vector<LineSegment> found = DetectLines(image, LineDetectorOptions());
    for (const TrueLine& line : truth) {
      double best_theta = 1e9, best_rho = 1e9;
      for (const LineSegment& segment : found) {
        const auto [dtheta, drho] = LineDistance(segment.rho, segment.theta, line.rho, line.theta);
        if (dtheta < 1 * M_PI / 180 && drho < 3 && drho < best_rho) {
          best_theta = dtheta;
          best_rho = drho;
        }
      }
      worst_rho = std::max(worst_rho, best_rho);
      worst_theta = std::max(worst_theta, best_theta * 180 / M_PI);
      EXPECT_LT(best_rho, 0.5) << "trial " << trial << " rho " << line.rho << " theta "
                               << line.theta;
      EXPECT_LT(best_theta * 180 / M_PI, 0.2) << "trial " << trial;
    }
    // Nothing but the four edges (each may be found once).
    EXPECT_LE(found.size(), 4u) << "trial " << trial;
  }
  std::printf("worst rho error %.3f px, worst theta error %.3f deg\n", worst_rho, worst_theta);
}

// Edges whose normals lie within the gradient's reach of theta = 0 (= pi): their votes run
// over the end of the angle bins and on from the start, with the distance's sign turned.
TEST(LineDetector, FindsEdgesWhoseNormalsLieAcrossTheAngleWrap) {
  for (const double tilt_deg : {-9.0, -2.5, 0.0, 2.5, 9.0}) {
    const double tilt = tilt_deg * M_PI / 180;
    const Eigen::Vector2d centre(160, 120), along(std::cos(tilt), std::sin(tilt));
    const Eigen::Vector2d across(-along.y(), along.x());
    std::vector<Eigen::Vector2d> corners;
    for (const auto& [a, b] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}) {
      corners.push_back(centre + 90.0 * a * along + 70.0 * b * across);
    }
    std::vector<TrueLine> truth;
    const cv::Mat image = RenderPolygon(corners, {320, 240}, 2.0, &truth);
    const std::vector<LineSegment> found = DetectLines(image, LineDetectorOptions());
    for (const TrueLine& line : truth) {
      const bool found_it = std::any_of(found.begin(), found.end(), [&](const LineSegment& s) {
        const auto [dtheta, drho] = LineDistance(s.rho, s.theta, line.rho, line.theta);
        return dtheta < 0.2 * M_PI / 180 && drho < 0.5;
      });
      EXPECT_TRUE(found_it) << "tilt " << tilt_deg << " deg: line rho " << line.rho << " theta "
                            << line.theta * 180 / M_PI << " deg not found";
    }
    EXPECT_EQ(found.size(), 4u) << "tilt " << tilt_deg << " deg";
  }
}

TEST(LineDetector, ReportsNoLineOnPureNoise) {
  cv::Mat noise(240, 320, CV_8U);
  cv::randn(noise, 128, 30);
  EXPECT_TRUE(DetectLines(noise, LineDetectorOptions()).empty());
}

}  // namespace
}  // namespace autocal
