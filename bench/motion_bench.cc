// Per-frame time of boxes 4-6 (corners, flow, planes) and of boxes 4-7 (with the
// accelerometer) on simulated office walks, on box 3's rectified image; frames are
// rendered and rectified before the timing.
#include <benchmark/benchmark.h>

#include <chrono>
#include <map>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "devices/sim/simulator.h"
#include "pipeline/inertial.h"
#include "pipeline/motion_stage.h"
#include "pipeline/rectifier.h"
#include "pipeline/stopwatch.h"

namespace autocal {
namespace {

constexpr int kFrames = 90;

struct Clip {
  std::vector<cv::Mat> frames;  // Box 3's output: green, equalized, undistorted.
  std::vector<int64_t> times;
  CameraIntrinsics camera;  // The rectified image's: no distortion.
  // Box 7's input: the accelerometer's readings, and the true camera poses standing in for
  // vision's (box 7's cost does not depend on where they come from).
  std::vector<SpecificForceSample> accel;
  std::vector<VisualPose> poses;
  AccelCalibration calibration;
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
    const GroundTruthFrame& pose = (*sequence->ground_truth())[i];
    clip.poses.push_back(
        {pose.t_ns, pose.world_from_cam_rotation, pose.world_from_cam_translation});
  }
  for (const AccelSample& sample : sequence->accel()) {
    clip.accel.push_back({sample.t_ns, sample.specific_force});
  }
  clip.calibration.cam_from_accel = sequence->session().cam_from_accel;
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

// Per-frame figures of boxes 4-7 summed over the timed frames, reported as means.
struct MotionTotals {
  double features = 0.0, flow = 0.0, planes = 0.0, refind = 0.0, inertial = 0.0, tracks = 0.0,
         found = 0.0;

  void Add(const MotionSnapshot& snapshot) {
    features += snapshot.features_ms;
    flow += snapshot.flow_ms;
    planes += snapshot.planes_ms;
    refind += snapshot.refind_ms;
    inertial += snapshot.inertial.inertial_ms;
    tracks += double(snapshot.tracks.size());
    found += double(snapshot.planes.size());
  }

  // `with_inertial`: box 7 ran too, so its time is reported.
  void Report(benchmark::State& state, bool with_inertial) const {
    const double n = double(state.iterations());
    state.counters["features_ms"] = features / n;
    state.counters["flow_ms"] = flow / n;
    state.counters["planes_ms"] = planes / n;
    state.counters["refind_ms"] = refind / n;
    if (with_inertial) state.counters["inertial_ms"] = inertial / n;
    state.counters["tracks"] = tracks / n;
    state.counters["planes"] = found / n;
    state.SetItemsProcessed(state.iterations());
    state.SetLabel("items/s = frames/s");
  }
};

void BM_MotionBoxes(benchmark::State& state) {
  const Clip& clip = OfficeClip(int(state.range(0)), int(state.range(1)));
  MotionStage stage;
  // Past the start, where there are no planes yet.
  size_t step = 0;
  for (; step < 30; ++step) {
    stage.Process(clip.times[step], clip.frames[step], clip.camera);
  }
  MotionTotals totals;
  int64_t t = clip.times[step];
  for (auto _ : state) {
    const size_t i = PingPong(step++, clip.frames.size());
    t += 33'333'333;
    totals.Add(stage.Process(t, clip.frames[i], clip.camera));
  }
  totals.Report(state, /*with_inertial=*/false);
}
BENCHMARK(BM_MotionBoxes)
    ->Args({320, 240})
    ->Args({640, 480})
    ->Args({1280, 720})
    ->Unit(benchmark::kMillisecond);

// Boxes 4-7 as the pipeline runs them: each frame through MotionStage, then box 7 with
// vision's rotation and direction of travel since the previous frame, and a metric scale
// over the last 2 s once a second. The clip plays once (box 7's time only goes forward):
// a second of start-up, then the timed frames.
constexpr int kStartupFrames = 30;
constexpr int kScaleEveryFrames = 30;
constexpr size_t kScaleWindowFrames = 61;

void BM_MotionAndInertial(benchmark::State& state) {
  const Clip& clip = OfficeClip(int(state.range(0)), int(state.range(1)));
  MotionStage motion;
  InertialStage inertial(clip.calibration);
  inertial.AddSamples(clip.accel);
  auto process = [&](size_t i) {
    MotionSnapshot snapshot = motion.Process(clip.times[i], clip.frames[i], clip.camera);
    const auto start = std::chrono::steady_clock::now();
    std::optional<VisualMotion> visual;
    if (i > 0) {
      const VisualPose& a = clip.poses[i - 1];
      const VisualPose& b = clip.poses[i];
      visual.emplace();
      visual->cam1_from_cam0 = b.world_from_cam.conjugate() * a.world_from_cam;
      visual->translation_direction =
          (a.world_from_cam.conjugate() * (b.position - a.position)).normalized();
    }
    snapshot.inertial.gravity_cam = inertial.Process(clip.times[i], visual).gravity_cam;
    if (i % kScaleEveryFrames == 0) {
      const size_t first = i + 1 > kScaleWindowFrames ? i + 1 - kScaleWindowFrames : 0;
      benchmark::DoNotOptimize(
          inertial.EstimateScale(std::span(clip.poses).subspan(first, i + 1 - first)));
    }
    snapshot.inertial.inertial_ms = MillisecondsSince(start);
    return snapshot;
  };
  size_t i = 0;
  for (; i < kStartupFrames; ++i) process(i);
  MotionTotals totals;
  for (auto _ : state) totals.Add(process(i++));
  totals.Report(state, /*with_inertial=*/true);
}
BENCHMARK(BM_MotionAndInertial)
    ->Args({320, 240})
    ->Args({640, 480})
    ->Args({1280, 720})
    ->Iterations(kFrames - kStartupFrames)
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace autocal

BENCHMARK_MAIN();
