// The vest check on real pipeline output: short simulated 320x240 walks through boxes 1-10
// on the threaded runtime, run as the procedure runs them (devices/vest_check_run.h). A walk
// whose lens is the pre-mission one passes; one whose lens is 3% shorter in focal length
// than the pre-mission calibration says fails on fx and fy; a camera at rest is
// inconclusive and asks for motion.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "devices/sim/simulator.h"
#include "devices/vest_check_run.h"
#include "pipeline/error.h"
#include "pipeline/vest_check.h"

namespace autocal {
namespace {

struct CheckRun {
  VestCheckResult result;
  std::vector<std::string> guidance;  // Every distinct line shown, in order.
  std::vector<double> progress;       // After every frame.
  bool complete = false;
};

// `premission`: the calibration the vest was sent out with (none: the simulator's lens,
// the truth). Runs as the vest check dialog does.
CheckRun RunCheck(const std::string& spec, const std::optional<CameraIntrinsics>& premission,
                  const VestCheckOptions& options = {},
                  std::optional<double> readout_ms = std::nullopt) {
  CheckRun run;
  VestCheckHooks hooks;
  hooks.checked = [&](const VestCheck& check) {
    if (run.guidance.empty() || run.guidance.back() != check.Guidance()) {
      run.guidance.push_back(check.Guidance());
    }
    run.progress.push_back(check.Progress());
    run.complete = check.Complete();
  };
  const std::atomic<bool> stop{false};
  run.result = RunVestCheck("sim:" + spec, "", premission, readout_ms, options, stop, hooks);
  return run;
}

const VestCriterion& Criterion(const VestCheckResult& result, const std::string& name) {
  for (const VestCriterion& c : result.criteria) {
    if (c.parameter == name) return c;
  }
  throw Error("no criterion " + name);
}

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// 8 s of the simulated office walk at 320x240: box 10 has its first updates after 2-3 s,
// and a wrong pre-mission calibration is replaced by a confirmed new regime after 4-5 s.
const char* kWalk = "office,resolution=320x240,seconds=8";

TEST(VestCheck, DefaultOptionsAreValid) {
  std::string error;
  EXPECT_TRUE(VestCheckOptions{}.Check(&error)) << error;
  VestCheckOptions bad;
  bad.tolerance.focal_percent = 0.0;
  EXPECT_FALSE(bad.Check(&error));
  EXPECT_TRUE(Contains(error, "focal_percent")) << error;
  EXPECT_THROW(VestCheck(CameraIntrinsics{}, {}), Error);
}

// A frame at `t_s` that judged an attempt with this verdict and reason in `regime`.
FrameSnapshot Judged(double t_s, Verdict verdict, const std::string& reason, int regime = 1) {
  FrameSnapshot snapshot;
  snapshot.t_ns = int64_t(t_s * 1e9);
  auto outcome = std::make_shared<AttemptOutcome>();
  outcome->record.t_ns = snapshot.t_ns;
  outcome->record.verdict = verdict;
  outcome->record.reason = reason;
  outcome->record.regime = regime;
  snapshot.attempt = outcome;
  snapshot.calibration.regime = regime;
  return snapshot;
}

// A frame at `t_s`, turning, with two planes whose normals are `angle_deg` apart, and why
// box 9 found it unfit (empty: fit).
FrameSnapshot Turning(double t_s, double angle_deg, const std::string& degraded) {
  FrameSnapshot snapshot;
  snapshot.t_ns = int64_t(std::llround(t_s * 1e9));
  snapshot.inertial.motion = MotionClass::kRotate;
  snapshot.degraded = degraded;
  const double a = angle_deg * M_PI / 180.0;
  DominantPlane wall, floor;
  wall.id = 1;
  wall.normal = Eigen::Vector3d(0, 0, -1);
  floor.id = 2;
  floor.normal = Eigen::Vector3d(0, -std::sin(a), -std::cos(a));
  snapshot.motion.planes = {wall, floor};
  return snapshot;
}

// Fogged or noisy frames are no material: their turning and their planes count for nothing,
// the guidance says what to do about the images, and a walk left short says why.
TEST(VestCheck, UnfitImagesAreNotMaterialAndAskToWipeTheLens) {
  const CameraIntrinsics premission = CameraIntrinsics::FromFieldOfView(320, 240, 75);
  VestCheck check(premission);
  const std::string fogged =
      "image degraded: fogged (blur 0.34, usually 0.23; contrast 70.00 grey levels, usually "
      "108.00; noise 1.06, usually 1.69)";
  int frame = 0;
  for (; frame < 60; ++frame) check.Add(Turning(frame / 30.0, 40.0, fogged));
  EXPECT_EQ(check.Guidance(), "Image fogged or blurred: wipe the lens");
  EXPECT_EQ(check.Coverage()[int(VestNeed::kRotation)].measured, "0.0 of 2.0 s");
  EXPECT_EQ(check.Coverage()[int(VestNeed::kPlanes)].measured, "0 of 20 deg");
  EXPECT_NEAR(check.elapsed_s(), 59 / 30.0, 1e-9);  // Walk time all the same.
  check.Add(Turning(frame++ / 30.0, 40.0, "image degraded: noisy (21.30 grey levels, usually 1.70)"));
  EXPECT_EQ(check.Guidance(), "Image noisy: move to where there is more light");
  check.Add(Turning(frame++ / 30.0, 40.0,
                    "image degraded: blurred (0.50, usually 0.35, the image moving 6.00 px a "
                    "frame)"));
  EXPECT_EQ(check.Guidance(), "Image blurred by motion: turn more slowly");

  // Clear again: the same motion counts.
  for (const int end = frame + 75; frame < end; ++frame) check.Add(Turning(frame / 30.0, 40.0, ""));
  EXPECT_TRUE(check.Coverage()[int(VestNeed::kRotation)].done);
  EXPECT_TRUE(check.Coverage()[int(VestNeed::kPlanes)].done);
  EXPECT_EQ(check.Guidance().find("Image"), std::string::npos) << check.Guidance();
  const VestCheckResult result = check.Result();
  EXPECT_NEAR(result.unfit_s, 61 / 30.0, 1e-9);
  EXPECT_EQ(result.verdict, VestVerdict::kInconclusive);  // No update yet.
  EXPECT_EQ(result.reasons.back(),
            "the images were unfit for 2.0 s of the walk, which did not count (image fogged or "
            "blurred: wipe the lens)");
}

// What box 10 and the history said of the newest attempt decides the guidance while
// updates are missing; an alarm not yet confirmed leaves the verdict open.
TEST(VestCheck, GuidanceFollowsWhatTheHistorySaid) {
  const CameraIntrinsics premission = CameraIntrinsics::FromFieldOfView(320, 240, 75);
  VestCheck check(premission);
  EXPECT_EQ(check.Guidance(), "Stand facing a textured wall and hold still");
  check.Add(Judged(0.5, Verdict::kNoUpdate,
                   "no update: insufficient rotation (3.10 deg between views, 8.00 needed)"));
  EXPECT_EQ(check.Guidance(), "Turn slowly left and right");
  check.Add(Judged(1.0, Verdict::kNoUpdate,
                   "no update: focal length not observable (sigma 4.08%, 1.00% allowed)"));
  EXPECT_EQ(check.Guidance(), "Walk slowly, facing a textured wall or the floor");
  check.Add(Judged(1.5, Verdict::kRejected, "rejected: rms 1.4 px"));
  EXPECT_EQ(check.Guidance(), "Move more slowly");
  for (double t : {2.0, 2.5, 3.0}) check.Add(Judged(t, Verdict::kAccepted, "accepted"));
  check.Add(Judged(3.5, Verdict::kAlarm, "alarm: jump in fx -8.28 px"));
  VestCheckResult result = check.Result();
  EXPECT_EQ(result.verdict, VestVerdict::kInconclusive);
  EXPECT_EQ(result.reasons.front(), "a jump in the calibration was raised and not yet confirmed");
  ASSERT_EQ(result.alarms.size(), 1u);
  EXPECT_EQ(result.alarms.front(), "3.0 s: jump in fx -8.28 px");
  // Dismissed: the next attempt is back on the old trend.
  VestCheck dismissed = check;
  dismissed.Add(Judged(4.0, Verdict::kAccepted, "accepted"));
  EXPECT_TRUE(dismissed.Result().reasons.empty() ||
              dismissed.Result().reasons.front() != result.reasons.front());
  // Confirmed: a new regime, whose updates start again from its founder.
  check.Add(Judged(4.0, Verdict::kNewRegime, "new regime", 2));
  EXPECT_EQ(check.Coverage()[int(VestNeed::kUpdates)].measured, "1 of 3");
  result = check.Result();
  EXPECT_EQ(result.accepted_in_regime, 1);
  EXPECT_EQ(result.reasons.front(), "only 1 of 3 calibration updates were accepted");
}

TEST(VestCheck, WalkWithThePremissionLensPasses) {
  const CheckRun run = RunCheck(kWalk, std::nullopt);
  EXPECT_EQ(run.result.verdict, VestVerdict::kPass);
  EXPECT_TRUE(run.result.reasons.empty());
  ASSERT_EQ(run.result.criteria.size(), 5u);
  for (const VestCriterion& c : run.result.criteria) {
    EXPECT_TRUE(c.pass) << c.parameter << " differs by " << c.difference << " " << c.unit;
    EXPECT_LE(std::abs(c.difference), c.tolerance);
  }
  EXPECT_GE(run.result.accepted_in_regime, VestCheckOptions{}.min_accepted);
  EXPECT_TRUE(run.complete);
  EXPECT_DOUBLE_EQ(run.progress.back(), 1.0);
  EXPECT_LT(run.progress.front(), 0.5);
  // The walk begins with no plane: the first guidance asks for one.
  EXPECT_TRUE(Contains(run.guidance.front(), "wall")) << run.guidance.front();
  EXPECT_NEAR(run.result.seconds, 8.0, 0.1);
}

// A vest camera with a rolling shutter its source states (rows read over 30 ms): the check
// measures with it, and passes. With the pipeline's defaults (a global shutter) the same
// walk had none of its 14 attempts accepted: inconclusive.
TEST(VestCheck, RollingShutterTheSourceStatesIsUndone) {
  const CheckRun run = RunCheck(std::string(kWalk) + ",readout_ms=30", std::nullopt);
  EXPECT_EQ(run.result.readout_ms, 30.0) << "the readout measured with, for the record";
  EXPECT_EQ(run.result.verdict, VestVerdict::kPass);
  for (const std::string& reason : run.result.reasons) ADD_FAILURE() << reason;
  EXPECT_GE(run.result.accepted_in_regime, VestCheckOptions{}.min_accepted);
}

// The readout given wins over the one the source states: the same 30 ms walk checked as a
// global shutter (a live camera's check, told nothing) is inconclusive, few of its updates
// accepted.
TEST(VestCheck, ReadoutGivenWinsOverTheSources) {
  const CheckRun run = RunCheck(std::string(kWalk) + ",readout_ms=30", std::nullopt, {}, 0.0);
  std::printf("%s, %d of %d attempts accepted in the regime\n",
              VestVerdictName(run.result.verdict).c_str(), run.result.accepted_in_regime,
              run.result.attempts);
  EXPECT_EQ(run.result.verdict, VestVerdict::kInconclusive);
  EXPECT_LT(run.result.accepted_in_regime, VestCheckOptions{}.min_accepted);
  EXPECT_EQ(run.result.readout_ms, 0.0);
}

TEST(VestCheck, LensThreePercentShorterFailsOnFocalLength) {
  const CameraIntrinsics truth =
      MakeSimulatedSequence(ParseScenarioSpec(kWalk))->ground_truth()->front().intrinsics;
  CameraIntrinsics premission = truth;
  premission.fx *= 1.03;
  premission.fy *= 1.03;
  const CheckRun run = RunCheck(kWalk, premission);
  ASSERT_EQ(run.result.verdict, VestVerdict::kFail);
  for (const char* focal : {"fx", "fy"}) {
    const VestCriterion& c = Criterion(run.result, focal);
    EXPECT_FALSE(c.pass) << focal;
    // The lens itself is measured (-2.9%), not the pre-mission calibration kept (0%); box 10
    // runs up to 1% low on the first seconds of this walk.
    EXPECT_NEAR(c.difference, 100.0 * (1.0 / 1.03 - 1.0), 1.5) << focal;
    EXPECT_TRUE(Contains(c.reason, std::string(focal) + " is ")) << c.reason;
    EXPECT_TRUE(Contains(c.reason, "below the pre-mission value")) << c.reason;
  }
  EXPECT_TRUE(Criterion(run.result, "cx").pass);
  EXPECT_TRUE(Criterion(run.result, "cy").pass);
  EXPECT_TRUE(Criterion(run.result, "distortion").pass);
  EXPECT_EQ(run.result.reasons.size(), 2u);
  EXPECT_FALSE(run.result.alarms.empty()) << "the history saw the jump from the pre-mission lens";
  EXPECT_TRUE(std::find(run.guidance.begin(), run.guidance.end(),
                        "Keep walking: the calibration has moved, confirming") !=
              run.guidance.end());
}

TEST(VestCheck, WalkEndsWhenItsTimeIsUp) {
  VestCheckOptions options;
  options.duration_s = 1.0;
  const CheckRun run = RunCheck(kWalk, std::nullopt, options);
  // The frame that reached 1 s ends it; the few frames queued behind it are still judged.
  EXPECT_GE(run.result.seconds, 1.0);
  EXPECT_LT(run.result.seconds, 1.5);
  EXPECT_EQ(run.result.verdict, VestVerdict::kInconclusive) << "too short for an update";
}

TEST(VestCheck, CameraAtRestIsInconclusiveAndAsksToWalk) {
  const CheckRun run = RunCheck("static,resolution=320x240,seconds=4", std::nullopt);
  EXPECT_EQ(run.result.verdict, VestVerdict::kInconclusive);
  EXPECT_TRUE(run.result.criteria.empty());
  ASSERT_FALSE(run.result.reasons.empty());
  EXPECT_EQ(run.result.reasons.front(), "only 0 of 3 calibration updates were accepted");
  const auto missing = [&](const char* what) {
    return std::any_of(run.result.reasons.begin(), run.result.reasons.end(),
                       [&](const std::string& r) { return Contains(r, what); });
  };
  EXPECT_TRUE(missing("missing: Planes from different angles"));
  EXPECT_TRUE(missing("missing: Turning"));
  // Holding still was all it did: covered, and not among the reasons.
  EXPECT_FALSE(missing("Holding still"));
  EXPECT_TRUE(run.result.coverage[int(VestNeed::kStill)].done);
  EXPECT_TRUE(Contains(run.guidance.back(), "Walk")) << run.guidance.back();
  EXPECT_LT(run.progress.back(), 0.5);
}

}  // namespace
}  // namespace autocal
