// The vest check (DESIGN.md, the field technician): fed every frame snapshot of a short walk,
// it keeps track of what the calibration needs that the walk has not given yet (motion that
// makes box 10's problem well posed, DESIGN.md "Opportunism and observability"), says what
// to do next in one line, and ends in a verdict against the pre-mission calibration: pass,
// fail with a reason per failing parameter, or inconclusive with what was missing.
// docs/vest_check.md.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "pipeline/calibration_error.h"
#include "pipeline/calibration_pipeline.h"
#include "pipeline/camera_model.h"

namespace autocal {

struct VestCheckOptions {
  double duration_s = 60.0;  // The walk the procedure asks for.
  // Attempts of box 10 accepted in the regime in effect at the end (a new regime's founder
  // counts): fewer, and the measured calibration is not the walk's.
  int min_accepted = 3;
  double min_rotate_s = 2.0;     // Seconds box 7 classed as turning.
  double min_translate_s = 2.0;  // Seconds classed as walking forward or stepping sideways.
  double min_still_s = 2.0;      // Seconds at rest, where gravity is measured.
  // Box 10 needs neither to fix the intrinsics (gravity steadies the tilt, translation gives
  // the metric scale): asked for last, and missing them leaves the verdict standing.
  bool require_still = false;
  bool require_translation = false;
  // A plane's normal (camera frame) turned by this much while it was followed, or two planes
  // seen together with normals this far apart: views of planes that fix the focal length.
  double min_plane_angle_deg = 20.0;
  int min_line_shapes = 60;  // Snake shapes pooled by box 1 (the plumb-line distortion).
  // Pass when the measured calibration differs from the pre-mission one by no more than
  // these: focal lengths in percent, principal point in pixels, distortion as the largest
  // displacement between the two lenses out to `radius_fraction` of the half-diagonal.
  CalibrationTolerance tolerance{1.5, 4.0, 1.0};
  double radius_fraction = 0.9;
  // Longest gap between two frames counted as motion (a stall is not seconds of turning).
  double max_frame_gap_s = 0.25;

  bool Check(std::string* error) const;
};

// What the calibration needs from the walk, in the order the guidance asks for it.
enum class VestNeed { kPlanes, kRotation, kLines, kUpdates, kStill, kTranslation };
inline constexpr int kNumVestNeeds = 6;

struct VestNeedStatus {
  VestNeed need = VestNeed::kPlanes;
  std::string name;       // "Turning", for the checklist.
  std::string measured;   // "1.2 of 2.0 s".
  double fraction = 0.0;  // 0-1.
  bool done = false;
  bool required = true;  // Missing it makes the verdict inconclusive.
};

enum class VestVerdict { kPass, kFail, kInconclusive };
// "PASS", "FAIL", "INCONCLUSIVE".
std::string VestVerdictName(VestVerdict verdict);

// One compared parameter. Focal lengths in percent of the pre-mission value; the principal
// point and the distortion in pixels.
struct VestCriterion {
  std::string parameter;    // "fx", "fy", "cx", "cy", "distortion".
  std::string unit;         // "%" or "px".
  double premission = 0.0;  // The parameter's values (none for the distortion: 0).
  double measured = 0.0;
  double difference = 0.0;  // Signed, in `unit` (distortion: the displacement, >= 0).
  double tolerance = 0.0;   // Largest |difference| that passes.
  bool pass = false;
  std::string reason;  // For a failing one: "fx 3.2% below the pre-mission value (1.5% allowed)".
};

struct VestCheckResult {
  VestVerdict verdict = VestVerdict::kInconclusive;
  // The verdict in one line, with its reasons: failing criteria, or what was missing.
  std::vector<std::string> reasons;
  std::vector<VestCriterion> criteria;  // Empty when inconclusive for want of updates.
  std::vector<VestNeedStatus> coverage;
  CameraIntrinsics premission;
  CameraIntrinsics measured;  // The filtered calibration at the end.
  double seconds = 0.0;       // Walk time covered by the frames.
  int frames = 0;
  int attempts = 0;  // Box 10's attempts judged, and by verdict.
  std::map<Verdict, int> verdicts;
  int accepted_in_regime = 0;
  // Walk time whose images box 9 found unfit (fog, noise): it counts towards no need.
  double unfit_s = 0.0;
  std::vector<std::string> alarms;  // "2.5 s: jump in fx ..." (the attempts that raised one).
  // The camera's rolling-shutter readout the walk was measured with (ms; 0: a global
  // shutter): set by whoever runs the pipeline (RunVestCheck), for the record.
  double readout_ms = 0.0;
};

class VestCheck {
 public:
  // Throws Error when the options or the pre-mission calibration are not valid.
  VestCheck(const CameraIntrinsics& premission, const VestCheckOptions& options = {});

  // Every frame's snapshot, in frame order. A frame box 9 found unfit (snapshot.degraded)
  // counts as walk time but towards no need: its motion and planes are not material.
  void Add(const FrameSnapshot& snapshot);

  // What is covered so far, in VestNeed order.
  std::vector<VestNeedStatus> Coverage() const;
  // Every required need is covered.
  bool Complete() const;
  // 0-1: the walk's share of what the calibration requires.
  double Progress() const;
  // One line for the technician: what to do now ("Turn slowly left and right"; while the
  // images are unfit, what to do about them: "Image fogged or blurred: wipe the lens").
  std::string Guidance() const;
  double elapsed_s() const { return elapsed_s_; }

  // The verdict on what was added so far.
  VestCheckResult Result() const;

  const VestCheckOptions& options() const { return options_; }
  const CameraIntrinsics& premission() const { return premission_; }

 private:
  VestNeedStatus Status(VestNeed need) const;
  int AcceptedInRegime() const;

  CameraIntrinsics premission_;
  VestCheckOptions options_;

  std::optional<int64_t> first_ns_, last_ns_;
  int frames_ = 0;
  double elapsed_s_ = 0.0;
  double rotate_s_ = 0.0, translate_s_ = 0.0, still_s_ = 0.0;
  double unfit_s_ = 0.0;
  std::string newest_degraded_;  // Why the newest frame is unfit; empty when it is fit.
  std::string first_degraded_;   // Why the first unfit frame of the walk was.
  double plane_angle_deg_ = 0.0;
  int line_shapes_ = 0;
  int planes_now_ = 0;
  std::map<int, Eigen::Vector3d> first_normal_;  // Per plane id: its normal when first known.
  std::vector<AttemptRecord> attempts_;          // Judged so far, in order.
  FilteredCalibration calibration_;
};

}  // namespace autocal
