#include "pipeline/calibration_pipeline.h"

#include <algorithm>
#include <chrono>

#include "pipeline/error.h"
#include "pipeline/stopwatch.h"

namespace autocal {
namespace {

template <typename Options>
bool CheckNested(const Options& options, const char* name, std::string* error) {
  std::string why;
  if (options.Check(&why)) return true;
  if (error) *error = std::string(name) + "." + why;
  return false;
}

// An estimate only counts for the distortion when box 10 let the distortion move.
bool EstimatesDistortion(const AttemptRecord& record) {
  return std::find(record.free_parameters.begin(), record.free_parameters.end(), kK1) !=
         record.free_parameters.end();
}

// The history told how long box 9's windows are: attempts closer than that share views.
AcceptanceOptions AcceptanceFor(const PipelineOptions& options) {
  AcceptanceOptions acceptance = options.acceptance;
  acceptance.attempt_window_s = options.material.window_s;
  return acceptance;
}

}  // namespace

bool PipelineOptions::Check(std::string* error) const {
  return CheckNested(lens, "lens", error) && CheckNested(motion, "motion", error) &&
         CheckNested(inertial, "inertial", error) && CheckNested(board, "board", error) &&
         CheckNested(material, "material", error) &&
         CheckNested(calibration, "calibration", error) &&
         CheckNested(acceptance, "acceptance", error);
}

std::vector<std::pair<std::string, double>> BoxTimings::Named() const {
  return {{"lines", lines_ms},       {"distortion", distortion_ms},
          {"rectify", rectify_ms},   {"features", features_ms},
          {"flow", flow_ms},         {"planes", planes_ms},
          {"refind", refind_ms},     {"inertial", inertial_ms},
          {"material", material_ms}, {"calibration", calibration_ms},
          {"history", history_ms}};
}

LensHalf::LensHalf(const PipelineOptions& options, bool live)
    : lens_(options.lens), rectifier_(options.lens.rectify) {
  lens_.set_readout_ms(options.calibration.readout_ms);
  lens_.set_wait_for_estimates(!live);
}

void LensHalf::set_options(const PipelineOptions& options) {
  lens_.set_options(options.lens);
  lens_.set_readout_ms(options.calibration.readout_ms);
  rectifier_.set_options(options.lens.rectify);
}

LensFrame LensHalf::Process(int64_t t_ns, const cv::Mat& raw, const CalibrationState& state) {
  LensFrame frame;
  frame.t_ns = t_ns;
  // Box 2 measured the distortion in pixels at the focal length it was given: the same
  // pixels at today's focal length, until the history has accepted a distortion.
  frame.working = state.distortion_accepted || !plumb_line_
                      ? state.filtered.calibration
                      : WithDistortionOf(state.filtered.calibration, plumb_line_->estimate);

  // Box 2's estimates are taken only until then: afterwards box 10 estimates the distortion
  // with the pinhole, from the whole pool of shapes.
  lens_.set_estimating(!state.distortion_accepted);
  frame.lens = lens_.Process(t_ns, raw, frame.working);
  if (frame.lens.distortion && frame.lens.distortion->usable) plumb_line_ = frame.lens.distortion;

  const auto start = std::chrono::steady_clock::now();
  frame.gray = rectifier_.Equalize(rectifier_.Channel(raw));
  frame.quality = MeasureImageQuality(raw);
  frame.rectify_ms = MillisecondsSince(start);

  if (pooled_version_ != lens_.pool_version()) {
    pooled_ = std::make_shared<const std::vector<LineObservation>>(lens_.PooledShapes());
    pooled_version_ = lens_.pool_version();
  }
  frame.pooled_shapes = pooled_;
  return frame;
}

MotionHalf::MotionHalf(const CameraIntrinsics& premission, const AccelCalibration& accel,
                       const PipelineOptions& options)
    : options_(options),
      motion_(options.motion),
      inertial_(accel, options.inertial),
      material_(options.material),
      history_(premission, AcceptanceFor(options)),
      quality_gate_(options.material.quality) {
  std::string why;
  if (!options.Check(&why)) throw Error("pipeline options: " + why);
  filtered_ = history_.Current(0);
}

void MotionHalf::set_options(const PipelineOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw Error("pipeline options: " + why);
  options_ = options;
  motion_.set_options(options.motion);
  inertial_.set_options(options.inertial);
  material_.set_options(options.material);
  quality_gate_.set_options(options.material.quality);
}

void MotionHalf::AddAccel(std::span<const SpecificForceSample> samples) {
  inertial_.AddSamples(samples);
}

std::optional<VisualMotion> MotionHalf::VisionBetweenFrames(const MotionSnapshot& motion) {
  // The plane with the most tracks whose decomposition, from the same reference, is known
  // in both frames: X_now = R X_ref + t d for each, so between the frames the camera turned
  // by R_now R_before^T.
  std::optional<VisualMotion> visual;
  size_t best_tracks = 0;
  std::vector<std::pair<int, std::pair<int64_t, Eigen::Matrix3d>>> now;
  for (const DominantPlane& plane : motion.planes) {
    if (!plane.motion) continue;
    now.push_back({plane.id, {plane.reference_t_ns, plane.motion->rotation}});
    const auto before =
        std::find_if(previous_rotations_.begin(), previous_rotations_.end(),
                     [&](const auto& entry) { return entry.first == plane.id; });
    if (before == previous_rotations_.end() || before->second.first != plane.reference_t_ns ||
        plane.track_ids.size() <= best_tracks) {
      continue;
    }
    best_tracks = plane.track_ids.size();
    const Eigen::Matrix3d turn = plane.motion->rotation * before->second.second.transpose();
    VisualMotion found;
    found.cam1_from_cam0 = Eigen::Quaterniond(turn).normalized();
    visual = found;
  }
  previous_rotations_ = std::move(now);
  return visual;
}

FrameSnapshot MotionHalf::Process(LensFrame frame, std::optional<CalibrationJob>* job) {
  FrameSnapshot snapshot;
  snapshot.t_ns = frame.t_ns;
  snapshot.index = frames_++;
  snapshot.working = frame.working;
  snapshot.timing.lines_ms = frame.lens.lines_ms;
  snapshot.timing.distortion_ms = frame.lens.distortion_ms;
  snapshot.lens = std::move(frame.lens);
  snapshot.timing.rectify_ms = frame.rectify_ms;

  snapshot.motion = motion_.Process(frame.t_ns, frame.gray, snapshot.working);
  snapshot.timing.features_ms = snapshot.motion.features_ms;
  snapshot.timing.flow_ms = snapshot.motion.flow_ms;
  snapshot.timing.planes_ms = snapshot.motion.planes_ms;
  snapshot.timing.refind_ms = snapshot.motion.refind_ms;

  auto start = std::chrono::steady_clock::now();
  snapshot.inertial = inertial_.Process(frame.t_ns, VisionBetweenFrames(snapshot.motion));
  snapshot.motion.inertial.gravity_cam = snapshot.inertial.gravity_cam;
  snapshot.motion.inertial.motion_class = MotionClassName(snapshot.inertial.motion);
  snapshot.timing.inertial_ms = MillisecondsSince(start);
  snapshot.motion.inertial.inertial_ms = snapshot.timing.inertial_ms;

  start = std::chrono::steady_clock::now();
  snapshot.quality = frame.quality;
  const std::optional<double> image_speed_px = ImageSpeedPx(snapshot.motion.tracks);
  if (auto degraded = quality_gate_.Judge(frame.t_ns, frame.quality, image_speed_px)) {
    snapshot.degraded = *degraded;
    last_degraded_ns_ = frame.t_ns;
    last_degraded_ = *degraded;
  }
  snapshot.view = snapshot.degraded.empty() &&
                  material_.Add(snapshot.motion, snapshot.inertial, frame.gray, snapshot.working);
  // While frames are unfit, attempts still come when due, so that the history says why
  // nothing is updated; they stay without an update until the window is clean again.
  const bool window_degraded =
      last_degraded_ns_ &&
      double(frame.t_ns - *last_degraded_ns_) <= options_.material.window_s * 1e9;
  const bool due = !last_attempt_ns_ || double(frame.t_ns - *last_attempt_ns_) >=
                                            options_.material.attempt_every_s * 1e9;
  if (job && (snapshot.view || !snapshot.degraded.empty()) && due && !job_pending_ &&
      material_.span_s() >= 0.5 * options_.material.window_s) {
    CalibrationJob next;
    next.t_ns = frame.t_ns;
    next.material = material_.Assemble(frame.pooled_shapes ? *frame.pooled_shapes
                                                           : std::vector<LineObservation>{});
    if (window_degraded) {
      next.material.degraded = "unfit images in the window (latest: " + last_degraded_ + ")";
    }
    next.prior = snapshot.working;
    next.view_times = material_.view_times();
    if (last_solved_) {
      next.material.start = StartFrom(last_solved_->second, last_solved_->first, next.view_times);
    }
    *job = std::move(next);
    job_pending_ = true;
    last_attempt_ns_ = frame.t_ns;
  }
  snapshot.timing.material_ms = MillisecondsSince(start);
  snapshot.calibration = filtered_;
  return snapshot;
}

std::shared_ptr<const AttemptOutcome> MotionHalf::Judge(const CalibrationJob& job,
                                                        const SelfCalibrationResult& result) {
  job_pending_ = false;
  const Verdict verdict = history_.Judge(job.t_ns, result);
  if (verdict == Verdict::kAccepted || verdict == Verdict::kNewRegime) {
    last_solved_.emplace(job.view_times, result);
  }
  auto outcome = std::make_shared<AttemptOutcome>();
  outcome->record = history_.attempts().back();
  outcome->view_times = job.view_times;
  if (result.usable) {
    outcome->cam_from_world = result.cam_from_world;
    for (const PlaneEstimate& plane : result.planes) {
      outcome->boards.push_back(
          AttachBoard(plane.id, plane.world_from_plane, plane.points, options_.board));
    }
  }
  if ((verdict == Verdict::kAccepted || verdict == Verdict::kNewRegime) &&
      EstimatesDistortion(outcome->record)) {
    distortion_accepted_ = true;
  }
  filtered_ = history_.Current(job.t_ns);
  return outcome;
}

CalibrationPipeline::CalibrationPipeline(const CameraIntrinsics& premission,
                                         const AccelCalibration& accel,
                                         const PipelineOptions& options)
    : lens_(options), motion_(premission, accel, options) {}

void CalibrationPipeline::set_options(const PipelineOptions& options) {
  motion_.set_options(options);  // Checks them first.
  lens_.set_options(options);
}

void CalibrationPipeline::AddAccel(std::span<const SpecificForceSample> samples) {
  motion_.AddAccel(samples);
}

FrameSnapshot CalibrationPipeline::ProcessFrame(int64_t t_ns, const cv::Mat& raw,
                                                std::optional<CalibrationJob>* job) {
  return motion_.Process(lens_.Process(t_ns, raw, motion_.state()), job);
}

std::shared_ptr<const AttemptOutcome> CalibrationPipeline::Judge(
    const CalibrationJob& job, const SelfCalibrationResult& result) {
  return motion_.Judge(job, result);
}

FrameSnapshot CalibrationPipeline::Process(int64_t t_ns, const cv::Mat& raw) {
  std::optional<CalibrationJob> job;
  FrameSnapshot snapshot = ProcessFrame(t_ns, raw, &job);
  if (!job) return snapshot;
  auto start = std::chrono::steady_clock::now();
  const SelfCalibrationResult result =
      SelfCalibrate(job->material, job->prior, options().calibration);
  snapshot.timing.calibration_ms = MillisecondsSince(start);
  start = std::chrono::steady_clock::now();
  snapshot.attempt = Judge(*job, result);
  snapshot.calibration = motion_.state().filtered;
  snapshot.timing.history_ms = MillisecondsSince(start);
  return snapshot;
}

}  // namespace autocal
