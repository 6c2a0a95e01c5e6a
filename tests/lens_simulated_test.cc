// Boxes 1-3 on simulated office walks, measured against the simulator's ground truth.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <future>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "devices/sim/simulator.h"
#include "pipeline/lens_stage.h"

namespace autocal {
namespace {

struct LensRun {
  CameraIntrinsics truth;
  PlumbLineResult estimate;  // From the whole pool.
  // The stage's own periodic estimate on the last frame, from the newest 4 shapes of each
  // cell and orientation (LensOptions::estimate_per_cell), and what it cost.
  PlumbLineResult periodic;
  double periodic_ms = 0.0;
  // Distances (px, in the image) of confirmed snake hinges to the true curve of their
  // world line, and of the probing end hinges.
  std::vector<double> vertex_px;  // Every confirmed hinge's distance, sorted.
  int vertices_near_border = 0;  // Confirmed hinges within 10% of the image border.
  double worst_near_border_px = 0.0;
  double worst_end_px = 0.0;
  int snakes_checked = 0;
  int snakes_off_lines = 0;  // Following edges that are curved in the world.
};

// The distance `fraction` of the confirmed hinges are within.
double HingeQuantile(const LensRun& run, double fraction) {
  if (run.vertex_px.empty()) return 0.0;
  return run.vertex_px[std::min(run.vertex_px.size() - 1, size_t(fraction * run.vertex_px.size()))];
}

bool NearBorder(const Eigen::Vector2d& p, const CameraIntrinsics& c) {
  return p.x() < 0.1 * c.width || p.x() > 0.9 * c.width || p.y() < 0.1 * c.height ||
         p.y() > 0.9 * c.height;
}

// Walks `seconds` of the office with `lens`, starting from the true focal length and
// principal point but no distortion at all.
LensRun RunOffice(const std::string& lens, double seconds) {
  Scenario scenario = LoadScenario("office");
  ApplyScenarioOverride(&scenario, "lens", lens);
  ApplyScenarioOverride(&scenario, "seconds", std::to_string(seconds));
  ApplyScenarioOverride(&scenario, "resolution", "640x480");
  const auto sequence = MakeSimulatedSequence(scenario);
  LensRun run;
  run.truth = sequence->ground_truth()->front().intrinsics;
  CameraIntrinsics start = run.truth;
  start.k1 = start.k2 = start.p1 = start.p2 = start.k3 = 0.0;

  LensOptions options;
  options.estimate_every_frames = int(sequence->frame_count());  // One, on the last frame.
  options.estimate_lag_frames = 0;
  options.estimate_per_cell = 4;
  LensStage stage(options);
  // Render the next frame on the other core while this one is processed.
  std::future<cv::Mat> next =
      std::async(std::launch::async, [&] { return sequence->LoadFrame(0); });
  for (size_t i = 0; i < sequence->frame_count(); ++i) {
    const cv::Mat frame = next.get();
    if (i + 1 < sequence->frame_count()) {
      next = std::async(std::launch::async, [&, i] { return sequence->LoadFrame(i + 1); });
    }
    const LensSnapshot snapshot = stage.Process(sequence->frame_time_ns(i), frame, start);
    if (snapshot.distortion) {
      run.periodic = *snapshot.distortion;
      run.periodic_ms = snapshot.distortion_ms;
    }
    // A snake on a straight world line is straight once the true distortion is removed:
    // its world line is the line through its truly undistorted hinges, and the true curve
    // is that line seen through the true lens.
    const CameraIntrinsics& truth = (*sequence->ground_truth())[i].intrinsics;
    for (const RadonSnake& snake : snapshot.snakes) {
      if (snake.age < 3) continue;
      std::vector<Eigen::Vector2d> ideal;
      for (const Eigen::Vector2d& v : snake.vertices) ideal.push_back(*Unproject(truth, v));
      const LineFit fit = FitLine(ideal);
      if (truth.fx * fit.rms > 1.0) {
        ++run.snakes_off_lines;
        continue;
      }
      ++run.snakes_checked;
      const Eigen::Vector2d normal(std::cos(fit.theta), std::sin(fit.theta));
      for (size_t k = 0; k < snake.vertices.size(); ++k) {
        const Eigen::Vector2d foot = ideal[k] - (normal.dot(ideal[k]) - fit.rho) * normal;
        const double d = (Project(truth, {foot.x(), foot.y(), 1.0}) - snake.vertices[k]).norm();
        if (k == 0 || k + 1 == snake.vertices.size()) {
          run.worst_end_px = std::max(run.worst_end_px, d);
          continue;
        }
        run.vertex_px.push_back(d);
        if (NearBorder(snake.vertices[k], truth)) {
          ++run.vertices_near_border;
          run.worst_near_border_px = std::max(run.worst_near_border_px, d);
        }
      }
    }
  }
  run.estimate = stage.EstimateNow(start);
  std::sort(run.vertex_px.begin(), run.vertex_px.end());
  std::printf("%s periodic estimate (%.0f ms): %s\n", lens.c_str(), run.periodic_ms,
              run.periodic.message.c_str());
  std::printf(
      "%s: %s\n  snakes on world lines %d (confirmed hinges: %zu, 99.9%% within %.3f px, "
      "worst %.3f px; %d within 10%% of the border, worst %.3f px; worst probing end %.3f px), "
      "on curved edges %d\n",
      lens.c_str(), run.estimate.message.c_str(), run.snakes_checked, run.vertex_px.size(),
      HingeQuantile(run, 0.999), run.vertex_px.empty() ? 0.0 : run.vertex_px.back(),
      run.vertices_near_border, run.worst_near_border_px, run.worst_end_px, run.snakes_off_lines);
  return run;
}

// Box 2 runs on a worker of its own: its periodic estimate takes effect
// estimate_lag_frames after it was begun, and is the estimate it would have been inline.
TEST(LensSimulated, PeriodicEstimateTakesEffectItsLagLater) {
  const auto sequence =
      MakeSimulatedSequence(ParseScenarioSpec("office,lens=sonnar,resolution=320x240,seconds=4"));
  CameraIntrinsics start = sequence->ground_truth()->front().intrinsics;
  start.k1 = start.k2 = start.p1 = start.p2 = start.k3 = 0.0;
  std::vector<cv::Mat> frames;  // Rendered once for both runs.
  for (size_t i = 0; i < sequence->frame_count(); ++i) frames.push_back(sequence->LoadFrame(i));
  struct Effect {
    size_t frame;
    PlumbLineResult estimate;
  };
  auto run = [&](int lag) {
    LensOptions options;
    options.estimate_lag_frames = lag;
    LensStage stage(options);
    std::vector<Effect> effects;
    for (size_t i = 0; i < frames.size(); ++i) {
      const LensSnapshot snapshot = stage.Process(sequence->frame_time_ns(i), frames[i], start);
      EXPECT_EQ(snapshot.distortion.has_value(), !effects.empty() || snapshot.distortion_ms > 0)
          << "frame " << i << ": an estimate shows from the frame it takes effect on";
      if (snapshot.distortion_ms > 0) effects.push_back({i, *snapshot.distortion});
    }
    return effects;
  };
  const std::vector<Effect> inline_effects = run(0), lagged = run(5);
  ASSERT_GE(inline_effects.size(), 3u);
  ASSERT_EQ(lagged.size(), inline_effects.size() - 1) << "the last one begun still running";
  for (size_t k = 0; k < lagged.size(); ++k) {
    EXPECT_EQ(inline_effects[k].frame % LensOptions{}.estimate_every_frames,
              size_t(LensOptions{}.estimate_every_frames - 1));
    EXPECT_EQ(lagged[k].frame, inline_effects[k].frame + 5);
    EXPECT_EQ(lagged[k].estimate.estimate.k1, inline_effects[k].estimate.estimate.k1);
    EXPECT_EQ(lagged[k].estimate.estimate.k2, inline_effects[k].estimate.estimate.k2);
  }
}

// Live, no frame waits for box 2: with no lag, an estimate is begun and due on the same
// frame, which offline waits for it there; live it takes effect on the first frame after
// it ended (the test gives it half a second), and is the same estimate.
TEST(LensSimulated, LiveEstimateTakesEffectOnceEndedWithoutHoldingTheFrame) {
  const auto sequence =
      MakeSimulatedSequence(ParseScenarioSpec("office,lens=sonnar,resolution=320x240,seconds=2.5"));
  CameraIntrinsics start = sequence->ground_truth()->front().intrinsics;
  start.k1 = start.k2 = start.p1 = start.p2 = start.k3 = 0.0;
  std::vector<cv::Mat> frames;
  for (size_t i = 0; i < sequence->frame_count(); ++i) frames.push_back(sequence->LoadFrame(i));
  LensOptions options;
  options.estimate_lag_frames = 0;
  struct Effect {
    size_t frame;
    double k1, ms;
  };
  auto run = [&](bool wait) {
    LensStage stage(options);
    stage.set_wait_for_estimates(wait);
    std::vector<Effect> effects;
    for (size_t i = 0; i < frames.size(); ++i) {
      const LensSnapshot snapshot = stage.Process(sequence->frame_time_ns(i), frames[i], start);
      if (snapshot.distortion_ms > 0) {
        effects.push_back({i, snapshot.distortion->estimate.k1, snapshot.distortion_ms});
      }
      if (!wait && (i + 1) % size_t(options.estimate_every_frames) == 0) {
        std::this_thread::sleep_for(std::chrono::milliseconds(500));
      }
    }
    return effects;
  };
  const std::vector<Effect> offline = run(true), live = run(false);
  ASSERT_EQ(offline.size(), 2u);
  ASSERT_EQ(live.size(), offline.size());
  for (size_t k = 0; k < live.size(); ++k) {
    SCOPED_TRACE("estimate " + std::to_string(k) + ", " + std::to_string(live[k].ms) + " ms");
    EXPECT_EQ((offline[k].frame + 1) % size_t(options.estimate_every_frames), 0u)
        << "offline: taken on the frame it was begun on";
    EXPECT_EQ(live[k].frame, offline[k].frame + 1) << "live: on the next frame";
    EXPECT_EQ(live[k].k1, offline[k].k1);
  }
}

TEST(LensSimulated, SonnarDistortionFromTenSecondsOfOffice) {
  const LensRun run = RunOffice("sonnar", 10.0);
  ASSERT_TRUE(run.estimate.usable) << run.estimate.message;
  const double error = MaxDistortionDifference(run.estimate.estimate, run.truth, 0.9);
  std::printf("sonnar: worst displacement error %.3f px out to 90%% of the half-diagonal\n", error);
  EXPECT_LT(error, 0.5) << "px: estimated vs true distortion out to 90% of the half-diagonal";
  ASSERT_TRUE(run.periodic.usable) << run.periodic.message;
  EXPECT_LT(run.periodic.lines_used + run.periodic.lines_rejected,
            run.estimate.lines_used + run.estimate.lines_rejected)
      << "the periodic estimate takes fewer shapes";
  EXPECT_LT(MaxDistortionDifference(run.periodic.estimate, run.truth, 0.9), 0.5)
      << "px: the periodic estimate";
  EXPECT_LT(run.estimate.rms_after_px, 0.2) << "straightness residual after correction, px RMS";
  EXPECT_GT(run.estimate.rms_before_px, 0.5) << "the lens must bend the snakes to begin with";
  // The snakes themselves: on the true curve of their world line, out to the border.
  EXPECT_GT(run.snakes_checked, 1000);
  EXPECT_LT(run.snakes_off_lines, run.snakes_checked / 20) << "snakes off any world line";
  // Hinges 2-3 px from a parallel edge of the same sign are pulled toward it (the edges'
  // gradients merge): the desk's back edge beside the papers on it, 0.56 px at worst.
  ASSERT_FALSE(run.vertex_px.empty());
  EXPECT_LT(HingeQuantile(run, 0.999), 0.3);
  EXPECT_LT(run.vertex_px.back(), 1.0);
  EXPECT_GT(run.vertices_near_border, 1000);
  EXPECT_LT(run.worst_near_border_px, 0.5);
  EXPECT_LT(run.worst_end_px, 1.0) << "even the probing ends stay near their line";
}

TEST(LensSimulated, TessarShowsNoSpuriousDistortion) {
  const LensRun run = RunOffice("tessar", 10.0);
  ASSERT_TRUE(run.estimate.usable) << run.estimate.message;
  CameraIntrinsics undistorted = run.truth;
  undistorted.k1 = undistorted.k2 = undistorted.p1 = undistorted.p2 = undistorted.k3 = 0.0;
  EXPECT_LT(MaxDistortionDifference(run.estimate.estimate, undistorted, 0.9), 0.5)
      << "px against no distortion at all";
  EXPECT_LT(MaxDistortionDifference(run.estimate.estimate, run.truth, 0.9), 0.5)
      << "px against the true (tiny) distortion";
  EXPECT_LT(run.estimate.rms_after_px, 0.2);
  ASSERT_TRUE(run.periodic.usable) << run.periodic.message;
  EXPECT_LT(MaxDistortionDifference(run.periodic.estimate, undistorted, 0.9), 0.5);
}

struct PooledShapes {
  // How far each shape is from straight once the true distortion is removed (px RMS about
  // its line), sorted: a rolling shutter bends the shapes of a turning camera.
  std::vector<double> bends;
  PlumbLineResult estimate;  // Box 2's from the pool, with the distortion centre free.

  double Bend(double quantile) const {
    return bends.at(std::min(bends.size() - 1, size_t(quantile * bends.size())));
  }
  double CentreErrorPx(const CameraIntrinsics& truth) const {
    return std::hypot(estimate.estimate.cx - truth.cx, estimate.estimate.cy - truth.cy);
  }
};

PooledShapes Pool(const Sequence& sequence, const std::vector<cv::Mat>& frames,
                  double told_readout_ms) {
  const CameraIntrinsics truth = sequence.ground_truth()->front().intrinsics;
  LensStage stage;
  stage.set_readout_ms(told_readout_ms);
  for (size_t i = 0; i < frames.size(); ++i) {
    stage.Process(sequence.frame_time_ns(i), frames[i], truth);
  }
  PooledShapes pooled;
  const std::vector<LineObservation> shapes = stage.PooledShapes();
  for (const LineObservation& shape : shapes) {
    std::vector<Eigen::Vector2d> ideal;
    for (const Eigen::Vector2d& p : shape.points) ideal.push_back(*Unproject(truth, p));
    pooled.bends.push_back(truth.fx * FitLine(ideal).rms);
  }
  std::sort(pooled.bends.begin(), pooled.bends.end());
  PlumbLineOptions centre_free;
  centre_free.estimate_centre = true;
  pooled.estimate = EstimateDistortion(shapes, truth, centre_free);
  return pooled;
}

// Told the readout, boxes 1-3 pool each snake's shape as the frame's time saw it: as
// straight as a global shutter's; not told, as the rows' times bent it.
TEST(LensSimulated, RollingShutterBendIsTakenOutOfThePooledShapes) {
  const std::string spec = "office,lens=sonnar,resolution=320x240,seconds=6";
  const auto global = MakeSimulatedSequence(ParseScenarioSpec(spec));
  const auto rolling = MakeSimulatedSequence(ParseScenarioSpec(spec + ",readout_ms=30"));
  const CameraIntrinsics truth = global->ground_truth()->front().intrinsics;
  std::vector<cv::Mat> global_frames, rolling_frames;
  for (size_t i = 0; i < global->frame_count(); ++i) {
    global_frames.push_back(global->LoadFrame(i));
    rolling_frames.push_back(rolling->LoadFrame(i));
  }
  const PooledShapes reference = Pool(*global, global_frames, 0.0);
  const PooledShapes ignored = Pool(*rolling, rolling_frames, 0.0);
  const PooledShapes undone = Pool(*rolling, rolling_frames, 30.0);
  for (const auto& [name, pooled] :
       {std::pair{"global shutter", &reference}, std::pair{"rolling, ignored", &ignored},
        std::pair{"rolling, undone", &undone}}) {
    std::printf("%s: %zu shapes, bend median %.3f, 90%% %.3f px; centre %.2f px off (%s)\n", name,
                pooled->bends.size(), pooled->Bend(0.5), pooled->Bend(0.9),
                pooled->CentreErrorPx(truth), pooled->estimate.message.c_str());
  }
  ASSERT_GT(undone.bends.size(), reference.bends.size() / 2) << "most shapes still pooled";
  EXPECT_GT(ignored.Bend(0.9), 1.5 * reference.Bend(0.9)) << "the shutter must bend them";
  EXPECT_GT(ignored.CentreErrorPx(truth), 4.0) << "and pull box 2's centre off (px)";
  EXPECT_LT(undone.Bend(0.9), 1.2 * reference.Bend(0.9)) << "undone: as straight as global";
  ASSERT_TRUE(undone.estimate.usable) << undone.estimate.message;
  EXPECT_LT(undone.CentreErrorPx(truth), 2.0) << "px: the centre where a global shutter's is";
}

}  // namespace
}  // namespace autocal
