// End-to-end: simulated recordings (640x480 unless named) through boxes 1-10 and the history, as
// `autocal run` processes them, against the simulator's ground truth. The tolerances are
// those of the calibration issue; each assertion states its own. The images carry the
// simulator's sensor noise (1.5 grey levels), the tracks whatever noise Lucas-Kanade makes
// of it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include <gtest/gtest.h>

#include "devices/offline_runner.h"
#include "devices/sim/simulator.h"
#include "pipeline/calibration_error.h"
#include "pipeline/history_store.h"
#include "test_util.h"

namespace autocal {
namespace {

struct ScenarioRun {
  RunReport report;
  StoredHistory stored;
  std::vector<GroundTruthFrame> truth;
};

ScenarioRun RunScenario(const std::string& spec, const std::optional<CameraIntrinsics>& prior = {},
                        const PipelineOptions& pipeline = {}) {
  const test::TempDir dir;
  const std::unique_ptr<Sequence> sequence = MakeSimulatedSequence(ParseScenarioSpec(spec));
  RunSettings settings;
  settings.pipeline = pipeline;
  settings.prior = prior;
  settings.history_path = dir / "history.sqlite";
  ScenarioRun run;
  run.report = RunSequence(*sequence, settings);
  run.stored = HistoryStore(settings.history_path, HistoryStore::Mode::kOpenExisting).Load();
  run.truth = *sequence->ground_truth();
  return run;
}

int Count(const RunReport& report, Verdict verdict) {
  const auto found = report.verdicts.find(verdict);
  return found == report.verdicts.end() ? 0 : found->second;
}

void ExpectConvergesFromAWrongStart(const std::string& lens) {
  const Scenario scenario = ParseScenarioSpec("office,lens=" + lens);
  const CameraIntrinsics truth = MakeSimulatedSequence(scenario)->ground_truth()->front().intrinsics;
  const ScenarioRun run =
      RunScenario("office,lens=" + lens + ",seconds=20", test::WrongStart(truth));
  ASSERT_TRUE(run.report.truth);
  const CalibrationError& e = run.report.truth->final;
  EXPECT_LT(std::abs(e.fx_percent), 0.5) << "fx within 0.5% of the truth after 20 s";
  EXPECT_LT(std::abs(e.fy_percent), 0.5) << "fy within 0.5% of the truth after 20 s";
  EXPECT_LT(std::abs(e.cx_px), 2.0) << "cx within 2 px";
  EXPECT_LT(std::abs(e.cy_px), 2.0) << "cy within 2 px";
  EXPECT_LT(e.distortion_px, 0.5)
      << "distortion within 0.5 px of the true one out to 90% of the half-diagonal";
  EXPECT_GT(run.report.final_rms_px, 0.0);
  EXPECT_LT(run.report.final_rms_px, 0.3) << "reprojection error below 0.3 px RMS";
  // A circular estimator would stay at the start: the start is far outside the tolerance.
  const CalibrationError start = CompareCalibration(test::WrongStart(truth), truth);
  EXPECT_FALSE(CalibrationTolerance{}.Admits(start));
  // The history file holds every attempt the run judged.
  EXPECT_EQ(int(run.stored.attempts.size()), run.report.attempts);
}

TEST(CalibrationEndToEnd, SonnarConvergesFromAWrongStart) { ExpectConvergesFromAWrongStart("sonnar"); }

TEST(CalibrationEndToEnd, TessarConvergesFromAWrongStart) { ExpectConvergesFromAWrongStart("tessar"); }

// The issue asks fx within 0.5% of the drifting truth and cx, cy within 2 px; fy is held
// to the same. Measured worst after convergence: fx -0.25% (sonnar) and -0.23% (tessar),
// fy -0.24% and -0.22%, cx 0.97 and 0.94 px (before box 9 measured the tracks against
// their anchors: fx -0.39% and -0.38%, fy up to 0.75%, the attempts 0.3% low on the first
// seconds from the tracks' drift).
void ExpectFollowsDrift(const std::string& lens) {
  const ScenarioRun run = RunScenario("drift,lens=" + lens + ",seconds=20");
  ASSERT_TRUE(run.report.truth);
  const GroundTruthReport& truth = *run.report.truth;
  const CalibrationError drifted =
      CompareCalibration(run.truth.front().intrinsics, run.truth.back().intrinsics);
  EXPECT_GT(std::abs(drifted.fx_percent), 0.6) << "the truth drifts beyond the tolerance";
  ASSERT_TRUE(truth.converged_at_s);
  ASSERT_TRUE(truth.worst_after_convergence);
  const CalibrationError& worst = *truth.worst_after_convergence;
  EXPECT_LT(std::abs(worst.fx_percent), 0.5) << "fx follows the drifting truth";
  EXPECT_LT(std::abs(worst.fy_percent), 0.5) << "fy follows the drifting truth";
  EXPECT_LT(std::abs(worst.cx_px), 2.0) << "cx within 2 px of the drifting truth";
  EXPECT_LT(std::abs(worst.cy_px), 2.0) << "cy within 2 px of the drifting truth";
  EXPECT_LT(std::abs(truth.final.fx_percent), 0.5) << "fx within 0.5% at the end";
  EXPECT_EQ(run.report.alarms.size(), 0u) << "a gradual drift raises no alarm";
}

TEST(CalibrationEndToEnd, SonnarFollowsDrift) { ExpectFollowsDrift("sonnar"); }

TEST(CalibrationEndToEnd, TessarFollowsDrift) { ExpectFollowsDrift("tessar"); }

void ExpectCatchesAJolt(const std::string& lens) {
  const ScenarioRun run = RunScenario("jolt,lens=" + lens + ",seconds=20");
  ASSERT_TRUE(run.report.truth);
  // The jolt: the first frame whose focal length differs from the first one's.
  int64_t jolt_ns = 0;
  for (const GroundTruthFrame& frame : run.truth) {
    if (frame.intrinsics.fx != run.truth.front().intrinsics.fx) {
      jolt_ns = frame.t_ns;
      break;
    }
  }
  ASSERT_GT(jolt_ns, 0);
  ASSERT_FALSE(run.report.alarms.empty()) << "the jolt raises an alarm";
  const Alarm& alarm = run.report.alarms.front();
  std::printf("alarm %.2f s after the jolt\n", 1e-9 * double(alarm.t_ns - jolt_ns));
  EXPECT_GE(alarm.t_ns, jolt_ns) << "no alarm before the jolt";
  // The issue asks 3 s. An alarm needs two consistent attempts off the trend; windows (2 s)
  // that straddle the jolt give estimates between the two focal lengths, which the trend
  // must not take for drift (acceptance.max_sigma 3; at 4 they were accepted and the alarm
  // came 4.5 s after the jolt). Measured 2.00 s with either lens.
  EXPECT_LE(alarm.t_ns - jolt_ns, int64_t(3e9)) << "the alarm within 3 s of the jolt";
  // Within 10 s the output is back within 0.5% of the new focal length, and stays there.
  const GroundTruthReport& truth = *run.report.truth;
  for (size_t i = 0; i < truth.t_ns.size(); ++i) {
    if (truth.t_ns[i] < jolt_ns + int64_t(10e9)) continue;
    ASSERT_LT(std::abs(truth.errors[i].fx_percent), 0.5)
        << "fx within 0.5% of the truth 10 s after the jolt, at " << 1e-9 * truth.t_ns[i] << " s";
  }
  EXPECT_GE(Count(run.report, Verdict::kNewRegime), 1) << "the jolt starts a new regime";
}

TEST(CalibrationEndToEnd, SonnarCatchesAJolt) { ExpectCatchesAJolt("sonnar"); }

TEST(CalibrationEndToEnd, TessarCatchesAJolt) { ExpectCatchesAJolt("tessar"); }

// Fog (blur 2.5 px, half the contrast) over 8-11 s, then a noise burst (20 grey levels)
// over 11-12 s. The issue asks that no update be accepted while either lasts and that the
// output stay within 0.2% of the truth. Box 9's image-quality gate finds the unfit frames,
// and every attempt from the burst's start until a window is clean of them is no update,
// with that reason. Asserted: that, no alarm and no new regime, the output moves less than
// 0.2% across the burst and stays within 0.2% of the truth throughout (measured: 0.031%
// sonnar, 0.155% tessar; 0.26-0.37% before box 9 measured the tracks against their
// anchors, when this was held to 0.5%).
void ExpectRidesOutATransient(const std::string& lens) {
  const std::string spec = "transient,lens=" + lens + ",seconds=16";
  const ScenarioRun run = RunScenario(spec);
  const Scenario scenario = ParseScenarioSpec(spec);
  ASSERT_FALSE(scenario.disturbances.empty());
  double burst_start = 1e9, burst_end = 0.0;
  for (const Disturbance& disturbance : scenario.disturbances) {
    burst_start = std::min(burst_start, disturbance.start.Seconds(scenario.seconds));
    burst_end = std::max(burst_end, disturbance.end.Seconds(scenario.seconds));
  }
  const int64_t t0 = run.truth.front().t_ns;
  int in_burst = 0;
  for (const AttemptRecord& attempt : run.stored.attempts) {
    const double t = 1e-9 * double(attempt.t_ns - t0);
    if (t < burst_start || t > burst_end) continue;
    ++in_burst;
    EXPECT_EQ(attempt.verdict, Verdict::kNoUpdate) << "at " << t << " s: " << attempt.reason;
    EXPECT_NE(attempt.reason.find("unfit images"), std::string::npos) << attempt.reason;
  }
  EXPECT_GE(in_burst, 4) << "attempts were made during the burst, and said why they were empty";
  EXPECT_TRUE(run.report.alarms.empty()) << "a transient raises no alarm";
  EXPECT_EQ(Count(run.report, Verdict::kNewRegime), 0) << "a transient starts no new regime";
  const GroundTruthReport& truth = *run.report.truth;
  std::optional<double> before;
  double moved = 0.0;
  for (size_t i = 0; i < truth.t_ns.size(); ++i) {
    const double t = 1e-9 * double(truth.t_ns[i] - t0);
    EXPECT_LT(std::abs(truth.errors[i].fx_percent), 0.2)
        << "the output near the truth, at " << t << " s";
    if (t < burst_start) before = truth.errors[i].fx_percent;
    if (before && t >= burst_start && t <= burst_end + MaterialOptions{}.window_s) {
      moved = std::max(moved, std::abs(truth.errors[i].fx_percent - *before));
    }
  }
  ASSERT_TRUE(before);
  EXPECT_LT(moved, 0.2) << "the output moves less than 0.2% across the burst";
}

TEST(CalibrationEndToEnd, SonnarRidesOutATransient) { ExpectRidesOutATransient("sonnar"); }

TEST(CalibrationEndToEnd, TessarRidesOutATransient) { ExpectRidesOutATransient("tessar"); }

// A lens that does not change, at 320x240, from its own calibration: every accepted
// attempt and the output stay near the truth, and nothing raises an alarm. Box 10's
// attempts used to lean with box 5's drifting tracks, by up to 3% on the office walk's
// turn and 5.5% in the corridor, which the history took first for drift and then, as the
// attempts came back, for a jump: one alarm and a new regime on the office walk, three on
// the corridor. Measuring the tracks against their anchors (pipeline/anchored_tracks.h)
// brought the worst output to 0.34% and 0.48%.
void ExpectSteadyLensStaysPut(const std::string& spec) {
  const ScenarioRun run = RunScenario(spec);
  ASSERT_TRUE(run.report.truth);
  const GroundTruthReport& truth = *run.report.truth;
  ASSERT_TRUE(truth.worst_after_convergence);
  std::printf("%s: worst fx %+.3f%% fy %+.3f%% cx %+.2f cy %+.2f px, final fx %+.3f%%\n",
              spec.c_str(), truth.worst_after_convergence->fx_percent,
              truth.worst_after_convergence->fy_percent, truth.worst_after_convergence->cx_px,
              truth.worst_after_convergence->cy_px, truth.final.fx_percent);
  EXPECT_EQ(run.report.alarms.size(), 0u) << "a lens that does not change raises no alarm";
  EXPECT_LT(std::abs(truth.worst_after_convergence->fx_percent), 1.0) << "fx, worst";
  EXPECT_LT(std::abs(truth.worst_after_convergence->fy_percent), 1.0) << "fy, worst";
  EXPECT_LT(std::abs(truth.final.fx_percent), 0.5) << "fx at the end";
  EXPECT_LT(std::abs(truth.final.fy_percent), 0.5) << "fy at the end";
  EXPECT_GE(Count(run.report, Verdict::kAccepted), run.report.attempts / 2);
}

TEST(CalibrationEndToEnd, SteadyLensStaysPutInTheOfficeAt320x240) {
  ExpectSteadyLensStaysPut("office,lens=sonnar,resolution=320x240,seconds=10");
}

// Four people walk across the view in 10 s, 1.8-3 m ahead (one close by fills two fifths
// of the image): box 6 follows them as planes while they cross (they are rigid and
// textured), and they hide the walls behind them. The calibration must not follow them.
TEST(CalibrationEndToEnd, SteadyLensStaysPutWithPeopleWalkingAcross) {
  ExpectSteadyLensStaysPut("office,lens=sonnar,resolution=320x240,seconds=10,people=4");
}

TEST(CalibrationEndToEnd, SteadyLensStaysPutInTheCorridorAt320x240) {
  ExpectSteadyLensStaysPut("corridor,lens=sonnar,resolution=320x240,seconds=10");
}

// Through a 110 deg lens (the simulator's hologon) the calibration comes right out to the
// edges of the image. Box 9 used to warp each anchor by its linearization at the anchor,
// which this lens bends by up to 0.3 px across a window near the edge: the attempts' k2
// came out 1.8% high on average over 20 s (4%, and fx 0.45% high, with the plumb lines left
// out), and the output ended 1.69 px off the true distortion at 90% of the half-diagonal
// (docs/calibration.md, "Lenses it was not tuned on").
TEST(CalibrationEndToEnd, AnUltraWideLensComesRightOutToTheEdges) {
  const ScenarioRun run = RunScenario("office,lens=hologon,resolution=320x240,seconds=10");
  ASSERT_TRUE(run.report.truth);
  const CalibrationError& final = run.report.truth->final;
  std::printf("final fx %+.3f%% fy %+.3f%% cx %+.2f cy %+.2f px, distortion %.3f px\n",
              final.fx_percent, final.fy_percent, final.cx_px, final.cy_px, final.distortion_px);
  EXPECT_EQ(run.report.alarms.size(), 0u) << "a lens that does not change raises no alarm";
  EXPECT_LT(std::abs(final.fx_percent), 0.5) << "fx at the end";
  EXPECT_LT(std::abs(final.fy_percent), 0.5) << "fy at the end";
  EXPECT_LT(final.distortion_px, 0.5) << "out to 90% of the half-diagonal, px";
  EXPECT_GE(Count(run.report, Verdict::kAccepted), run.report.attempts / 2);
}

// The office walk seen through a rolling shutter (rows read over 30 ms, a USB camera's),
// told: box 10 measures each tracked point, and box 1 pools each snake's shape, as the
// frame's time saw them. With the points undone but not the snakes, the walk ended 1.8 px
// off in cx (its worst after convergence too) and 3 of 18 attempts were rejected.
TEST(CalibrationEndToEnd, RollingShutterUndoneInTheOfficeAt320x240) {
  PipelineOptions told;
  told.calibration.readout_ms = 30.0;
  const ScenarioRun run =
      RunScenario("office,lens=sonnar,resolution=320x240,seconds=10,readout_ms=30", {}, told);
  ASSERT_TRUE(run.report.truth);
  const GroundTruthReport& truth = *run.report.truth;
  ASSERT_TRUE(truth.worst_after_convergence);
  const CalibrationError& worst = *truth.worst_after_convergence;
  std::printf("worst fx %+.3f%% fy %+.3f%% cx %+.2f cy %+.2f px; final fx %+.3f%% cx %+.2f px\n",
              worst.fx_percent, worst.fy_percent, worst.cx_px, worst.cy_px, truth.final.fx_percent,
              truth.final.cx_px);
  EXPECT_EQ(run.report.alarms.size(), 0u);
  EXPECT_LT(std::abs(worst.fx_percent), 1.0) << "fx, worst";
  EXPECT_LT(std::abs(worst.fy_percent), 1.0) << "fy, worst";
  EXPECT_LT(std::abs(truth.final.fx_percent), 0.5) << "fx at the end";
  EXPECT_LT(std::abs(truth.final.fy_percent), 0.5) << "fy at the end";
  EXPECT_LT(std::abs(worst.cx_px), 1.0) << "cx, worst";
  EXPECT_LT(std::abs(worst.cy_px), 1.0) << "cy, worst";
}

// A global shutter told a readout of 25 ms (a wrong guess, or one of `autocal readout`'s
// trials). In the sonnar walk's fastest turn (190 deg/s) the first structure posed a view
// far off on a few points, and undoing the rolling shutter with that view's motion moved
// its neighbours' points by up to 13700 px: the solve came apart (RMS 1.6e10 px). A point
// is now moved no further than its view's points were seen to move over the row's delay.
// A solve that still comes apart (a view torn from the rest) says so, where it used to
// blame the focal length, its covariance scaled by the RMS.
TEST(CalibrationEndToEnd, AWrongReadoutToldTearsNoSolveApartUnsaid) {
  PipelineOptions told;
  told.calibration.readout_ms = 25.0;
  const ScenarioRun run =
      RunScenario("office,lens=sonnar,resolution=320x240,seconds=6.5,seed=2", {}, told);
  ASSERT_GE(run.stored.attempts.size(), 11u);  // Every half second from 1 s.
  for (const AttemptRecord& attempt : run.stored.attempts) {
    EXPECT_LT(attempt.rms_px, 100.0) << attempt.reason;
    if (attempt.rms_px > 1.0) {
      EXPECT_NE(attempt.reason.find("no update: the solve came apart"), std::string::npos)
          << attempt.rms_px << " px: " << attempt.reason;
    }
  }
}

// A 16 ms exposure smears the office walk's turns by up to 7 px at 320x240. The image
// gate used to call those frames fogged or blurred and every window holding one unfit: 13
// of 18 attempts over 10 s made no update. It now judges a moving image's blur against
// frames that moved as fast, and the calibration keeps being measured through the turns.
TEST(CalibrationEndToEnd, MotionBlurredTurnsStillCalibrate) {
  const ScenarioRun run =
      RunScenario("office,resolution=320x240,seconds=6.5,seed=2,exposure_ms=16");
  ASSERT_GE(run.stored.attempts.size(), 11u);  // Every half second from 1 s.
  for (const AttemptRecord& attempt : run.stored.attempts) {
    EXPECT_EQ(attempt.reason.find("unfit images"), std::string::npos) << attempt.reason;
  }
  EXPECT_GE(Count(run.report, Verdict::kAccepted), 9);
  const CalibrationError e =
      CompareCalibration(run.report.final.calibration, run.truth.back().intrinsics);
  EXPECT_LT(std::abs(e.fx_percent), 0.5);
  EXPECT_LT(std::abs(e.cx_px), 2.0);
  EXPECT_LT(std::abs(e.cy_px), 2.0);
}

// The whole outdoor loop (30 s): far facades and a horizon. It used to raise two alarms
// and end 1% off: five snake shapes of the horizon over a corner of the ground (two
// straight edges at a slight angle) bent the distortion and fx at 17 s, and the two
// facades at a building's corner, one homography's worth apart while the walker turned,
// were merged into one plane at 27 s.
TEST(CalibrationEndToEnd, SteadyLensStaysPutOutdoorsAt320x240) {
  ExpectSteadyLensStaysPut("outdoor,lens=tessar,resolution=320x240");
}

// Another walker on the loop (seed 4), 16 s: two attempts in a row fx 2.2% off the trend,
// from windows sharing three quarters of their frames, raised a false jump alarm when two
// consistent attempts were enough (acceptance.alarm_after, now 3).
TEST(CalibrationEndToEnd, SteadyLensStaysPutOutdoorsForAnotherWalker) {
  ExpectSteadyLensStaysPut("outdoor,lens=tessar,resolution=320x240,seconds=16,seed=4");
}

TEST(CalibrationEndToEnd, StaticCameraMakesNoUpdateAndSaysWhy) {
  const ScenarioRun run = RunScenario("static,seconds=6");
  EXPECT_EQ(Count(run.report, Verdict::kAccepted), 0) << "no update accepted from a static camera";
  EXPECT_EQ(Count(run.report, Verdict::kNewRegime), 0);
  EXPECT_GT(run.report.attempts, 0) << "attempts were made and judged";
  for (const AttemptRecord& attempt : run.stored.attempts) {
    EXPECT_EQ(attempt.verdict, Verdict::kNoUpdate);
    // The physical cause, with the motion measured: the image moved under a pixel.
    EXPECT_EQ(NoUpdateCause(attempt.reason), kBarelyMovedCause) << attempt.reason;
    EXPECT_NE(attempt.reason.find("its image moved at most 0."), std::string::npos)
        << attempt.reason;
  }
  ASSERT_EQ(run.report.no_update_causes.size(), 1u) << "one cause, counted";
  EXPECT_EQ(run.report.no_update_causes[0].cause, kBarelyMovedCause);
  EXPECT_EQ(run.report.no_update_causes[0].count, run.report.attempts);
  // The output is the pre-mission calibration, untouched.
  const CalibrationError moved =
      CompareCalibration(run.report.final.calibration, run.truth.front().intrinsics);
  EXPECT_LT(std::abs(moved.fx_percent), 1e-9);
  EXPECT_LT(std::abs(moved.cx_px), 1e-9);
  EXPECT_LT(moved.distortion_px, 1e-9);
}

}  // namespace
}  // namespace autocal
