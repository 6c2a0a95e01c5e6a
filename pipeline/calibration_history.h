// Calibration history and acceptance (paper, section VIII-D, steps 5-8; DESIGN.md "History
// and acceptance"). Every box-10 attempt is judged against a trend fitted over the accepted
// attempts of the current regime and kept, with its verdict and the reason for it. Gradual
// drift bends the trend and is followed; outliers and transients are rejected; a jump that
// persists raises an alarm and, once confirmed, starts a new regime. The calibration handed
// on is the trend evaluated now, not the newest estimate. See docs/history.md.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "pipeline/camera_model.h"
#include "pipeline/self_calibration.h"

namespace autocal {

struct AcceptanceOptions {
  double max_rms_px = 1.0;  // Attempts with a larger reprojection RMS are rejected.
  double max_sigma = 3.0;  // An attempt fits the trend (or another attempt) within this many sigma.
  // Least sigmas of an attempt, added to its covariance: box 10's scatter beyond what its
  // covariance admits (model error; set when the covariance took each view of a track for
  // independent, kept since it counts them as one: docs/calibration.md, "How far an attempt's
  // sigmas can be trusted").
  double focal_floor_fraction = 0.003;  // fx, fy, as a fraction of the pre-mission focal length.
  double principal_floor_px = 1.0;      // cx, cy.
  double distortion_floor_px = 0.5;     // Displacement caused by the distortion.
  // Distortion is compared by the displacement it causes (pixels) at this fraction of the
  // image half-diagonal and at half of it, not by its coefficients, which trade off.
  double distortion_radius_fraction = 0.8;
  double window_s = 60.0;     // The trend fits the accepted attempts this far back from the newest.
  int max_order = 2;          // Highest order of the trend (0 constant, 1 linear, 2 quadratic).
  int min_points_linear = 10;  // Fewer accepted attempts in the window: a constant trend.
  int min_points_quadratic = 20;  // Fewer: at most a linear trend.
  // A higher order is used only when it lowers some parameter's chi-square by this much
  // (scaled by the scatter left), so noise is averaged rather than followed.
  double order_evidence_chi2 = 9.0;
  double max_extrapolation_s = 10.0;  // The trend is held this long after its newest attempt.
  // How long each attempt's material spans (the pipeline sets it to material.window_s).
  // Attempts closer than this share views, and the output's covariance takes their errors
  // as correlated by the share of the window they have in common; 0: as independent.
  double attempt_window_s = 2.0;
  // Consecutive mutually consistent attempts off the trend that raise a jump alarm, and
  // that confirm it and start a new regime. Windows overlap (2 s, one every 0.5 s): two
  // attempts in a row share three quarters of their material, and with 2 a steady lens
  // raised 13 false alarms over 36 walks from the truth (docs/history.md).
  int alarm_after = 3;
  int confirm_after = 4;

  // Says which field is out of range.
  bool Check(std::string* error) const;
};

enum class Verdict { kAccepted, kRejected, kNoUpdate, kAlarm, kNewRegime };
inline constexpr int kNumVerdicts = 5;

// "accepted", "rejected", "no update", "alarm", "new regime".
std::string VerdictName(Verdict verdict);
std::optional<Verdict> VerdictFromName(const std::string& name);

// The parameters as named in records: "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3".
std::string IntrinsicName(int index);
std::optional<int> IntrinsicFromName(const std::string& name);

// One judged attempt: what box 10 reported and what was made of it.
struct AttemptRecord {
  int id = 0;  // Index in the history.
  int64_t t_ns = 0;
  Verdict verdict = Verdict::kNoUpdate;
  std::string reason;  // Why this verdict ("no update: insufficient rotation", "rejected: ...").
  int regime = 0;      // The regime it was judged in (for kNewRegime: the one it started).

  // From box 10.
  bool usable = false;
  std::string solver_report;  // Box 10's own report or reason.
  CameraIntrinsics estimate;
  Eigen::MatrixXd covariance;        // Over `free_parameters`, in their order.
  std::vector<int> free_parameters;  // IntrinsicIndex values.
  double rms_px = 0.0;
  std::string material;  // The counts below, as text.
  int frames = 0, planes = 0, points = 0, observations = 0, lines = 0;
  double rotation_spread_deg = 0.0;

  // The judgement.
  double max_sigma = 0.0;  // Largest deviation from the trend in sigmas (0 when not compared).
  std::array<double, kNumIntrinsics> trend{};         // The trend at t before judging.
  std::array<double, kNumIntrinsics> output{};        // The filtered calibration after it.
  std::array<double, kNumIntrinsics> output_sigma{};  // Its standard deviations.
};

// How far one compared quantity jumped.
struct JumpSize {
  std::string quantity;  // "fx", "cx", ..., "radial_edge", ... (docs/history.md).
  double size_px = 0.0;  // Mean deviation of the jumping attempts from the trend.
};

struct Alarm {
  int id = 0;
  int64_t t_ns = 0;
  std::string kind = "jump";
  int attempt = 0;  // The attempt that raised it.
  std::vector<JumpSize> jumped;
  std::string description;
};

// A stretch of time over which the lens is taken to be one lens: the trend never reaches
// back across a regime boundary.
struct Regime {
  int id = 0;
  int64_t start_ns = 0;       // The first attempt of the regime (its first founder).
  int64_t confirmed_ns = 0;   // When it took over (the confirming attempt).
  int alarm = -1;             // The alarm it confirms; -1 for the first regime.
  std::vector<int> founders;  // Attempts it starts from; none for the first regime.
  CameraIntrinsics start;     // The pre-mission calibration, or the founders' mean.
};

// The calibration to use at a time: the trend of the regime in effect then.
struct FilteredCalibration {
  CameraIntrinsics calibration;
  // Covariance of the packed parameters (IntrinsicIndex order); zero for parameters no
  // accepted attempt estimated, which are held at the regime's start.
  Eigen::Matrix<double, kNumIntrinsics, kNumIntrinsics> covariance =
      Eigen::Matrix<double, kNumIntrinsics, kNumIntrinsics>::Zero();
  int regime = 0;
  int points = 0;  // Points the trend was fitted to (the pre-mission calibration is one).
  int order = 0;   // Order of the trend (highest over the parameters).
};

// One point of a trend curve, for plots.
struct TrendSample {
  int64_t t_ns = 0;
  int regime = 0;
  std::array<double, kNumIntrinsics> value{};
  std::array<double, kNumIntrinsics> sigma{};
};

class CalibrationHistory {
 public:
  // Throws Error when the options or the pre-mission calibration are not valid.
  explicit CalibrationHistory(const CameraIntrinsics& premission,
                              const AcceptanceOptions& options = {});

  // Judges and records one box-10 attempt made at `t_ns` (usable or not). Times must not
  // decrease; a covariance whose size does not match the free parameters is bad input.
  // Both throw Error.
  Verdict Judge(int64_t t_ns, const SelfCalibrationResult& result);

  // The filtered calibration at `t_ns`, from what was accepted up to then: the trend of
  // the regime in effect. The first regime's trend starts from the pre-mission calibration.
  FilteredCalibration Current(int64_t t_ns) const;

  // The filtered calibration at `samples` times evenly spread over [from_ns, to_ns].
  std::vector<TrendSample> TrendCurve(int64_t from_ns, int64_t to_ns, int samples) const;

  int Count(Verdict verdict) const;
  const std::vector<AttemptRecord>& attempts() const { return attempts_; }
  const std::vector<Alarm>& alarms() const { return alarms_; }
  // Empty until the first attempt, which opens the first regime.
  const std::vector<Regime>& regimes() const { return regimes_; }
  const CameraIntrinsics& premission() const { return premission_; }
  const AcceptanceOptions& options() const { return options_; }

 private:
  struct Comparison;  // Deviations of one attempt from a reference, per compared quantity.

  Comparison Compare(const AttemptRecord& attempt, const FilteredCalibration& reference) const;
  Comparison CompareAttempts(const AttemptRecord& a, const AttemptRecord& b) const;
  FilteredCalibration Evaluate(int regime, int64_t t_ns) const;
  int RegimeAt(int64_t t_ns) const;
  // Rejects, raises an alarm or starts a new regime for an attempt off the trend.
  void JudgeOffTrend(AttemptRecord* record, const Comparison& off_trend);
  // An attempt's covariance over all parameters, with the floors on the diagonal.
  Eigen::Matrix<double, kNumIntrinsics, kNumIntrinsics> InflatedCovariance(
      const AttemptRecord& attempt) const;
  // Its symmetric square root, kept for each attempt as it is judged (the trend pairs every
  // point with its neighbours each time it is evaluated).
  Eigen::Matrix<double, kNumIntrinsics, kNumIntrinsics> InflatedRoot(
      const AttemptRecord& attempt) const;

  CameraIntrinsics premission_;
  AcceptanceOptions options_;
  // Compared quantities (pixels) from the parameters: a linear map, set by the pre-mission
  // calibration, with the least sigma of each quantity and of each parameter.
  Eigen::MatrixXd to_compared_;
  Eigen::VectorXd compared_floor_;
  std::array<double, kNumIntrinsics> parameter_floor_{};

  std::vector<AttemptRecord> attempts_;
  std::vector<Eigen::Matrix<double, kNumIntrinsics, kNumIntrinsics>> inflated_roots_;
  std::vector<Alarm> alarms_;
  std::vector<Regime> regimes_;
  // The pre-mission calibration as the first point of the first regime, at its start, as
  // certain as the floors say.
  AttemptRecord anchor_;
  std::vector<std::vector<int>> accepted_;  // Per regime: founders, then accepted attempts.
  std::vector<int> jump_run_;               // Consecutive consistent attempts off the trend.
};

}  // namespace autocal
