// Box 1 on rendered images of known 3-D lines: the simulator's checkerboard (its grid and
// its outline) seen through a distortion-free lens from oblique viewpoints.
#include <cmath>
#include <cstdio>
#include <ostream>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "devices/sim/renderer.h"
#include "devices/sim/scene.h"
#include "devices/sim/simulator.h"
#include "pipeline/line_detector.h"
#include "tests/sim_test_util.h"

namespace autocal {
namespace {

struct ImageLine {
  double rho, theta;
};

// The image line through the pinhole images of two world points.
ImageLine Through(const CameraIntrinsics& k, const Eigen::Isometry3d& cam_from_world,
                  const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector2d pa = Project(k, cam_from_world * a), pb = Project(k, cam_from_world * b);
  const Eigen::Vector2d d = (pb - pa).normalized();
  const Eigen::Vector2d normal(-d.y(), d.x());
  double theta = std::atan2(normal.y(), normal.x());
  double rho = normal.dot(pa);
  if (theta < 0) {
    theta += M_PI;
    rho = -rho;
  }
  return {rho, theta};
}

struct View {
  double yaw_deg, pitch_deg, roll_deg, distance_m;
};

void PrintTo(const View& v, std::ostream* out) {
  *out << "yaw " << v.yaw_deg << " pitch " << v.pitch_deg << " roll " << v.roll_deg << " at "
       << v.distance_m << " m";
}

class LinesSimulatedTest : public ::testing::TestWithParam<View> {};

TEST_P(LinesSimulatedTest, FindsTheBoardsLinesWhereTheyAre) {
  Scenario scenario;
  scenario.scene = "checkerboard";
  scenario.motion.type = "static";
  const CheckerboardOptions& board = scenario.checkerboard;
  const auto scene = BuildScene(scenario);
  const Plane& plane = scene->planes.front();

  CameraIntrinsics pinhole = CameraIntrinsics::FromFieldOfView(640, 480, 75.0);
  pinhole.cx += 3.0;
  pinhole.cy -= 2.0;
  const View& view = GetParam();
  const Eigen::Isometry3d world_from_cam =
      test::LookingAt(plane.Point(0.5 * plane.width_m, 0.5 * plane.height_m), view.distance_m,
                      view.yaw_deg, view.pitch_deg, view.roll_deg);
  RenderOptions options;
  options.effects.noise_sigma = 2.0;
  const RenderedFrame frame = Renderer(scene).Render(pinhole, world_from_cam, options);
  cv::Mat grey;
  cv::cvtColor(frame.image, grey, cv::COLOR_BGR2GRAY);

  // The grid lines between squares and the board's outline, all straight in the world.
  const Eigen::Isometry3d cam_from_world = world_from_cam.inverse();
  const double s = board.square_m;
  std::vector<ImageLine> truth;
  for (int i = 0; i <= board.squares_x; ++i) {
    truth.push_back(Through(pinhole, cam_from_world, plane.Point((i + 1) * s, s),
                            plane.Point((i + 1) * s, (board.squares_y + 1) * s)));
  }
  for (int j = 0; j <= board.squares_y; ++j) {
    truth.push_back(Through(pinhole, cam_from_world, plane.Point(s, (j + 1) * s),
                            plane.Point((board.squares_x + 1) * s, (j + 1) * s)));
  }
  truth.push_back(
      Through(pinhole, cam_from_world, plane.Point(0, 0), plane.Point(plane.width_m, 0)));
  truth.push_back(Through(pinhole, cam_from_world, plane.Point(0, plane.height_m),
                          plane.Point(plane.width_m, plane.height_m)));
  truth.push_back(
      Through(pinhole, cam_from_world, plane.Point(0, 0), plane.Point(0, plane.height_m)));
  truth.push_back(Through(pinhole, cam_from_world, plane.Point(plane.width_m, 0),
                          plane.Point(plane.width_m, plane.height_m)));

  LineDetectorOptions line_options;
  line_options.max_lines = 60;
  const std::vector<LineSegment> found = DetectLines(grey, line_options);
  std::vector<bool> matched(truth.size(), false);
  double worst_rho = 0.0, worst_theta = 0.0;
  for (const LineSegment& segment : found) {
    double best_rho = 1e9, best_theta = 1e9;
    size_t best = 0;
    for (size_t t = 0; t < truth.size(); ++t) {
      const auto [dtheta, drho] =
          LineDistance(segment.rho, segment.theta, truth[t].rho, truth[t].theta);
      if (drho + 100 * dtheta < best_rho + 100 * best_theta) {
        best_rho = drho;
        best_theta = dtheta;
        best = t;
      }
    }
    matched[best] = true;
    worst_rho = std::max(worst_rho, best_rho);
    worst_theta = std::max(worst_theta, best_theta * 180 / M_PI);
    EXPECT_LT(best_rho, 0.5) << "segment " << segment.start.transpose() << " -> "
                             << segment.end.transpose() << " is off every true line";
    EXPECT_LT(best_theta * 180 / M_PI, 0.2);
  }
  const int found_lines = static_cast<int>(std::count(matched.begin(), matched.end(), true));
  std::printf("%zu segments on %d of %zu true lines; worst %.3f px, %.3f deg\n", found.size(),
              found_lines, truth.size(), worst_rho, worst_theta);
  EXPECT_GE(found_lines, int(0.8 * truth.size())) << "true lines found";
}

INSTANTIATE_TEST_SUITE_P(Views, LinesSimulatedTest,
                         ::testing::Values(View{0, 0, 12, 0.6}, View{28, -8, -5, 0.55},
                                           View{-20, 15, 30, 0.5}));

}  // namespace
}  // namespace autocal
