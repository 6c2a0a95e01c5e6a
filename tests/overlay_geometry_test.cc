#include "pipeline/overlay_geometry.h"

#include <cmath>
#include <limits>
#include <utility>

#include <gtest/gtest.h>

#include "tests/test_util.h"

namespace autocal {
namespace {

// A frame with one of everything, in raw pixels of a sonnar-like lens.
FrameSnapshot Frame() {
  FrameSnapshot frame;
  frame.working = test::SonnarLikeCamera();
  LineSegment line;
  line.start = {20, 30};
  line.end = {300, 40};
  frame.lens.lines.push_back(line);
  RadonSnake snake;
  snake.id = 4;
  snake.vertices = {{40, 200}, {80, 204}, {120, 206}, {160, 207}, {200, 206}};
  frame.lens.snakes.push_back(snake);
  Track track;
  track.id = 9;
  track.history = {{0, cv::Point2f(50, 60)}, {1, cv::Point2f(53, 61)}};
  frame.motion.tracks.push_back(track);
  DominantPlane plane;
  plane.id = 2;
  plane.track_ids = {9};
  plane.points = {cv::Point2f(100, 100), cv::Point2f(140, 100), cv::Point2f(120, 140)};
  plane.outline = plane.points;
  frame.motion.planes.push_back(plane);
  frame.inertial.gravity_cam = Eigen::Vector3d(0.0, 9.81, 0.0);
  frame.inertial.gravity_sigma_deg = 0.7;
  return frame;
}

TEST(OverlayGeometry, RawSpaceKeepsThePipelinesPixels) {
  const FrameSnapshot frame = Frame();
  const OverlayGeometry overlay = MakeOverlayGeometry(frame, {}, {}, OverlaySpace::kRaw);
  ASSERT_EQ(overlay.lines.size(), 1u);
  EXPECT_EQ(overlay.lines[0], (Polyline{{20, 30}, {300, 40}}));
  ASSERT_EQ(overlay.snakes.size(), 1u);
  EXPECT_EQ(overlay.snakes[0].id, 4);
  EXPECT_EQ(overlay.snakes[0].vertices, frame.lens.snakes[0].vertices);
  const std::vector<double> bends = frame.lens.snakes[0].BendAngles();
  ASSERT_EQ(overlay.snakes[0].bend_deg.size(), 5u);
  EXPECT_EQ(overlay.snakes[0].bend_deg.front(), 0.0);
  EXPECT_EQ(overlay.snakes[0].bend_deg.back(), 0.0);
  for (size_t i = 0; i < bends.size(); ++i) EXPECT_EQ(overlay.snakes[0].bend_deg[i + 1], bends[i]);
  ASSERT_EQ(overlay.tracks.size(), 1u);
  EXPECT_EQ(overlay.tracks[0].plane_id, 2);
  EXPECT_EQ(overlay.tracks[0].now, Eigen::Vector2d(53, 61));
  ASSERT_TRUE(overlay.tracks[0].previous);
  EXPECT_EQ(*overlay.tracks[0].previous, Eigen::Vector2d(50, 60));
  ASSERT_EQ(overlay.planes.size(), 1u);
  EXPECT_EQ(overlay.planes[0].hull.size(), 3u);
  EXPECT_NEAR((overlay.planes[0].centre - Eigen::Vector2d(120, 340.0 / 3)).norm(), 0.0, 1e-9);
}

// Box 2's verdict goes with every frame once there is an estimate, in words the widgets
// show as they are.
TEST(OverlayGeometry, CarriesBox2sVerdictOnTheLens) {
  FrameSnapshot frame = Frame();
  EXPECT_EQ(MakeOverlayGeometry(frame, {}, {}, OverlaySpace::kRaw).lens_verdict, "")
      << "no estimate yet";
  PlumbLineResult refused;
  refused.message = "not observable: 3 lines with at least 8 points, 8 needed";
  frame.lens.distortion = refused;
  OverlayGeometry overlay = MakeOverlayGeometry(frame, {}, {}, OverlaySpace::kRaw);
  EXPECT_EQ(overlay.lens_verdict, "lens not observable: 3 lines with at least 8 points, 8 needed");
  EXPECT_FALSE(overlay.lens_observable);
  EXPECT_EQ(overlay.lens_detail, refused.message) << "in full, for the tooltip";
  refused.observability.reason = "the lines reach only 36% of the half-diagonal (50% needed)";
  refused.observability.brief_reason = "lines reach only 36%";
  frame.lens.distortion = refused;
  EXPECT_EQ(MakeOverlayGeometry(frame, {}, {}, OverlaySpace::kRectified).lens_verdict,
            "lens not observable: lines reach only 36%");

  PlumbLineResult taken;
  taken.usable = true;
  taken.lines_used = 214;
  taken.observability.observable = true;
  taken.observability.covered_radius = 0.784;
  taken.observability.max_shift_px = 12.34;
  taken.observability.shift_sigma_px = 0.087;
  frame.lens.distortion = taken;
  overlay = MakeOverlayGeometry(frame, {}, {}, OverlaySpace::kRaw);
  EXPECT_EQ(overlay.lens_verdict, "lens: 12.3 \u00b1 0.09 px to 78% (214 lines)");
  EXPECT_TRUE(overlay.lens_observable);
}

TEST(OverlayGeometry, RectifiedSpaceIsTheUndistortedCameraMatrixImage) {
  const FrameSnapshot frame = Frame();
  const CameraIntrinsics& camera = frame.working;
  const OverlayGeometry overlay = MakeOverlayGeometry(frame, {}, {}, OverlaySpace::kRectified);
  // Each rectified point, projected back through the lens, lands on its raw pixel.
  const auto raw_of = [&](const Eigen::Vector2d& rectified) {
    const Eigen::Vector3d ray((rectified.x() - camera.cx) / camera.fx,
                              (rectified.y() - camera.cy) / camera.fy, 1.0);
    return Project(camera, ray);
  };
  ASSERT_EQ(overlay.tracks.size(), 1u);
  EXPECT_LT((raw_of(overlay.tracks[0].now) - Eigen::Vector2d(53, 61)).norm(), 1e-6);
  // Far from the centre the barrel moved it visibly.
  EXPECT_GT((overlay.tracks[0].now - Eigen::Vector2d(53, 61)).norm(), 5.0);
  ASSERT_EQ(overlay.snakes.size(), 1u);
  for (size_t i = 0; i < frame.lens.snakes[0].vertices.size(); ++i) {
    EXPECT_LT((raw_of(overlay.snakes[0].vertices[i]) - frame.lens.snakes[0].vertices[i]).norm(),
              1e-6);
  }
  // A straight raw line is sampled along its length, since undistortion bends it.
  ASSERT_EQ(overlay.lines.size(), 1u);
  EXPECT_GE(overlay.lines[0].size(), 35u);
  for (const Eigen::Vector2d& p : overlay.lines[0]) {
    const Eigen::Vector2d raw = raw_of(p);
    EXPECT_NEAR(raw.y(), 30.0 + (raw.x() - 20.0) * 10.0 / 280.0, 1e-6);
  }
}

TEST(OverlayGeometry, GravityPointsDownAndTheHorizonIsPerpendicularToIt) {
  FrameSnapshot frame = Frame();
  for (const OverlaySpace space : {OverlaySpace::kRaw, OverlaySpace::kRectified}) {
    const OverlayGeometry overlay = MakeOverlayGeometry(frame, {}, {}, space);
    ASSERT_TRUE(overlay.gravity);
    EXPECT_EQ(overlay.gravity->sigma_deg, 0.7);
    // Gravity along +y, across the optical axis: straight down, a quarter image high.
    EXPECT_EQ(overlay.gravity->from, Eigen::Vector2d(322.5, 237.0));
    EXPECT_NEAR((overlay.gravity->to - Eigen::Vector2d(322.5, 237.0 + 120.0)).norm(), 0.0, 1e-9);
    // Level camera: the horizon runs through the principal point, across the whole image.
    ASSERT_EQ(overlay.gravity->horizon.size(), 1u);
    const Polyline& horizon = overlay.gravity->horizon[0];
    double low = 1e9, high = -1e9;
    for (const Eigen::Vector2d& p : horizon) {
      EXPECT_NEAR(p.y(), 237.0, 1e-6);
      low = std::min(low, p.x());
      high = std::max(high, p.x());
    }
    EXPECT_LT(low, 8.0);
    EXPECT_GT(high, 631.0);
  }

  // Tilted: every horizon point's ray is perpendicular to gravity.
  const Eigen::Vector3d down = Eigen::Vector3d(0.3, 9.0, 3.0);
  frame.inertial.gravity_cam = down;
  const OverlayGeometry overlay = MakeOverlayGeometry(frame, {}, {}, OverlaySpace::kRaw);
  ASSERT_TRUE(overlay.gravity);
  ASSERT_FALSE(overlay.gravity->horizon.empty());
  for (const Polyline& piece : overlay.gravity->horizon) {
    for (const Eigen::Vector2d& p : piece) {
      const std::optional<Eigen::Vector2d> ray = Unproject(frame.working, p);
      ASSERT_TRUE(ray);
      EXPECT_NEAR(Eigen::Vector3d(ray->x(), ray->y(), 1.0).normalized().dot(down.normalized()), 0.0,
                  1e-6);
    }
  }
  // Part of gravity along the optical axis: a shorter arrow.
  EXPECT_LT((overlay.gravity->to - overlay.gravity->from).norm(), 118.0);
  EXPECT_GT(overlay.gravity->to.y(), overlay.gravity->from.y());

  frame.inertial.gravity_cam.reset();
  EXPECT_FALSE(MakeOverlayGeometry(frame, {}, {}, OverlaySpace::kRaw).gravity);
}

// A board 2 m ahead over five tracked points, and a frame whose tracks of them are where
// the board's pose puts them, plus `shift_px`.
struct BoardFrame {
  FrameSnapshot frame;
  PlacedBoard placed;
};
BoardFrame BoardSeen(double shift_px, int tracks_seen = 5) {
  BoardFrame out{Frame(), {}};
  const std::vector<std::pair<int, Eigen::Vector2d>> tracked = {
      {21, {-0.5, -0.4}}, {22, {0.5, 0.4}}, {23, {0.0, 0.0}}, {24, {0.4, -0.3}}, {25, {-0.3, 0.3}}};
  out.placed.board = AttachBoard(2, Eigen::Isometry3d::Identity(), tracked, {});
  out.placed.cam_from_world.translation() = Eigen::Vector3d(0, 0, 2.0);
  for (int k = 0; k < tracks_seen; ++k) {
    const auto& [id, uv] = tracked[k];
    const Eigen::Vector2d pixel =
        Project(out.frame.working, out.placed.cam_from_world * Eigen::Vector3d(uv.x(), uv.y(), 0)) +
        Eigen::Vector2d(shift_px, 0.0);
    Track track;
    track.id = id;
    track.history = {{0, cv::Point2f(pixel.x(), pixel.y())}};
    out.frame.motion.tracks.push_back(track);
  }
  return out;
}

TEST(OverlayGeometry, BoardsAreProjectedThroughTheWorkingCalibration) {
  const auto [frame, placed] = BoardSeen(1.0);
  const VirtualBoardOptions options;
  const OverlayGeometry overlay = MakeOverlayGeometry(frame, {placed}, options, OverlaySpace::kRaw);
  ASSERT_EQ(overlay.boards.size(), 1u);
  EXPECT_EQ(overlay.boards[0].plane_id, 2);
  const BoardProjection expected =
      ProjectBoard(placed.board, placed.cam_from_world, frame.working, options);
  EXPECT_EQ(overlay.boards[0].lines, expected.lines);

  CameraIntrinsics pinhole = frame.working;
  pinhole.k1 = pinhole.k2 = 0.0;
  const OverlayGeometry rectified =
      MakeOverlayGeometry(frame, {placed}, options, OverlaySpace::kRectified);
  ASSERT_EQ(rectified.boards.size(), 1u);
  EXPECT_EQ(rectified.boards[0].lines,
            ProjectBoard(placed.board, placed.cam_from_world, pinhole, options).lines);
}

// A board is drawn only where the frame's own tracks confirm its pose: box 10 posed some
// views of the office walk wrongly, and their boards were drawn across another wall.
TEST(OverlayGeometry, BoardsAreDrawnOnlyWhereTheFramesTracksConfirmThem) {
  const VirtualBoardOptions options;  // Within 1% of the diagonal (8 px at 640x480).
  const auto drawn = [&](const BoardFrame& seen) {
    return MakeOverlayGeometry(seen.frame, {seen.placed}, options, OverlaySpace::kRaw)
        .boards.size();
  };
  EXPECT_EQ(drawn(BoardSeen(7.0)), 1u);
  EXPECT_EQ(drawn(BoardSeen(9.0)), 0u) << "the pose puts the tracks 9 px off";
  EXPECT_EQ(drawn(BoardSeen(0.0, options.min_tracks_seen - 1)), 0u) << "too few tracks seen";
  EXPECT_EQ(drawn(BoardSeen(0.0, options.min_tracks_seen)), 1u);
  BoardFrame behind = BoardSeen(0.0);
  behind.placed.cam_from_world.translation().z() = -2.0;
  EXPECT_EQ(drawn(behind), 0u) << "the board behind the camera";
  ASSERT_EQ(BoardTrackError(behind.placed.board, behind.placed.cam_from_world,
                            behind.frame.working, {{21, Eigen::Vector2d(320, 240)}}, 1),
            std::numeric_limits<double>::infinity());
}

TEST(OverlayGeometry, ViewPoseIsBox10sAtViewsAndInterpolatedBetween) {
  AttemptOutcome attempt;
  attempt.view_times = {100, 200, 300};
  Eigen::Isometry3d first = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d second = Eigen::Isometry3d::Identity();
  second.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY()).toRotationMatrix();
  second.translation() = Eigen::Vector3d(1.0, 0.0, 2.0);
  attempt.cam_from_world = {first, second, std::nullopt};

  ASSERT_TRUE(ViewPoseAt(attempt, 200));
  EXPECT_TRUE(ViewPoseAt(attempt, 200)->isApprox(second));
  const std::optional<Eigen::Isometry3d> between = ViewPoseAt(attempt, 150);
  ASSERT_TRUE(between);
  EXPECT_NEAR(Eigen::AngleAxisd(between->rotation()).angle(), 0.2, 1e-9);
  EXPECT_TRUE(between->translation().isApprox(Eigen::Vector3d(0.5, 0.0, 1.0)));
  EXPECT_FALSE(ViewPoseAt(attempt, 50));   // Before the views.
  EXPECT_FALSE(ViewPoseAt(attempt, 250));  // Next to a view box 10 left out.
  EXPECT_FALSE(ViewPoseAt(attempt, 300));
  EXPECT_FALSE(ViewPoseAt(attempt, 400));  // After them.
}

}  // namespace
}  // namespace autocal
