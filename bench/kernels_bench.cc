// The kernels inside the boxes, each on its own: the Radon transform that finds lines
// (box 1), the snake update (box 1), tracking (boxes 4-5), a robust homography fit like
// box 6's, and box 10's calibration solve over a window of material. Frames of a simulated
// office walk through the sonnar lens are rendered before any timing.
#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <optional>
#include <tuple>
#include <utility>
#include <vector>

#include <opencv2/calib3d.hpp>

#include "devices/sim/simulator.h"
#include "pipeline/calibration_pipeline.h"
#include "pipeline/flow.h"
#include "pipeline/homography_ransac.h"
#include "pipeline/line_detector.h"
#include "pipeline/radon_snake.h"
#include "pipeline/rectifier.h"
#include "pipeline/self_calibration.h"

namespace autocal {
namespace {

struct Clip {
  std::vector<cv::Mat> raw;    // BGR, as rendered.
  std::vector<cv::Mat> green;  // Box 1's input: the raw green channel.
  std::vector<cv::Mat> gray;   // Boxes 4-6's input: the green channel equalized.
  std::vector<int64_t> times;
  CameraIntrinsics calibration;  // Pre-mission.
  AccelCalibration accel;
  std::vector<AccelSample> samples;
};

const Clip& OfficeClip(int width, int height, double seconds = 2.0) {
  static std::map<std::tuple<int, int, double>, Clip> clips;
  Clip& clip = clips[{width, height, seconds}];
  if (!clip.raw.empty()) return clip;
  Scenario scenario = ParseScenarioSpec("office,lens=sonnar");
  ApplyScenarioOverride(&scenario, "resolution",
                        std::to_string(width) + "x" + std::to_string(height));
  ApplyScenarioOverride(&scenario, "seconds", std::to_string(seconds));
  const auto sequence = MakeSimulatedSequence(scenario);
  const Rectifier rectifier;
  for (size_t i = 0; i < sequence->frame_count(); ++i) {
    clip.raw.push_back(sequence->LoadFrame(i));
    clip.green.push_back(rectifier.Channel(clip.raw.back()));
    clip.gray.push_back(rectifier.Equalize(clip.green.back()));
    clip.times.push_back(sequence->frame_time_ns(i));
  }
  clip.calibration = *sequence->session().premission_calibration;
  clip.accel.cam_from_accel = sequence->session().cam_from_accel;
  clip.samples = sequence->accel();
  return clip;
}

void Resolutions(benchmark::internal::Benchmark* bench) {
  bench->Args({320, 240})->Args({640, 480})->Args({1280, 720})->Unit(benchmark::kMillisecond);
}

// Box 1: edge gradients and the linear Radon transform with its peaks.
void BM_RadonLines(benchmark::State& state) {
  const Clip& clip = OfficeClip(int(state.range(0)), int(state.range(1)));
  const LineDetectorOptions options;
  size_t i = 0, lines = 0;
  for (auto _ : state) {
    const Gradients gradients(clip.green[i], 1.0);
    const std::vector<LineSegment> found = DetectLines(gradients, options);
    lines += found.size();
    i = (i + 1) % clip.green.size();
  }
  state.counters["lines/frame"] = double(lines) / double(state.iterations());
}
BENCHMARK(BM_RadonLines)->Apply(Resolutions);

// Box 1: every snake slid and bent onto the next frame's edges (lines found untimed).
void BM_SnakeUpdate(benchmark::State& state) {
  const Clip& clip = OfficeClip(int(state.range(0)), int(state.range(1)));
  std::vector<Gradients> gradients;
  std::vector<std::vector<LineSegment>> lines;
  for (const cv::Mat& green : clip.green) {
    gradients.emplace_back(green, 1.0);
    lines.push_back(DetectLines(gradients.back(), {}));
  }
  SnakeTracker tracker;
  const Eigen::Vector2d centre(clip.calibration.cx, clip.calibration.cy);
  size_t i = 0, snakes = 0;
  for (auto _ : state) {
    if (i == 0) tracker.Reset();  // The clip starts again: no jump for the snakes.
    tracker.Update(gradients[i], lines[i], centre, clip.green[i].size());
    snakes += tracker.snakes().size();
    i = (i + 1) % clip.green.size();
  }
  state.counters["snakes/frame"] = double(snakes) / double(state.iterations());
}
BENCHMARK(BM_SnakeUpdate)->Apply(Resolutions);

// Boxes 4-5: tracks followed by pyramidal Lucas-Kanade, checked back, and replenished.
void BM_Tracking(benchmark::State& state) {
  const Clip& clip = OfficeClip(int(state.range(0)), int(state.range(1)));
  std::unique_ptr<FlowTracker> tracker;
  size_t i = 0, tracks = 0;
  for (auto _ : state) {
    if (i == 0) tracker = std::make_unique<FlowTracker>();  // No jump back in time.
    tracker->Update(clip.times[i], clip.gray[i]);
    tracks += tracker->tracks().size();
    i = (i + 1) % clip.gray.size();
  }
  state.counters["tracks/frame"] = double(tracks) / double(state.iterations());
}
BENCHMARK(BM_Tracking)->Apply(Resolutions);

// Box 6's fit: a homography by RANSAC between the tracks' positions 10 frames apart, with
// box 6's own sampling (`FitHomographyRansac`) and, for reference, cv::findHomography's.
void BM_HomographyFit(benchmark::State& state) {
  const bool ours = state.range(0) == 1;
  const Clip& clip = OfficeClip(640, 480);
  FlowTracker tracker;
  std::vector<std::pair<std::vector<cv::Point2f>, std::vector<cv::Point2f>>> pairs;
  for (size_t i = 0; i < clip.gray.size(); ++i) {
    tracker.Update(clip.times[i], clip.gray[i]);
    std::vector<cv::Point2f> from, to;
    for (const Track& track : tracker.tracks()) {
      if (const TrackPoint* before = track.FramesAgo(10)) {
        from.push_back(before->pixel);
        to.push_back(track.current());
      }
    }
    if (from.size() >= 8) pairs.emplace_back(std::move(from), std::move(to));
  }
  if (pairs.empty()) {
    state.SkipWithError("no tracks 10 frames old");
    return;
  }
  const PlaneOptions options;
  size_t i = 0, points = 0;
  for (auto _ : state) {
    if (ours) {
      std::vector<uchar> inliers;
      const auto h =
          FitHomographyRansac(pairs[i].first, pairs[i].second, options.eject_threshold_px,
                              options.ransac_iterations, kRansacConfidence, &inliers);
      benchmark::DoNotOptimize(h);
    } else {
      cv::Mat mask;
      const cv::Mat h = cv::findHomography(pairs[i].first, pairs[i].second, cv::RANSAC,
                                           options.eject_threshold_px, mask,
                                           options.ransac_iterations, kRansacConfidence);
      benchmark::DoNotOptimize(h.data);
    }
    points += pairs[i].first.size();
    i = (i + 1) % pairs.size();
  }
  state.counters["points"] = double(points) / double(state.iterations());
  state.SetLabel(ours ? "FitHomographyRansac" : "cv::findHomography");
}
BENCHMARK(BM_HomographyFit)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond);

// Box 10: the solve over a full window of material, as the pipeline hands it out.
void BM_CalibrationSolve(benchmark::State& state) {
  const Clip& clip = OfficeClip(int(state.range(0)), int(state.range(1)), 4.0);
  CalibrationPipeline pipeline(clip.calibration, clip.accel);
  const SelfCalibrationOptions options;
  // Box 7's windows are centred on the frames: readings run half of one ahead.
  const int64_t lead_ns = int64_t(0.5 * InertialOptions{}.quasi_static.window_s * 1e9);
  std::optional<CalibrationJob> last;
  size_t fed = 0;
  for (size_t i = 0; i < clip.raw.size(); ++i) {
    std::vector<SpecificForceSample> batch;
    while (fed < clip.samples.size() && clip.samples[fed].t_ns <= clip.times[i] + lead_ns) {
      batch.push_back({clip.samples[fed].t_ns, clip.samples[fed].specific_force});
      ++fed;
    }
    pipeline.AddAccel(batch);
    std::optional<CalibrationJob> job;
    pipeline.ProcessFrame(clip.times[i], clip.raw[i], &job);
    if (!job) continue;
    pipeline.Judge(*job, SelfCalibrate(job->material, job->prior, options));
    last = std::move(job);
  }
  if (!last) {
    state.SkipWithError("no attempt in the clip");
    return;
  }
  // Third argument 1: from the previous attempt's solution, as the pipeline hands it on;
  // 0: from the homographies between views.
  if (state.range(2) == 0) last->material.start.reset();
  int iterations = 0;
  for (auto _ : state) {
    const SelfCalibrationResult result = SelfCalibrate(last->material, last->prior, options);
    benchmark::DoNotOptimize(result.usable);
    iterations = result.iterations;
  }
  state.counters["views"] = double(last->view_times.size());
  state.counters["iterations"] = iterations;
}
BENCHMARK(BM_CalibrationSolve)
    ->ArgsProduct({{320}, {240}, {0, 1}})
    ->ArgsProduct({{640}, {480}, {0, 1}})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace autocal

BENCHMARK_MAIN();
