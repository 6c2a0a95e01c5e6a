// Box 6: homography decomposition, plane tracking on synthetic tracks with known planes,
// and planes between two rendered still shots.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <random>
#include <set>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

#include "devices/sim/renderer.h"
#include "devices/sim/scene.h"
#include "devices/sim/simulator.h"
#include "pipeline/motion_stage.h"
#include "pipeline/planes.h"
#include "tests/sim_test_util.h"

namespace autocal {
namespace {

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

CameraIntrinsics TestCamera() { return CameraIntrinsics::FromFieldOfView(320, 240, 75.0); }

TEST(PlaneOptions, DefaultsAreValidAndFaultsAreNamed) {
  std::string error;
  EXPECT_TRUE(PlaneOptions().Check(&error)) << error;
  auto fails_on = [](auto change, const std::string& field) {
    PlaneOptions options;
    change(&options);
    std::string message;
    EXPECT_FALSE(options.Check(&message)) << field;
    EXPECT_NE(message.find(field), std::string::npos) << message;
  };
  fails_on([](PlaneOptions* o) { o->baseline_frames = 0; }, "baseline_frames");
  fails_on([](PlaneOptions* o) { o->inlier_threshold_px = 0; }, "inlier_threshold_px");
  fails_on([](PlaneOptions* o) { o->eject_threshold_px = 0.5; }, "eject_threshold_px");
  fails_on([](PlaneOptions* o) { o->join_radius = 0; }, "join_radius");
  fails_on([](PlaneOptions* o) { o->ransac_iterations = 1; }, "ransac_iterations");
  fails_on([](PlaneOptions* o) { o->min_inliers = 3; }, "min_inliers");
  fails_on([](PlaneOptions* o) { o->min_area_fraction = 1; }, "min_area_fraction");
  fails_on([](PlaneOptions* o) { o->min_tracks_to_keep = 30; }, "min_tracks_to_keep");
  fails_on([](PlaneOptions* o) { o->min_parallax_px = -1; }, "min_parallax_px");
  fails_on([](PlaneOptions* o) { o->min_spread = -1; }, "min_spread");
  fails_on([](PlaneOptions* o) { o->max_planes = 0; }, "max_planes");
  fails_on([](PlaneOptions* o) { o->max_reference_frames = 5; }, "max_reference_frames");
  fails_on([](PlaneOptions* o) { o->merge_fraction = 0; }, "merge_fraction");
  fails_on([](PlaneOptions* o) { o->normal_votes = 0; }, "normal_votes");
  fails_on([](PlaneOptions* o) { o->normal_agreement_deg = 90; }, "normal_agreement_deg");
  fails_on([](PlaneOptions* o) { o->shot_inlier_threshold_px = 0; }, "shot_inlier_threshold_px");
  fails_on([](PlaneOptions* o) { o->young_frames = 10; }, "young_frames");
  fails_on([](PlaneOptions* o) { o->max_noise_scale = 0.5; }, "max_noise_scale");
}

TEST(MotionStageOptions, DefaultsAreValidAndFaultsAreNamed) {
  std::string error;
  EXPECT_TRUE(MotionStageOptions().Check(&error)) << error;
  auto fails_on = [](auto change, const std::string& field) {
    MotionStageOptions options;
    change(&options);
    std::string message;
    EXPECT_FALSE(options.Check(&message)) << field;
    EXPECT_NE(message.find(field), std::string::npos) << message;
  };
  fails_on([](MotionStageOptions* o) { o->lost_planes_kept = -1; }, "lost_planes_kept");
  fails_on([](MotionStageOptions* o) { o->refind_min_matches = 3; }, "refind_min_matches");
  fails_on([](MotionStageOptions* o) { o->flow.history_frames = 20; }, "flow.history_frames");
  fails_on([](MotionStageOptions* o) { o->planes.baseline_frames = 0; }, "planes.baseline_frames");
}

// OpenCV's undistortion of `pixels` through `camera`, iterated as the criteria say.
std::vector<cv::Point2f> OpenCvUndistorted(const std::vector<cv::Point2f>& pixels,
                                           const CameraIntrinsics& camera, int steps,
                                           double epsilon) {
  const auto d = camera.Distortion();
  cv::Matx33d k;
  cv::eigen2cv(camera.CameraMatrix(), k);
  std::vector<cv::Point2f> undistorted;
  cv::undistortPoints(
      pixels, undistorted, k, std::vector<double>(d.begin(), d.end()), cv::noArray(), k,
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, steps, epsilon));
  return undistorted;
}

TEST(UndistortPixels, AgreesWithTheCameraModelOnAStrongBarrel) {
  CameraIntrinsics camera = TestCamera();
  camera.k1 = -0.3;
  camera.k2 = 0.1;
  camera.p1 = 0.001;
  std::vector<cv::Point2f> pixels;
  for (int y = 0; y < camera.height; y += 17) {
    for (int x = 0; x < camera.width; x += 19) pixels.emplace_back(float(x), float(y));
  }
  pixels.emplace_back(0.f, 0.f);
  pixels.emplace_back(float(camera.width - 1), float(camera.height - 1));
  const std::vector<cv::Point2f> ideal = UndistortPixels(pixels, camera);
  ASSERT_EQ(ideal.size(), pixels.size());
  // Distorted again by the forward model, each lands on its pixel; and OpenCV, iterating to
  // convergence, finds the same.
  const std::vector<cv::Point2f> opencv = OpenCvUndistorted(pixels, camera, 1000, 1e-9);
  double worst = 0.0, worst_from_opencv = 0.0;
  for (size_t i = 0; i < pixels.size(); ++i) {
    const Eigen::Vector3d ray((ideal[i].x - camera.cx) / camera.fx,
                              (ideal[i].y - camera.cy) / camera.fy, 1.0);
    worst =
        std::max(worst, (Project(camera, ray) - Eigen::Vector2d(pixels[i].x, pixels[i].y)).norm());
    worst_from_opencv = std::max(worst_from_opencv, double(cv::norm(ideal[i] - opencv[i])));
  }
  EXPECT_LT(worst, 1e-3) << "px";
  EXPECT_LT(worst_from_opencv, 1e-3) << "px";
  // A barrel so strong that the corners lie beyond its fold: no ray sees them, and there
  // the points are OpenCV's fixed point, as before; a point inside is still exact.
  CameraIntrinsics folded = TestCamera();
  folded.k1 = -1.0;
  const std::vector<cv::Point2f> corner_and_inside = {{0.f, 0.f}, {170.f, 125.f}};
  ASSERT_FALSE(Unproject(folded, {0.0, 0.0}).has_value());
  const std::vector<cv::Point2f> past_fold = UndistortPixels(corner_and_inside, folded);
  EXPECT_EQ(past_fold[0], OpenCvUndistorted({corner_and_inside[0]}, folded, 100, 1e-6)[0]);
  const Eigen::Vector3d inside_ray((past_fold[1].x - folded.cx) / folded.fx,
                                   (past_fold[1].y - folded.cy) / folded.fy, 1.0);
  EXPECT_LT((Project(folded, inside_ray) - Eigen::Vector2d(170, 125)).norm(), 1e-3);
  // Without distortion, nothing moves.
  CameraIntrinsics pinhole = TestCamera();
  EXPECT_EQ(UndistortPixels(pixels, pinhole), pixels);
}

Eigen::Vector2d Pixel(const CameraIntrinsics& c, const Eigen::Vector3d& p) {
  return {c.fx * p.x() / p.z() + c.cx, c.fy * p.y() / p.z() + c.cy};
}

TEST(DecomposePlaneHomography, RecoversTheTrueMotionAndNormal) {
  const CameraIntrinsics camera = TestCamera();
  // A plane 3 m ahead, turned 30 deg about the vertical, facing the camera.
  const Eigen::Vector3d normal =
      Eigen::AngleAxisd(30.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()) * -Eigen::Vector3d::UnitZ();
  const double distance = 3.0;  // From the reference camera.
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(0.1, Eigen::Vector3d(0.2, 1.0, 0.1).normalized()).toRotationMatrix();
  const Eigen::Vector3d translation(0.3, -0.05, 0.2);
  std::vector<cv::Point2f> reference, current;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  while (reference.size() < 50) {
    // A point of the plane: a ray through the reference image hits it.
    const Eigen::Vector3d ray((u(rng) * 0.5 * camera.width) / camera.fx,
                              (u(rng) * 0.5 * camera.height) / camera.fy, 1.0);
    const Eigen::Vector3d point = ray * (distance / -normal.dot(ray));
    const Eigen::Vector3d moved = rotation * point + translation;
    const Eigen::Vector2d a = Pixel(camera, point), b = Pixel(camera, moved);
    reference.emplace_back(float(a.x()), float(a.y()));
    current.emplace_back(float(b.x()), float(b.y()));
  }
  const Eigen::Matrix3d k = camera.CameraMatrix();
  const Eigen::Matrix3d h =
      k * (rotation + translation * (-normal).transpose() / distance) * k.inverse();
  cv::Matx33d homography;
  cv::eigen2cv(h, homography);
  const std::vector<PlaneMotion> motions =
      DecomposePlaneHomography(homography, camera, reference, current);
  ASSERT_GE(motions.size(), 1u);
  EXPECT_LE(motions.size(), 2u) << "the solutions with points behind a camera are gone";
  const auto best = std::min_element(motions.begin(), motions.end(), [&](auto& a, auto& b) {
    return AngleDeg(a.normal_reference, normal) < AngleDeg(b.normal_reference, normal);
  });
  EXPECT_LT(AngleDeg(best->normal_reference, normal), 1e-4);
  EXPECT_LT((best->rotation - rotation).norm(), 1e-6);
  EXPECT_LT((best->translation_over_distance - translation / distance).norm(), 1e-6);
}

// Tracks of world points seen by a moving camera at 30 frames a second: positions measured
// with noise, tracks ending where points leave the view or their frames of texture end.
class SyntheticTracks {
 public:
  virtual ~SyntheticTracks() = default;

  // Advances to frame `k` and returns the live tracks.
  const std::vector<Track>& Frame(int k) {
    const double t = k / 30.0;
    const Eigen::Matrix3d world_from_cam = WorldFromCam(t);
    const Eigen::Vector3d position = Position(t);
    std::normal_distribution<double> noise(0.0, 0.1);
    std::vector<Track> live;
    for (size_t i = 0; i < points_.size(); ++i) {
      const Point& point = points_[i];
      const Eigen::Vector3d p = world_from_cam.transpose() * (point.world - position);
      const Eigen::Vector2d pixel = Pixel(camera_, p);
      const bool visible = k >= point.first_frame && k <= point.last_frame && p.z() > 0.1 &&
                           pixel.x() > 5 && pixel.y() > 5 && pixel.x() < camera_.width - 5 &&
                           pixel.y() < camera_.height - 5;
      auto it = std::find_if(tracks_.begin(), tracks_.end(),
                             [&](const Track& tr) { return tr.id == int(i) + 1; });
      if (!visible || (it == tracks_.end() && ended_.count(int(i) + 1))) {
        if (it != tracks_.end()) ended_.insert(it->id);
        continue;
      }
      Track track = it == tracks_.end() ? Track{int(i) + 1, -1, {}} : *it;
      ++track.age;
      track.history.push_back(
          {Time(k), cv::Point2f(float(pixel.x() + noise(rng_)), float(pixel.y() + noise(rng_)))});
      if (track.history.size() > 30) track.history.erase(track.history.begin());
      live.push_back(std::move(track));
    }
    tracks_ = std::move(live);
    return tracks_;
  }

  static int64_t Time(int k) { return 1'000'000'000 + k * 33'333'333LL; }
  virtual Eigen::Matrix3d WorldFromCam(double t) const = 0;
  virtual Eigen::Vector3d Position(double t) const = 0;
  // Which true plane a track's point lies on.
  int PlaneOf(int track_id) const { return points_[track_id - 1].plane; }
  const CameraIntrinsics& camera() const { return camera_; }

 protected:
  struct Point {
    Eigen::Vector3d world;
    int plane;
    int first_frame = 0, last_frame = std::numeric_limits<int>::max();  // Textured then.
  };
  std::vector<Point> points_;

 private:
  CameraIntrinsics camera_ = TestCamera();
  std::vector<Track> tracks_;
  std::set<int> ended_;
  std::mt19937 rng_{11};
};

// A floor and a wall seen by a camera walking toward the wall, with a little sway and yaw.
// From `stop_s` on the camera stands and only turns.
class SyntheticWalk : public SyntheticTracks {
 public:
  explicit SyntheticWalk(double speed_mps, double stop_s = kNever)
      : speed_(speed_mps), stop_s_(stop_s) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> across(-2.0, 2.0), along(1.0, 6.0), up(0.0, 2.5);
    // World: camera axes at time 0 (x right, y down, z forward), floor (1) at y = 1.4,
    // wall (2) at z = 6.
    for (int i = 0; i < 500; ++i) points_.push_back({{across(rng), 1.4, along(rng)}, 1});
    for (int i = 0; i < 500; ++i) points_.push_back({{across(rng), 1.4 - up(rng), 6.0}, 2});
  }

  Eigen::Matrix3d WorldFromCam(double t) const override {
    return Eigen::AngleAxisd(0.08 * std::sin(1.5 * t), Eigen::Vector3d::UnitY()).toRotationMatrix();
  }
  Eigen::Vector3d Position(double t) const override {
    const double moving = std::min(t, stop_s_);
    return {0.1 * std::sin(2.0 * moving), 0.02 * std::sin(11.0 * moving), speed_ * moving};
  }

 private:
  static constexpr double kNever = 1e9;
  double speed_;
  double stop_s_;
};

// Two walls meeting in a corner, seen by a camera stepping sideways and turning toward the
// corner: the wall faced (1, z = 4 left of the corner at x = 1) is tracked all over until
// `switch_frame`, then only within `band_m` of the corner; the wall beyond (2, turning back
// toward the camera at 45 deg) only from then on, as when the camera turns from one wall
// to the next, and from 0.4 m past the corner: tracks right by it would fit the strip's
// homography and join the strip's plane, which box 6 does not prevent (docs/motion.md).
class SyntheticCorner : public SyntheticTracks {
 public:
  SyntheticCorner(int switch_frame, double band_m) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> up(-1.0, 1.0), unit(0.0, 1.0);
    for (int i = 0; i < 400; ++i) {
      const double x = 1.0 - 3.0 * unit(rng);
      points_.push_back({{x, up(rng), 4.0}, 1, 0, x > 1.0 - band_m ? kAlways : switch_frame});
    }
    for (int i = 0; i < 400; ++i) {
      const double a = 0.4 + 1.6 * unit(rng);
      points_.push_back({{1.0 + a, up(rng), 4.0 - a}, 2, switch_frame, kAlways});
    }
  }

  Eigen::Matrix3d WorldFromCam(double t) const override {
    return Eigen::AngleAxisd(0.2 + 0.2 * t, Eigen::Vector3d::UnitY()).toRotationMatrix();
  }
  Eigen::Vector3d Position(double t) const override { return {-1.0 + 1.2 * t, 0.0, 0.0}; }

 private:
  static constexpr int kAlways = std::numeric_limits<int>::max();
};

// A plane whose tracks dwindle to a strip along a corner is not the next wall, though the
// next wall's homography fits that strip: the strip lies on both. Merged into it, the
// plane's id passed to the other wall, and box 10 took tracks of both walls as one plane
// (the office walk at 640x480, 30 s: 36 tracks on one wall and 84 on the next, the solve
// 69-106 iterations).
TEST(PlaneTracker, APlaneDwindledToACornerKeepsItsWall) {
  const int switch_frame = 40;
  SyntheticCorner corner(switch_frame, 0.25);
  PlaneTracker tracker;
  std::map<int, int> identity;  // Plane id -> the wall most of its tracks lay on first.
  int frames_with_the_next_wall = 0;
  for (int k = 0; k < 90; ++k) {
    tracker.Update(SyntheticTracks::Time(k), corner.Frame(k), corner.camera());
    for (const DominantPlane& plane : tracker.planes()) {
      const auto on_next = std::count_if(plane.track_ids.begin(), plane.track_ids.end(),
                                         [&](int id) { return corner.PlaneOf(id) == 2; });
      const int wall = 2 * on_next > long(plane.track_ids.size()) ? 2 : 1;
      if (!identity.count(plane.id)) identity[plane.id] = wall;
      EXPECT_EQ(identity[plane.id], wall)
          << "frame " << k << ": plane " << plane.id << " holds " << on_next << " of "
          << plane.track_ids.size() << " tracks on the next wall";
      frames_with_the_next_wall += wall == 2 && on_next == long(plane.track_ids.size());
    }
  }
  EXPECT_EQ(identity.size(), 2u) << "one id per wall";
  // Found once its tracks are a baseline old, and followed to the end.
  EXPECT_GE(frames_with_the_next_wall, 90 - switch_frame - PlaneOptions().baseline_frames - 1);
}

TEST(PlaneTracker, FindsAndFollowsTheFloorAndTheWall) {
  SyntheticWalk walk(1.2);
  PlaneTracker tracker;
  std::map<int, int> identity;  // Plane id -> true plane, from its first frame.
  int frames_with_both = 0, members = 0, impure = 0;
  std::vector<double> normal_errors;
  const int frames = 75;
  for (int k = 0; k < frames; ++k) {
    tracker.Update(SyntheticWalk::Time(k), walk.Frame(k), walk.camera());
    std::set<int> seen;
    for (const DominantPlane& plane : tracker.planes()) {
      ASSERT_EQ(plane.track_ids.size(), plane.points.size());
      ASSERT_EQ(plane.track_ids.size(), plane.reference_points.size());
      ASSERT_TRUE(std::is_sorted(plane.track_ids.begin(), plane.track_ids.end()));
      const int on_floor = int(std::count_if(plane.track_ids.begin(), plane.track_ids.end(),
                                             [&](int id) { return walk.PlaneOf(id) == 1; }));
      const int truth = 2 * on_floor >= int(plane.track_ids.size()) ? 1 : 2;
      if (!identity.count(plane.id)) identity[plane.id] = truth;
      EXPECT_EQ(identity[plane.id], truth) << "plane " << plane.id << " changed identity";
      for (int id : plane.track_ids) {
        ++members;
        impure += walk.PlaneOf(id) != truth;
      }
      seen.insert(truth);
      // The reference points map onto the current ones by the homography (all but those
      // that strayed since the reference frame and stay for following the plane lately),
      // where it is determined: not on the thin strip of floor left at the end.
      if (!plane.normal) continue;
      int mapped = 0;
      for (size_t i = 0; i < plane.points.size(); ++i) {
        const cv::Vec3d q = plane.homography * cv::Vec3d(plane.reference_points[i].x,
                                                         plane.reference_points[i].y, 1.0);
        mapped += std::hypot(q[0] / q[2] - plane.points[i].x, q[1] / q[2] - plane.points[i].y) <=
                  PlaneOptions().eject_threshold_px;
      }
      EXPECT_GE(mapped, 0.8 * plane.points.size()) << "plane " << plane.id << " frame " << k;
      const Eigen::Matrix3d cam_from_world = walk.WorldFromCam(k / 30.0).transpose();
      const Eigen::Vector3d truth_normal =
          cam_from_world * (truth == 1 ? -Eigen::Vector3d::UnitY() : -Eigen::Vector3d::UnitZ());
      normal_errors.push_back(AngleDeg(*plane.normal, truth_normal));
    }
    if (k >= PlaneOptions().baseline_frames + 2) frames_with_both += seen.size() == 2;
  }
  std::printf("%d of %d memberships on the wrong plane\n", impure, members);
  EXPECT_LT(impure, 0.01 * members);
  EXPECT_EQ(identity.size(), 2u) << "one id per true plane, kept throughout";
  EXPECT_EQ(frames_with_both, frames - PlaneOptions().baseline_frames - 2);
  ASSERT_GT(normal_errors.size(), 40u);
  std::sort(normal_errors.begin(), normal_errors.end());
  std::printf("%zu normals: median error %.2f deg, worst %.2f deg\n", normal_errors.size(),
              normal_errors[normal_errors.size() / 2], normal_errors.back());
  EXPECT_LT(normal_errors[normal_errors.size() / 2], 2.0) << "median normal error, deg";
  EXPECT_LT(normal_errors.back(), 10.0) << "worst normal error, deg";
}

// Without translation every plane moves by the same homography: nothing can be told
// apart, and no plane may be claimed.
TEST(PlaneTracker, NoPlanesWithoutParallax) {
  SyntheticWalk still(0.0);
  PlaneTracker tracker;
  for (int k = 0; k < 40; ++k) {
    tracker.Update(SyntheticWalk::Time(k), still.Frame(k), still.camera());
    EXPECT_TRUE(tracker.planes().empty()) << "frame " << k;
  }
}

// Once the camera only turns, one homography (the rotation's) fits the floor and the wall
// alike: that says nothing about their being one plane, and two planes told apart while
// the camera walked must not be merged into one (far facades outdoors were, as the walker
// turned a corner).
TEST(PlaneTracker, PlanesToldApartStayApartWhileTheCameraOnlyTurns) {
  SyntheticWalk walk(1.2, 1.5);
  PlaneTracker tracker;
  int mixed = 0, planes_seen = 0;
  for (int k = 0; k < 90; ++k) {
    tracker.Update(SyntheticWalk::Time(k), walk.Frame(k), walk.camera());
    for (const DominantPlane& plane : tracker.planes()) {
      const auto on_floor = std::count_if(plane.track_ids.begin(), plane.track_ids.end(),
                                          [&](int id) { return walk.PlaneOf(id) == 1; });
      const double minority =
          double(std::min<size_t>(on_floor, plane.track_ids.size() - on_floor)) /
          double(plane.track_ids.size());
      ++planes_seen;
      if (minority > 0.2) {
        ++mixed;
        std::printf("frame %d: plane %d holds %zd floor and %zd wall tracks\n", k, plane.id,
                    on_floor, plane.track_ids.size() - on_floor);
      }
    }
  }
  EXPECT_GT(planes_seen, 60);
  EXPECT_EQ(mixed, 0) << "planes holding both the floor and the wall";
}

// Two views of a corner of the office, planes from matched keypoints.
TEST(FindPlanesBetweenShots, FloorAndWallFromTwoViews) {
  Scenario scenario = LoadScenario("office");
  ApplyScenarioOverride(&scenario, "resolution", "640x480");
  const std::shared_ptr<const Scene> scene = BuildScene(scenario);
  const Renderer renderer(scene);
  const CameraIntrinsics camera =
      MakeSimulatedSequence(scenario)->ground_truth()->front().intrinsics;
  // Looking at the east wall (x = 4) and the floor in front of it, from 2.5 m, then a
  // step to the side and forward, turned a little.
  const Eigen::Isometry3d a = test::LookingAt({4.0, 0.0, 0.6}, 2.5, 0.0, 20.0);
  const Eigen::Isometry3d b = test::LookingAt({4.0, 0.2, 0.6}, 2.2, -5.0, 22.0, 2.0);
  RenderOptions render;
  const RenderedFrame view_a = renderer.Render(camera, a, render);
  const RenderedFrame view_b = renderer.Render(camera, b, render);
  cv::Mat gray_a, gray_b;
  cv::extractChannel(view_a.image, gray_a, 1);
  cv::extractChannel(view_b.image, gray_b, 1);
  const FeatureOptions features;
  const std::vector<ShotPlane> planes =
      FindPlanesBetweenShots(DetectKeypoints(gray_a, features), DetectKeypoints(gray_b, features),
                             camera, PlaneOptions(), features);
  const KeypointSet keys_b = DetectKeypoints(gray_b, features);
  std::set<std::string> found;
  for (const ShotPlane& plane : planes) {
    std::map<int, int> votes;
    for (const cv::DMatch& m : plane.matches) {
      const cv::Point2f p = keys_b.keypoints[m.trainIdx].pt;
      ++votes[view_b.labels.at<uint16_t>(cvRound(p.y), cvRound(p.x))];
    }
    const auto majority = std::max_element(votes.begin(), votes.end(),
                                           [](auto& x, auto& y) { return x.second < y.second; });
    ASSERT_GT(majority->first, 0);
    const Plane& truth = scene->planes[majority->first - 1];
    found.insert(truth.name);
    std::printf("%s: %zu matches, %d on it, %zu motions\n", truth.name.c_str(),
                plane.matches.size(), majority->second, plane.motions.size());
    EXPECT_GE(majority->second, 0.95 * plane.matches.size()) << truth.name;
    EXPECT_FALSE(plane.motions.empty());
    if (plane.motions.size() == 1) {
      const Eigen::Vector3d truth_normal = a.linear().transpose() * truth.normal();
      EXPECT_LT(AngleDeg(plane.motions[0].normal_reference, truth_normal), 5.0) << truth.name;
    }
  }
  EXPECT_TRUE(found.count("floor"));
  EXPECT_TRUE(found.count("wall_east"));
}

}  // namespace
}  // namespace autocal
