#include "pipeline/calibration_history.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "pipeline/error.h"

namespace autocal {

using Matrix9d = Eigen::Matrix<double, kNumIntrinsics, kNumIntrinsics>;

namespace {

// The quantities attempts are compared by, all in pixels.
enum Compared {
  kCompFx = 0,
  kCompFy,
  kCompCx,
  kCompCy,
  kCompRadialMid,   // Radial displacement at half the comparison radius.
  kCompRadialEdge,  // Radial displacement at the comparison radius.
  kCompTangentialP1,
  kCompTangentialP2,
  kNumCompared
};

constexpr const char* kComparedNames[kNumCompared] = {
    "fx", "fy", "cx", "cy", "radial_mid", "radial_edge", "tangential_p1", "tangential_p2"};

constexpr const char* kIntrinsicNames[kNumIntrinsics] = {"fx", "fy", "cx", "cy", "k1",
                                                         "k2", "p1", "p2", "k3"};

constexpr const char* kVerdictNames[kNumVerdicts] = {"accepted", "rejected", "no update", "alarm",
                                                     "new regime"};

std::string Fixed(double value, int digits, bool sign = false) {
  std::ostringstream out;
  out.precision(digits);
  out << std::fixed << (sign ? std::showpos : std::noshowpos) << value;
  return out.str();
}

// A weighted least-squares polynomial in tau, evaluated at one tau.
struct PolynomialFit {
  double value = 0.0;
  double chi2 = 0.0;
  int dof = 0;
  Eigen::VectorXd influence;  // d value / d x_i: the prediction is influence . x.
};

PolynomialFit FitPolynomial(const std::vector<double>& tau, const std::vector<double>& x,
                            const std::vector<double>& variance, int order, double tau_eval) {
  const int n = int(tau.size());
  const int terms = order + 1;
  Eigen::MatrixXd basis(n, terms);
  for (int i = 0; i < n; ++i) {
    double power = 1.0;
    for (int k = 0; k < terms; ++k, power *= tau[i]) basis(i, k) = power;
  }
  Eigen::VectorXd weight(n), values(n), at(terms);
  for (int i = 0; i < n; ++i) {
    weight(i) = 1.0 / variance[i];
    values(i) = x[i];
  }
  double power = 1.0;
  for (int k = 0; k < terms; ++k, power *= tau_eval) at(k) = power;
  const Eigen::MatrixXd normal = basis.transpose() * weight.asDiagonal() * basis;
  const Eigen::LDLT<Eigen::MatrixXd> solver(normal);
  const Eigen::VectorXd coefficients =
      solver.solve(basis.transpose() * weight.asDiagonal() * values);
  PolynomialFit fit;
  fit.value = at.dot(coefficients);
  const Eigen::VectorXd residual = values - basis * coefficients;
  fit.chi2 = residual.dot(weight.asDiagonal() * residual);
  fit.dof = n - terms;
  fit.influence = weight.asDiagonal() * basis * solver.solve(at);
  return fit;
}

int DistinctCount(std::vector<double> tau) {
  std::sort(tau.begin(), tau.end());
  return int(std::unique(tau.begin(), tau.end()) - tau.begin());
}

bool AllFinite(const CameraIntrinsics& c) {
  for (double v : c.Packed()) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

}  // namespace

bool AcceptanceOptions::Check(std::string* error) const {
  std::ostringstream why;
  if (!(max_rms_px > 0)) {
    why << "max_rms_px must be positive";
  } else if (!(max_sigma > 0)) {
    why << "max_sigma must be positive";
  } else if (!(focal_floor_fraction > 0)) {
    why << "focal_floor_fraction must be positive";
  } else if (!(principal_floor_px > 0)) {
    why << "principal_floor_px must be positive";
  } else if (!(distortion_floor_px > 0)) {
    why << "distortion_floor_px must be positive";
  } else if (!(distortion_radius_fraction > 0 && distortion_radius_fraction <= 1)) {
    why << "distortion_radius_fraction must be in (0, 1]";
  } else if (!(window_s > 0)) {
    why << "window_s must be positive";
  } else if (max_order < 0 || max_order > 2) {
    why << "max_order must be 0, 1 or 2";
  } else if (min_points_linear < 2) {
    why << "min_points_linear must be at least 2";
  } else if (min_points_quadratic <= min_points_linear) {
    why << "min_points_quadratic must exceed min_points_linear";
  } else if (!(order_evidence_chi2 >= 0)) {
    why << "order_evidence_chi2 must not be negative";
  } else if (!(max_extrapolation_s >= 0)) {
    why << "max_extrapolation_s must not be negative";
  } else if (!(attempt_window_s >= 0)) {
    why << "attempt_window_s must not be negative";
  } else if (alarm_after < 1) {
    why << "alarm_after must be at least 1";
  } else if (confirm_after < std::max(2, alarm_after)) {
    why << "confirm_after must be at least 2 and at least alarm_after";
  }
  if (why.str().empty()) return true;
  if (error) *error = why.str();
  return false;
}

std::string VerdictName(Verdict verdict) { return kVerdictNames[int(verdict)]; }

std::optional<Verdict> VerdictFromName(const std::string& name) {
  for (int i = 0; i < kNumVerdicts; ++i) {
    if (name == kVerdictNames[i]) return Verdict(i);
  }
  return std::nullopt;
}

std::string IntrinsicName(int index) { return kIntrinsicNames[index]; }

std::optional<int> IntrinsicFromName(const std::string& name) {
  for (int i = 0; i < kNumIntrinsics; ++i) {
    if (name == kIntrinsicNames[i]) return i;
  }
  return std::nullopt;
}

struct CalibrationHistory::Comparison {
  Eigen::VectorXd deviation = Eigen::VectorXd::Zero(kNumCompared);  // Pixels.
  Eigen::VectorXd sigma = Eigen::VectorXd::Ones(kNumCompared);      // Pixels.
  double max_sigma = 0.0;
  int worst = 0;

  double Z(int q) const { return deviation(q) / sigma(q); }
  // "fx -10.2 px (6.9 sigma), cx +5.1 px (4.2 sigma)": the quantities beyond `limit`.
  std::string Describe(double limit) const {
    std::string text;
    for (int q = 0; q < kNumCompared; ++q) {
      if (std::abs(Z(q)) <= limit && q != worst) continue;
      text += (text.empty() ? "" : ", ") + std::string(kComparedNames[q]) + " " +
              Fixed(deviation(q), 2, true) + " px (" + Fixed(std::abs(Z(q)), 1) + " sigma)";
    }
    return text;
  }
};

CalibrationHistory::CalibrationHistory(const CameraIntrinsics& premission,
                                       const AcceptanceOptions& options)
    : premission_(premission), options_(options) {
  std::string error;
  if (!options.Check(&error)) throw Error("acceptance options: " + error);
  if (!premission.Check(&error)) throw Error("pre-mission calibration: " + error);

  // The comparison radius, in ideal normalized units of the pre-mission calibration.
  const double rho =
      options.distortion_radius_fraction *
      std::hypot(0.5 * premission.width / premission.fx, 0.5 * premission.height / premission.fy);
  const double f = premission.fx;
  to_compared_ = Eigen::MatrixXd::Zero(kNumCompared, kNumIntrinsics);
  to_compared_(kCompFx, kFx) = 1.0;
  to_compared_(kCompFy, kFy) = 1.0;
  to_compared_(kCompCx, kCx) = 1.0;
  to_compared_(kCompCy, kCy) = 1.0;
  // Radial displacement f r (k1 r^2 + k2 r^4 + k3 r^6) at two radii, so that a change of
  // shape that leaves the edge alone still shows.
  const std::pair<int, double> radii[] = {{kCompRadialMid, 0.5 * rho}, {kCompRadialEdge, rho}};
  for (const auto& [row, r] : radii) {
    to_compared_(row, kK1) = f * std::pow(r, 3);
    to_compared_(row, kK2) = f * std::pow(r, 5);
    to_compared_(row, kK3) = f * std::pow(r, 7);
  }
  // Largest tangential displacement on the circle of radius rho: 3 f p rho^2.
  to_compared_(kCompTangentialP1, kP1) = 3.0 * f * rho * rho;
  to_compared_(kCompTangentialP2, kP2) = 3.0 * f * rho * rho;

  compared_floor_.resize(kNumCompared);
  compared_floor_ << options.focal_floor_fraction * premission.fx,
      options.focal_floor_fraction * premission.fy, options.principal_floor_px,
      options.principal_floor_px, options.distortion_floor_px, options.distortion_floor_px,
      options.distortion_floor_px, options.distortion_floor_px;
  // A distortion coefficient's floor moves the point at the comparison radius by the
  // distortion floor.
  for (int p = 0; p < kNumIntrinsics; ++p) {
    parameter_floor_[p] =
        p <= kCy ? compared_floor_(p)
                 : options.distortion_floor_px / to_compared_.col(p).cwiseAbs().maxCoeff();
  }
  anchor_.estimate = premission;
  anchor_.covariance = Eigen::MatrixXd::Zero(kNumIntrinsics, kNumIntrinsics);
  for (int p = 0; p < kNumIntrinsics; ++p) anchor_.free_parameters.push_back(p);
}

Matrix9d CalibrationHistory::InflatedRoot(const AttemptRecord& attempt) const {
  const Eigen::SelfAdjointEigenSolver<Matrix9d> eigen(InflatedCovariance(attempt));
  return eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal() *
         eigen.eigenvectors().transpose();
}

Matrix9d CalibrationHistory::InflatedCovariance(const AttemptRecord& attempt) const {
  Matrix9d covariance = Matrix9d::Zero();
  const std::vector<int>& free = attempt.free_parameters;
  for (size_t a = 0; a < free.size(); ++a) {
    for (size_t b = 0; b < free.size(); ++b) {
      covariance(free[a], free[b]) = attempt.covariance(a, b);
    }
    covariance(free[a], free[a]) += parameter_floor_[free[a]] * parameter_floor_[free[a]];
  }
  return covariance;
}

CalibrationHistory::Comparison CalibrationHistory::Compare(
    const AttemptRecord& attempt, const FilteredCalibration& reference) const {
  // Only what the attempt estimated is compared; the rest it took from its prior.
  Eigen::Matrix<double, kNumIntrinsics, 1> difference =
      Eigen::Matrix<double, kNumIntrinsics, 1>::Zero();
  Matrix9d covariance = Matrix9d::Zero();
  const auto estimate = attempt.estimate.Packed();
  const auto predicted = reference.calibration.Packed();
  const std::vector<int>& free = attempt.free_parameters;
  for (size_t a = 0; a < free.size(); ++a) {
    difference(free[a]) = estimate[free[a]] - predicted[free[a]];
    for (size_t b = 0; b < free.size(); ++b) {
      covariance(free[a], free[b]) =
          attempt.covariance(a, b) + reference.covariance(free[a], free[b]);
    }
  }
  Comparison comparison;
  comparison.deviation = to_compared_ * difference;
  const Eigen::MatrixXd compared = to_compared_ * covariance * to_compared_.transpose();
  for (int q = 0; q < kNumCompared; ++q) {
    comparison.sigma(q) = std::sqrt(compared(q, q) + compared_floor_(q) * compared_floor_(q));
    if (std::abs(comparison.Z(q)) > comparison.max_sigma) {
      comparison.max_sigma = std::abs(comparison.Z(q));
      comparison.worst = q;
    }
  }
  return comparison;
}

CalibrationHistory::Comparison CalibrationHistory::CompareAttempts(const AttemptRecord& a,
                                                                   const AttemptRecord& b) const {
  // b as the reference, as uncertain as its covariance and floors; only what both
  // estimated is compared.
  FilteredCalibration reference;
  reference.calibration = b.estimate;
  reference.covariance = InflatedCovariance(b);
  AttemptRecord shared = a;
  shared.free_parameters.clear();
  std::vector<int> rows;
  for (size_t i = 0; i < a.free_parameters.size(); ++i) {
    const int p = a.free_parameters[i];
    const auto& other = b.free_parameters;
    if (std::find(other.begin(), other.end(), p) == other.end()) continue;
    shared.free_parameters.push_back(p);
    rows.push_back(int(i));
  }
  shared.covariance = a.covariance(rows, rows);
  return Compare(shared, reference);
}

int CalibrationHistory::RegimeAt(int64_t t_ns) const {
  int regime = 0;
  for (const Regime& r : regimes_) {
    if (r.confirmed_ns <= t_ns) regime = r.id;
  }
  return regime;
}

FilteredCalibration CalibrationHistory::Evaluate(int regime, int64_t t_ns) const {
  FilteredCalibration out;
  out.regime = regime;
  out.calibration = regimes_[regime].start;

  std::vector<const AttemptRecord*> points;
  if (regime == 0) points.push_back(&anchor_);  // Known from the start.
  for (int i : accepted_[regime]) {
    if (attempts_[i].t_ns <= t_ns) points.push_back(&attempts_[i]);
  }
  if (points.empty()) return out;
  if (points.size() == 1 && points.front() == &anchor_) {
    // Nothing accepted yet: the pre-mission calibration itself, not a fit's rounding of it.
    out.covariance = InflatedCovariance(anchor_);
    out.points = 1;
    return out;
  }
  int64_t newest = points.front()->t_ns;
  for (const AttemptRecord* a : points) newest = std::max(newest, a->t_ns);
  const double window_ns = options_.window_s * 1e9;
  std::erase_if(points,
                [&](const AttemptRecord* a) { return double(newest - a->t_ns) > window_ns; });
  out.points = int(points.size());
  int64_t oldest = newest;
  for (const AttemptRecord* a : points) oldest = std::min(oldest, a->t_ns);

  // Time in windows from the newest point keeps the normal equations well conditioned. A
  // polynomial is not trusted far outside its points: beyond them it is held.
  const double extrapolation_ns = options_.max_extrapolation_s * 1e9;
  const double tau_eval = std::clamp(double(t_ns - newest),
                                     double(oldest - newest) - extrapolation_ns, extrapolation_ns) /
                          window_ns;
  std::vector<Matrix9d> inflated(points.size());
  for (size_t i = 0; i < points.size(); ++i) inflated[i] = InflatedCovariance(*points[i]);

  // Per parameter: the points that estimated it.
  struct Series {
    std::vector<int> point;
    std::vector<double> tau, x, variance;
    int max_order = 0;
  };
  std::array<Series, kNumIntrinsics> series;
  int max_order = 0;
  for (int p = 0; p < kNumIntrinsics; ++p) {
    Series& s = series[p];
    for (size_t i = 0; i < points.size(); ++i) {
      const std::vector<int>& free = points[i]->free_parameters;
      if (std::find(free.begin(), free.end(), p) == free.end()) continue;
      s.point.push_back(int(i));
      s.tau.push_back(double(points[i]->t_ns - newest) / window_ns);
      s.x.push_back(points[i]->estimate.Packed()[p]);
      s.variance.push_back(inflated[i](p, p));
    }
    const int n = int(s.point.size());
    s.max_order = n >= options_.min_points_quadratic ? 2 : n >= options_.min_points_linear ? 1 : 0;
    s.max_order =
        std::min({s.max_order, options_.max_order, std::max(0, DistinctCount(s.tau) - 1)});
    max_order = std::max(max_order, s.max_order);
  }

  // The lowest order no parameter's data argue against: noise is averaged, a drift that
  // shows in any parameter raises the order of all.
  int order = 0;
  while (order < max_order) {
    bool evidence = false;
    for (const Series& s : series) {
      if (s.max_order <= order) continue;
      const PolynomialFit lower = FitPolynomial(s.tau, s.x, s.variance, order, tau_eval);
      const PolynomialFit higher = FitPolynomial(s.tau, s.x, s.variance, order + 1, tau_eval);
      const double scatter = higher.dof > 0 ? std::max(1.0, higher.chi2 / higher.dof) : 1.0;
      if ((lower.chi2 - higher.chi2) / scatter > options_.order_evidence_chi2) evidence = true;
    }
    if (!evidence) break;
    ++order;
  }

  // Value and covariance: the prediction is linear in the points, so its covariance follows
  // from theirs, scaled up where the points scatter more than their covariances admit.
  auto value = out.calibration.Packed();
  Eigen::MatrixXd influence = Eigen::MatrixXd::Zero(points.size(), kNumIntrinsics);
  Eigen::Matrix<double, kNumIntrinsics, 1> scale = Eigen::Matrix<double, kNumIntrinsics, 1>::Zero();
  for (int p = 0; p < kNumIntrinsics; ++p) {
    const Series& s = series[p];
    if (s.point.empty()) continue;
    const int used = std::min(order, s.max_order);
    const PolynomialFit fit = FitPolynomial(s.tau, s.x, s.variance, used, tau_eval);
    value[p] = fit.value;
    for (size_t k = 0; k < s.point.size(); ++k) influence(s.point[k], p) = fit.influence(k);
    scale(p) = std::sqrt(fit.dof > 0 ? std::max(1.0, fit.chi2 / fit.dof) : 1.0);
    out.order = std::max(out.order, used);
  }
  // Overlapping windows share views, and a track's errors with them: attempts t apart are
  // taken as correlated by 1 - t / window (the share of views in common), each pair's
  // cross-covariance the product of their covariances' square roots so weighted. Taken as
  // independent, the output's sigma of a steady lens was half its error.
  std::vector<Matrix9d> weighted_root(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const Matrix9d root = points[i] == &anchor_ ? InflatedRoot(anchor_)
                                                : inflated_roots_[points[i] - attempts_.data()];
    weighted_root[i] = influence.row(i).transpose().asDiagonal() * root;
  }
  const double attempt_window_ns = options_.attempt_window_s * 1e9;
  Matrix9d covariance = Matrix9d::Zero();
  for (size_t i = 0; i < points.size(); ++i) {
    covariance += weighted_root[i] * weighted_root[i].transpose();
    if (points[i] == &anchor_) continue;
    for (size_t j = i + 1; j < points.size(); ++j) {
      if (points[j] == &anchor_) continue;
      const double apart = std::abs(double(points[j]->t_ns - points[i]->t_ns));
      if (apart >= attempt_window_ns) continue;
      const Matrix9d cross =
          (1.0 - apart / attempt_window_ns) * weighted_root[i] * weighted_root[j].transpose();
      covariance += cross + cross.transpose();
    }
  }
  out.covariance = scale.asDiagonal() * covariance * scale.asDiagonal();
  out.calibration = CameraIntrinsics::FromPacked(value, premission_.width, premission_.height);
  return out;
}

FilteredCalibration CalibrationHistory::Current(int64_t t_ns) const {
  if (regimes_.empty()) {
    FilteredCalibration out;
    out.calibration = premission_;
    out.covariance = InflatedCovariance(anchor_);
    out.points = 1;
    return out;
  }
  return Evaluate(RegimeAt(t_ns), t_ns);
}

std::vector<TrendSample> CalibrationHistory::TrendCurve(int64_t from_ns, int64_t to_ns,
                                                        int samples) const {
  std::vector<TrendSample> curve;
  for (int i = 0; i < samples; ++i) {
    TrendSample sample;
    sample.t_ns =
        samples == 1 ? from_ns : from_ns + int64_t(double(to_ns - from_ns) * i / (samples - 1));
    const FilteredCalibration filtered = Current(sample.t_ns);
    sample.regime = filtered.regime;
    sample.value = filtered.calibration.Packed();
    for (int p = 0; p < kNumIntrinsics; ++p) sample.sigma[p] = std::sqrt(filtered.covariance(p, p));
    curve.push_back(sample);
  }
  return curve;
}

int CalibrationHistory::Count(Verdict verdict) const {
  return int(std::count_if(attempts_.begin(), attempts_.end(),
                           [&](const AttemptRecord& a) { return a.verdict == verdict; }));
}

Verdict CalibrationHistory::Judge(int64_t t_ns, const SelfCalibrationResult& result) {
  if (!attempts_.empty() && t_ns < attempts_.back().t_ns) {
    throw Error("calibration history: attempt at " + std::to_string(t_ns) +
                " ns comes before the previous one at " + std::to_string(attempts_.back().t_ns) +
                " ns");
  }
  if (result.usable) {
    const Eigen::Index n = Eigen::Index(result.free_parameters.size());
    if (result.covariance.rows() != n || result.covariance.cols() != n) {
      throw Error("calibration history: covariance is " + std::to_string(result.covariance.rows()) +
                  "x" + std::to_string(result.covariance.cols()) + " for " + std::to_string(n) +
                  " free parameters");
    }
    const std::set<int> distinct(result.free_parameters.begin(), result.free_parameters.end());
    if (int(distinct.size()) != n ||
        (n > 0 && (*distinct.begin() < 0 || *distinct.rbegin() >= kNumIntrinsics))) {
      throw Error("calibration history: free parameters must be distinct intrinsic indices");
    }
  }
  if (regimes_.empty()) {
    Regime first;
    first.start_ns = first.confirmed_ns = t_ns;
    first.start = premission_;
    regimes_.push_back(first);
    anchor_.t_ns = t_ns;
    accepted_.emplace_back();
  }

  AttemptRecord record;
  record.id = int(attempts_.size());
  record.t_ns = t_ns;
  record.regime = regimes_.back().id;
  record.usable = result.usable;
  record.solver_report = result.reason;
  record.estimate = result.estimate;
  if (result.usable) {
    record.covariance = result.covariance;
    record.free_parameters = result.free_parameters;
  }
  record.rms_px = result.rms_px;
  record.frames = result.frames_used;
  record.planes = result.planes_used;
  record.points = result.points_used;
  record.observations = result.observations_used;
  record.lines = result.lines_used;
  record.rotation_spread_deg = result.rotation_spread_deg;
  record.material = std::to_string(record.frames) + " frames, " + std::to_string(record.planes) +
                    " planes, " + std::to_string(record.points) + " points, " +
                    std::to_string(record.observations) + " observations, " +
                    std::to_string(record.lines) + " lines, rotation spread " +
                    Fixed(record.rotation_spread_deg, 1) + " deg";
  const FilteredCalibration trend = Evaluate(record.regime, t_ns);
  record.trend = trend.calibration.Packed();
  attempts_.push_back(record);
  inflated_roots_.push_back(InflatedRoot(record));
  AttemptRecord& judged = attempts_.back();

  if (!result.usable) {
    judged.verdict = Verdict::kNoUpdate;
    judged.reason = result.reason.empty() ? "no update" : result.reason;
  } else if (result.free_parameters.empty()) {
    judged.verdict = Verdict::kNoUpdate;
    judged.reason = "no update: no parameter was estimated";
  } else if (!AllFinite(result.estimate) || !judged.covariance.allFinite()) {
    judged.verdict = Verdict::kRejected;
    judged.reason = "rejected: the estimate or its covariance is not finite";
  } else if (!(result.rms_px <= options_.max_rms_px)) {
    judged.verdict = Verdict::kRejected;
    judged.reason = "rejected: reprojection RMS " + Fixed(result.rms_px, 2) + " px above " +
                    Fixed(options_.max_rms_px, 2) + " px";
  } else {
    const Comparison off_trend = Compare(judged, trend);
    judged.max_sigma = off_trend.max_sigma;
    if (off_trend.max_sigma <= options_.max_sigma) {
      judged.verdict = Verdict::kAccepted;
      judged.reason = "accepted: within " + Fixed(off_trend.max_sigma, 1) +
                      " sigma of the trend (largest: " + kComparedNames[off_trend.worst] + ")";
      accepted_[judged.regime].push_back(judged.id);
      jump_run_.clear();
    } else {
      JudgeOffTrend(&judged, off_trend);
    }
  }

  const FilteredCalibration output = Current(t_ns);
  judged.output = output.calibration.Packed();
  for (int p = 0; p < kNumIntrinsics; ++p)
    judged.output_sigma[p] = std::sqrt(output.covariance(p, p));
  return judged.verdict;
}

void CalibrationHistory::JudgeOffTrend(AttemptRecord* record, const Comparison& off_trend) {
  // A jump persists: each attempt of the run agrees with every earlier one. Anything else
  // is a transient, and the run starts again from this attempt.
  bool agrees = !jump_run_.empty();
  for (int member : jump_run_) {
    if (CompareAttempts(*record, attempts_[member]).max_sigma > options_.max_sigma) agrees = false;
  }
  if (!agrees) jump_run_.clear();
  jump_run_.push_back(record->id);
  const int run = int(jump_run_.size());
  const int regime = record->regime;

  record->verdict = Verdict::kRejected;
  record->reason = "rejected: off the trend, " + off_trend.Describe(options_.max_sigma) +
                   "; jump candidate " + std::to_string(run) + " of " +
                   std::to_string(options_.confirm_after);

  if (run == options_.alarm_after) {
    // What jumped, and by how much: the run's mean deviation from the trend.
    Eigen::VectorXd deviation = Eigen::VectorXd::Zero(kNumCompared);
    Eigen::VectorXd z = Eigen::VectorXd::Zero(kNumCompared);
    for (int member : jump_run_) {
      const AttemptRecord& m = attempts_[member];
      const Comparison c = Compare(m, Evaluate(regime, m.t_ns));
      deviation += c.deviation / run;
      z += c.deviation.cwiseQuotient(c.sigma) / run;
    }
    Alarm alarm;
    alarm.id = int(alarms_.size());
    alarm.t_ns = record->t_ns;
    alarm.attempt = record->id;
    Eigen::Index largest = 0;
    z.cwiseAbs().maxCoeff(&largest);
    std::string sizes;
    for (int q = 0; q < kNumCompared; ++q) {
      if (std::abs(z(q)) <= options_.max_sigma && q != largest) continue;
      alarm.jumped.push_back({kComparedNames[q], deviation(q)});
      sizes += (sizes.empty() ? "" : ", ") + std::string(kComparedNames[q]) + " " +
               Fixed(deviation(q), 2, true) + " px";
    }
    alarm.description =
        "jump in " + sizes + ": " + std::to_string(run) + " consistent attempts off the trend";
    alarms_.push_back(alarm);
    record->verdict = Verdict::kAlarm;
    record->reason = "alarm: " + alarm.description + "; a new regime after " +
                     std::to_string(options_.confirm_after);
  }

  if (run == options_.confirm_after) {
    Regime next;
    next.id = int(regimes_.size());
    next.start_ns = attempts_[jump_run_.front()].t_ns;
    next.confirmed_ns = record->t_ns;
    next.alarm = alarms_.back().id;
    next.founders = jump_run_;
    // Parameters no founder estimated carry over from the old trend.
    next.start = Evaluate(regime, record->t_ns).calibration;
    regimes_.push_back(next);
    accepted_.push_back(jump_run_);
    regimes_.back().start = Evaluate(next.id, record->t_ns).calibration;
    jump_run_.clear();
    record->regime = next.id;
    record->verdict = Verdict::kNewRegime;
    record->reason = "new regime " + std::to_string(next.id) + " from " + std::to_string(run) +
                     " consistent attempts off the trend (alarm " + std::to_string(next.alarm) +
                     ")";
  }
}

}  // namespace autocal
