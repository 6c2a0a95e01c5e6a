// Per-frame time of boxes 1-3 (lines, snakes, rectification) on simulated office frames
// through the sonnar lens and on a real photograph panned across, of one distortion
// estimate over the pooled snakes, and of boxes 1-2 in rounds on a real still image.
#include <benchmark/benchmark.h>

#include <map>
#include <tuple>
#include <utility>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "devices/sim/simulator.h"
#include "pipeline/lens_stage.h"

namespace autocal {
namespace {

struct Clip {
  std::vector<cv::Mat> frames;
  std::vector<int64_t> times;
  CameraIntrinsics calibration;
};

// `seconds` of walking, rendered once per resolution.
const Clip& OfficeClip(int width, int height, int seconds = 2) {
  static std::map<std::tuple<int, int, int>, Clip> clips;
  Clip& clip = clips[{width, height, seconds}];
  if (!clip.frames.empty()) return clip;
  Scenario scenario = LoadScenario("office");
  ApplyScenarioOverride(&scenario, "lens", "sonnar");
  ApplyScenarioOverride(&scenario, "resolution",
                        std::to_string(width) + "x" + std::to_string(height));
  ApplyScenarioOverride(&scenario, "seconds", std::to_string(seconds));
  const auto sequence = MakeSimulatedSequence(scenario);
  for (size_t i = 0; i < sequence->frame_count(); ++i) {
    clip.frames.push_back(sequence->LoadFrame(i));
    clip.times.push_back(sequence->frame_time_ns(i));
  }
  clip.calibration = sequence->session().premission_calibration.value();
  return clip;
}

void BM_LensBoxes(benchmark::State& state) {
  const Clip& clip = OfficeClip(int(state.range(0)), int(state.range(1)));
  LensOptions options;
  options.estimate_every_frames = 1 << 30;  // Box 2's solve is timed on its own below.
  LensStage stage(options);
  size_t i = 0;
  cv::Mat rectified;
  for (auto _ : state) {
    const LensSnapshot snapshot =
        stage.Process(clip.times[i], clip.frames[i], clip.calibration, &rectified);
    benchmark::DoNotOptimize(snapshot.snakes.data());
    i = (i + 1) % clip.frames.size();
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel("items/s = frames/s");
}
BENCHMARK(BM_LensBoxes)
    ->Args({320, 240})
    ->Args({640, 480})
    ->Args({1280, 720})
    ->Unit(benchmark::kMillisecond);

// OpenCV's real photograph of a building (Debian's opencv-doc), scaled to 1.25 times
// `width` x `height` and panned across in 30 frames of that size: real edges, texture and
// JPEG noise. Empty when the photograph is not installed.
const Clip& BuildingPan(int width, int height) {
  static std::map<std::pair<int, int>, Clip> clips;
  Clip& clip = clips[{width, height}];
  if (!clip.frames.empty()) return clip;
  const cv::Mat photo = cv::imread("/usr/share/doc/opencv-doc/examples/data/building.jpg");
  if (photo.empty()) return clip;
  cv::Mat large;
  cv::resize(photo, large, {width * 5 / 4, height * 5 / 4}, 0, 0, cv::INTER_AREA);
  constexpr int kFrames = 30;
  for (int i = 0; i < kFrames; ++i) {
    const int x = (large.cols - width) * i / (kFrames - 1);
    const int y = (large.rows - height) * (kFrames - 1 - i) / (kFrames - 1);
    clip.frames.push_back(large(cv::Rect(x, y, width, height)).clone());
    clip.times.push_back(int64_t(i) * 33'333'333);
  }
  clip.calibration.width = width;
  clip.calibration.height = height;
  clip.calibration.fx = clip.calibration.fy = 0.8 * width;
  clip.calibration.cx = 0.5 * (width - 1);
  clip.calibration.cy = 0.5 * (height - 1);
  return clip;
}

// Boxes 1-3 a frame on the real photograph, as a live run does them (box 2's solve, on its
// worker in a live run, is left out as above).
void BM_LensBoxesRealFrames(benchmark::State& state) {
  const Clip& clip = BuildingPan(int(state.range(0)), int(state.range(1)));
  if (clip.frames.empty()) {
    state.SkipWithError("building.jpg is missing: apt-get install opencv-doc");
    return;
  }
  LensOptions options;
  options.estimate_every_frames = 1 << 30;
  LensStage stage(options);
  size_t i = 0;
  cv::Mat rectified;
  for (auto _ : state) {
    const LensSnapshot snapshot =
        stage.Process(clip.times[i], clip.frames[i], clip.calibration, &rectified);
    benchmark::DoNotOptimize(snapshot.snakes.data());
    i = (i + 1) % clip.frames.size();
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel("items/s = frames/s");
}
BENCHMARK(BM_LensBoxesRealFrames)
    ->Args({640, 480})
    ->Args({1280, 720})
    ->Unit(benchmark::kMillisecond);

// Boxes 1-2 on one real still image, in rounds through the distortion found so far
// (LensStage::EstimateFromStills, as `autocal distortion` and `run --stills` do it).
void BM_StillRounds(benchmark::State& state) {
  const Clip& clip = BuildingPan(int(state.range(0)), int(state.range(1)));
  if (clip.frames.empty()) {
    state.SkipWithError("building.jpg is missing: apt-get install opencv-doc");
    return;
  }
  int rounds = 0;
  for (auto _ : state) {
    LensStage stage;
    const LensStage::StillsResult result =
        stage.EstimateFromStills({clip.frames.front()}, clip.calibration);
    rounds = result.rounds;
    benchmark::DoNotOptimize(result.distortion.estimate.k1);
  }
  state.counters["rounds"] = rounds;
}
BENCHMARK(BM_StillRounds)->Args({640, 480})->Args({1280, 720})->Unit(benchmark::kMillisecond);

// One distortion estimate after 10 s of the walk at 640x480, starting from no distortion:
// over the whole pool, box 10's plumb-line material and box 2's by default (argument 0), or
// over the newest 4 shapes of each cell and orientation (argument 1, `estimate_per_cell`).
void BM_DistortionEstimate(benchmark::State& state) {
  const Clip& clip = OfficeClip(640, 480, 10);
  LensOptions options;
  options.estimate_every_frames = 1 << 30;
  LensStage stage(options);
  for (size_t i = 0; i < clip.frames.size(); ++i) {
    stage.Process(clip.times[i], clip.frames[i], clip.calibration);
  }
  const std::vector<LineObservation> shapes =
      state.range(0) ? stage.NewestShapes(4) : stage.PooledShapes();
  CameraIntrinsics start = clip.calibration;
  start.k1 = start.k2 = 0.0;
  for (auto _ : state) {
    const PlumbLineResult result = EstimateDistortion(shapes, start, options.plumb_line);
    benchmark::DoNotOptimize(result.estimate.k1);
  }
  state.counters["shapes"] = double(shapes.size());
}
BENCHMARK(BM_DistortionEstimate)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace autocal

BENCHMARK_MAIN();
