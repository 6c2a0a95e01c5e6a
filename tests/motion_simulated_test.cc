// Boxes 4-6 on simulated walks, measured against the simulator's plane labels: which
// scene plane each pixel sees, so which plane each track truly lies on.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <future>
#include <map>
#include <set>

#include <gtest/gtest.h>

#include "devices/sim/scene.h"
#include "devices/sim/simulator.h"
#include "pipeline/motion_stage.h"
#include "pipeline/rectifier.h"

namespace autocal {
namespace {

// Planes come from parallax: a frame is scored once the camera has moved at least this
// far over box 6's baseline (the corridor walk starts turning on the spot).
constexpr double kMinTravelM = 0.15;
const int kBaselineFrames = PlaneOptions().baseline_frames;
// A plane can be found only once its tracks have been followed over the baseline. A wall
// sweeping into view in a fast turn takes longer: its tracks followed that long are the
// first to come into view, by its corner with the wall before it, where both walls fit
// them, and those that tell it apart are younger (office walk: found 13 frames after it
// filled 20% of the image at 640x480, 14 at 320x240). The floor and the wall faced must
// be found in every frame once they have filled 20% of the image this long.
const int kStartupFrames = kBaselineFrames + PlaneOptions().young_frames;

struct WalkRun {
  int frames = 0;            // Frames scored (the camera moving).
  int64_t members = 0;       // Plane memberships, over all frames and planes...
  int64_t pure_members = 0;  // ...of them on the plane's true identity.
  int big_floor_frames = 0;  // Frames where the floor has filled 20% of the image for the
  int floor_found = 0;       // start-up, and of them those where a plane is the floor.
  int big_wall_frames = 0;   // Likewise the wall faced (the wall filling most).
  int wall_found = 0;
  int late = 0;  // Frames where floor or wall filled 20% but not yet for long.
  int late_found = 0;
  // The shortest start-up after which the floor and the wall faced were found in every
  // frame: the most frames either had filled 20% of the image in a frame missing it.
  int startup_needed = 0;
  int id_pairs = 0;                       // (true plane, consecutive frames) both detected...
  int id_kept = 0;                        // ...where one id carries over.
  std::vector<double> normal_errors_deg;  // Of planes with a normal, against the truth.
  double tracks = 0.0;                    // Mean live tracks per frame.
  double planes = 0.0;                    // Mean planes per frame.
  double features_ms = 0.0, flow_ms = 0.0, planes_ms = 0.0;  // Mean per frame.

  double Purity() const { return double(pure_members) / std::max<int64_t>(1, members); }
  double FloorRate() const { return double(floor_found) / std::max(1, big_floor_frames); }
  double WallRate() const { return double(wall_found) / std::max(1, big_wall_frames); }
  double Stability() const { return double(id_kept) / std::max(1, id_pairs); }
  double NormalQuantile(double q) const {
    if (normal_errors_deg.empty()) return 180.0;
    std::vector<double> e = normal_errors_deg;
    std::nth_element(e.begin(), e.begin() + size_t(q * (e.size() - 1)), e.end());
    return e[size_t(q * (e.size() - 1))];
  }
};

// The true plane under a point of the image boxes 4-6 saw, described by `camera`: the
// labels live in the raw image, taken with `lens`.
int TruePlane(const cv::Mat& labels, const cv::Point2f& p, const CameraIntrinsics& camera,
              const CameraIntrinsics& lens) {
  Eigen::Vector2d raw(p.x, p.y);
  if (!(camera == lens)) {
    raw = Project(lens, Eigen::Vector3d((p.x - camera.cx) / camera.fx,
                                        (p.y - camera.cy) / camera.fy, 1.0));
  }
  const int x = int(std::lround(raw.x())), y = int(std::lround(raw.y()));
  if (x < 0 || y < 0 || x >= labels.cols || y >= labels.rows) return 0;
  return labels.at<uint16_t>(y, x);
}

// The true plane most of a plane's tracks lie on, and how many do.
std::pair<int, int> Identity(const DominantPlane& plane, const cv::Mat& labels,
                             const CameraIntrinsics& camera, const CameraIntrinsics& lens) {
  std::map<int, int> votes;
  for (const cv::Point2f& p : plane.points) ++votes[TruePlane(labels, p, camera, lens)];
  return *std::max_element(votes.begin(), votes.end(),
                           [](const auto& a, const auto& b) { return a.second < b.second; });
}

bool IsWall(const std::string& name) {
  return name.rfind("wall_", 0) == 0 || name.rfind("end_", 0) == 0;
}

// Walks a scenario and scores every frame. `rectified`: boxes 4-6 see box 3's
// undistorted, equalized image (as in the pipeline); otherwise the raw green channel,
// and the tracks are undistorted with the true lens.
WalkRun RunWalk(const std::string& scenario_name, const std::string& lens, double seconds,
                const std::string& resolution, bool rectified) {
  Scenario scenario = LoadScenario(scenario_name);
  ApplyScenarioOverride(&scenario, "lens", lens);
  ApplyScenarioOverride(&scenario, "seconds", std::to_string(seconds));
  ApplyScenarioOverride(&scenario, "resolution", resolution);
  const auto sequence = MakeSimulatedSequence(scenario);
  const std::shared_ptr<const Scene> scene = BuildScene(scenario);
  int floor_id = 0;
  for (const Plane& p : scene->planes) {
    if (p.name == "floor" || p.name == "ground") floor_id = p.id;
  }

  MotionStage stage;
  Rectifier rectifier;
  WalkRun run;
  std::map<int, int> previous_identity;  // Plane id -> true plane id, last frame.
  std::map<int, int> big_for;            // True plane id -> frames it has filled 20%.
  struct Rendered {
    cv::Mat frame, labels;
  };
  auto render = [&](size_t i) {
    return Rendered{sequence->LoadFrame(i), *sequence->LoadPlaneLabels(i)};
  };
  std::future<Rendered> next = std::async(std::launch::async, render, 0);
  for (size_t i = 0; i < sequence->frame_count(); ++i) {
    const Rendered rendered = next.get();
    if (i + 1 < sequence->frame_count()) next = std::async(std::launch::async, render, i + 1);
    const GroundTruthFrame& truth = (*sequence->ground_truth())[i];
    CameraIntrinsics camera = truth.intrinsics;
    cv::Mat gray;
    if (rectified) {
      gray = rectifier.Geometry(rendered.frame, camera);
      camera.k1 = camera.k2 = camera.p1 = camera.p2 = camera.k3 = 0.0;
    } else {
      gray = rectifier.Equalize(rectifier.Channel(rendered.frame));
    }
    const MotionSnapshot snapshot = stage.Process(truth.t_ns, gray, camera);

    // How much of the image each true plane fills.
    const cv::Mat& labels = rendered.labels;
    std::map<int, double> fill;
    for (int y = 0; y < labels.rows; ++y) {
      for (int x = 0; x < labels.cols; ++x) fill[labels.at<uint16_t>(y, x)] += 1.0;
    }
    for (auto& [id, f] : fill) f /= double(labels.total());
    for (const Plane& p : scene->planes) big_for[p.id] = fill[p.id] >= 0.2 ? big_for[p.id] + 1 : 0;
    if (i < size_t(kBaselineFrames) ||
        (truth.world_from_cam_translation -
         (*sequence->ground_truth())[i - kBaselineFrames].world_from_cam_translation)
                .norm() < kMinTravelM) {
      previous_identity.clear();
      continue;
    }

    ++run.frames;
    run.tracks += snapshot.tracks.size();
    run.planes += snapshot.planes.size();
    run.features_ms += snapshot.features_ms;
    run.flow_ms += snapshot.flow_ms;
    run.planes_ms += snapshot.planes_ms;

    // The true plane under a tracked point: labels live in the raw image.
    int wall_faced = 0;
    for (const auto& [id, f] : fill) {
      if (id > 0 && IsWall(scene->planes[id - 1].name) && (!wall_faced || f > fill[wall_faced])) {
        wall_faced = id;
      }
    }

    const Eigen::Matrix3d cam_from_world =
        truth.world_from_cam_rotation.toRotationMatrix().transpose();
    std::map<int, int> identity;  // Plane id -> true plane id.
    std::set<int> found;
    for (const DominantPlane& plane : snapshot.planes) {
      const auto [majority, count] = Identity(plane, labels, camera, truth.intrinsics);
      identity[plane.id] = majority;
      found.insert(majority);
      run.members += plane.points.size();
      run.pure_members += majority != 0 ? count : 0;
      if (plane.normal && majority != 0) {
        const Eigen::Vector3d truth_normal =
            cam_from_world * scene->planes[majority - 1].normal();
        run.normal_errors_deg.push_back(
            std::acos(std::clamp(plane.normal->dot(truth_normal), -1.0, 1.0)) * 180.0 / M_PI);
      }
    }
    for (int id : {floor_id, wall_faced}) {
      if (id == 0 || big_for[id] == 0) continue;
      if (!found.count(id)) run.startup_needed = std::max(run.startup_needed, big_for[id]);
      if (big_for[id] <= kStartupFrames) {
        ++run.late;
        run.late_found += found.count(id);
      } else if (id == floor_id) {
        ++run.big_floor_frames;
        run.floor_found += found.count(id);
      } else {
        ++run.big_wall_frames;
        run.wall_found += found.count(id);
      }
    }
    // A true plane detected in two consecutive frames should keep one of its ids.
    std::set<int> both;
    for (const auto& [id, truth_id] : previous_identity) {
      if (truth_id != 0 && found.count(truth_id)) both.insert(truth_id);
    }
    for (int truth_id : both) {
      ++run.id_pairs;
      bool kept = false;
      for (const auto& [id, t] : identity) {
        kept |= t == truth_id && previous_identity.count(id) && previous_identity[id] == truth_id;
      }
      run.id_kept += kept;
    }
    previous_identity = identity;
  }
  const double n = std::max(1, run.frames);
  run.tracks /= n;
  run.planes /= n;
  run.features_ms /= n;
  run.flow_ms /= n;
  run.planes_ms /= n;
  std::printf(
      "%s %s %s %s: %d frames, %.0f tracks, %.1f planes a frame; purity %.4f (%lld "
      "memberships); floor found %d/%d, wall faced found %d/%d (and %d/%d within the start-up "
      "of filling 20%%, all found after %d); ids kept %d/%d (%.3f); normals %zu, median "
      "%.2f deg, 90%% %.2f deg; ms/frame features %.2f flow %.2f planes %.2f\n",
      scenario_name.c_str(), lens.c_str(), resolution.c_str(), rectified ? "rectified" : "raw",
      run.frames, run.tracks, run.planes, run.Purity(), (long long)run.members, run.floor_found,
      run.big_floor_frames, run.wall_found, run.big_wall_frames, run.late_found, run.late,
      run.startup_needed, run.id_kept, run.id_pairs, run.Stability(), run.normal_errors_deg.size(),
      run.NormalQuantile(0.5), run.NormalQuantile(0.9), run.features_ms, run.flow_ms,
      run.planes_ms);
  return run;
}

// What the issue asks of box 6 on a walk: at least 95% of the tracks a plane holds lie on
// its true plane; the floor and the wall faced are found in every frame once they have
// filled 20% of the image for the start-up (`wall_rate` of them for the wall on the raw
// sonnar image); planes keep their ids from frame to frame.
void ExpectGood(const WalkRun& run, double purity = 0.95, double wall_rate = 1.0) {
  EXPECT_GT(run.frames, 0);
  EXPECT_GE(run.Purity(), purity) << "fraction of plane tracks on the plane's true identity";
  EXPECT_GT(run.big_floor_frames, 0);
  EXPECT_EQ(run.floor_found, run.big_floor_frames)
      << "frames with the floor over 20% but no floor plane";
  EXPECT_GT(run.big_wall_frames, 0);
  EXPECT_GE(run.WallRate(), wall_rate) << "frames with the wall faced over 20% and a plane on it";
  EXPECT_GE(run.Stability(), 0.9) << "consecutive frames where a plane kept its id";
  EXPECT_LT(run.NormalQuantile(0.5), 6.0) << "median error of the plane normals, deg";
}

TEST(MotionSimulated, OfficeWalk) {
  ExpectGood(RunWalk("office", "tessar", 10.0, "320x240", true));
}

TEST(MotionSimulated, CorridorWalk) {
  ExpectGood(RunWalk("corridor", "tessar", 10.0, "320x240", true));
}

// Outdoors the ground is the plane box 10 leans on, seen to the horizon under facades 18 m
// and more away, which never fill 20% of the image. The ground's plane must hold the
// ground's tracks, not the facades' feet (measured: purity 0.973, the ground found in
// every frame; at 640x480 purity 0.993, 0-6 of the ground plane's 100-180 tracks on a
// facade, its normal within 0.6 deg of the truth once voted, the far facades' 16 deg off
// at the median).
TEST(MotionSimulated, OutdoorWalkGroundHoldsTheGround) {
  const WalkRun run = RunWalk("outdoor", "sonnar", 10.0, "320x240", true);
  EXPECT_GE(run.Purity(), 0.95);
  EXPECT_GT(run.big_floor_frames, 100);
  EXPECT_EQ(run.floor_found, run.big_floor_frames)
      << "frames with the ground over 20% but no plane on it";
  EXPECT_GE(run.Stability(), 0.9);
}

// The raw image through a strong barrel, tracks undistorted with the lens for box 6. Its
// periphery is squeezed, so tracks there are shorter on texture and purity is lower;
// without undistortion the normals would be off by 28 deg (median) and purity 0.88.
TEST(MotionSimulated, OfficeWalkRawSonnar) {
  ExpectGood(RunWalk("office", "sonnar", 6.0, "320x240", false), 0.9, 0.9);
}

// The resolution; 320x240 above keeps the tests fast (rendering and tracking a
// quarter of the pixels), with purity a point lower: thresholds are in pixels, which
// span twice the angle. Run with --gtest_also_run_disabled_tests.
TEST(MotionSimulated, DISABLED_OfficeWalk640x480) {
  ExpectGood(RunWalk("office", "tessar", 10.0, "640x480", true));
}

TEST(MotionSimulated, DISABLED_CorridorWalk640x480) {
  ExpectGood(RunWalk("corridor", "tessar", 10.0, "640x480", true));
}

// Box 4's keypoints re-find a lost plane: walking slowly round the office while looking
// 80 deg to either side, the camera turns away from the west wall, whose plane is lost,
// and back to it 3 s later. The plane found there again must get the wall's old id back,
// and does not without the keypoints.
struct Refinding {
  int gap_end = -1;   // The first frame a plane is on the wall after a second with none.
  int id_before = 0;  // The id on the wall before the gap.
  int refound = -1;   // The first frame after the gap where that id is back...
  bool refound_on_wall = false;  // ...on a plane that lies on the wall.
};

Refinding WalkAwayAndBack(int lost_planes_kept) {
  Scenario scenario = LoadScenario("office");
  ApplyScenarioOverride(&scenario, "lens", "tessar");
  ApplyScenarioOverride(&scenario, "seconds", "8");
  ApplyScenarioOverride(&scenario, "resolution", "320x240");
  scenario.motion.speed_mps = 0.6;
  scenario.motion.scan_deg = 80.0;
  scenario.motion.scan_hz = 0.2;
  const auto sequence = MakeSimulatedSequence(scenario);
  const std::shared_ptr<const Scene> scene = BuildScene(scenario);
  int wall = 0;
  for (const Plane& p : scene->planes) {
    if (p.name == "wall_west") wall = p.id;
  }
  MotionStageOptions options;
  options.lost_planes_kept = lost_planes_kept;
  MotionStage stage(options);
  Rectifier rectifier;
  Refinding result;
  int last_seen = -1;
  for (size_t i = 0; i < sequence->frame_count(); ++i) {
    const GroundTruthFrame& truth = (*sequence->ground_truth())[i];
    CameraIntrinsics camera = truth.intrinsics;
    const cv::Mat gray = rectifier.Geometry(sequence->LoadFrame(i), camera);
    camera.k1 = camera.k2 = camera.p1 = camera.p2 = camera.k3 = 0.0;
    const cv::Mat labels = *sequence->LoadPlaneLabels(i);
    const MotionSnapshot snapshot = stage.Process(truth.t_ns, gray, camera);
    for (const DominantPlane& plane : snapshot.planes) {
      const bool on_wall = Identity(plane, labels, camera, truth.intrinsics).first == wall;
      if (result.gap_end >= 0 && result.refound < 0 && plane.id == result.id_before) {
        result.refound = int(i);
        result.refound_on_wall = on_wall;
      }
      if (!on_wall) continue;
      if (result.gap_end < 0 && last_seen >= 0 && int(i) - last_seen > 30) {
        result.gap_end = int(i);
      }
      if (result.gap_end < 0) result.id_before = plane.id;
      last_seen = int(i);
    }
  }
  std::printf("west wall: plane %d, none on it until frame %d, plane %d again from frame %d%s\n",
              result.id_before, result.gap_end, result.id_before, result.refound,
              result.refound_on_wall ? " on the wall" : "");
  return result;
}

TEST(MotionSimulated, RefindsWallAfterTurningAway) {
  const Refinding run = WalkAwayAndBack(MotionStageOptions().lost_planes_kept);
  ASSERT_GE(run.gap_end, 0) << "the walk must turn away from the wall and back";
  EXPECT_GE(run.refound, run.gap_end) << "the wall's old id never came back";
  EXPECT_LE(run.refound, run.gap_end + 30) << "the wall's old id came back over a second late";
  EXPECT_TRUE(run.refound_on_wall) << "the wall's old id went to another plane";
  const Refinding without = WalkAwayAndBack(0);
  EXPECT_EQ(without.gap_end, run.gap_end);
  EXPECT_LT(without.refound, 0) << "box 6 alone gave the old id back";
}

}  // namespace
}  // namespace autocal
