#include "pipeline/vest_check.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>
#include <string_view>
#include <utility>

#include "pipeline/error.h"

namespace autocal {
namespace {

std::string Fixed(double value, int decimals) {
  std::ostringstream out;
  out.precision(decimals);
  out << std::fixed << value;
  return out.str();
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / M_PI;
}

bool Founds(Verdict verdict) {
  return verdict == Verdict::kAccepted || verdict == Verdict::kNewRegime;
}

// What box 10's "no update" or the history's rejection asks of the walk; nothing when the
// reason names no motion (the solver failed, ...).
std::optional<VestNeed> NeedFromReason(const std::string& reason) {
  const auto has = [&](std::string_view text) { return reason.find(text) != std::string::npos; };
  // A camera that barely moved needs to be walked before anything else (whatever failed
  // after that, insufficient rotation included).
  if (has(kBarelyMovedCause)) return VestNeed::kPlanes;
  if (has("insufficient rotation")) return VestNeed::kRotation;
  // Too few tracks on a plane, or views of the planes too alike to fix the focal length.
  if (has("no plane with") || has("frames could be placed") || has("seen from two placed") ||
      has("not observable") || has("does not constrain")) {
    return VestNeed::kPlanes;
  }
  return std::nullopt;
}

// What the technician can do about images box 9 found unfit, from its reason
// ("image degraded: fogged (...)", "... noisy (...)").
std::string UnfitGuidance(const std::string& degraded) {
  const auto has = [&](const char* text) { return degraded.find(text) != std::string::npos; };
  // Blurrier than frames that moved about as fast: the exposure smears a fast turn.
  if (has("blurred") && has("the image moving")) return "Image blurred by motion: turn more slowly";
  if (has("fogged") || has("blurred") || has("low contrast")) {
    return "Image fogged or blurred: wipe the lens";
  }
  if (has("noisy")) return "Image noisy: move to where there is more light";
  return "Image unfit to measure from: check the camera";
}

std::string GuidanceFor(VestNeed need, const VestCheckOptions& options, int planes_now,
                        int accepted) {
  switch (need) {
    case VestNeed::kPlanes:
      return planes_now == 0 ? "Walk slowly, facing a textured wall or the floor"
                             : "Look at the floor, then at a wall, turning between them";
    case VestNeed::kStill:
      return "Hold still for " + Fixed(options.min_still_s, 0) + " s";
    case VestNeed::kRotation:
      return "Turn slowly left and right";
    case VestNeed::kTranslation:
      return "Walk towards a wall, then step sideways";
    case VestNeed::kLines:
      return "Look at straight edges: door frames, shelves, windows";
    case VestNeed::kUpdates:
      return "Keep walking and turning: " + std::to_string(accepted) + " of " +
             std::to_string(options.min_accepted) + " calibration updates so far";
  }
  return {};
}

}  // namespace

bool VestCheckOptions::Check(std::string* error) const {
  const std::pair<bool, const char*> rules[] = {
      {duration_s > 0, "duration_s must be positive"},
      {min_accepted >= 1, "min_accepted must be at least 1"},
      {min_rotate_s >= 0 && min_translate_s >= 0 && min_still_s >= 0,
       "min_rotate_s, min_translate_s and min_still_s must not be negative"},
      {min_plane_angle_deg >= 0 && min_plane_angle_deg < 90,
       "min_plane_angle_deg must be in [0, 90)"},
      {min_line_shapes >= 0, "min_line_shapes must not be negative"},
      {tolerance.focal_percent > 0 && tolerance.principal_px > 0 && tolerance.distortion_px > 0,
       "tolerance (focal_percent, principal_px, distortion_px) must be positive"},
      {radius_fraction > 0 && radius_fraction <= 1, "radius_fraction must be in (0, 1]"},
      {max_frame_gap_s > 0, "max_frame_gap_s must be positive"},
  };
  for (const auto& [ok, message] : rules) {
    if (!ok) {
      if (error) *error = message;
      return false;
    }
  }
  return true;
}

std::string VestVerdictName(VestVerdict verdict) {
  switch (verdict) {
    case VestVerdict::kPass:
      return "PASS";
    case VestVerdict::kFail:
      return "FAIL";
    case VestVerdict::kInconclusive:
      return "INCONCLUSIVE";
  }
  return {};
}

VestCheck::VestCheck(const CameraIntrinsics& premission, const VestCheckOptions& options)
    : premission_(premission), options_(options) {
  std::string error;
  if (!options.Check(&error)) throw Error("vest check: " + error);
  if (!premission.Check(&error)) throw Error("pre-mission calibration: " + error);
  calibration_.calibration = premission;
}

void VestCheck::Add(const FrameSnapshot& snapshot) {
  const bool unfit = !snapshot.degraded.empty();
  newest_degraded_ = snapshot.degraded;
  if (unfit && first_degraded_.empty()) first_degraded_ = snapshot.degraded;
  if (last_ns_) {
    const double dt = 1e-9 * double(snapshot.t_ns - *last_ns_);
    elapsed_s_ = 1e-9 * double(snapshot.t_ns - *first_ns_);
    if (unfit && dt > 0 && dt <= options_.max_frame_gap_s) unfit_s_ += dt;
    if (!unfit && dt > 0 && dt <= options_.max_frame_gap_s) {
      switch (snapshot.inertial.motion) {
        case MotionClass::kRotate:
          rotate_s_ += dt;
          break;
        case MotionClass::kForward:
        case MotionClass::kSidestep:
          translate_s_ += dt;
          break;
        default:
          break;
      }
      if (snapshot.inertial.quasi_static) still_s_ += dt;
    }
  } else {
    first_ns_ = snapshot.t_ns;
  }
  last_ns_ = snapshot.t_ns;
  ++frames_;

  // A plane seen at an angle: its normal turned while it was followed; or two planes with
  // different orientations in one view.
  const std::vector<DominantPlane>& planes = snapshot.motion.planes;
  planes_now_ = unfit ? 0 : int(planes.size());
  for (size_t a = 0; a < size_t(planes_now_); ++a) {
    if (!planes[a].normal) continue;
    const Eigen::Vector3d& first =
        first_normal_.try_emplace(planes[a].id, *planes[a].normal).first->second;
    plane_angle_deg_ = std::max(plane_angle_deg_, AngleDeg(first, *planes[a].normal));
    for (size_t b = a + 1; b < planes.size(); ++b) {
      if (planes[b].normal) {
        plane_angle_deg_ =
            std::max(plane_angle_deg_, AngleDeg(*planes[a].normal, *planes[b].normal));
      }
    }
  }
  line_shapes_ = std::max(line_shapes_, snapshot.lens.pooled_shapes);
  if (snapshot.attempt) attempts_.push_back(snapshot.attempt->record);
  calibration_ = snapshot.calibration;
}

int VestCheck::AcceptedInRegime() const {
  return int(std::count_if(attempts_.begin(), attempts_.end(), [&](const AttemptRecord& a) {
    return Founds(a.verdict) && a.regime == calibration_.regime;
  }));
}

VestNeedStatus VestCheck::Status(VestNeed need) const {
  VestNeedStatus status;
  status.need = need;
  const auto seconds = [&](const char* name, double have, double want) {
    status.name = name;
    status.measured = Fixed(std::min(have, want), 1) + " of " + Fixed(want, 1) + " s";
    status.fraction = want > 0 ? have / want : 1.0;
  };
  switch (need) {
    case VestNeed::kPlanes:
      status.name = "Planes from different angles";
      status.measured = Fixed(std::min(plane_angle_deg_, options_.min_plane_angle_deg), 0) +
                        " of " + Fixed(options_.min_plane_angle_deg, 0) + " deg";
      status.fraction =
          options_.min_plane_angle_deg > 0 ? plane_angle_deg_ / options_.min_plane_angle_deg : 1.0;
      break;
    case VestNeed::kStill:
      seconds("Holding still", still_s_, options_.min_still_s);
      break;
    case VestNeed::kRotation:
      seconds("Turning", rotate_s_, options_.min_rotate_s);
      break;
    case VestNeed::kTranslation:
      seconds("Walking or stepping sideways", translate_s_, options_.min_translate_s);
      break;
    case VestNeed::kLines:
      status.name = "Straight edges";
      status.measured = std::to_string(std::min(line_shapes_, options_.min_line_shapes)) + " of " +
                        std::to_string(options_.min_line_shapes) + " shapes";
      status.fraction =
          options_.min_line_shapes > 0 ? double(line_shapes_) / options_.min_line_shapes : 1.0;
      break;
    case VestNeed::kUpdates: {
      const int accepted = AcceptedInRegime();
      status.name = "Calibration updates accepted";
      status.measured = std::to_string(std::min(accepted, options_.min_accepted)) + " of " +
                        std::to_string(options_.min_accepted);
      status.fraction = double(accepted) / options_.min_accepted;
      break;
    }
  }
  status.required = (need != VestNeed::kStill || options_.require_still) &&
                    (need != VestNeed::kTranslation || options_.require_translation);
  status.fraction = std::clamp(status.fraction, 0.0, 1.0);
  status.done = status.fraction >= 1.0;
  return status;
}

std::vector<VestNeedStatus> VestCheck::Coverage() const {
  std::vector<VestNeedStatus> all;
  for (int need = 0; need < kNumVestNeeds; ++need) all.push_back(Status(VestNeed(need)));
  return all;
}

bool VestCheck::Complete() const {
  const std::vector<VestNeedStatus> all = Coverage();
  return std::all_of(all.begin(), all.end(),
                     [](const VestNeedStatus& s) { return s.done || !s.required; });
}

double VestCheck::Progress() const {
  double sum = 0.0;
  int required = 0;
  for (const VestNeedStatus& status : Coverage()) {
    if (!status.required) continue;
    sum += status.fraction;
    ++required;
  }
  return sum / required;
}

std::string VestCheck::Guidance() const {
  if (frames_ == 0) return "Stand facing a textured wall and hold still";
  if (!newest_degraded_.empty()) return UnfitGuidance(newest_degraded_);
  const int accepted = AcceptedInRegime();
  // While updates are missing, what box 10 said of the newest attempt comes first: it is
  // what the walk lacked just now.
  if (accepted < options_.min_accepted && !attempts_.empty() && !Founds(attempts_.back().verdict)) {
    if (attempts_.back().verdict == Verdict::kAlarm) {
      return "Keep walking: the calibration has moved, confirming";
    }
    if (attempts_.back().verdict == Verdict::kRejected) return "Move more slowly";
    if (const auto need = NeedFromReason(attempts_.back().reason)) {
      return GuidanceFor(*need, options_, planes_now_, accepted);
    }
  }
  const std::vector<VestNeedStatus> all = Coverage();
  for (const VestNeedStatus& status : all) {
    if (!status.done && status.required) {
      return GuidanceFor(status.need, options_, planes_now_, accepted);
    }
  }
  for (const VestNeedStatus& status : all) {
    if (!status.done) {
      std::string more = GuidanceFor(status.need, options_, planes_now_, accepted);
      more[0] = char(std::tolower(more[0]));
      return "Enough for a verdict. To help further: " + more;
    }
  }
  return "All covered: keep walking until the time is up";
}

VestCheckResult VestCheck::Result() const {
  VestCheckResult result;
  result.premission = premission_;
  result.measured = calibration_.calibration;
  result.seconds = elapsed_s_;
  result.frames = frames_;
  result.coverage = Coverage();
  result.attempts = int(attempts_.size());
  for (const AttemptRecord& attempt : attempts_) {
    ++result.verdicts[attempt.verdict];
    if (attempt.verdict == Verdict::kAlarm) {
      const std::string prefix = "alarm: ";
      const std::string what = attempt.reason.rfind(prefix, 0) == 0
                                   ? attempt.reason.substr(prefix.size())
                                   : attempt.reason;
      result.alarms.push_back(Fixed(1e-9 * double(attempt.t_ns - first_ns_.value_or(0)), 1) +
                              " s: " + what);
    }
  }
  result.accepted_in_regime = AcceptedInRegime();

  // Inconclusive: the measured calibration is not (yet) the walk's own.
  if (result.accepted_in_regime < options_.min_accepted) {
    result.reasons.push_back("only " + std::to_string(result.accepted_in_regime) + " of " +
                             std::to_string(options_.min_accepted) +
                             " calibration updates were accepted");
  }
  // A jump alarm with no update accepted since, on the old trend or as a new regime: the
  // history has not decided whether the lens moved.
  const auto last_alarm = std::find_if(attempts_.rbegin(), attempts_.rend(),
                                       [](const auto& a) { return a.verdict == Verdict::kAlarm; });
  const auto last_founding = std::find_if(attempts_.rbegin(), attempts_.rend(),
                                          [](const auto& a) { return Founds(a.verdict); });
  if (last_alarm < last_founding) {
    result.reasons.push_back("a jump in the calibration was raised and not yet confirmed");
  }
  for (const VestNeedStatus& status : result.coverage) {
    if (!status.done && status.required && status.need != VestNeed::kUpdates) {
      result.reasons.push_back("missing: " + status.name + " (" + status.measured + ")");
    }
  }
  result.unfit_s = unfit_s_;
  // Why the walk fell short, when part of it was lost to the images.
  if (!result.reasons.empty() && unfit_s_ > 0.0) {
    std::string advice = UnfitGuidance(first_degraded_);
    advice[0] = char(std::tolower(advice[0]));
    result.reasons.push_back("the images were unfit for " + Fixed(unfit_s_, 1) +
                             " s of the walk, which did not count (" + advice + ")");
  }
  if (!result.reasons.empty()) {
    result.verdict = VestVerdict::kInconclusive;
    return result;
  }

  const CalibrationError error =
      CompareCalibration(calibration_.calibration, premission_, options_.radius_fraction);
  const CalibrationTolerance& tol = options_.tolerance;
  const CameraIntrinsics& m = calibration_.calibration;
  const auto add = [&](const char* name, const char* unit, double before, double after,
                       double difference, double tolerance) {
    VestCriterion c{
        name, unit, before, after, difference, tolerance, std::abs(difference) <= tolerance, {}};
    if (!c.pass) {
      const std::string amount = Fixed(std::abs(difference), unit[0] == '%' ? 2 : 1) + unit;
      const std::string allowed = " (" + Fixed(tolerance, 1) + unit + " allowed)";
      c.reason = c.parameter == "distortion"
                     ? "the lens distortion moves points by " + amount +
                           " from where the pre-mission calibration puts them, out to " +
                           Fixed(100 * options_.radius_fraction, 0) + "% of the half-diagonal" +
                           allowed
                     : c.parameter + " is " + amount + (difference > 0 ? " above" : " below") +
                           " the pre-mission value" + allowed;
      result.reasons.push_back(c.reason);
    }
    result.criteria.push_back(c);
  };
  add("fx", "%", premission_.fx, m.fx, error.fx_percent, tol.focal_percent);
  add("fy", "%", premission_.fy, m.fy, error.fy_percent, tol.focal_percent);
  add("cx", "px", premission_.cx, m.cx, error.cx_px, tol.principal_px);
  add("cy", "px", premission_.cy, m.cy, error.cy_px, tol.principal_px);
  add("distortion", "px", 0.0, 0.0, error.distortion_px, tol.distortion_px);
  result.verdict = result.reasons.empty() ? VestVerdict::kPass : VestVerdict::kFail;
  return result;
}

}  // namespace autocal
