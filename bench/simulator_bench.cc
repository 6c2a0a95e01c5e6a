// Simulator speed: frames rendered per second (items_per_second, wall clock: rendering
// runs on all cores through cv::parallel_for_).
#include <map>
#include <memory>
#include <string>

#include <benchmark/benchmark.h>

#include "devices/sim/simulator.h"

namespace autocal {
namespace {

// One sequence per spec, kept for the whole run so the scene is built once.
const Sequence& SequenceFor(const std::string& spec) {
  static std::map<std::string, std::unique_ptr<Sequence>> sequences;
  auto& sequence = sequences[spec];
  if (!sequence) sequence = MakeSimulatedSequence(ParseScenarioSpec(spec));
  return *sequence;
}

// Renders consecutive frames of a walk (a new pose, and for drift new intrinsics, each).
void RenderFrames(benchmark::State& state, const std::string& spec) {
  const Sequence& sequence = SequenceFor(spec);
  size_t index = 0;
  sequence.LoadFrame(index);  // Builds the scene and the ray table.
  for (auto _ : state) {
    index = (index + 1) % sequence.frame_count();
    benchmark::DoNotOptimize(sequence.LoadFrame(index));
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel("frames/s");
}

void BM_Office320x240(benchmark::State& state) { RenderFrames(state, "office,resolution=320x240"); }
void BM_Office640x480(benchmark::State& state) { RenderFrames(state, "office"); }
void BM_Office1280x720(benchmark::State& state) {
  RenderFrames(state, "office,resolution=1280x720");
}
void BM_OfficeSonnar640x480(benchmark::State& state) { RenderFrames(state, "office,lens=sonnar"); }
// The intrinsics change every frame: every frame also rebuilds its ray table.
void BM_Drift640x480(benchmark::State& state) { RenderFrames(state, "drift"); }
void BM_Corridor640x480(benchmark::State& state) { RenderFrames(state, "corridor"); }
void BM_Outdoor640x480(benchmark::State& state) { RenderFrames(state, "outdoor"); }

void BM_PlaneLabels640x480(benchmark::State& state) {
  const Sequence& sequence = SequenceFor("office");
  size_t index = 0;
  for (auto _ : state) {
    index = (index + 1) % sequence.frame_count();
    benchmark::DoNotOptimize(sequence.LoadPlaneLabels(index));
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel("frames/s");
}

// Building a sequence: trajectory, ground truth and 60 s of 1600 Hz accelerometer samples.
void BM_MakeDriftSequence1600Hz(benchmark::State& state) {
  const Scenario scenario = ParseScenarioSpec("drift,accel_rate=1600");
  for (auto _ : state) benchmark::DoNotOptimize(MakeSimulatedSequence(scenario));
}

BENCHMARK(BM_Office320x240)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Office640x480)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Office1280x720)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_OfficeSonnar640x480)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Drift640x480)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Corridor640x480)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Outdoor640x480)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PlaneLabels640x480)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MakeDriftSequence1600Hz)->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace autocal

BENCHMARK_MAIN();
