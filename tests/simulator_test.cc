#include "devices/sim/simulator.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <ostream>
#include <set>
#include <thread>
#include <tuple>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "devices/sim/accelerometer.h"
#include "devices/sim/lens.h"
#include "devices/sim/renderer.h"
#include "devices/sim/scene.h"
#include "devices/sim/texture.h"
#include "devices/sim/trajectory.h"
#include "pipeline/error.h"
#include "tests/sim_test_util.h"
#include "tests/test_util.h"

namespace autocal {
namespace {

using test::LookingAt;

// Small, quiet scenarios keep the tests fast.
Scenario Small(const std::string& name) {
  Scenario s = LoadScenario(name);
  s.width = 320;
  s.height = 240;
  s.seconds = 2.0;
  return s;
}

class SimulatorTest : public ::testing::Test {
 protected:
  // The office scene takes a moment to build; keep it alive for the whole suite so every
  // sequence shares it.
  static void SetUpTestSuite() { office_ = BuildScene(LoadScenario("office")); }
  static void TearDownTestSuite() { office_.reset(); }
  static std::shared_ptr<const Scene> office_;
};
std::shared_ptr<const Scene> SimulatorTest::office_;

// --- Rendering geometry -----------------------------------------------------------------

struct BoardCase {
  const char* lens;
  double distance_m;
  double yaw_deg;
  double pitch_deg;
};

void PrintTo(const BoardCase& c, std::ostream* out) {
  *out << c.lens << " at " << c.distance_m << " m, yaw " << c.yaw_deg << ", pitch " << c.pitch_deg;
}

class CheckerboardTest : public ::testing::TestWithParam<BoardCase> {};

// The board's inner corners as OpenCV's detector finds them; none where it finds no board.
std::vector<cv::Point2f> DetectBoardCorners(const cv::Mat& image, const cv::Size& pattern) {
  cv::Mat grey;
  cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  std::vector<cv::Point2f> found;
  if (!cv::findChessboardCornersSB(grey, pattern, found,
                                   cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY)) {
    found.clear();
  }
  return found;
}

// The rendered board's corners, found by OpenCV's detector, lie where the camera model
// projects the true 3-D corners: the renderer's lens is the pipeline's lens.
TEST_P(CheckerboardTest, CornersLandWhereProjectPutsThem) {
  const BoardCase& param = GetParam();
  Scenario s;
  s.scene = "checkerboard";
  s.motion.type = "static";
  s.lens = param.lens;
  const CheckerboardOptions& board = s.checkerboard;
  const auto scene = BuildScene(s);
  ASSERT_EQ(scene->planes.size(), 1u);
  const Plane& plane = scene->planes[0];

  const CameraIntrinsics k = LensIntrinsics(s.lens, 640, 480);
  const Eigen::Isometry3d world_from_cam = LookingAt(
      {kCheckerboardDistanceM, 0.0, 1.0}, param.distance_m, param.yaw_deg, param.pitch_deg);
  RenderOptions options;  // No noise, vignetting or colour fringes.
  const RenderedFrame frame = Renderer(scene).Render(k, world_from_cam, options);

  const cv::Size pattern(board.squares_x - 1, board.squares_y - 1);
  const std::vector<cv::Point2f> found = DetectBoardCorners(frame.image, pattern);
  ASSERT_EQ(found.size(), static_cast<size_t>(pattern.area()));

  double sum_sq = 0.0, max_err = 0.0, max_distortion = 0.0;
  for (int j = 0; j < pattern.height; ++j) {
    for (int i = 0; i < pattern.width; ++i) {
      const Eigen::Vector3d corner =
          plane.Point((i + 2) * board.square_m, (j + 2) * board.square_m);
      const Eigen::Vector3d in_cam = world_from_cam.inverse() * corner;
      const Eigen::Vector2d expected = Project(k, in_cam);
      const Eigen::Vector2d pinhole(k.fx * in_cam.x() / in_cam.z() + k.cx,
                                    k.fy * in_cam.y() / in_cam.z() + k.cy);
      max_distortion = std::max(max_distortion, (expected - pinhole).norm());
      double best = std::numeric_limits<double>::infinity();
      for (const cv::Point2f& p : found) {
        best = std::min(best, std::hypot(p.x - expected.x(), p.y - expected.y()));
      }
      sum_sq += best * best;
      max_err = std::max(max_err, best);
    }
  }
  const double rms = std::sqrt(sum_sq / pattern.area());
  EXPECT_LT(rms, 0.1) << "max " << max_err << " px";
  EXPECT_LT(max_err, 0.3);
  if (std::string(param.lens) == "sonnar") {
    // The board must reach where the barrel bends it by many pixels, or the test proves
    // nothing about distortion.
    EXPECT_GT(max_distortion, 10.0);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Lenses, CheckerboardTest,
    ::testing::Values(BoardCase{"tessar", 0.45, 0.0, 0.0}, BoardCase{"tessar", 0.5, 25.0, -10.0},
                      BoardCase{"sonnar", 0.33, 0.0, 0.0}, BoardCase{"sonnar", 0.42, -30.0, 20.0}),
    [](const ::testing::TestParamInfo<BoardCase>& param_info) {
      return std::string(param_info.param.lens) + "_" + std::to_string(param_info.index);
    });

// A rolling shutter turning at 90 deg/s: each corner lies where the pose of the row it
// lands on projects it (found by iterating on the row), and visibly off where the middle
// row's pose alone would put it, more so the farther its row is from the middle.
TEST(RollingShutterTest, EachRowSeesTheSceneFromItsOwnPose) {
  Scenario s;
  s.scene = "checkerboard";
  s.motion.type = "static";
  const auto scene = BuildScene(s);
  const Plane& plane = scene->planes[0];
  const CheckerboardOptions& board = s.checkerboard;
  const CameraIntrinsics k = LensIntrinsics("tessar", 640, 480);
  constexpr double kYawDegPerRow = 90.0 * 0.030 / 480;  // 90 deg/s, 30 ms readout.
  const Eigen::Isometry3d middle = LookingAt({kCheckerboardDistanceM, 0.0, 1.0}, 0.45, 0.0, 0.0);
  const auto pose_of_row = [&](double v) {  // Turning in place about the camera's y axis.
    Eigen::Isometry3d pose = middle;
    pose.linear() *=
        Eigen::AngleAxisd(kYawDegPerRow * (v - 239.5) * M_PI / 180, Eigen::Vector3d::UnitY())
            .toRotationMatrix();
    return pose;
  };
  RenderOptions options;
  for (int v = 0; v < k.height; ++v) options.world_from_cam_by_row.push_back(pose_of_row(v));
  const RenderedFrame frame = Renderer(scene).Render(k, middle, options);

  const cv::Size pattern(board.squares_x - 1, board.squares_y - 1);
  const std::vector<cv::Point2f> found = DetectBoardCorners(frame.image, pattern);
  ASSERT_EQ(found.size(), static_cast<size_t>(pattern.area()));
  double max_err = 0.0, max_shift = 0.0;
  for (int j = 0; j < pattern.height; ++j) {
    for (int i = 0; i < pattern.width; ++i) {
      const Eigen::Vector3d corner =
          plane.Point((i + 2) * board.square_m, (j + 2) * board.square_m);
      const auto project_from = [&](double row) {
        return Project(k, pose_of_row(row).inverse() * corner);
      };
      Eigen::Vector2d expected = project_from(239.5);
      for (int it = 0; it < 10; ++it) expected = project_from(expected.y());
      const Eigen::Vector2d global_shutter = project_from(239.5);
      double best = std::numeric_limits<double>::infinity();
      for (const cv::Point2f& p : found) {
        best = std::min(best, std::hypot(p.x - expected.x(), p.y - expected.y()));
      }
      max_err = std::max(max_err, best);
      max_shift = std::max(max_shift, (expected - global_shutter).norm());
      // About fx * 90 deg/s * 30 ms / 480 rows per row from the middle.
      EXPECT_NEAR((expected - global_shutter).norm(),
                  k.fx * kYawDegPerRow * M_PI / 180 * std::abs(expected.y() - 239.5),
                  0.25 + 0.1 * (expected - global_shutter).norm());
    }
  }
  EXPECT_LT(max_err, 0.3);
  EXPECT_GT(max_shift, 3.0);  // Else the test could not tell the shutters apart.
}

// Ray-rectangle intersection written independently of the renderer, with the moving
// planes where they are at `time_s`.
int PlaneSeenBy(const Scene& scene, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                double* margin_m, double time_s = 0.0) {
  int best_id = 0;
  double best_t = std::numeric_limits<double>::infinity();
  for (const Plane& p : scene.planes) {
    if (time_s < p.from_s || time_s >= p.until_s) continue;
    const Eigen::Vector3d plane_origin = p.origin + time_s * p.velocity_mps;
    const Eigen::Vector3d n = p.axis_u.cross(p.axis_v);
    const double den = n.dot(dir);
    if (std::abs(den) < 1e-12) continue;
    const double t = n.dot(plane_origin - origin) / den;
    if (t <= 0.0 || t >= best_t) continue;
    const Eigen::Vector3d local = origin + t * dir - plane_origin;
    const double a = local.dot(p.axis_u), b = local.dot(p.axis_v);
    if (a < 0 || a > p.width_m || b < 0 || b > p.height_m) continue;
    best_t = t;
    best_id = p.id;
    *margin_m = std::min({a, p.width_m - a, b, p.height_m - b});
  }
  return best_id;
}

TEST_F(SimulatorTest, PlaneLabelsAgreeWithGeometry) {
  const Scenario s = Small("static");
  const auto sequence = MakeSimulatedSequence(s);
  const GroundTruthFrame& truth = sequence->ground_truth()->at(0);
  const cv::Mat labels = *sequence->LoadPlaneLabels(0);
  ASSERT_EQ(labels.type(), CV_16U);
  const Eigen::Matrix3d r = truth.world_from_cam_rotation.toRotationMatrix();

  auto expected_at = [&](int u, int v, double* margin) {
    const auto ray = Unproject(truth.intrinsics, Eigen::Vector2d(u, v));
    EXPECT_TRUE(ray.has_value());
    return PlaneSeenBy(*office_, truth.world_from_cam_translation,
                       r * Eigen::Vector3d(ray->x(), ray->y(), 1.0), margin);
  };
  // The image centre sees the east wall, as the static scenario says.
  double margin = 0.0;
  const int cu = static_cast<int>(std::lround(truth.intrinsics.cx));
  const int cv = static_cast<int>(std::lround(truth.intrinsics.cy));
  const int centre_id = expected_at(cu, cv, &margin);
  ASSERT_GT(centre_id, 0);
  EXPECT_EQ(office_->planes[centre_id - 1].name, "wall_east");
  EXPECT_EQ(labels.at<uint16_t>(cv, cu), centre_id);

  // And so does every pixel of a grid, away from plane edges.
  int checked = 0;
  std::set<int> seen;
  for (int v = 3; v < s.height; v += 17) {
    for (int u = 2; u < s.width; u += 19) {
      const int id = expected_at(u, v, &margin);
      if (id != 0 && margin < 0.01) continue;
      EXPECT_EQ(labels.at<uint16_t>(v, u), id) << "pixel " << u << ", " << v;
      seen.insert(id);
      ++checked;
    }
  }
  EXPECT_GT(checked, 200);
  EXPECT_GE(seen.size(), 3u);  // Wall, floor and desk at least.
}

// People walk across the view: each pixel's label is the plane its ray meets with every
// person where they are at that row's time (a rolling shutter reads rows at their own),
// and the people move (where they stood at the start, most of their pixels see the room).
TEST(PeopleTest, LabelsFollowThePeopleAsTheyWalk) {
  for (const double readout_ms : {0.0, 30.0}) {
    SCOPED_TRACE(readout_ms);
    Scenario s = Small("office");
    s.seconds = 6.0;
    s.people = 3;
    s.image.readout_ms = readout_ms;
    const auto sequence = MakeSimulatedSequence(s);
    const std::shared_ptr<const Scene> scene = BuildScene(s);
    const Trajectory trajectory(s.motion, s.scene);
    std::set<int> people;
    for (const Plane& p : scene->planes) {
      if (p.name.rfind("person", 0) == 0) {
        people.insert(p.id);
        EXPECT_TRUE(p.moves());
        EXPECT_NEAR(p.velocity_mps.norm(), 1.3, 1e-9);
      }
    }
    ASSERT_EQ(people.size(), 15u);  // Four sides and a top each.
    int person_pixels = 0, still_agree = 0;
    for (size_t i = 0; i < sequence->frame_count(); i += 3) {
      const cv::Mat labels = *sequence->LoadPlaneLabels(i);
      const GroundTruthFrame& truth = sequence->ground_truth()->at(i);
      const double t = s.SecondsAt(truth.t_ns);
      for (int v = 3; v < s.height; v += 9) {
        const double row_t = t + (v - 0.5 * (s.height - 1)) * 1e-3 * readout_ms / s.height;
        const Eigen::Matrix3d r = trajectory.WorldFromCamAt(row_t);
        const Eigen::Vector3d position = trajectory.PositionAt(row_t);
        for (int u = 2; u < s.width; u += 7) {
          const auto ray = Unproject(truth.intrinsics, Eigen::Vector2d(u, v));
          ASSERT_TRUE(ray.has_value());
          const Eigen::Vector3d dir = r * Eigen::Vector3d(ray->x(), ray->y(), 1.0);
          double margin = 0.0;
          const int id = PlaneSeenBy(*scene, position, dir, &margin, row_t);
          if (id != 0 && margin < 0.01) continue;
          const int label = labels.at<uint16_t>(v, u);
          EXPECT_EQ(label, id) << "frame " << i << ", pixel " << u << ", " << v;
          if (!people.count(id)) continue;
          ++person_pixels;
          // Where the person was at the start of their walk.
          still_agree +=
              PlaneSeenBy(*scene, position, dir, &margin, scene->planes[id - 1].from_s) == id;
        }
      }
    }
    std::printf("%d person pixels, %d seen there at the start\n", person_pixels, still_agree);
    EXPECT_GT(person_pixels, 300);
    EXPECT_LT(still_agree, person_pixels / 3);
  }
}

// Trackers need corners all over the image, not only on posters: the textures must
// provide them (noise is off, so the corners are the scene's).
TEST_F(SimulatorTest, OfficeHasCornersEverywhere) {
  Scenario s = LoadScenario("office");
  ApplyScenarioOverride(&s, "noise_sigma", "0");
  const auto sequence = MakeSimulatedSequence(s);
  for (size_t index : {size_t{0}, size_t{150}, size_t{375}}) {
    cv::Mat grey;
    cv::cvtColor(sequence->LoadFrame(index), grey, cv::COLOR_BGR2GRAY);
    std::vector<cv::KeyPoint> corners;
    cv::FAST(grey, corners, 20);
    int cells[4][4] = {};
    for (const cv::KeyPoint& k : corners) {
      ++cells[std::min(3, static_cast<int>(4 * k.pt.y / grey.rows))]
             [std::min(3, static_cast<int>(4 * k.pt.x / grey.cols))];
    }
    int rich = 0;
    for (const auto& row : cells)
      rich += static_cast<int>(std::count_if(row, row + 4, [](int n) { return n >= 5; }));
    EXPECT_GE(rich, 15) << "frame " << index;
  }
}

// Scenario::surface_texture takes the fine texture off painted walls and leaves what is
// drawn on them: a patch of bare paint on the office's north wall goes flat, while its
// poster (random colours, drawn between the paint's texture and its grain) stays the same
// but for the grain, so the scene's generator was drawn from the same.
TEST(SurfaceTextureTest, BarePaintIsFlatAndThePicturesStay) {
  auto north_wall = [](double texture) {
    Scenario s = LoadScenario("office");
    s.surface_texture = texture;
    const std::shared_ptr<const Scene> scene = BuildScene(s);
    const auto wall = std::find_if(scene->planes.begin(), scene->planes.end(),
                                   [](const Plane& p) { return p.name == "wall_north"; });
    return std::make_pair(scene, scene->textures.at(wall->texture));
  };
  // Grey levels of the wall's texels over a region (plane metres), 1 cm apart.
  auto patch = [](const Texture& texture, double a0, double b0, double a1, double b1) {
    std::vector<double> grey;
    for (double a = a0; a < a1; a += 0.01) {
      for (double b = b0; b < b1; b += 0.01) {
        const cv::Vec3f bgr = texture.Sample(Footprint{a, b, 0.0, 0.0, 0.0, 0.0});
        grey.push_back((bgr[0] + bgr[1] + bgr[2]) / 3.0);
      }
    }
    return grey;
  };
  auto spread = [](const std::vector<double>& v) {
    double mean = 0.0, square = 0.0;
    for (double x : v) mean += x / double(v.size());
    for (double x : v) square += (x - mean) * (x - mean) / double(v.size());
    return std::sqrt(square);
  };
  const auto [textured_scene, textured] = north_wall(1.0);
  const auto [half_scene, half] = north_wall(0.5);
  const auto [bare_scene, bare] = north_wall(0.0);
  // Bare paint left of the window (which starts 1.4 m along, 0.6 m down).
  const double textured_spread = spread(patch(textured, 0.1, 0.1, 1.2, 0.5));
  const double half_spread = spread(patch(half, 0.1, 0.1, 1.2, 0.5));
  const double bare_spread = spread(patch(bare, 0.1, 0.1, 1.2, 0.5));
  EXPECT_GT(textured_spread, 2.0);
  EXPECT_NEAR(half_spread / textured_spread, 0.5, 0.1);
  EXPECT_LT(bare_spread, 0.05);
  // The poster 6.1 m along: only the grain (+-5 grey levels at full texture) differs.
  const std::vector<double> poster_textured = patch(textured, 6.15, 0.75, 6.65, 1.5);
  const std::vector<double> poster_bare = patch(bare, 6.15, 0.75, 6.65, 1.5);
  double most = 0.0;
  for (size_t i = 0; i < poster_bare.size(); ++i) {
    most = std::max(most, std::abs(poster_bare[i] - poster_textured[i]));
  }
  EXPECT_LE(most, 5.5);
  EXPECT_GT(spread(poster_bare), 20.0);  // It is a picture, not paint.
}

// --- Lenses and intrinsics profiles -------------------------------------------------------

TEST(LensTest, TessarIsNearlyDistortionFree) {
  const CameraIntrinsics k = LensIntrinsics("tessar", 640, 480);
  double worst = 0.0;
  for (int v = 0; v < 480; v += 4) {
    for (int u : {0, 160, 320, 639}) {
      const auto ray = Unproject(k, Eigen::Vector2d(u, v));
      ASSERT_TRUE(ray.has_value());
      const Eigen::Vector2d pinhole(k.fx * ray->x() + k.cx, k.fy * ray->y() + k.cy);
      worst = std::max(worst, (pinhole - Eigen::Vector2d(u, v)).norm());
    }
  }
  EXPECT_LT(worst, 0.5);
  EXPECT_GT(worst, 0.01);  // Small, not nothing.
  // 75 deg horizontal field of view.
  EXPECT_EQ(LensFieldOfViewDeg("tessar"), 75.0);
  const auto right = Unproject(k, Eigen::Vector2d(k.cx + 320.0, k.cy));
  EXPECT_NEAR(std::atan(right->x()) * 180.0 / M_PI, 37.5, 1e-6);
}

TEST(LensTest, SonnarHasStrongBarrelAndSeesEightyFiveDegrees) {
  const CameraIntrinsics k = LensIntrinsics("sonnar", 640, 480);
  EXPECT_DOUBLE_EQ(k.k1, -0.3);
  EXPECT_DOUBLE_EQ(k.k2, 0.1);
  EXPECT_EQ(LensFieldOfViewDeg("sonnar"), 85.0);
  const auto right = Unproject(k, Eigen::Vector2d(k.cx + 320.0, k.cy));
  ASSERT_TRUE(right.has_value());
  EXPECT_NEAR(std::atan(right->x()) * 180.0 / M_PI, 42.5, 1e-6);
  // Every pixel, corners included, has a ray.
  for (const Eigen::Vector2d& corner :
       {Eigen::Vector2d(-0.5, -0.5), Eigen::Vector2d(639.5, 479.5)}) {
    EXPECT_TRUE(Unproject(k, corner).has_value());
  }
}

// The lenses the pipeline was not tuned on: each edge sees half the field of view through
// the distortion, every pixel has one ray, and the distortion bends the way it should.
TEST(LensTest, HologonAndTelephotoSeeTheirFieldsOfView) {
  for (const auto& [lens, fov_deg, barrel] :
       {std::tuple{"hologon", 110.0, true}, std::tuple{"telephoto", 55.0, false}}) {
    const CameraIntrinsics k = LensIntrinsics(lens, 640, 480);
    EXPECT_EQ(LensFieldOfViewDeg(lens), fov_deg);
    const auto right = Unproject(k, Eigen::Vector2d(k.cx + 320.0, k.cy));
    ASSERT_TRUE(right.has_value()) << lens;
    EXPECT_NEAR(std::atan(right->x()) * 180.0 / M_PI, 0.5 * fov_deg, 1e-6) << lens;
    for (int v = 0; v < 480; v += 8) {
      for (int u = 0; u < 640; u += 8) ASSERT_TRUE(Unproject(k, Eigen::Vector2d(u, v))) << lens;
    }
    // Barrel: the ray of an edge pixel lies farther out than the pinhole would put it.
    const double pinhole_x = 320.0 / k.fx;
    EXPECT_EQ(right->x() > pinhole_x, barrel) << lens;
  }
}

TEST(LensTest, FieldsAreDistinguishableAndScaleWithResolution) {
  for (const std::string& lens : LensNames()) {
    const CameraIntrinsics k = LensIntrinsics(lens, 640, 480);
    EXPECT_NEAR(k.fy / k.fx, 1.002, 1e-12);
    EXPECT_GT(std::abs(k.cx - 319.5), 1.0);
    EXPECT_LT(std::abs(k.cx - 319.5), 10.0);
    EXPECT_GT(std::abs(k.cy - 239.5), 1.0);
    EXPECT_LT(std::abs(k.cy - 239.5), 10.0);
    const CameraIntrinsics big = LensIntrinsics(lens, 1280, 960);
    EXPECT_NEAR(big.fx, 2.0 * k.fx, 1e-9);
    EXPECT_NEAR(big.cx - 639.5, 2.0 * (k.cx - 319.5), 1e-9);
  }
  EXPECT_THROW(LensIntrinsics("fisheye", 640, 480), Error);
}

TEST(IntrinsicsProfileTest, DriftIsLinearOverSixtySeconds) {
  const Scenario s = LoadScenario("drift");
  const CameraIntrinsics k0 = LensIntrinsics(s.lens, s.width, s.height);
  const CameraIntrinsics start = IntrinsicsAt(s, 0.0);
  const CameraIntrinsics middle = IntrinsicsAt(s, 30.0);
  const CameraIntrinsics end = IntrinsicsAt(s, 60.0);
  EXPECT_EQ(start, k0);
  EXPECT_NEAR(middle.fx, 1.01 * k0.fx, 1e-9);
  EXPECT_NEAR(middle.fy, 1.01 * k0.fy, 1e-9);
  EXPECT_NEAR(middle.cx, k0.cx + 3.0, 1e-9);
  EXPECT_NEAR(middle.cy, k0.cy - 2.0, 1e-9);
  EXPECT_NEAR(end.fx, 1.02 * k0.fx, 1e-9);
  EXPECT_NEAR(end.fy, 1.02 * k0.fy, 1e-9);
  EXPECT_NEAR(end.cx, k0.cx + 6.0, 1e-9);
  EXPECT_NEAR(end.cy, k0.cy - 4.0, 1e-9);
  EXPECT_EQ(end.k1, k0.k1);
  EXPECT_EQ(IntrinsicsAt(s, 75.0), end);
}

TEST(IntrinsicsProfileTest, JoltStepsAtHalfTimeAndStays) {
  Scenario s = LoadScenario("jolt");
  const CameraIntrinsics k0 = LensIntrinsics(s.lens, s.width, s.height);
  const double half = 0.5 * s.seconds;
  EXPECT_EQ(IntrinsicsAt(s, 0.0), k0);
  EXPECT_EQ(IntrinsicsAt(s, half - 1e-6), k0);
  for (double t : {half, half + 1.0, s.seconds}) {
    const CameraIntrinsics k = IntrinsicsAt(s, t);
    EXPECT_NEAR(k.fx, 0.98 * k0.fx, 1e-9);
    EXPECT_NEAR(k.fy, 0.98 * k0.fy, 1e-9);
    EXPECT_NEAR(k.cx, k0.cx + 5.0, 1e-9);
    EXPECT_EQ(k.cy, k0.cy);
  }
  // The step is at half the duration whatever the duration.
  ApplyScenarioOverride(&s, "seconds", "10");
  EXPECT_EQ(IntrinsicsAt(s, 4.99), k0);
  EXPECT_NEAR(IntrinsicsAt(s, 5.0).fx, 0.98 * k0.fx, 1e-9);
}

TEST(IntrinsicsProfileTest, TransientFogThenNoiseThenClear) {
  const Scenario s = LoadScenario("transient");
  const FrameEffects before = EffectsAt(s, 7.9);
  const FrameEffects fog = EffectsAt(s, 9.0);
  const FrameEffects burst = EffectsAt(s, 11.5);
  const FrameEffects after = EffectsAt(s, 12.5);
  EXPECT_EQ(before.fog_blur_sigma_px, 0.0);
  EXPECT_EQ(before.fog_contrast, 1.0);
  EXPECT_GT(fog.fog_blur_sigma_px, 1.0);
  EXPECT_DOUBLE_EQ(fog.fog_contrast, 0.5);
  EXPECT_EQ(burst.fog_contrast, 1.0);
  EXPECT_GT(burst.noise_sigma, 10.0 * before.noise_sigma);
  EXPECT_EQ(after.noise_sigma, before.noise_sigma);
  EXPECT_EQ(after.fog_blur_sigma_px, 0.0);
  EXPECT_EQ(IntrinsicsAt(s, 9.0), IntrinsicsAt(s, 0.0));
}

// --- Body and accelerometer ---------------------------------------------------------------

TEST(TrajectoryTest, OfficeWalkStaysClearOfWallsAndBoxes) {
  const Scenario s = LoadScenario("office");
  const Trajectory walk(s.motion, s.scene);
  const double period = walk.loop_period_s();
  double length = 0.0, min_height = 10.0, max_height = 0.0;
  Eigen::Vector3d previous = walk.PositionAt(0.0);
  constexpr int kSteps = 4000;
  for (int i = 1; i <= kSteps; ++i) {
    const Eigen::Vector3d p = walk.PositionAt(period * i / kSteps);
    length += (p - previous).head<2>().norm();
    previous = p;
    EXPECT_GE(4.0 - std::abs(p.x()), 0.8);
    EXPECT_GE(3.0 - std::abs(p.y()), 0.8);
    // Boxes (see scene.cc): desk at the centre, box and cabinet in corners.
    EXPECT_GT(std::max(std::abs(p.x()) - 0.7, std::abs(p.y()) - 0.4), 0.5);
    EXPECT_GT(std::max(std::abs(p.x() - 3.3) - 0.4, std::abs(p.y() + 2.3) - 0.3), 0.5);
    EXPECT_GT(std::max(std::abs(p.x() + 3.25) - 0.3, std::abs(p.y() - 2.35) - 0.25), 0.5);
    min_height = std::min(min_height, p.z());
    max_height = std::max(max_height, p.z());
  }
  EXPECT_NEAR(length / period, 1.2, 0.05);
  EXPECT_NEAR(max_height - min_height, 0.025, 1e-3);
  EXPECT_NEAR(0.5 * (max_height + min_height), 1.4, 1e-3);
  EXPECT_NEAR(walk.PositionAt(period).x(), walk.PositionAt(0.0).x(), 0.05);
}

TEST(TrajectoryTest, CameraLooksInVariedDirections) {
  const Scenario s = LoadScenario("office");
  const Trajectory walk(s.motion, s.scene);
  double min_pitch = 90.0, max_pitch = -90.0;
  std::set<int> headings;  // 45 degree sectors seen.
  for (double t = 0.0; t < walk.loop_period_s(); t += 0.1) {
    const Eigen::Vector3d forward = walk.WorldFromCamAt(t).col(2);
    const double pitch = std::asin(-forward.z()) * 180.0 / M_PI;
    min_pitch = std::min(min_pitch, pitch);
    max_pitch = std::max(max_pitch, pitch);
    headings.insert(
        static_cast<int>(std::floor(std::atan2(forward.y(), forward.x()) / (M_PI / 4))));
  }
  EXPECT_EQ(headings.size(), 8u);
  EXPECT_NEAR(min_pitch, 4.0, 1.0);  // 10 deg down, +-6.
  EXPECT_NEAR(max_pitch, 16.0, 1.0);
}

TEST(AccelerometerTest, BodyAtRestReadsGravityUp) {
  const Scenario s = Small("static");
  const auto sequence = MakeSimulatedSequence(s);
  const Eigen::Matrix3d world_from_accel =
      sequence->ground_truth()->front().world_from_cam_rotation.toRotationMatrix() *
      sequence->session().cam_from_accel;
  const Eigen::Vector3d expected = world_from_accel.transpose() * Eigen::Vector3d(0, 0, kGravity);
  const double sigma = s.accelerometer.noise_density * std::sqrt(s.accelerometer.rate_hz);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const AccelSample& sample : sequence->accel()) {
    EXPECT_NEAR((sample.specific_force - s.accelerometer.bias).norm(), kGravity, 6.0 * sigma);
    mean += sample.specific_force;
  }
  mean /= static_cast<double>(sequence->accel().size());
  const double sigma_mean = sigma / std::sqrt(static_cast<double>(sequence->accel().size()));
  EXPECT_LT((mean - s.accelerometer.bias - expected).norm(), 5.0 * sigma_mean + 1e-3);
  // The accelerometer's own axes are not the camera's: z is up when the camera looks
  // level, so at rest z carries most of gravity (the camera on the table looks 8 deg down).
  EXPECT_GT(expected.z(), 9.5);
  EXPECT_FALSE(sequence->session().cam_from_accel.isApprox(Eigen::Matrix3d::Identity()));
  EXPECT_NEAR(sequence->session().cam_from_accel.determinant(), 1.0, 1e-12);
}

TEST(AccelerometerTest, NoiseFreeSamplesAreTheSecondDerivativeOfThePath) {
  Scenario s = LoadScenario("office");
  s.seconds = 3.0;
  s.accelerometer.noise_density = 0.0;
  s.accelerometer.bias.setZero();
  s.accelerometer.bits = 0;
  s.accelerometer.range_g = 16.0;
  const Trajectory walk(s.motion, s.scene);
  const std::vector<AccelSample> samples = SimulateAccelerometer(s, walk);
  const Eigen::Matrix3d cam_from_accel = CamFromAccel(s.accelerometer);
  // Central differences with h = 1 ms: truncation error h^2/12 max|p''''|, and the
  // path's largest fourth derivative is the step bob's (0.0125 m (2 pi 1.8 Hz)^4 = 205
  // m/s^4) plus the sway's (20 m/s^4): under 2e-5 m/s^2. Rounding adds about
  // 4 eps |p| / h^2 = 3e-9 m/s^2. 1e-4 leaves a margin of 5.
  constexpr double h = 1e-3;
  double worst = 0.0, largest = 0.0;
  for (size_t i = 0; i < samples.size(); i += 7) {
    const double t = s.SecondsAt(samples[i].t_ns);
    const Eigen::Vector3d a =
        (walk.PositionAt(t + h) - 2.0 * walk.PositionAt(t) + walk.PositionAt(t - h)) / (h * h);
    const Eigen::Matrix3d world_from_accel = walk.WorldFromCamAt(t) * cam_from_accel;
    const Eigen::Vector3d expected = world_from_accel.transpose() * (a - kGravityWorld);
    worst = std::max(worst, (samples[i].specific_force - expected).norm());
    largest = std::max(largest, (a).norm());
  }
  EXPECT_LT(worst, 1e-4);
  EXPECT_GT(largest, 1.0);  // The walk does accelerate.
}

TEST(AccelerometerTest, SamplesSpanTheFramesAtTheirOwnRate) {
  Scenario s = Small("office");
  ApplyScenarioOverride(&s, "accel_rate", "1600");
  const auto sequence = MakeSimulatedSequence(s);
  const auto& accel = sequence->accel();
  ASSERT_GT(accel.size(), 2u);
  EXPECT_LT(accel.front().t_ns, sequence->frame_time_ns(0));
  EXPECT_GT(accel.back().t_ns, sequence->frame_time_ns(sequence->frame_count() - 1));
  for (size_t i = 1; i < accel.size(); ++i) {
    const int64_t dt = accel[i].t_ns - accel[i - 1].t_ns;
    ASSERT_GE(dt, 624999);
    ASSERT_LE(dt, 625001);
  }
}

TEST(AccelerometerTest, SaturatesAndQuantizes) {
  Scenario s = LoadScenario("office");
  s.seconds = 2.0;
  s.accelerometer.range_g = 1.0;  // Gravity alone nearly saturates.
  s.accelerometer.bits = 8;
  const std::vector<AccelSample> samples = SimulateAccelerometer(s, Trajectory(s.motion, s.scene));
  const double range = kGravity, lsb = 2.0 * range / 256.0;
  bool saturated = false;
  for (const AccelSample& sample : samples) {
    for (int axis = 0; axis < 3; ++axis) {
      const double value = sample.specific_force[axis];
      EXPECT_LE(std::abs(value), range + 1e-9);
      EXPECT_NEAR(value / lsb, std::round(value / lsb), 1e-6);
      saturated = saturated || std::abs(value) >= range - lsb;
    }
  }
  EXPECT_TRUE(saturated);
}

// --- Determinism --------------------------------------------------------------------------

bool Identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

// A frame read again soon after comes from the recently rendered ones (the workbench's
// display following its pipeline), as a copy: what one reader writes to its frame, the next
// does not see.
TEST_F(SimulatorTest, AFrameReadAgainIsTheReadersOwn) {
  const auto sequence = MakeSimulatedSequence(Small("office"));
  cv::Mat first = sequence->LoadFrame(3);
  const cv::Mat rendered = first.clone();
  first.setTo(cv::Scalar::all(0));
  cv::Mat again = sequence->LoadFrame(3);
  EXPECT_TRUE(Identical(again, rendered));
  again.setTo(cv::Scalar::all(255));
  EXPECT_TRUE(Identical(sequence->LoadFrame(3), rendered));
}

TEST_F(SimulatorTest, FramesAreDeterministicInAnyOrderAndThread) {
  Scenario s = Small("drift");  // Intrinsics change every frame: ray tables are rebuilt.
  const auto sequence = MakeSimulatedSequence(s);
  const cv::Mat first = sequence->LoadFrame(5);
  ASSERT_EQ(first.type(), CV_8UC3);
  ASSERT_EQ(first.size(), cv::Size(320, 240));
  // Enough other frames that frame 5 is rendered again, not taken from the recent ones.
  for (size_t i = 40; i < 60; ++i) sequence->LoadFrame(i);
  EXPECT_TRUE(Identical(sequence->LoadFrame(5), first));

  cv::Mat from_thread_a, from_thread_b;
  std::thread a([&] { from_thread_a = sequence->LoadFrame(5); });
  std::thread b([&] { from_thread_b = sequence->LoadFrame(5); });
  a.join();
  b.join();
  EXPECT_TRUE(Identical(from_thread_a, first));
  EXPECT_TRUE(Identical(from_thread_b, first));

  // A fresh sequence (fresh caches) gives the same frames and samples.
  const auto again = MakeSimulatedSequence(s);
  EXPECT_TRUE(Identical(again->LoadFrame(5), first));
  EXPECT_EQ(again->accel().size(), sequence->accel().size());
  EXPECT_TRUE(again->accel().back().specific_force == sequence->accel().back().specific_force);

  // Noise differs between frames and seeds.
  s.seed = 2;
  const auto other = MakeSimulatedSequence(s);
  EXPECT_FALSE(Identical(other->LoadFrame(5), first));
  EXPECT_FALSE(other->accel().back().specific_force == sequence->accel().back().specific_force);
}

TEST_F(SimulatorTest, StaticFramesDifferOnlyBySensorNoise) {
  const Scenario s = Small("static");
  const auto sequence = MakeSimulatedSequence(s);
  cv::Mat a, b;
  sequence->LoadFrame(0).convertTo(a, CV_32F);
  sequence->LoadFrame(1).convertTo(b, CV_32F);
  const cv::Mat difference = cv::Mat(a - b).reshape(1);
  cv::Scalar mean, stddev;
  cv::meanStdDev(difference, mean, stddev);
  // Two independent noises (and rounding to grey levels, variance 1/12 each).
  const double expected = std::sqrt(2.0 * (s.image.noise_sigma * s.image.noise_sigma + 1.0 / 12.0));
  EXPECT_NEAR(stddev[0], expected, 0.15 * expected);
  EXPECT_NEAR(mean[0], 0.0, 0.05);
}

// --- Scenarios ----------------------------------------------------------------------------

TEST(ScenarioTest, BuiltInScenariosLoadAndCheck) {
  const std::vector<std::string> names = BuiltInScenarioNames();
  for (const char* expected :
       {"office", "corridor", "outdoor", "static", "drift", "jolt", "transient"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  }
  for (const std::string& name : names) {
    const Scenario s = LoadScenario(name);
    std::string why;
    EXPECT_TRUE(s.Check(&why)) << name << ": " << why;
    EXPECT_EQ(s.name, name);
    EXPECT_FALSE(s.description.empty());
  }
  const Scenario office = LoadScenario("office");
  EXPECT_EQ(office.width, 640);
  EXPECT_EQ(office.height, 480);
  EXPECT_EQ(office.fps, 30.0);
  EXPECT_EQ(office.seconds, 20.0);
  EXPECT_EQ(office.frame_count(), 600u);
  EXPECT_EQ(LoadScenario("drift").seconds, 60.0);
  EXPECT_EQ(LoadScenario("static").motion.type, "static");
  EXPECT_TRUE(Scenario().Check(nullptr));
}

TEST(ScenarioTest, BadFilesNameFileFieldAndLine) {
  test::TempDir dir;
  const std::string path = dir / "bad.yaml";
  test::WriteTextFile(path, "name: bad\nscene: office\naccelerometer:\n  rate_hz: fast\n");
  try {
    LoadScenario(path);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.line(), 4);
    EXPECT_NE(e.what_expected().find("accelerometer.rate_hz"), std::string::npos) << e.what();
    EXPECT_NE(e.what_expected().find("number"), std::string::npos) << e.what();
  }
  test::WriteTextFile(path,
                      "scene: office\nfps: 30\naccelerometer:\n  bits: 12\n  rate_hz: 2000\n");
  try {
    LoadScenario(path);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.line(), 5);
    EXPECT_NE(e.what_expected().find("accelerometer.rate_hz"), std::string::npos) << e.what();
    EXPECT_NE(e.what_expected().find("1600"), std::string::npos) << e.what();
  }
  test::WriteTextFile(path, "scene: office\nlense: sonnar\n");
  try {
    LoadScenario(path);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.line(), 2);
    EXPECT_NE(e.what_expected().find("lense"), std::string::npos) << e.what();
  }
  test::WriteTextFile(
      path,
      "disturbances:\n  - {kind: fog, start: 1, end: 2}\n  - {kind: smoke, start: 1, end: 2}\n");
  try {
    LoadScenario(path);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.line(), 3);
    EXPECT_NE(e.what_expected().find("disturbances[1].kind"), std::string::npos) << e.what();
  }
  test::WriteTextFile(path, "seconds: [1, 2\n");
  EXPECT_THROW(LoadScenario(path), Error);
  EXPECT_THROW(LoadScenario(dir / "missing.yaml"), Error);
}

TEST(ScenarioTest, OverridesAndSpecs) {
  Scenario s = ParseScenarioSpec("office,lens=sonnar,seconds=10,resolution=320x240,seed=7");
  EXPECT_EQ(s.lens, "sonnar");
  EXPECT_EQ(s.seconds, 10.0);
  EXPECT_EQ(s.width, 320);
  EXPECT_EQ(s.height, 240);
  EXPECT_EQ(s.seed, 7u);
  ApplyScenarioOverride(&s, "fps", "15");
  ApplyScenarioOverride(&s, "accel_rate", "800");
  ApplyScenarioOverride(&s, "noise_sigma", "0");
  EXPECT_EQ(s.fps, 15.0);
  EXPECT_EQ(s.accelerometer.rate_hz, 800.0);
  EXPECT_EQ(s.image.noise_sigma, 0.0);
  EXPECT_EQ(s.frame_count(), 150u);
  EXPECT_THROW(ApplyScenarioOverride(&s, "accel_rate", "2000"), Error);
  EXPECT_THROW(ApplyScenarioOverride(&s, "resolution", "640by480"), Error);
  EXPECT_THROW(ApplyScenarioOverride(&s, "lens", "pinhole"), Error);
  EXPECT_THROW(ApplyScenarioOverride(&s, "colour", "red"), Error);
  EXPECT_THROW(ApplyScenarioOverride(&s, "seconds", "ten"), Error);
  ApplyScenarioOverride(&s, "readout_ms", "30");
  EXPECT_EQ(s.image.readout_ms, 30.0);
  EXPECT_THROW(ApplyScenarioOverride(&s, "readout_ms", "70"), Error);  // Over 1/15 s.
  ApplyScenarioOverride(&s, "exposure_ms", "20");
  EXPECT_EQ(s.image.exposure_ms, 20.0);
  EXPECT_THROW(ApplyScenarioOverride(&s, "exposure_ms", "70"), Error);
  ApplyScenarioOverride(&s, "people", "4");
  EXPECT_EQ(s.people, 4);
  EXPECT_THROW(ApplyScenarioOverride(&s, "people", "101"), Error);
  EXPECT_THROW(ApplyScenarioOverride(&s, "motion", "static"), Error);  // People need a walk.
  ApplyScenarioOverride(&s, "surface_texture", "0.25");
  EXPECT_EQ(s.surface_texture, 0.25);
  EXPECT_THROW(ApplyScenarioOverride(&s, "surface_texture", "1.5"), Error);
  EXPECT_THROW(ApplyScenarioOverride(&s, "surface_texture", "bare"), Error);
  EXPECT_EQ(s.accelerometer.rate_hz, 800.0);  // Failed overrides change nothing.
  EXPECT_THROW(ParseScenarioSpec("office,lens"), Error);
  EXPECT_THROW(ParseScenarioSpec("nowhere"), Error);
}

// --- The sequence -------------------------------------------------------------------------

// With a rolling shutter each row is the row a global shutter sees at that row's time, the
// middle row at the frame's (its ground truth); rows read one every readout / height.
TEST_F(SimulatorTest, RollingShutterRowsAreTakenAroundTheFramesTime) {
  Scenario s = Small("office");
  s.image.readout_ms = 30.0;
  const auto sequence = MakeSimulatedSequence(s);
  const Trajectory trajectory(s.motion, s.scene);
  const Renderer renderer(office_);
  const size_t index = 40;
  const GroundTruthFrame& truth = sequence->ground_truth()->at(index);
  const double t = s.SecondsAt(truth.t_ns);
  const cv::Mat labels = *sequence->LoadPlaneLabels(index);
  const auto global_at = [&](double row_t) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = trajectory.WorldFromCamAt(row_t);
    pose.translation() = trajectory.PositionAt(row_t);
    return renderer.RenderLabels(truth.intrinsics, pose);
  };
  const double line_s = 0.030 / s.height;
  int differing_from_frame_time = 0;
  for (const int v : {0, s.height / 2, s.height - 1}) {
    const cv::Mat own = global_at(t + (v - 0.5 * (s.height - 1)) * line_s).row(v);
    EXPECT_EQ(cv::countNonZero(labels.row(v) != own), 0) << "row " << v;
    differing_from_frame_time += cv::countNonZero(global_at(t).row(v) != own);
  }
  EXPECT_GT(differing_from_frame_time, 0);  // The walk turns enough to tell.
}

// With an exposure each pixel gathers the light over it: near the image's centre the frame
// is the instantaneous one smeared along the image's motion over the exposure, by the
// whole of that motion (not by none, half or more).
TEST_F(SimulatorTest, ExposureSmearsAlongTheImagesMotion) {
  Scenario s = Small("office");
  s.seconds = 6.0;
  s.image.noise_sigma = 0.0;
  s.image.vignetting = 0.0;
  s.image.chromatic_px = 0.0;
  s.image.exposure_ms = 20.0;
  const auto sequence = MakeSimulatedSequence(s);
  const auto& truth = *sequence->ground_truth();
  size_t index = 1;  // The frame of the walk's fastest turn.
  double fastest = 0.0;
  for (size_t i = 1; i < truth.size(); ++i) {
    const double turn =
        truth[i - 1].world_from_cam_rotation.angularDistance(truth[i].world_from_cam_rotation);
    if (turn > fastest) fastest = turn, index = i;
  }
  const Trajectory trajectory(s.motion, s.scene);
  const Renderer renderer(office_);
  const double t = s.SecondsAt(truth[index].t_ns);
  const auto sharp_at = [&](double at) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = trajectory.WorldFromCamAt(at);
    pose.translation() = trajectory.PositionAt(at);
    cv::Mat grey;
    cv::cvtColor(renderer.Render(truth[index].intrinsics, pose, {}).image, grey,
                 cv::COLOR_BGR2GRAY);
    return grey;
  };

  // The image's motion over the exposure near the centre, tracked between its two ends.
  const cv::Rect centre(s.width / 2 - 50, s.height / 2 - 40, 100, 80);
  std::vector<cv::Point2f> from, to;
  for (int y = centre.y + 5; y < centre.br().y; y += 10) {
    for (int x = centre.x + 5; x < centre.br().x; x += 10) from.emplace_back(x, y);
  }
  std::vector<uchar> found;
  std::vector<float> errors;
  cv::calcOpticalFlowPyrLK(sharp_at(t - 0.010), sharp_at(t + 0.010), from, to, found, errors);
  std::vector<double> dx, dy;
  for (size_t i = 0; i < from.size(); ++i) {
    if (!found[i]) continue;
    dx.push_back(to[i].x - from[i].x);
    dy.push_back(to[i].y - from[i].y);
  }
  ASSERT_GT(dx.size(), from.size() / 2);
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  const cv::Point2d motion(median(dx), median(dy));
  ASSERT_GT(cv::norm(motion), 4.0) << "the walk should turn fast enough to smear";

  cv::Mat frame, middle;
  cv::cvtColor(sequence->LoadFrame(index), frame, cv::COLOR_BGR2GRAY);
  sharp_at(t).convertTo(middle, CV_32F);
  frame.convertTo(frame, CV_32F);
  // The instantaneous frame averaged over shifts spanning `fraction` of the motion.
  const auto rms_smeared = [&](double fraction) {
    constexpr int kShifts = 41;
    cv::Mat sum = cv::Mat::zeros(middle.size(), CV_32F), moved;
    for (int j = 0; j < kShifts; ++j) {
      const double f = fraction * (double(j) / (kShifts - 1) - 0.5);
      const cv::Matx23d shift(1, 0, f * motion.x, 0, 1, f * motion.y);
      cv::warpAffine(middle, moved, shift, middle.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
      sum += moved;
    }
    const cv::Mat difference = frame(centre) - sum(centre) / kShifts;
    return std::sqrt(cv::mean(difference.mul(difference))[0]);
  };
  const double unsmeared = rms_smeared(0.0), whole = rms_smeared(1.0);
  EXPECT_LT(whole, 0.3 * unsmeared) << "motion " << motion;
  EXPECT_LT(whole, rms_smeared(0.5));
  EXPECT_LT(whole, rms_smeared(1.5));
}

TEST_F(SimulatorTest, SequenceDescribesItselfAndItsTruth) {
  const Scenario s = Small("drift");
  const auto sequence = MakeSimulatedSequence(s);
  const SessionInfo& session = sequence->session();
  EXPECT_EQ(session.camera_device, "autocal simulator (drift, tessar)");
  EXPECT_EQ(session.width, 320);
  EXPECT_EQ(session.frame_rate_hz, 30.0);
  EXPECT_EQ(session.accel_rate_hz, 400.0);
  ASSERT_TRUE(session.premission_calibration.has_value());
  EXPECT_EQ(*session.premission_calibration, IntrinsicsAt(s, 0.0));
  ASSERT_EQ(sequence->frame_count(), 60u);
  const auto& truth = *sequence->ground_truth();
  ASSERT_EQ(truth.size(), 60u);
  for (size_t i : {size_t{0}, size_t{1}, size_t{59}}) {
    EXPECT_EQ(sequence->frame_time_ns(i), s.start_ns + std::llround(i * 1e9 / 30.0));
    EXPECT_EQ(truth[i].t_ns, sequence->frame_time_ns(i));
    EXPECT_EQ(truth[i].intrinsics, IntrinsicsAt(s, s.SecondsAt(truth[i].t_ns)));
  }
  EXPECT_GT(truth[59].intrinsics.fx, truth[0].intrinsics.fx);
  EXPECT_THROW(sequence->LoadFrame(60), Error);
  EXPECT_EQ(session.notes.find("people"), std::string::npos);
  EXPECT_EQ(session.notes.find("surface texture"), std::string::npos);
  // A recording says what the scenario changed of its scene.
  Scenario changed = Small("office");
  changed.people = 2;
  changed.surface_texture = 0.25;
  EXPECT_PRED_FORMAT2(::testing::IsSubstring, "seed 1, 2 people, surface texture 0.25)",
                      MakeSimulatedSequence(changed)->session().notes);

  // The scene description lists every plane with its id.
  const std::string yaml = SceneDescriptionYaml(s);
  cv::FileStorage storage(yaml, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  const cv::FileNode planes = storage["planes"];
  ASSERT_EQ(planes.size(), office_->planes.size());
  EXPECT_EQ(static_cast<int>(planes[0]["id"]), 1);
  EXPECT_EQ(static_cast<std::string>(planes[0]["name"]), "floor");
  EXPECT_EQ(planes[0]["corners"].size(), 4u);
  EXPECT_EQ(sequence->SceneDescription(), yaml);
}

}  // namespace
}  // namespace autocal
