// Still shots (pipeline/still_shots.h, devices/still_shot_run.h): photographs of the
// simulated office from viewpoints 20-40 degrees apart, rendered through the true lens,
// calibrated from a wrong start and compared with the truth; the planes the shots were
// chained into compared with the simulator's plane labels; and the errors a folder of
// shots can hold.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>

#include "devices/recording_writer.h"
#include "devices/sequence.h"
#include "devices/sim/renderer.h"
#include "devices/sim/scene.h"
#include "devices/sim/simulator.h"
#include "devices/source.h"
#include "devices/still_shot_run.h"
#include "pipeline/calibration_error.h"
#include "pipeline/error.h"
#include "pipeline/history_store.h"
#include "pipeline/still_shots.h"
#include "tests/sim_test_util.h"
#include "tests/test_util.h"

namespace autocal {
namespace {

using ::testing::HasSubstr;

struct RenderedShots {
  Scenario scenario;
  CameraIntrinsics truth;
  std::vector<Eigen::Isometry3d> world_from_cam;
  std::vector<cv::Mat> images;  // BGR.
  std::vector<cv::Mat> labels;  // The scene plane each pixel sees.
};

// A wall of the office (the east wall at x = 4 m, facing_deg 0; the west wall, 180) and the
// floor before it, from eight viewpoints: turned left and right, looking down more and
// less, tilted, from 2.2-3 m away; neighbouring shots 20-40 degrees apart. With the
// scenario's sensor noise, vignetting and colour fringes.
RenderedShots RenderOfficeShots(const std::string& lens, const std::string& resolution,
                                double facing_deg = 0.0) {
  RenderedShots shots;
  shots.scenario = LoadScenario("office");
  ApplyScenarioOverride(&shots.scenario, "lens", lens);
  ApplyScenarioOverride(&shots.scenario, "resolution", resolution);
  shots.truth = IntrinsicsAt(shots.scenario, 0.0);
  const double facing = facing_deg * M_PI / 180.0;
  const Eigen::Vector3d target(4.0 * std::cos(facing), 4.0 * std::sin(facing), 0.7);
  struct View {
    double distance_m, yaw_deg, pitch_deg, roll_deg;
  };
  for (const View& v : {View{2.6, -22, 18, 0}, View{2.4, -4, 40, -10}, View{2.2, 18, 22, 12},
                        View{2.7, 0, 10, -4}, View{2.8, 28, 14, -6}, View{2.5, 30, 38, 0},
                        View{2.3, 8, 32, 8}, View{3.0, -30, 30, 6}}) {
    shots.world_from_cam.push_back(
        test::LookingAt(target, v.distance_m, facing_deg + v.yaw_deg, v.pitch_deg, v.roll_deg));
  }
  const Renderer renderer(BuildScene(shots.scenario));
  for (size_t i = 0; i < shots.world_from_cam.size(); ++i) {
    RenderOptions options;
    options.effects = EffectsAt(shots.scenario, 0.0);
    options.noise_seed = 100 + i;
    const RenderedFrame frame = renderer.Render(shots.truth, shots.world_from_cam[i], options);
    shots.images.push_back(frame.image);
    shots.labels.push_back(frame.labels);
  }
  return shots;
}

double AngleBetweenDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * 180.0 / M_PI;
}

void PrintError(const char* what, const CalibrationError& e) {
  std::printf("%s: fx %+.3f%% fy %+.3f%% cx %+.2f px cy %+.2f px distortion %.3f px\n", what,
              e.fx_percent, e.fy_percent, e.cx_px, e.cy_px, e.distortion_px);
}

TEST(StillShots, SimulatedOfficeViewsAreTwentyToFortyDegreesApart) {
  const RenderedShots shots = RenderOfficeShots("tessar", "320x240");
  for (size_t i = 0; i + 1 < shots.world_from_cam.size(); ++i) {
    const double angle = AngleBetweenDeg(shots.world_from_cam[i], shots.world_from_cam[i + 1]);
    EXPECT_GE(angle, 20.0) << "shots " << i << ", " << i + 1;
    EXPECT_LE(angle, 40.0) << "shots " << i << ", " << i + 1;
  }
}

// Every lens: from the wrong start to the truth, and the planes' tracks on one scene plane.
struct StillShotCase {
  std::string lens;
  double facing_deg;    // Which wall (RenderOfficeShots).
  double focal_percent;  // Tolerance on fx, fy.
};

class StillShotsFromWrongPrior : public ::testing::TestWithParam<StillShotCase> {};

TEST_P(StillShotsFromWrongPrior, ConvergeToTheTruthOnTrueScenePlanes) {
  const StillShotCase& c = GetParam();
  const RenderedShots shots = RenderOfficeShots(c.lens, "640x480", c.facing_deg);
  const CameraIntrinsics prior = test::WrongStart(shots.truth);
  StillShotOptions options;
  options.lens.pool_per_cell = 1000;
  options.calibration.min_frames = 3;
  const StillShotCalibration result = CalibrateStillShots(shots.images, prior, options);

  // The planes: every track's observations on one plane of the scene.
  ASSERT_FALSE(result.material.planes.empty());
  size_t observations = 0, on_majority = 0;
  for (const PlaneTrack& plane : result.material.planes) {
    std::map<int, int> votes;
    for (const PlaneObservation& o : plane.observations) {
      ++votes[shots.labels[o.frame].at<uint16_t>(int(std::lround(o.pixel.y())),
                                                  int(std::lround(o.pixel.x())))];
    }
    std::vector<std::pair<int, int>> ranked;  // (count, label), most first.
    for (const auto& [label, count] : votes) ranked.emplace_back(count, label);
    std::sort(ranked.rbegin(), ranked.rend());
    const auto name = [&](int label) {
      return label ? BuildScene(shots.scenario)->planes[label - 1].name : std::string("(none)");
    };
    const int best = ranked[0].first;
    std::printf("plane %d: %zu observations, %.1f%% on scene plane %s", plane.id,
                plane.observations.size(), 100.0 * best / double(plane.observations.size()),
                name(ranked[0].second).c_str());
    if (ranked.size() > 1) {
      std::printf(", then %d on %s", ranked[1].first, name(ranked[1].second).c_str());
    }
    std::printf("\n");
    observations += plane.observations.size();
    on_majority += best;
  }
  std::printf(
      "%d of %d pairs of shots share a plane; %zu planes, %d tracks off them, %zu lines; box 2: "
      "%s\n",
      result.pairs_with_planes, result.pairs, result.material.planes.size(),
      result.outlier_tracks, result.material.lines.size(), result.distortion.message.c_str());
  EXPECT_GE(on_majority, 0.97 * observations) << "observations on their plane's scene plane";

  ASSERT_FALSE(result.attempts.empty());
  for (const StillShotAttempt& attempt : result.attempts) {
    std::printf("%s: %s\n", attempt.shots.c_str(), attempt.result.reason.c_str());
  }
  const SelfCalibrationResult& all = result.attempts.front().result;
  ASSERT_TRUE(all.usable) << all.reason;
  const CalibrationError start = CompareCalibration(prior, shots.truth);
  const CalibrationError error = CompareCalibration(all.estimate, shots.truth);
  PrintError("start", start);
  PrintError("all shots", error);
  std::printf("RMS %.3f px, sigma fx %.3f%%\n", all.rms_px,
              100.0 * std::sqrt(all.covariance(0, 0)) / all.estimate.fx);
  // The calibration issue's tolerances for a 20 s walk. Measured on the east wall: sonnar
  // fx +0.020%, fy +0.077%, cx -0.01 px, cy +0.24 px, distortion 0.08 px; tessar -0.053%,
  // -0.052%, -0.23 px, -0.31 px, 0.07 px. On the west wall, sonnar: fx -0.12%, fy -0.10%,
  // cx +0.01 px, cy -0.18 px, 0.33 px; -0.64% before the tracks were aligned to their first
  // shot (AlignTracksToTheirFirstShot), the bias of SIFT's keypoint positions on the
  // slanted wall.
  EXPECT_LT(std::abs(error.fx_percent), c.focal_percent);
  EXPECT_LT(std::abs(error.fy_percent), c.focal_percent);
  EXPECT_LT(std::abs(error.cx_px), 2.0);
  EXPECT_LT(std::abs(error.cy_px), 2.0);
  EXPECT_LT(error.distortion_px, 0.5);
  EXPECT_LT(all.rms_px, 0.3);
  int usable = 0;
  for (const StillShotAttempt& attempt : result.attempts) usable += attempt.result.usable;
  EXPECT_GE(usable, 5) << "of " << result.attempts.size() << " attempts";
}

INSTANTIATE_TEST_SUITE_P(LensesAndWalls, StillShotsFromWrongPrior,
                         ::testing::Values(StillShotCase{"sonnar", 0.0, 0.5},
                                           StillShotCase{"tessar", 0.0, 0.5},
                                           StillShotCase{"sonnar", 180.0, 0.5}),
                         [](const ::testing::TestParamInfo<StillShotCase>& param_info) {
                           return param_info.param.lens +
                                  (param_info.param.facing_deg == 0.0 ? "EastWall" : "WestWall");
                         });

// The shots as a native recording with ground truth, run as `autocal run --stills` does.
TEST(StillShots, RunJudgesTheAttemptsAndComparesWithTheTruth) {
  const RenderedShots shots = RenderOfficeShots("sonnar", "640x480");
  const test::TempDir dir;
  SessionInfo session;
  session.camera_device = "simulated still shots";
  session.width = shots.truth.width;
  session.height = shots.truth.height;
  session.premission_calibration = test::WrongStart(shots.truth);
  {
    RecordingWriter writer(dir / "shots", session);
    for (size_t i = 0; i < shots.images.size(); ++i) {
      GroundTruthFrame truth;
      truth.t_ns = 1'000'000'000 * int64_t(i + 1);
      truth.intrinsics = shots.truth;
      truth.world_from_cam_translation = shots.world_from_cam[i].translation();
      truth.world_from_cam_rotation = Eigen::Quaterniond(shots.world_from_cam[i].linear());
      writer.AddFrame(truth.t_ns, shots.images[i]);
      writer.AddGroundTruth(truth, cv::Mat());
    }
  }
  const std::unique_ptr<Sequence> sequence = OpenSequence(dir / "shots");
  RunSettings settings;  // The prior: the recording's (wrong) pre-mission calibration.
  settings.history_path = dir / "history.sqlite";
  std::vector<std::string> steps;
  const RunReport report =
      RunStillShots(*sequence, settings, [&](const std::string& s) { steps.push_back(s); });
  for (const std::string& s : steps) std::printf("  %s\n", s.c_str());

  EXPECT_EQ(report.frames, shots.images.size());
  EXPECT_EQ(report.prior, test::WrongStart(shots.truth));
  ASSERT_TRUE(report.truth.has_value());
  PrintError("output", report.truth->final);
  std::printf(
      "attempts %d, regime %d, final RMS %.3f px; %.1f s in all, median ms: features %.0f, "
      "planes %.0f (per pair), calibration %.0f (per solve)\n",
      report.attempts, report.final.regime, report.final_rms_px, report.wall_seconds,
      report.timing.at("features").median_ms, report.timing.at("planes").median_ms,
      report.timing.at("calibration").median_ms);
  // The wrong prior is left by an alarm and a new regime, as on video; then the output is
  // the new regime's trend over the attempts that agree.
  EXPECT_FALSE(report.alarms.empty());
  EXPECT_GE(report.final.regime, 1);
  EXPECT_LT(std::abs(report.truth->final.fx_percent), 0.5);
  EXPECT_LT(std::abs(report.truth->final.fy_percent), 0.5);
  EXPECT_LT(std::abs(report.truth->final.cx_px), 2.0);
  EXPECT_LT(std::abs(report.truth->final.cy_px), 2.0);
  EXPECT_LT(report.truth->final.distortion_px, 0.5);
  EXPECT_TRUE(report.truth->converged_at_s.has_value());

  const StoredHistory stored = HistoryStore(settings.history_path).Load();
  EXPECT_EQ(int(stored.attempts.size()), report.attempts);
  EXPECT_EQ(stored.premission, report.prior);
}

// A stop request (Ctrl-C in `autocal run --stills`) ends the work after the step in hand:
// each attempt is in the history file as soon as it is made, and none is made after the
// stop.
TEST(StillShots, AStopKeepsTheAttemptsMadeAndMakesNoMore) {
  const RenderedShots shots = RenderOfficeShots("sonnar", "640x480");
  const test::TempDir dir;
  std::filesystem::create_directories(dir / "shots");
  for (size_t i = 0; i < shots.images.size(); ++i) {
    cv::imwrite(dir / ("shots/shot" + std::to_string(i) + ".png"), shots.images[i]);
  }
  const std::unique_ptr<Sequence> sequence = OpenImageFolder(dir / "shots");
  RunSettings settings;
  settings.prior = test::WrongStart(shots.truth);

  struct Case {
    std::string stop_at;  // The stop is requested when a step starts with this.
    int attempts;         // Those the report and the history file then hold.
  };
  for (const Case& c : {Case{"planes (box 6)", 0}, Case{"all 8 shots:", 1}}) {
    SCOPED_TRACE("stopped at " + c.stop_at);
    settings.history_path = dir / ("history" + std::to_string(c.attempts) + ".sqlite");
    std::atomic<bool> stop{false};
    std::vector<std::string> steps;
    size_t in_file_at_stop = 0;  // A run killed then keeps these.
    const RunReport report = RunStillShots(
        *sequence, settings,
        [&](const std::string& step) {
          steps.push_back(step);
          if (!step.starts_with(c.stop_at)) return;
          stop = true;
          in_file_at_stop = HistoryStore(settings.history_path).Load().attempts.size();
        },
        &stop);
    EXPECT_EQ(in_file_at_stop, size_t(c.attempts));
    EXPECT_TRUE(report.stopped);
    EXPECT_EQ(report.frames_in_input, shots.images.size());
    EXPECT_EQ(report.attempts, c.attempts);
    EXPECT_EQ(report.final.calibration, settings.prior) << "one attempt cannot leave the prior";
    ASSERT_FALSE(steps.empty());
    EXPECT_TRUE(steps.back().starts_with(c.stop_at)) << "a step after the stop: " << steps.back();
    const StoredHistory stored = HistoryStore(settings.history_path).Load();
    EXPECT_EQ(int(stored.attempts.size()), c.attempts);
    EXPECT_EQ(stored.premission, settings.prior);
  }
}

// An image folder of shots: what can be wrong with it is said, naming the file.
TEST(StillShots, FolderErrorsAreNamed) {
  const RenderedShots shots = RenderOfficeShots("tessar", "320x240");
  const test::TempDir dir;
  RunSettings settings;
  settings.prior = shots.truth;

  std::filesystem::create_directories(dir / "two");
  for (int i = 0; i < 2; ++i) {
    cv::imwrite(dir / ("two/shot" + std::to_string(i) + ".png"), shots.images[i]);
  }
  try {
    RunStillShots(*OpenImageFolder(dir / "two"), settings);
    ADD_FAILURE() << "two shots accepted";
  } catch (const Error& error) {
    EXPECT_THAT(error.what(), HasSubstr("at least 3")) << error.what();
  }

  std::filesystem::create_directories(dir / "broken");
  for (int i = 0; i < 3; ++i) {
    cv::imwrite(dir / ("broken/shot" + std::to_string(i) + ".png"), shots.images[i]);
  }
  test::WriteTextFile(dir / "broken/shot3.png", "not a picture");
  try {
    RunStillShots(*OpenImageFolder(dir / "broken"), settings);
    ADD_FAILURE() << "an unreadable shot accepted";
  } catch (const Error& error) {
    EXPECT_THAT(error.what(), HasSubstr("shot3.png")) << error.what();
  }

  // Featureless walls: keypoints match nothing.
  std::filesystem::create_directories(dir / "blank");
  for (int i = 0; i < 4; ++i) {
    cv::imwrite(dir / ("blank/shot" + std::to_string(i) + ".png"),
                cv::Mat(240, 320, CV_8UC3, cv::Scalar::all(40 * (i + 1))));
  }
  try {
    RunStillShots(*OpenImageFolder(dir / "blank"), settings);
    ADD_FAILURE() << "blank shots calibrated";
  } catch (const Error& error) {
    EXPECT_THAT(error.what(), HasSubstr("no plane found")) << error.what();
  }
}

}  // namespace
}  // namespace autocal
