#include "pipeline/virtual_board.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "tests/test_util.h"

namespace autocal {
namespace {

// A floor seen from 1.5 m up, looking ahead and slightly down, through a strong barrel: a
// board 12 m long on it reaches far past the image's field, where the lens polynomial folds
// back. Every point drawn must be a true image of its board point (unprojecting the pixel
// gives the point's own ray), so nothing folded is drawn near the image centre.
TEST(VirtualBoard, ProjectionDrawsOnlyTrueImagesOfTheBoard) {
  const CameraIntrinsics camera = test::SonnarLikeCamera(-0.32, 0.11);
  VirtualBoard board;
  board.plane_id = 1;
  // The floor y = 1.5 in the camera (y down), plane axes x (right) and z (ahead).
  const double pitch = 10.0 * M_PI / 180;  // Looking down a little.
  Eigen::Isometry3d cam_from_world = Eigen::Isometry3d::Identity();
  cam_from_world.linear() = Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitX()).toRotationMatrix();
  board.world_from_plane.linear() << 1, 0, 0, 0, 0, 1, 0, 1, 0;
  board.world_from_plane.translation() = Eigen::Vector3d(0.0, 1.5, 0.0);
  board.origin = Eigen::Vector2d(-6.0, 0.2);
  board.square = 1.0;
  board.squares_x = 12;
  board.squares_y = 12;
  const Eigen::Isometry3d cam_from_plane = cam_from_world * board.world_from_plane;

  VirtualBoardOptions options;
  const BoardProjection projection = ProjectBoard(board, cam_from_world, camera, options);
  ASSERT_FALSE(projection.lines.empty()) << "part of the board is in view";
  int points = 0;
  for (const auto& line : projection.lines) {
    for (const Eigen::Vector2d& pixel : line) {
      const auto ray = Unproject(camera, pixel);
      ASSERT_TRUE(ray) << "drawn beyond the lens's fold at " << pixel.transpose();
      // Which board point is this? The ray meets the plane once.
      const Eigen::Vector3d direction(ray->x(), ray->y(), 1.0);
      const Eigen::Vector3d normal = cam_from_plane.linear().col(2);
      const double depth = normal.dot(cam_from_plane.translation()) / normal.dot(direction);
      ASSERT_GT(depth, 0.0) << "the pixel's ray meets the board behind the camera";
      const Eigen::Vector3d on_board = cam_from_plane.inverse() * (depth * direction);
      EXPECT_NEAR(on_board.z(), 0.0, 1e-6);
      // On the board's rectangle (with a small tolerance for the unprojection).
      const Eigen::Vector2d uv = on_board.head<2>() - board.origin;
      EXPECT_GE(uv.x(), -1e-3);
      EXPECT_LE(uv.x(), board.square * board.squares_x + 1e-3);
      EXPECT_GE(uv.y(), -1e-3);
      EXPECT_LE(uv.y(), board.square * board.squares_y + 1e-3);
      // And on one of its grid lines: one coordinate a whole number of squares.
      const double off_i = std::abs(uv.x() / board.square - std::round(uv.x() / board.square));
      const double off_j = std::abs(uv.y() / board.square - std::round(uv.y() / board.square));
      EXPECT_LT(std::min(off_i, off_j), 1e-3) << "pixel " << pixel.transpose();
      ++points;
    }
  }
  EXPECT_GT(points, 100);
}

// Box 10 placed one of the office wall's tracks 400 times the patch's size away: the board
// covers the patch, not the way to that point.
TEST(VirtualBoard, AttachedOverThePatchNotOverAnOutlyingPoint) {
  std::vector<std::pair<int, Eigen::Vector2d>> tracked;
  for (int k = 0; k < 40; ++k) {
    tracked.emplace_back(k, Eigen::Vector2d(0.1 * (k % 8), 0.12 * (k / 8)));  // 0.7 x 0.48.
  }
  tracked.emplace_back(99, Eigen::Vector2d(-420.0, 143.0));
  const VirtualBoardOptions options;
  const VirtualBoard board = AttachBoard(3, Eigen::Isometry3d::Identity(), tracked, options);
  EXPECT_EQ(board.tracked.size(), 40u);
  EXPECT_TRUE(std::none_of(board.tracked.begin(), board.tracked.end(),
                           [](const auto& entry) { return entry.first == 99; }));
  // Corner (0, 0) on the first point; the squares fit the patch on both axes (0.7 / 8 and
  // 0.48 / 6 m: the smaller).
  EXPECT_TRUE(board.origin.isApprox(Eigen::Vector2d(0.0, 0.0)));
  EXPECT_NEAR(board.square, 0.08, 1e-9);
  for (const Eigen::Vector2d& corner : board.outline) {
    EXPECT_GE(corner.minCoeff(), -1e-6);
    EXPECT_LE(corner.x(), 0.7 + 1e-6);
    EXPECT_LE(corner.y(), 0.48 + 1e-6);
  }
  EXPECT_EQ(board.outline.size(), 4u) << "the patch's corners";
}

// Only the part of the board inside its outline (where the plane's tracks were) is drawn:
// every drawn pixel's ray meets the plane inside the outline.
TEST(VirtualBoard, ProjectionStaysInsideTheOutline) {
  const CameraIntrinsics camera = test::SonnarLikeCamera();
  VirtualBoard board;
  board.world_from_plane.translation() = Eigen::Vector3d(-1.0, -0.8, 3.0);
  board.square = 0.25;
  board.outline = {{0.0, 0.0}, {2.0, 0.0}, {0.0, 1.5}};  // The rectangle's lower-left half.
  const Eigen::Isometry3d cam_from_world = Eigen::Isometry3d::Identity();
  const BoardProjection projection = ProjectBoard(board, cam_from_world, camera, {});
  int points = 0;
  for (const auto& line : projection.lines) {
    for (const Eigen::Vector2d& pixel : line) {
      const auto ray = Unproject(camera, pixel);
      ASSERT_TRUE(ray);
      const double depth = 3.0;  // The plane z = 3 in the camera.
      const Eigen::Vector2d uv = depth * *ray - Eigen::Vector2d(-1.0, -0.8);
      EXPECT_GE(uv.x(), -1e-4);
      EXPECT_GE(uv.y(), -1e-4);
      EXPECT_LE(uv.x() / 2.0 + uv.y() / 1.5, 1.0 + 1e-4) << "beyond the outline's diagonal";
      ++points;
    }
  }
  // Each of the 9 + 7 grid lines crosses the triangle, but the corner (2, 1.5) and its two
  // edges do not.
  EXPECT_EQ(projection.lines.size(), 14u);
  EXPECT_GT(points, 60);
}

}  // namespace
}  // namespace autocal
