#include "devices/still_shot_run.h"

#include <chrono>
#include <memory>
#include <vector>

#include "pipeline/calibration_history.h"
#include "pipeline/error.h"
#include "pipeline/history_store.h"

namespace autocal {

StillShotOptions StillShotOptionsFrom(const PipelineOptions& pipeline) {
  StillShotOptions options;
  options.lens = pipeline.lens;
  options.lens.pool_per_cell = 1000;  // Still images: every shape is a new view, keep them.
  options.features = pipeline.motion.flow.features;
  options.planes = pipeline.motion.planes;
  options.calibration = pipeline.calibration;
  options.calibration.min_frames = 3;
  options.max_lines = pipeline.material.max_lines;
  return options;
}

RunReport RunStillShots(const Sequence& sequence, const RunSettings& settings,
                        const std::function<void(const std::string&)>& step,
                        const std::atomic<bool>* stop) {
  const auto start = std::chrono::steady_clock::now();
  const auto say = [&](const std::string& what) {
    if (step) step(what);
  };
  RunReport report;
  report.input = sequence.Describe() + ", as still shots";
  report.prior = StartingCalibration(report.input, sequence.session(), settings.prior);
  AcceptanceOptions acceptance = settings.pipeline.acceptance;
  // One lens at one moment: the trend over the attempts is a constant.
  acceptance.max_order = 0;
  CalibrationHistory history(report.prior, acceptance);
  const std::unique_ptr<HistoryStore> store = OpenNewHistory(settings);
  if (store) store->Record(history);  // The start, so that a run stopped early says it.

  say("reading " + std::to_string(sequence.frame_count()) + " shots");
  std::vector<cv::Mat> shots;
  std::string unreadable;
  for (size_t i = 0; i < sequence.frame_count(); ++i) {
    try {
      shots.push_back(sequence.LoadFrame(i));
    } catch (const Error& error) {
      unreadable += std::string(unreadable.empty() ? "" : "; ") + error.what();
    }
  }
  if (!unreadable.empty()) throw Error("cannot read every shot: " + unreadable);
  for (size_t i = 1; i < shots.size(); ++i) {
    if (shots[i].size() != shots[0].size()) {
      throw Error(sequence.FrameName(i) + " is " + std::to_string(shots[i].cols) + "x" +
                  std::to_string(shots[i].rows) + " and " + sequence.FrameName(0) +
                  ", the first shot, is " + std::to_string(shots[0].cols) + "x" +
                  std::to_string(shots[0].rows) + ": still shots come from one camera");
    }
  }
  if (shots.size() < 3) {
    throw Error(report.input + ": " + std::to_string(shots.size()) +
                " images; still shots need at least 3 (a plane seen from 3 viewpoints)");
  }
  report.frames = shots.size();
  const int64_t first_ns = sequence.frame_time_ns(0);
  const int64_t last_ns = sequence.frame_time_ns(sequence.frame_count() - 1);
  report.seconds = 1e-9 * double(last_ns - first_ns);

  // The attempts, one second apart after the last shot, judged as a video's windows are,
  // and in the history file as each is made: a run killed later keeps them.
  std::vector<int64_t> times;
  std::vector<CameraIntrinsics> outputs;
  StillShotProgress progress;
  progress.step = say;
  progress.stop = stop;
  progress.attempted = [&](const StillShotAttempt& attempt) {
    const int64_t t_ns = last_ns + static_cast<int64_t>(times.size()) * 1'000'000'000;
    history.Judge(t_ns, attempt.result);
    if (store) store->Record(history);
    say(attempt.shots + ": " + history.attempts().back().reason);
    times.push_back(t_ns);
    outputs.push_back(history.Current(t_ns).calibration);
  };
  const StillShotOptions options = StillShotOptionsFrom(settings.pipeline);
  const StillShotCalibration calibrated =
      CalibrateStillShots(shots, report.prior, options, progress);
  report.stopped = calibrated.stopped;
  report.frames_in_input = sequence.frame_count();
  if (calibrated.distortion.lines_used > 0) report.plumb_line = calibrated.distortion;
  if (calibrated.material.planes.empty() && !calibrated.stopped) {
    throw Error(report.input + ": no plane found: " + std::to_string(calibrated.pairs_with_planes) +
                " of " + std::to_string(calibrated.pairs) +
                " pairs of shots share a plane by their keypoints, and none is seen in enough "
                "shots with " +
                std::to_string(options.calibration.min_points_per_plane) +
                " points; the shots need a textured plane in common, seen from viewpoints "
                "20-40 degrees apart");
  }

  SummarizeHistory(history, times.empty() ? last_ns : times.back(), &report);
  for (const auto& [box, ms] : calibrated.timing_ms) report.timing[box] = TimingStatsOf(ms);
  report.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  report.fps = report.wall_seconds > 0 ? double(report.frames) / report.wall_seconds : 0.0;
  if (const std::vector<GroundTruthFrame>* truth = sequence.ground_truth();
      truth && !truth->empty() && !times.empty()) {
    // The lens of the last shot, after every attempt.
    const std::vector<GroundTruthFrame> lens(times.size(), truth->back());
    report.truth = CompareWithTruth(times, outputs, lens, settings.convergence);
  }
  return report;
}

}  // namespace autocal
