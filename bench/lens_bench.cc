// Per-frame time of boxes 1-3 (lines, snakes, rectification) on simulated office frames
// through the sonnar lens, and of one distortion estimate over the pooled snakes.
#include <benchmark/benchmark.h>

#include <map>
#include <tuple>
#include <utility>
#include <vector>

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
