#include "pipeline/camera_model.h"

#include <vector>

#include <ceres/jet.h>
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

namespace autocal {
namespace {

struct Lens {
  const char* name;
  CameraIntrinsics camera;
};

void PrintTo(const Lens& lens, std::ostream* os) { *os << lens.name; }

CameraIntrinsics MakeCamera(double fx, double fy, double cx, double cy, double k1, double k2,
                            double p1, double p2, double k3) {
  CameraIntrinsics c;
  c.width = 640;
  c.height = 480;
  c.fx = fx;
  c.fy = fy;
  c.cx = cx;
  c.cy = cy;
  c.k1 = k1;
  c.k2 = k2;
  c.p1 = p1;
  c.p2 = p2;
  c.k3 = k3;
  return c;
}

std::vector<Lens> Lenses() {
  return {
      {"pinhole", MakeCamera(500, 500, 319.5, 239.5, 0, 0, 0, 0, 0)},
      {"tessar_like", MakeCamera(417, 419, 322.0, 237.0, -0.02, 0.01, 0, 0, 0)},
      {"sonnar_like", MakeCamera(427, 427, 319.5, 239.5, -0.3, 0.1, 0, 0, 0)},
      {"strong_barrel", MakeCamera(440, 436, 316.0, 243.0, -0.35, 0.12, 0, 0, 0)},
      {"tangential_k3", MakeCamera(520, 515, 330.0, 230.0, -0.12, 0.03, 0.0015, -0.001, -0.004)},
  };
}

cv::Mat CvCameraMatrix(const CameraIntrinsics& c) {
  return (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
}

cv::Mat CvDistortion(const CameraIntrinsics& c) {
  return (cv::Mat_<double>(1, 5) << c.k1, c.k2, c.p1, c.p2, c.k3);
}

// Pixels on a grid covering the whole image, borders and corners included.
std::vector<cv::Point2d> PixelGrid(const CameraIntrinsics& c, int steps) {
  std::vector<cv::Point2d> pixels;
  for (int i = 0; i <= steps; ++i) {
    for (int j = 0; j <= steps; ++j) {
      pixels.emplace_back(-0.5 + (c.width) * double(i) / steps,
                          -0.5 + (c.height) * double(j) / steps);
    }
  }
  return pixels;
}

class CameraModelTest : public ::testing::TestWithParam<Lens> {};

TEST_P(CameraModelTest, ProjectAgreesWithOpenCv) {
  const CameraIntrinsics& camera = GetParam().camera;
  // 3-D points whose images cover the whole frame: unproject a pixel grid (with a depth
  // that varies) so that the comparison reaches the corners.
  std::vector<cv::Point3d> points;
  for (const cv::Point2d& pixel : PixelGrid(camera, 40)) {
    const auto ray = Unproject(camera, {pixel.x, pixel.y});
    ASSERT_TRUE(ray.has_value()) << pixel;
    const double depth = 0.5 + 0.01 * points.size();
    points.emplace_back(ray->x() * depth, ray->y() * depth, depth);
  }
  std::vector<cv::Point2d> expected;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), CvCameraMatrix(camera),
                    CvDistortion(camera), expected);
  double worst = 0.0;
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d ours = Project(camera, {points[i].x, points[i].y, points[i].z});
    worst = std::max(worst, (ours - Eigen::Vector2d(expected[i].x, expected[i].y)).norm());
  }
  EXPECT_LT(worst, 1e-6) << "worst disagreement with cv::projectPoints, px";
}

TEST_P(CameraModelTest, UnprojectAgreesWithOpenCv) {
  const CameraIntrinsics& camera = GetParam().camera;
  const std::vector<cv::Point2d> pixels = PixelGrid(camera, 40);
  std::vector<cv::Point2d> expected;
  // OpenCV's default stops after 5 iterations; ask it to converge fully.
  cv::undistortPoints(
      pixels, expected, CvCameraMatrix(camera), CvDistortion(camera), cv::noArray(), cv::noArray(),
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 1000, 1e-15));
  double worst = 0.0;
  for (size_t i = 0; i < pixels.size(); ++i) {
    const auto ours = Unproject(camera, {pixels[i].x, pixels[i].y});
    ASSERT_TRUE(ours.has_value()) << pixels[i];
    // Disagreement expressed in pixels at this focal length.
    const Eigen::Vector2d diff(camera.fx * (ours->x() - expected[i].x),
                               camera.fy * (ours->y() - expected[i].y));
    worst = std::max(worst, diff.norm());
  }
  EXPECT_LT(worst, 1e-6) << "worst disagreement with cv::undistortPoints, px";
}

// The undistorted pixel is OpenCV's with the camera matrix as the new projection.
TEST_P(CameraModelTest, UndistortPixelAgreesWithOpenCv) {
  const CameraIntrinsics& camera = GetParam().camera;
  const std::vector<cv::Point2d> pixels = PixelGrid(camera, 40);
  std::vector<cv::Point2d> expected;
  cv::undistortPoints(
      pixels, expected, CvCameraMatrix(camera), CvDistortion(camera), cv::noArray(),
      CvCameraMatrix(camera),
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 1000, 1e-15));
  double worst = 0.0;
  for (size_t i = 0; i < pixels.size(); ++i) {
    const auto ours = UndistortPixel(camera, {pixels[i].x, pixels[i].y});
    ASSERT_TRUE(ours.has_value()) << pixels[i];
    worst = std::max(worst, (*ours - Eigen::Vector2d(expected[i].x, expected[i].y)).norm());
  }
  EXPECT_LT(worst, 1e-6) << "worst disagreement with cv::undistortPoints, px";
}

TEST_P(CameraModelTest, UnprojectInvertsProjectTo1e9) {
  const CameraIntrinsics& camera = GetParam().camera;
  double worst = 0.0;
  for (const cv::Point2d& pixel : PixelGrid(camera, 60)) {
    const auto ray = Unproject(camera, {pixel.x, pixel.y});
    ASSERT_TRUE(ray.has_value());
    const Eigen::Vector2d back = Project(camera, {ray->x(), ray->y(), 1.0});
    worst = std::max(worst, (back - Eigen::Vector2d(pixel.x, pixel.y)).norm());
  }
  EXPECT_LT(worst, 1e-9) << "px";
}

TEST_P(CameraModelTest, JetDerivativesMatchCentralDifferences) {
  using Jet = ceres::Jet<double, kNumIntrinsics + 3>;
  const CameraIntrinsics& camera = GetParam().camera;
  const auto packed = camera.Packed();
  const std::array<double, 3> point = {0.31, -0.22, 1.7};

  std::array<Jet, kNumIntrinsics> intrinsics_jet;
  for (int i = 0; i < kNumIntrinsics; ++i) intrinsics_jet[i] = Jet(packed[i], i);
  std::array<Jet, 3> point_jet;
  for (int i = 0; i < 3; ++i) point_jet[i] = Jet(point[i], kNumIntrinsics + i);
  std::array<Jet, 2> pixel_jet;
  ProjectPoint(intrinsics_jet.data(), point_jet.data(), pixel_jet.data());

  auto project = [&](std::array<double, kNumIntrinsics> k, std::array<double, 3> p) {
    std::array<double, 2> pixel;
    ProjectPoint(k.data(), p.data(), pixel.data());
    return pixel;
  };
  for (int v = 0; v < kNumIntrinsics + 3; ++v) {
    auto k_plus = packed, k_minus = packed;
    auto p_plus = point, p_minus = point;
    const double h = 1e-6;
    if (v < kNumIntrinsics) {
      k_plus[v] += h;
      k_minus[v] -= h;
    } else {
      p_plus[v - kNumIntrinsics] += h;
      p_minus[v - kNumIntrinsics] -= h;
    }
    const auto plus = project(k_plus, p_plus), minus = project(k_minus, p_minus);
    for (int axis = 0; axis < 2; ++axis) {
      const double numeric = (plus[axis] - minus[axis]) / (2 * h);
      EXPECT_NEAR(pixel_jet[axis].v[v], numeric, 1e-4 * (1.0 + std::abs(numeric)))
          << "variable " << v << " axis " << axis;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Lenses, CameraModelTest, ::testing::ValuesIn(Lenses()),
                         [](const auto& test_param) { return std::string(test_param.param.name); });

TEST(CameraModel, UndistortReportsTheFoldOfAStrongBarrel) {
  // r_d = r (1 - 0.35 r^2) peaks at r_d = 0.65: nothing beyond maps back to a ray.
  const std::array<double, 5> dist = {-0.35, 0, 0, 0, 0};
  EXPECT_FALSE(UndistortNormalized(dist, {0.9, 0.0}).has_value());
  const auto inside = UndistortNormalized(dist, {0.5, 0.0});
  ASSERT_TRUE(inside.has_value());
  EXPECT_NEAR(inside->x() * (1 - 0.35 * inside->x() * inside->x()), 0.5, 1e-12);
}

TEST(CameraModel, CheckNamesTheWrongField) {
  CameraIntrinsics c = CameraIntrinsics::FromFieldOfView(640, 480, 75.0);
  std::string error;
  EXPECT_TRUE(c.Check(&error));
  c.fx = -1;
  EXPECT_FALSE(c.Check(&error));
  EXPECT_NE(error.find("fx"), std::string::npos) << error;
  c = CameraIntrinsics::FromFieldOfView(640, 480, 75.0);
  c.width = 0;
  EXPECT_FALSE(c.Check(&error));
  EXPECT_NE(error.find("size"), std::string::npos) << error;
}

TEST(CameraModel, FieldOfViewFixesTheFocalLength) {
  // A 90 degree lens on a 640 px wide image: the edge is at x = 1, so f = 320.
  const CameraIntrinsics c = CameraIntrinsics::FromFieldOfView(640, 480, 90.0);
  EXPECT_NEAR(c.fx, 320.0, 1e-9);
  EXPECT_DOUBLE_EQ(c.cx, 319.5);
  EXPECT_DOUBLE_EQ(c.cy, 239.5);
}

}  // namespace
}  // namespace autocal
