// The 3-D view's scene from a judged attempt: camera centres, the frustum through the image
// corners of a distorting lens, boards split into squares on their planes, gravity.
#include <cmath>

#include <gtest/gtest.h>

#include "pipeline/scene_geometry.h"

namespace autocal {
namespace {

CameraIntrinsics Lens() {
  CameraIntrinsics c;
  c.width = 320;
  c.height = 240;
  c.fx = c.fy = 250.0;
  c.cx = 161.0;
  c.cy = 118.0;
  c.k1 = -0.2;
  c.k2 = 0.05;
  return c;
}

// Three views walking along x and turning, one left out by box 10, and a wall at z = 2.
AttemptOutcome Attempt() {
  AttemptOutcome attempt;
  for (int i = 0; i < 4; ++i) {
    if (i == 2) {
      attempt.cam_from_world.push_back(std::nullopt);
      continue;
    }
    Eigen::Isometry3d world_from_cam = Eigen::Isometry3d::Identity();
    world_from_cam.linear() = Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d::UnitY()).matrix();
    world_from_cam.translation() = Eigen::Vector3d(0.2 * i, 0.05 * i, 0.0);
    attempt.cam_from_world.push_back(world_from_cam.inverse());
  }
  Eigen::Isometry3d world_from_plane = Eigen::Isometry3d::Identity();
  world_from_plane.translation() = Eigen::Vector3d(0.0, 0.0, 2.0);
  VirtualBoardOptions options;
  attempt.boards.push_back(
      AttachBoard(7, world_from_plane, {{-0.5, -0.4}, {0.7, 0.5}, {0.1, 0.0}}, options));
  return attempt;
}

TEST(SceneGeometry, TrajectoryFrustumBoardsAndGravity) {
  AttemptOutcome attempt = Attempt();
  // Without an outline the whole board is drawn (cut to it: CutToTheTrackedOutline).
  attempt.boards.front().outline.clear();
  const CameraIntrinsics lens = Lens();
  const Eigen::Vector3d gravity_cam(0.3, 9.7, 0.5);
  const std::optional<SceneGeometry> scene = MakeSceneGeometry(attempt, lens, gravity_cam);
  ASSERT_TRUE(scene);

  ASSERT_EQ(scene->trajectory.size(), 3u) << "the view box 10 left out has no centre";
  EXPECT_TRUE(scene->trajectory[1].isApprox(Eigen::Vector3d(0.2, 0.05, 0.0), 1e-12));
  EXPECT_TRUE(scene->trajectory[2].isApprox(Eigen::Vector3d(0.6, 0.15, 0.0), 1e-12));
  const Eigen::Isometry3d cam_from_world = *attempt.cam_from_world.back();
  EXPECT_TRUE(scene->world_from_camera.isApprox(cam_from_world.inverse(), 1e-12));

  // Half way from the newest camera to the board's centre.
  const VirtualBoard& board = attempt.boards.front();
  const Eigen::Vector3d board_centre =
      (board.Corner(0, 0) + board.Corner(board.squares_x, board.squares_y)) / 2.0;
  EXPECT_NEAR(scene->frustum_depth, 0.5 * (board_centre - scene->trajectory.back()).norm(), 1e-12);

  // The frustum's edges are the rays of the image corners through the distorting lens.
  EXPECT_TRUE(scene->frustum[0].isApprox(scene->trajectory.back(), 1e-12));
  const Eigen::Vector2d corners[] = {{0, 0}, {319, 0}, {319, 239}, {0, 239}};
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d in_camera = cam_from_world * scene->frustum[size_t(k) + 1];
    EXPECT_NEAR(in_camera.z(), scene->frustum_depth, 1e-9);
    const Eigen::Vector2d pixel = Project(lens, in_camera);
    EXPECT_NEAR(pixel.x(), corners[k].x(), 1e-6) << k;
    EXPECT_NEAR(pixel.y(), corners[k].y(), 1e-6) << k;
  }
  // Barrel distortion: the corner rays reach wider than a pinhole's would.
  const Eigen::Vector3d corner_ray = cam_from_world * scene->frustum[1];
  EXPECT_GT(std::abs(corner_ray.x() / corner_ray.z()), (lens.cx - 0.0) / lens.fx);

  // The board in squares, all on its plane (z = 2), alternating, inside the grown plane.
  ASSERT_EQ(scene->boards.size(), 1u);
  const SceneBoard& drawn = scene->boards.front();
  EXPECT_EQ(drawn.plane_id, 7);
  EXPECT_EQ(drawn.dark.size() + drawn.light.size(), size_t(board.squares_x * board.squares_y));
  EXPECT_EQ(drawn.dark.size(), drawn.light.size());
  EXPECT_TRUE(drawn.light.front()[0].isApprox(board.Corner(1, 0), 1e-12));
  for (const auto* squares : {&drawn.dark, &drawn.light}) {
    for (const auto& square : *squares) {
      for (const Eigen::Vector3d& corner : square) EXPECT_NEAR(corner.z(), 2.0, 1e-12);
    }
  }
  EXPECT_TRUE(drawn.dark.front()[0].isApprox(board.Corner(0, 0), 1e-12));
  EXPECT_TRUE(drawn.plane[0].isApprox(board.Corner(-1, -1), 1e-12));
  EXPECT_TRUE(
      drawn.plane[2].isApprox(board.Corner(board.squares_x + 1, board.squares_y + 1), 1e-12));
  // The border runs from the plane's outline to the board's.
  EXPECT_TRUE(drawn.border[0][0].isApprox(drawn.plane[0], 1e-12));
  EXPECT_TRUE(drawn.border[0][3].isApprox(board.Corner(0, 0), 1e-12));
  EXPECT_TRUE(drawn.border[2][2].isApprox(board.Corner(0, board.squares_y), 1e-12));

  ASSERT_TRUE(scene->gravity);
  EXPECT_NEAR(scene->gravity->norm(), 1.0, 1e-12);
  EXPECT_TRUE(scene->gravity->isApprox(cam_from_world.inverse().linear() * gravity_cam.normalized(),
                                       1e-12));
  // Down, nearly along the wall: it meets the wall's plane far beyond the frustum's depth.
  EXPECT_EQ(scene->gravity_length, scene->frustum_depth);
}

// Gravity is drawn from the camera down, stopping short of the floor: with the floor 0.3
// below the newest camera (the frustum reaches 0.5 and more), at 0.8 of the way to it.
TEST(SceneGeometry, GravityStopsShortOfTheFloor) {
  AttemptOutcome attempt = Attempt();
  const Eigen::Isometry3d world_from_cam = attempt.cam_from_world.back()->inverse();
  Eigen::Isometry3d world_from_floor = Eigen::Isometry3d::Identity();
  world_from_floor.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).matrix();
  world_from_floor.translation() = world_from_cam.translation() + Eigen::Vector3d(0.4, 0.3, 1.0);
  attempt.boards.push_back(
      AttachBoard(8, world_from_floor, {{-0.5, -0.4}, {0.7, 0.5}, {0.1, 0.3}}, VirtualBoardOptions()));
  const Eigen::Vector3d down_world(0.0, 1.0, 0.0);  // The floor's normal, +y.
  const std::optional<SceneGeometry> scene =
      MakeSceneGeometry(attempt, Lens(), world_from_cam.linear().transpose() * down_world);
  ASSERT_TRUE(scene && scene->gravity);
  ASSERT_GT(scene->frustum_depth, 0.3);
  EXPECT_NEAR(scene->gravity_length, 0.8 * 0.3, 1e-9);
}

// The board as the video overlay draws it: only within the hull of the plane's tracked
// points, here the triangle (-0.5, -0.4), (0.7, 0.5), (0.1, 0) on the wall z = 2, which
// lies within the board grown by a square; its area, worked by hand, is 0.03.
TEST(SceneGeometry, CutToTheTrackedOutline) {
  const AttemptOutcome attempt = Attempt();
  ASSERT_EQ(attempt.boards.front().outline.size(), 3u);
  const std::optional<SceneGeometry> scene = MakeSceneGeometry(attempt, Lens(), std::nullopt);
  ASSERT_TRUE(scene);
  const SceneBoard& drawn = scene->boards.front();
  const Eigen::Vector2d a(-0.5, -0.4), b(0.7, 0.5), c(0.1, 0.0);
  auto cross = [](const Eigen::Vector2d& u, const Eigen::Vector2d& v) {
    return u.x() * v.y() - u.y() * v.x();
  };
  double area = 0.0;
  int polygons = 0;
  for (const auto* pieces : {&drawn.dark, &drawn.light, &drawn.border}) {
    for (const ScenePolygon& polygon : *pieces) {
      ASSERT_GE(polygon.size(), 3u);
      ++polygons;
      for (size_t k = 0; k < polygon.size(); ++k) {
        const Eigen::Vector3d& p = polygon[k];
        EXPECT_NEAR(p.z(), 2.0, 1e-12);
        const Eigen::Vector2d q = p.head<2>();
        // Inside the triangle (clockwise): on the inner side of each edge, within the
        // rounding of the outline (cv::convexHull keeps it in float).
        EXPECT_LE(cross(b - a, q - a), 1e-7) << q.transpose();
        EXPECT_LE(cross(c - b, q - b), 1e-7) << q.transpose();
        EXPECT_LE(cross(a - c, q - c), 1e-7) << q.transpose();
        area += 0.5 * cross(p.head<2>(), polygon[(k + 1) % polygon.size()].head<2>());
      }
    }
  }
  EXPECT_GT(polygons, 3);
  EXPECT_NEAR(std::abs(area), 0.03, 1e-7) << "the pieces cover the triangle, once";
}

TEST(SceneGeometry, NothingWithoutAPoseAndNoGravityUnlessKnown) {
  AttemptOutcome unposed;
  unposed.cam_from_world = {std::nullopt, std::nullopt};
  EXPECT_FALSE(MakeSceneGeometry(unposed, Lens(), Eigen::Vector3d(0, 9.8, 0)));

  AttemptOutcome no_boards = Attempt();
  no_boards.boards.clear();
  const std::optional<SceneGeometry> scene = MakeSceneGeometry(no_boards, Lens(), std::nullopt);
  ASSERT_TRUE(scene);
  EXPECT_FALSE(scene->gravity);
  EXPECT_DOUBLE_EQ(scene->frustum_depth, 0.5) << "half the first point's depth";
}

}  // namespace
}  // namespace autocal
