#include "pipeline/calibration_history.h"

#include <cmath>
#include <cstdio>
#include <functional>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>

#include "pipeline/error.h"
#include "pipeline/history_store.h"
#include "tests/test_util.h"

namespace autocal {
namespace {

constexpr int64_t kSecond = 1'000'000'000;

// Box-10 attempts drawn around a known truth with a known covariance over fx, fy, cx, cy,
// k1, k2: sigmas 0.2% of the focal length, 1 px, and 0.004 on k1 and k2 (about 0.7 px at
// the image edge), with the correlations box 10 shows (fx-fy, k1-k2).
class AttemptSource {
 public:
  explicit AttemptSource(unsigned seed) : random_(seed) {
    const CameraIntrinsics c = test::SonnarLikeCamera();
    const Eigen::Matrix<double, 6, 1> sigma(0.002 * c.fx, 0.002 * c.fy, 1.0, 1.0, 0.004, 0.004);
    Eigen::Matrix<double, 6, 6> correlation = Eigen::Matrix<double, 6, 6>::Identity();
    correlation(0, 1) = correlation(1, 0) = 0.8;
    correlation(4, 5) = correlation(5, 4) = -0.9;
    correlation(2, 4) = correlation(4, 2) = 0.2;
    covariance_ = sigma.asDiagonal() * correlation * sigma.asDiagonal();
    root_ = covariance_.llt().matrixL();
  }

  SelfCalibrationResult Draw(const CameraIntrinsics& truth, double rms_px = 0.4) {
    std::normal_distribution<double> normal;
    Eigen::Matrix<double, 6, 1> z;
    for (int i = 0; i < 6; ++i) z(i) = normal(random_);
    const Eigen::Matrix<double, 6, 1> noise = root_ * z;
    SelfCalibrationResult r;
    r.usable = true;
    r.estimate = truth;
    r.estimate.fx += noise(0);
    r.estimate.fy += noise(1);
    r.estimate.cx += noise(2);
    r.estimate.cy += noise(3);
    r.estimate.k1 += noise(4);
    r.estimate.k2 += noise(5);
    r.covariance = covariance_;
    r.free_parameters = {kFx, kFy, kCx, kCy, kK1, kK2};
    r.rms_px = rms_px;
    r.reason = "fx " + std::to_string(r.estimate.fx);
    r.frames_used = 12;
    r.planes_used = 2;
    r.points_used = 160;
    r.observations_used = 1500;
    r.lines_used = 24;
    r.rotation_spread_deg = 25.0;
    return r;
  }

 private:
  std::mt19937 random_;
  Eigen::Matrix<double, 6, 6> covariance_;
  Eigen::Matrix<double, 6, 6> root_;
};

SelfCalibrationResult NoUpdate(const std::string& reason) {
  SelfCalibrationResult r;
  r.estimate = test::SonnarLikeCamera();
  r.reason = reason;
  return r;
}

// Relative focal error and principal point error of the filtered output.
double FocalError(const CalibrationHistory& h, int64_t t, const CameraIntrinsics& truth) {
  return std::abs(h.Current(t).calibration.fx / truth.fx - 1.0);
}
double PrincipalError(const CalibrationHistory& h, int64_t t, const CameraIntrinsics& truth) {
  return std::abs(h.Current(t).calibration.cx - truth.cx);
}

TEST(AcceptanceOptionsTest, DefaultsAreValidAndBadFieldsAreNamed) {
  std::string error;
  EXPECT_TRUE(AcceptanceOptions().Check(&error)) << error;
  AcceptanceOptions bad;
  bad.confirm_after = 1;
  EXPECT_FALSE(bad.Check(&error));
  EXPECT_NE(error.find("confirm_after"), std::string::npos) << error;
  bad = {};
  bad.principal_floor_px = 0.0;
  EXPECT_FALSE(bad.Check(&error));
  EXPECT_NE(error.find("principal_floor_px"), std::string::npos) << error;
  EXPECT_THROW(CalibrationHistory(test::SonnarLikeCamera(), bad), Error);
}

TEST(CalibrationHistoryTest, BadInputThrows) {
  CalibrationHistory history(test::SonnarLikeCamera());
  AttemptSource source(1);
  SelfCalibrationResult wrong = source.Draw(test::SonnarLikeCamera());
  wrong.covariance = Eigen::MatrixXd::Identity(4, 4);
  EXPECT_THROW(history.Judge(kSecond, wrong), Error);
  history.Judge(2 * kSecond, source.Draw(test::SonnarLikeCamera()));
  EXPECT_THROW(history.Judge(kSecond, source.Draw(test::SonnarLikeCamera())), Error)
      << "time went backwards";
}

// The first regime's trend starts from the pre-mission calibration, which counts as one
// point as certain as the floors: the first accepted attempt moves the output only part way.
TEST(CalibrationHistoryTest, FirstRegimeStartsFromPremission) {
  const CameraIntrinsics premission = test::SonnarLikeCamera();
  CalibrationHistory history(premission);
  EXPECT_EQ(history.Current(0).calibration, premission);
  EXPECT_TRUE(history.regimes().empty());
  AttemptSource source(2);
  SelfCalibrationResult attempt = source.Draw(premission);
  attempt.estimate = premission;
  attempt.estimate.cx += 2.0;
  ASSERT_EQ(history.Judge(kSecond, attempt), Verdict::kAccepted)
      << history.attempts().back().reason;
  const FilteredCalibration now = history.Current(kSecond);
  EXPECT_EQ(now.points, 2);
  EXPECT_GT(now.calibration.cx, premission.cx + 0.2);
  EXPECT_LT(now.calibration.cx, premission.cx + 1.8);
  EXPECT_LT(std::sqrt(now.covariance(kCx, kCx)), 1.0) << "two points know more than one";
  ASSERT_EQ(history.regimes().size(), 1u);
  EXPECT_EQ(history.regimes()[0].start, premission);
}

// fx and fy grow 2% and cx moves +6 px, cy -4 px, linearly over 60 s (heat): every attempt
// is accepted and the filtered output follows the drifting truth.
TEST(CalibrationHistoryTest, GradualDriftIsFollowed) {
  const CameraIntrinsics start = test::SonnarLikeCamera();
  CalibrationHistory history(start);
  AttemptSource source(7);
  double worst_focal = 0.0, worst_principal = 0.0, worst_raw_focal = 0.0;
  for (int s = 1; s <= 60; ++s) {
    const double f = s / 60.0;
    CameraIntrinsics truth = start;
    truth.fx *= 1.0 + 0.02 * f;
    truth.fy *= 1.0 + 0.02 * f;
    truth.cx += 6.0 * f;
    truth.cy -= 4.0 * f;
    const int64_t t = s * kSecond;
    const SelfCalibrationResult attempt = source.Draw(truth);
    EXPECT_EQ(history.Judge(t, attempt), Verdict::kAccepted)
        << "at " << s << " s: " << history.attempts().back().reason;
    worst_focal = std::max(worst_focal, FocalError(history, t, truth));
    worst_principal = std::max(worst_principal, PrincipalError(history, t, truth));
    worst_raw_focal = std::max(worst_raw_focal, std::abs(attempt.estimate.fx / truth.fx - 1.0));
  }
  std::printf("drift: worst filtered fx error %.3f%% (raw attempts %.3f%%), cx %.2f px\n",
              100 * worst_focal, 100 * worst_raw_focal, worst_principal);
  EXPECT_EQ(history.Count(Verdict::kAccepted), 60);
  EXPECT_TRUE(history.alarms().empty());
  EXPECT_EQ(history.regimes().size(), 1u);
  EXPECT_LT(worst_focal, 0.005);
  EXPECT_LT(worst_principal, 2.0);
  // The trend bent: at the end it is 2% up, not at the start's value.
  EXPECT_NEAR(history.Current(60 * kSecond).calibration.fx / start.fx, 1.02, 0.004);
  EXPECT_GE(history.Current(60 * kSecond).order, 1) << "a drift needs more than a constant";
}

// Box 10's windows overlap (2 s, one every 0.5 s): each attempt's fx error is the mean of
// its four half-seconds' errors, and neighbours share them. The RMS over 300 walks of a
// steady lens (30 s each) of the output's fx error at the end over the output's own sigma.
// The trend spans 20 s, so the pre-mission calibration (as certain as the floors) has left
// it by then.
double OutputFocalZRms(double attempt_window_s) {
  const CameraIntrinsics truth = test::SonnarLikeCamera();
  AcceptanceOptions options;
  options.attempt_window_s = attempt_window_s;
  options.window_s = 20.0;
  options.focal_floor_fraction = 1e-9;  // The attempts' sigmas are the truth here.
  const double sigma = 0.002 * truth.fx;
  std::mt19937 random(11);
  std::normal_distribution<double> half_second(0.0, 2.0 * sigma);  // Four average to sigma.
  double sum_sq = 0.0;
  constexpr int kWalks = 300;
  for (int walk = 0; walk < kWalks; ++walk) {
    CalibrationHistory history(truth, options);
    std::vector<double> errors;
    int64_t t = 0;
    for (int step = 1; step <= 60; ++step) {
      errors.push_back(half_second(random));
      t = step * kSecond / 2;
      if (errors.size() < 4) continue;
      SelfCalibrationResult r;
      r.usable = true;
      r.estimate = truth;
      r.estimate.fx += (errors[errors.size() - 1] + errors[errors.size() - 2] +
                        errors[errors.size() - 3] + errors[errors.size() - 4]) /
                       4.0;
      r.covariance = Eigen::MatrixXd::Constant(1, 1, sigma * sigma);
      r.free_parameters = {kFx};
      r.rms_px = 0.3;
      history.Judge(t, r);
    }
    const FilteredCalibration out = history.Current(t);
    sum_sq += std::pow((out.calibration.fx - truth.fx), 2) / out.covariance(kFx, kFx);
  }
  return std::sqrt(sum_sq / kWalks);
}

TEST(CalibrationHistoryTest, OutputSigmaCountsOverlappingWindowsOnce) {
  const double overlapping = OutputFocalZRms(2.0);
  const double independent = OutputFocalZRms(0.0);
  std::printf("output fx error over its sigma (RMS): %.2f, %.2f taking attempts as independent\n",
              overlapping, independent);
  EXPECT_NEAR(overlapping, 1.0, 0.2);
  EXPECT_GT(independent, 1.5);
}

// At 30 s fx and fy drop 2% and cx moves +5 px, and stay (a knock): an alarm within 3 s,
// a new regime, and the output back on the truth within 10 s.
TEST(CalibrationHistoryTest, PersistentJumpRaisesAlarmAndStartsNewRegime) {
  const CameraIntrinsics before = test::SonnarLikeCamera();
  CameraIntrinsics after = before;
  after.fx *= 0.98;
  after.fy *= 0.98;
  after.cx += 5.0;
  CalibrationHistory history(before);
  AttemptSource source(11);
  double worst_settled = 0.0;
  int back_at = 0;  // From then on the output is within 0.5% of the truth.
  for (int s = 1; s <= 60; ++s) {
    const int64_t t = s * kSecond;
    const CameraIntrinsics& truth = s < 30 ? before : after;
    const Verdict verdict = history.Judge(t, source.Draw(truth));
    if (s < 30) {
      EXPECT_EQ(verdict, Verdict::kAccepted) << history.attempts().back().reason;
    }
    if (s < 30 || s >= 40) worst_settled = std::max(worst_settled, FocalError(history, t, truth));
    if (FocalError(history, t, truth) > 0.005) back_at = s + 1;
    if (s >= 40) {
      EXPECT_LT(PrincipalError(history, t, truth), 2.0) << "at " << s << " s";
    }
  }
  std::printf(
      "jolt at 30 s: output back within 0.5%% at %d s; worst fx error outside 30-40 s %.3f%%\n",
      back_at, 100 * worst_settled);
  EXPECT_LE(back_at, 40);
  EXPECT_LT(worst_settled, 0.005);

  ASSERT_EQ(history.alarms().size(), 1u);
  const Alarm& alarm = history.alarms()[0];
  EXPECT_EQ(alarm.kind, "jump");
  EXPECT_GE(alarm.t_ns, 30 * kSecond);
  EXPECT_LE(alarm.t_ns, 33 * kSecond);
  EXPECT_EQ(history.attempts()[alarm.attempt].verdict, Verdict::kAlarm);
  bool fx_jumped = false;
  for (const JumpSize& j : alarm.jumped) {
    if (j.quantity == "fx") {
      fx_jumped = true;
      EXPECT_NEAR(j.size_px, -0.02 * before.fx, 3.0);
    }
  }
  EXPECT_TRUE(fx_jumped) << alarm.description;

  ASSERT_EQ(history.regimes().size(), 2u);
  const Regime& regime = history.regimes()[1];
  EXPECT_EQ(regime.alarm, alarm.id);
  EXPECT_EQ(int(regime.founders.size()), AcceptanceOptions{}.confirm_after);
  EXPECT_GE(regime.start_ns, 30 * kSecond);
  EXPECT_LE(regime.confirmed_ns, 33 * kSecond);
  EXPECT_EQ(history.attempts()[regime.founders.back()].verdict, Verdict::kNewRegime);
  EXPECT_NEAR(regime.start.fx / after.fx, 1.0, 0.005);
  // After the new regime every attempt fits its trend again.
  for (const AttemptRecord& a : history.attempts()) {
    if (a.t_ns > regime.confirmed_ns) {
      EXPECT_EQ(a.verdict, Verdict::kAccepted) << a.reason;
    }
  }
  // The trend curve follows the regimes.
  const std::vector<TrendSample> curve = history.TrendCurve(kSecond, 60 * kSecond, 60);
  ASSERT_EQ(curve.size(), 60u);
  EXPECT_EQ(curve[10].regime, 0);
  EXPECT_NEAR(curve[10].value[kFx], before.fx, 0.005 * before.fx);
  EXPECT_EQ(curve[50].regime, 1);
  EXPECT_NEAR(curve[50].value[kFx], after.fx, 0.005 * after.fx);
  EXPECT_GT(curve[50].sigma[kFx], 0.0);
}

// 3 s of trouble in a steady stream: fog (high RMS), then a noise burst of wild estimates
// that disagree with each other. None is accepted, the regime stays, the output holds.
TEST(CalibrationHistoryTest, TransientIsRejected) {
  const CameraIntrinsics truth = test::SonnarLikeCamera();
  CalibrationHistory history(truth);
  AttemptSource source(23);
  double worst = 0.0;
  int burst = 0;
  for (int tick = 4; tick <= 240; ++tick) {  // Quarter seconds up to 60 s.
    const int64_t t = tick * kSecond / 4;
    const bool in_burst = tick >= 120 && tick < 132;  // 30 s to 33 s, 4 attempts a second.
    if (!in_burst && tick % 4 != 0) continue;         // One attempt a second outside the burst.
    SelfCalibrationResult attempt;
    if (in_burst && burst < 6) {
      CameraIntrinsics fogged = truth;
      fogged.fx *= 1.0 + (burst % 2 ? 0.015 : -0.01);
      attempt = source.Draw(fogged, 2.5);
    } else if (in_burst) {
      CameraIntrinsics wild = truth;
      const double sign = burst % 2 ? 1.0 : -1.0;
      wild.fx *= 1.0 + sign * (0.04 + 0.01 * (burst % 3));
      wild.fy *= 1.0 - sign * 0.03;
      wild.cx += sign * (15.0 + 5.0 * (burst % 4));
      wild.k1 += sign * 0.05;
      attempt = source.Draw(wild, 0.5);
    } else {
      attempt = source.Draw(truth);
    }
    const Verdict verdict = history.Judge(t, attempt);
    if (in_burst) {
      ++burst;
      EXPECT_EQ(verdict, Verdict::kRejected) << history.attempts().back().reason;
    } else {
      EXPECT_EQ(verdict, Verdict::kAccepted) << history.attempts().back().reason;
    }
    worst = std::max(worst, FocalError(history, t, truth));
  }
  std::printf("transient: worst fx error %.3f%%\n", 100 * worst);
  EXPECT_EQ(burst, 12);
  EXPECT_EQ(history.Count(Verdict::kRejected), 12);
  EXPECT_EQ(history.regimes().size(), 1u);
  EXPECT_TRUE(history.alarms().empty());
  EXPECT_LT(worst, 0.002);
  const AttemptRecord& fogged = history.attempts()[29];  // The first at 30 s.
  EXPECT_EQ(fogged.t_ns, 30 * kSecond);
  EXPECT_NE(fogged.reason.find("RMS"), std::string::npos) << fogged.reason;
}

// A camera at rest: box 10 says why it cannot update, every time. Nothing is accepted, the
// output stays the pre-mission calibration, and each attempt is stored with its reason.
TEST(CalibrationHistoryTest, StaticCameraOnlyNoUpdates) {
  const CameraIntrinsics premission = test::SonnarLikeCamera();
  const test::TempDir dir;
  CalibrationHistory history(premission);
  HistoryStore store(dir / "static.db");
  const std::function<std::string(int)> reason = [](int s) {
    return "no update: insufficient rotation (" + std::to_string(s % 3) + ".1 deg, 8.0 needed)";
  };
  for (int s = 1; s <= 30; ++s) {
    EXPECT_EQ(history.Judge(s * kSecond, NoUpdate(reason(s))), Verdict::kNoUpdate);
    store.Record(history);
  }
  EXPECT_EQ(history.Count(Verdict::kNoUpdate), 30);
  EXPECT_EQ(history.Count(Verdict::kAccepted), 0);
  EXPECT_EQ(history.Current(30 * kSecond).calibration, premission);
  const StoredHistory stored = HistoryStore(dir / "static.db").Load();
  ASSERT_EQ(stored.attempts.size(), 30u);
  for (int s = 1; s <= 30; ++s) {
    const AttemptRecord& a = stored.attempts[s - 1];
    EXPECT_EQ(a.verdict, Verdict::kNoUpdate);
    EXPECT_EQ(a.reason, reason(s));
    EXPECT_FALSE(a.usable);
    EXPECT_EQ(a.output, premission.Packed());
  }
}

// Distortion is compared by the pixels it moves, not by its coefficients, which trade off:
// k1 and k2 moved together by several of their sigmas so that the image barely changes is
// accepted; a k1 change that moves the image edge by 5 px is not.
TEST(CalibrationHistoryTest, DistortionComparedInPixels) {
  const CameraIntrinsics premission = test::SonnarLikeCamera();
  AttemptSource source(5);
  CalibrationHistory history(premission);
  for (int s = 1; s <= 10; ++s) history.Judge(s * kSecond, source.Draw(premission));
  ASSERT_EQ(history.Count(Verdict::kAccepted), 10);

  // Radial displacement f r (k1 r^2 + k2 r^4) at the comparison radius r (80% of the
  // half-diagonal): k1 up by 5 of its sigmas, k2 down to keep the edge where it was.
  const double r = 0.8 * std::hypot(320.0 / premission.fx, 240.0 / premission.fy);
  SelfCalibrationResult traded = source.Draw(premission);
  traded.estimate = premission;
  traded.estimate.k1 += 0.02;
  traded.estimate.k2 -= 0.02 / (r * r);
  EXPECT_EQ(history.Judge(11 * kSecond, traded), Verdict::kAccepted)
      << history.attempts().back().reason;

  SelfCalibrationResult bent = source.Draw(premission);
  bent.estimate = premission;
  bent.estimate.k1 -= 0.03;  // 5.4 px at the comparison radius.
  EXPECT_EQ(history.Judge(12 * kSecond, bent), Verdict::kRejected);
  EXPECT_NE(history.attempts().back().reason.find("radial_edge"), std::string::npos)
      << history.attempts().back().reason;
}

}  // namespace
}  // namespace autocal
