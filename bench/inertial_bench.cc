// Time of box 7: one frame of the stage (integration, rest test, class) on the simulated
// office walk's 400 Hz readings, and one 2-second scale window.
#include <benchmark/benchmark.h>

#include <span>
#include <vector>

#include <Eigen/Geometry>

#include "devices/sim/simulator.h"
#include "pipeline/inertial.h"

namespace autocal {
namespace {

struct Walk {
  std::vector<SpecificForceSample> samples;
  std::vector<VisualPose> poses;  // The true poses (vision's scale 1).
  AccelCalibration calibration;
};

const Walk& OfficeWalk() {
  static const Walk walk = [] {
    const auto sequence = MakeSimulatedSequence(ParseScenarioSpec("office,seconds=20"));
    Walk w;
    for (const AccelSample& sample : sequence->accel()) {
      w.samples.push_back({sample.t_ns, sample.specific_force});
    }
    for (const GroundTruthFrame& truth : *sequence->ground_truth()) {
      w.poses.push_back(
          {truth.t_ns, truth.world_from_cam_rotation, truth.world_from_cam_translation});
    }
    w.calibration.cam_from_accel = sequence->session().cam_from_accel;
    return w;
  }();
  return walk;
}

void BM_InertialFrame(benchmark::State& state) {
  const Walk& walk = OfficeWalk();
  const bool with_vision = state.range(0) != 0;
  InertialStage stage(walk.calibration);
  stage.AddSamples(walk.samples);
  size_t i = 1;
  for (auto _ : state) {
    std::optional<VisualMotion> visual;
    if (with_vision) {
      visual.emplace();
      visual->cam1_from_cam0 =
          walk.poses[i].world_from_cam.conjugate() * walk.poses[i - 1].world_from_cam;
      visual->translation_direction = (walk.poses[i - 1].world_from_cam.conjugate() *
                                       (walk.poses[i].position - walk.poses[i - 1].position))
                                          .normalized();
    }
    const InertialSnapshot snapshot = stage.Process(walk.poses[i].t_ns, visual);
    benchmark::DoNotOptimize(snapshot.motion);
    // Start again once the walk is done (a new stage: time only goes forward).
    if (++i == walk.poses.size()) {
      state.PauseTiming();
      stage = InertialStage(walk.calibration);
      stage.AddSamples(walk.samples);
      i = 1;
      state.ResumeTiming();
    }
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel("items/s = frames/s");
}
BENCHMARK(BM_InertialFrame)->Arg(0)->Arg(1);

void BM_ScaleWindow(benchmark::State& state) {
  const Walk& walk = OfficeWalk();
  const std::span<const VisualPose> window(walk.poses.data() + 150, 61);
  for (auto _ : state) {
    const ScaleEstimate estimate =
        EstimateMetricScale(walk.samples, walk.calibration, window, {}, {});
    benchmark::DoNotOptimize(estimate.scale);
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel("items/s = windows/s");
}
BENCHMARK(BM_ScaleWindow);

}  // namespace
}  // namespace autocal

BENCHMARK_MAIN();
