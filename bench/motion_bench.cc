// Per-frame time of boxes 4-6 (corners, flow, planes) on simulated office walks, on box
// 3's rectified image; frames are rendered and rectified before the timing.
#include <benchmark/benchmark.h>

#include <map>
#include <utility>
#include <vector>

#include "devices/sim/simulator.h"
#include "pipeline/motion_stage.h"
#include "pipeline/rectifier.h"

namespace autocal {
namespace {

constexpr int kFrames = 90;

struct Clip {
  std::vector<cv::Mat> frames;  // Box 3's output: green, equalized, undistorted.
  std::vector<int64_t> times;
  CameraIntrinsics camera;  // The rectified image's: no distortion.
};

// Three seconds of walking, rendered once per resolution.
const Clip& OfficeClip(int width, int height) {
  static std::map<std::pair<int, int>, Clip> clips;
  Clip& clip = clips[{width, height}];
  if (!clip.frames.empty()) return clip;
  Scenario scenario = LoadScenario("office");
  ApplyScenarioOverride(&scenario, "resolution",
                        std::to_string(width) + "x" + std::to_string(height));
  ApplyScenarioOverride(&scenario, "seconds", std::to_string(kFrames / scenario.fps));
  const auto sequence = MakeSimulatedSequence(scenario);
  Rectifier rectifier;
  for (size_t i = 0; i < sequence->frame_count(); ++i) {
    const CameraIntrinsics& truth = (*sequence->ground_truth())[i].intrinsics;
    clip.frames.push_back(rectifier.Geometry(sequence->LoadFrame(i), truth));
    clip.times.push_back(sequence->frame_time_ns(i));
  }
  clip.camera = sequence->ground_truth()->front().intrinsics;
  clip.camera.k1 = clip.camera.k2 = clip.camera.p1 = clip.camera.p2 = clip.camera.k3 = 0.0;
  return clip;
}

// The clip played forward and back again, so the walk never jumps.
size_t PingPong(size_t step, size_t frames) {
  const size_t period = 2 * (frames - 1);
  const size_t k = step % period;
  return k < frames ? k : period - k;
}

void BM_MotionBoxes(benchmark::State& state) {
  const Clip& clip = OfficeClip(int(state.range(0)), int(state.range(1)));
  MotionStage stage;
  // Past the start, where there are no planes yet.
  size_t step = 0;
  for (; step < 30; ++step) {
    stage.Process(clip.times[step], clip.frames[step], clip.camera);
  }
  double features = 0.0, flow = 0.0, planes = 0.0, tracks = 0.0, found = 0.0;
  int64_t t = clip.times[step];
  for (auto _ : state) {
    const size_t i = PingPong(step++, clip.frames.size());
    t += 33'333'333;
    const MotionSnapshot snapshot = stage.Process(t, clip.frames[i], clip.camera);
    features += snapshot.features_ms;
    flow += snapshot.flow_ms;
    planes += snapshot.planes_ms;
    tracks += snapshot.tracks.size();
    found += snapshot.planes.size();
  }
  const double n = double(state.iterations());
  state.counters["features_ms"] = features / n;
  state.counters["flow_ms"] = flow / n;
  state.counters["planes_ms"] = planes / n;
  state.counters["tracks"] = tracks / n;
  state.counters["planes"] = found / n;
  state.SetItemsProcessed(state.iterations());
  state.SetLabel("items/s = frames/s");
}
BENCHMARK(BM_MotionBoxes)
    ->Args({320, 240})
    ->Args({640, 480})
    ->Args({1280, 720})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace autocal

BENCHMARK_MAIN();
