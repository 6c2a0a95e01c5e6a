#include "pipeline/radon_snake.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "pipeline/camera_model.h"
#include "tests/test_util.h"

namespace autocal {
namespace {

// Renders the image of the world line n . x = c (x in ideal normalized coordinates)
// through the lens exactly: bright on one side, dark on the other, pixels near the
// curve supersampled 4x4 through the exact inverse distortion.
class LineRenderer {
 public:
  explicit LineRenderer(const CameraIntrinsics& camera) : camera_(camera) {
    rays_.resize(size_t(camera.width) * camera.height);
    for (int y = 0; y < camera.height; ++y) {
      for (int x = 0; x < camera.width; ++x)
        rays_[y * camera.width + x] = *Unproject(camera, {x, y});
    }
  }

  cv::Mat Render(const Eigen::Vector2d& normal, double offset, cv::RNG& rng) const {
    cv::Mat image(camera_.height, camera_.width, CV_32F);
    for (int y = 0; y < camera_.height; ++y) {
      for (int x = 0; x < camera_.width; ++x) {
        const double f = normal.dot(rays_[y * camera_.width + x]) - offset;
        double bright;
        if (std::abs(f) * camera_.fx > 2.0) {
          bright = f > 0 ? 1.0 : 0.0;
        } else {
          int inside = 0;
          for (int i = 0; i < 4; ++i) {
            for (int j = 0; j < 4; ++j) {
              const auto ray = Unproject(camera_, {x - 0.375 + 0.25 * j, y - 0.375 + 0.25 * i});
              inside += normal.dot(*ray) - offset > 0;
            }
          }
          bright = inside / 16.0;
        }
        image.at<float>(y, x) = float(50.0 + 150.0 * bright + rng.gaussian(2.0));
      }
    }
    cv::Mat gray;
    image.convertTo(gray, CV_8U);
    return gray;
  }

  // The true image of the line, as a dense polyline.
  std::vector<Eigen::Vector2d> TrueCurve(const Eigen::Vector2d& normal, double offset) const {
    const Eigen::Vector2d direction(-normal.y(), normal.x());
    std::vector<Eigen::Vector2d> curve;
    for (double s = -1.5; s <= 1.5; s += 0.0005) {
      const Eigen::Vector2d x = offset * normal + s * direction;
      curve.push_back(Project(camera_, {x.x(), x.y(), 1.0}));
    }
    return curve;
  }

 private:
  CameraIntrinsics camera_;
  std::vector<Eigen::Vector2d> rays_;
};

double DistanceToCurve(const Eigen::Vector2d& p, const std::vector<Eigen::Vector2d>& curve) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 1; i < curve.size(); ++i) {
    const Eigen::Vector2d a = curve[i - 1], ab = curve[i] - a;
    const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (a + t * ab - p).norm());
  }
  return best;
}

TEST(RadonSnake, DefaultOptionsAreValid) {
  std::string error;
  EXPECT_TRUE(SnakeOptions().Check(&error)) << error;
  SnakeOptions bad;
  bad.search_px = 20;
  EXPECT_FALSE(bad.Check(&error));
  EXPECT_NE(error.find("search_px"), std::string::npos);
}

TEST(RadonSnake, BendAnglesAreZeroOnlyWhenStraight) {
  RadonSnake snake;
  snake.vertices = {{0, 0}, {10, 0}, {20, 0}, {30, 0}};
  for (double bend : snake.BendAngles()) EXPECT_NEAR(bend, 0.0, 1e-12);
  snake.vertices[2] = {20, 1};
  const auto bends = snake.BendAngles();
  ASSERT_EQ(bends.size(), 2u);
  EXPECT_NEAR(bends[0], std::atan2(1, 10) * 180 / M_PI, 1e-9);
  EXPECT_NEAR(bends[1], -2 * std::atan2(1, 10) * 180 / M_PI, 1e-9);
}

// A world line seen first through the principal point (straight in the image), then
// moving to the border, where the sonnar lens bends it strongly: the snake stays on the
// true curve within 0.5 px all the way, including within 10% of the border.
TEST(RadonSnake, FollowsALineBentByTheLensToTheBorder) {
  const CameraIntrinsics camera = test::SonnarLikeCamera();
  const LineRenderer renderer(camera);
  const Eigen::Vector2d normal(std::cos(4 * M_PI / 180), std::sin(4 * M_PI / 180));
  cv::RNG rng(3);
  SnakeTracker tracker;
  int snake_id = 0;
  double worst = 0.0, worst_near_border = 0.0;
  int vertices_near_border = 0;
  const int frames = 70;
  for (int frame = 0; frame < frames; ++frame) {
    const double offset = -0.02 + 0.82 * frame / (frames - 1);
    const cv::Mat image = renderer.Render(normal, offset, rng);
    const Gradients gradients(image, 1.0);
    const std::vector<LineSegment> lines =
        frame == 0 ? DetectLines(image, LineDetectorOptions()) : std::vector<LineSegment>{};
    tracker.Update(gradients, lines, {camera.cx, camera.cy}, image.size());
    ASSERT_EQ(tracker.snakes().size(), 1u) << "frame " << frame;
    const RadonSnake& snake = tracker.snakes().front();
    if (frame == 0) snake_id = snake.id;
    EXPECT_EQ(snake.id, snake_id) << "the snake was lost at frame " << frame;
    const auto curve = renderer.TrueCurve(normal, offset);
    for (const Eigen::Vector2d& v : snake.vertices) {
      const double d = DistanceToCurve(v, curve);
      worst = std::max(worst, d);
      if (v.x() > 0.9 * camera.width) {
        ++vertices_near_border;
        worst_near_border = std::max(worst_near_border, d);
      }
    }
  }
  std::printf(
      "worst vertex distance to the true curve %.3f px (%.3f px within 10%% of the "
      "border, %d vertices there)\n",
      worst, worst_near_border, vertices_near_border);
  EXPECT_LT(worst, 0.5);
  EXPECT_GT(vertices_near_border, 50);
  // At the border the snake is visibly bent: the bends add up to the curve's turn.
  const auto bends = tracker.snakes().front().BendAngles();
  double total = 0.0;
  for (double b : bends) total += b;
  EXPECT_GT(std::abs(total), 5.0) << "degrees of turn along the final snake";
  // And it reaches from near the top to near the bottom of the image.
  EXPECT_GT(tracker.snakes().front().Length(), 0.8 * camera.height);
}

}  // namespace
}  // namespace autocal
