#include "pipeline/rectifier.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "pipeline/line_detector.h"

namespace autocal {
namespace {

CameraIntrinsics Sonnar() {
  CameraIntrinsics c;
  c.width = 320;
  c.height = 240;
  c.fx = 213.5;
  c.fy = 213.9;
  c.cx = 161.0;
  c.cy = 118.5;
  c.k1 = -0.3;
  c.k2 = 0.1;
  return c;
}

// Intensity centroid of a bright blob in a window around `near`.
Eigen::Vector2d Centroid(const cv::Mat& gray, const Eigen::Vector2d& near, int half) {
  double sum = 0, sx = 0, sy = 0;
  for (int y = int(near.y()) - half; y <= int(near.y()) + half; ++y) {
    for (int x = int(near.x()) - half; x <= int(near.x()) + half; ++x) {
      const double w = gray.at<uint8_t>(y, x);
      sum += w;
      sx += w * x;
      sy += w * y;
    }
  }
  return {sx / sum, sy / sum};
}

TEST(Rectifier, DefaultOptionsAreValid) {
  std::string error;
  EXPECT_TRUE(RectifyOptions().Check(&error)) << error;
  RectifyOptions bad;
  bad.clahe_tiles = 0;
  EXPECT_FALSE(bad.Check(&error));
  EXPECT_NE(error.find("clahe_tiles"), std::string::npos);
}

// A blob imaged through the lens at Project(X) lands, after undistortion, where the
// ideal pinhole puts X: K (X/Z).
TEST(Rectifier, UndistortionPutsPointsWhereThePinholeDoes) {
  const CameraIntrinsics camera = Sonnar();
  RectifyOptions options;
  options.equalization = Equalization::kNone;
  Rectifier rectifier(options);
  const Eigen::Vector2d ideal_points[] = {{0.55, 0.4}, {-0.6, -0.35}, {0.1, -0.5}, {-0.45, 0.45}};
  for (const Eigen::Vector2d& x : ideal_points) {
    // Render a Gaussian blob at the distorted position (sigma 1.2 px).
    const Eigen::Vector2d distorted = Project(camera, {x.x(), x.y(), 1.0});
    cv::Mat raw(camera.height, camera.width, CV_8U);
    for (int v = 0; v < raw.rows; ++v) {
      for (int u = 0; u < raw.cols; ++u) {
        const double d2 = (Eigen::Vector2d(u, v) - distorted).squaredNorm();
        raw.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(250 * std::exp(-d2 / (2 * 1.44)));
      }
    }
    const cv::Mat rectified = rectifier.Geometry(raw, camera);
    const Eigen::Vector2d expected(camera.fx * x.x() + camera.cx, camera.fy * x.y() + camera.cy);
    const Eigen::Vector2d found = Centroid(rectified, expected, 6);
    // The blob is stretched by the undistortion, so its centroid is good to ~0.2 px.
    EXPECT_LT((found - expected).norm(), 0.3) << "ideal " << x.transpose();
    EXPECT_GT((distorted - expected).norm(), 5.0) << "the lens must move this point";
  }
  EXPECT_EQ(rectifier.map_builds(), 1) << "same calibration: maps built once";
  CameraIntrinsics changed = camera;
  changed.fx *= 1.01;
  rectifier.Geometry(cv::Mat::zeros(camera.height, camera.width, CV_8U), changed);
  EXPECT_EQ(rectifier.map_builds(), 2) << "new calibration: maps rebuilt";
}

TEST(Rectifier, GlobalEqualizationIsEquationOne) {
  // h(v) = round((cdf(v) - cdf_min) / (M N - cdf_min) (L - 1)), worked on a 2x4 image.
  const cv::Mat image = (cv::Mat_<uint8_t>(2, 4) << 10, 10, 20, 20, 20, 30, 40, 40);
  // cdf: 10 -> 2, 20 -> 5, 30 -> 6, 40 -> 8; cdf_min = 2, M N = 8.
  const uint8_t expected[] = {0, 0, 128, 128, 128, 170, 255, 255};
  RectifyOptions options;
  options.undistort = false;
  options.equalization = Equalization::kGlobal;
  const cv::Mat equalized = Rectifier(options).Equalize(image);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(equalized.at<uint8_t>(i / 4, i % 4), expected[i]) << i;
}

TEST(Rectifier, LocalEqualizationFlattensVignetting) {
  // A texture with the same statistics everywhere, darkened by cos^4 toward the corners.
  cv::Mat texture(240, 320, CV_8U);
  cv::randu(texture, 60, 200);
  cv::GaussianBlur(texture, texture, cv::Size(), 1.5);
  cv::Mat vignetted(texture.size(), CV_8U);
  const double f = 200.0;
  for (int y = 0; y < texture.rows; ++y) {
    for (int x = 0; x < texture.cols; ++x) {
      const double r2 = (std::pow(x - 159.5, 2) + std::pow(y - 119.5, 2)) / (f * f);
      vignetted.at<uint8_t>(y, x) =
          cv::saturate_cast<uint8_t>(texture.at<uint8_t>(y, x) / ((1 + r2) * (1 + r2)));
    }
  }
  auto corner_to_centre = [](const cv::Mat& image) {
    const double centre = cv::mean(image(cv::Rect(130, 90, 60, 60)))[0];
    const double corner = cv::mean(image(cv::Rect(0, 0, 60, 60)))[0];
    return corner / centre;
  };
  RectifyOptions options;
  options.undistort = false;
  const cv::Mat flattened = Rectifier(options).Equalize(vignetted);
  // Per-tile equalization with a contrast limit lifts the dark corners part of the way.
  EXPECT_LT(corner_to_centre(vignetted), 0.42);
  EXPECT_GT(corner_to_centre(flattened), 1.25 * corner_to_centre(vignetted));
  RectifyOptions global = options;
  global.equalization = Equalization::kGlobal;
  EXPECT_LT(corner_to_centre(Rectifier(global).Equalize(vignetted)), corner_to_centre(flattened))
      << "one grey-level map for the whole image cannot undo a spatial falloff";
}

TEST(Rectifier, GreenChannelKeepsEdgesWhereTheyAre) {
  // A vertical edge at x = 100.5 in green; red and blue fringes displaced by 2 px.
  cv::Mat bgr(60, 200, CV_8UC3);
  for (int y = 0; y < bgr.rows; ++y) {
    for (int x = 0; x < bgr.cols; ++x) {
      auto step = [&](double edge) { return cv::saturate_cast<uint8_t>(x > edge ? 200 : 40); };
      bgr.at<cv::Vec3b>(y, x) = {step(102.5), step(100.5), step(102.5)};
    }
  }
  auto edge_x = [](const cv::Mat& gray) {
    const Gradients gradients(gray, 1.0);
    Eigen::Vector2d edge;
    EXPECT_TRUE(LocateEdgeAlongNormal(gradients, {100, 30}, {1, 0}, 5, 1, &edge));
    return edge.x();
  };
  RectifyOptions options;
  options.undistort = false;
  options.equalization = Equalization::kNone;
  EXPECT_NEAR(edge_x(Rectifier(options).Channel(bgr)), 100.5, 0.05);
  options.green_channel = false;
  EXPECT_GT(std::abs(edge_x(Rectifier(options).Channel(bgr)) - 100.5), 0.4)
      << "a grey mix of the channels moves the edge";
}

}  // namespace
}  // namespace autocal
