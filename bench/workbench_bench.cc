// What the workbench's GUI thread spends a frame. `VideoViewPaint`: one paint of the video
// view (a 640x480 frame of the simulated office walk, scaled into 1000x750, with box 1-6's
// real overlay of that frame) by overlay layers. `FollowPipeline`: the whole window following
// boxes 1-10 over an 8 s 640x480 recording (Playback › Follow the Pipeline, snakes, tracks
// and planes on), the GUI thread's CPU per distinct frame shown; 33 ms leaves room for the
// 30 frames a second the workbench issue asks for. Run it with a display (xvfb-run) or
// QT_QPA_PLATFORM=offscreen.
#include <benchmark/benchmark.h>
#include <time.h>

#include <QAction>
#include <QApplication>
#include <QCoreApplication>
#include <QElapsedTimer>
#include <QEventLoop>
#include <QImage>
#include <QSettings>
#include <QTemporaryDir>
#include <QTimer>
#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "devices/recording_writer.h"
#include "devices/sim/simulator.h"
#include "pipeline/calibration_pipeline.h"
#include "pipeline/overlay_geometry.h"
#include "widgets/image_convert.h"
#include "widgets/main_window.h"
#include "widgets/pipeline_controller.h"
#include "widgets/playback_controller.h"
#include "widgets/video_view.h"

namespace autocal {
namespace {

constexpr int kOverlayFrame = 60;  // 2 s into the walk: lines, snakes, tracks and planes.

struct OverlaidFrame {
  QImage image;
  FrameOverlays overlays;
};

// Boxes 1-10 over the walk's first frames, from the recording's own start calibration.
const OverlaidFrame& OfficeFrame() {
  static const OverlaidFrame frame = [] {
    const auto sequence = MakeSimulatedSequence(ParseScenarioSpec("office,resolution=640x480"));
    AccelCalibration accel;
    accel.cam_from_accel = sequence->session().cam_from_accel;
    CalibrationPipeline pipeline(*sequence->session().premission_calibration, accel);
    std::vector<SpecificForceSample> samples;
    for (const AccelSample& sample : sequence->accel()) {
      samples.push_back({sample.t_ns, sample.specific_force});
    }
    pipeline.AddAccel(samples);
    OverlaidFrame result;
    for (int i = 0; i <= kOverlayFrame; ++i) {
      const cv::Mat raw = sequence->LoadFrame(i);
      auto snapshot =
          std::make_shared<const FrameSnapshot>(pipeline.Process(sequence->frame_time_ns(i), raw));
      if (i < kOverlayFrame) continue;
      result.image = MatToQImage(raw);
      result.overlays.index = i;
      result.overlays.raw = std::make_shared<const OverlayGeometry>(
          MakeOverlayGeometry(*snapshot, {}, pipeline.options().board, OverlaySpace::kRaw));
      result.overlays.snapshot = std::move(snapshot);
    }
    return result;
  }();
  return frame;
}

void VideoViewPaint(benchmark::State& state, OverlayLayers layers) {
  const OverlaidFrame& frame = OfficeFrame();
  VideoView view;
  view.resize(1000, 750);
  view.setLayers(layers);
  view.setFrame(frame.overlays.index, frame.image);
  view.setOverlays(frame.overlays);
  QImage target(view.size(), QImage::Format_ARGB32_Premultiplied);
  for (auto _ : state) {
    view.render(&target);
    benchmark::DoNotOptimize(target.constBits());
  }
  const OverlayGeometry& geometry = *frame.overlays.raw;
  state.counters["tracks"] = static_cast<double>(geometry.tracks.size());
  state.counters["snakes"] = static_cast<double>(geometry.snakes.size());
  state.counters["planes"] = static_cast<double>(geometry.planes.size());
}
BENCHMARK_CAPTURE(VideoViewPaint, no_layers, OverlayLayers())->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(VideoViewPaint, snakes_tracks_planes,
                  OverlayLayers(OverlayLayer::kSnakes | OverlayLayer::kTracks |
                                OverlayLayer::kPlanes))
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(VideoViewPaint, tracks, OverlayLayers(OverlayLayer::kTracks))
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(VideoViewPaint, all_layers,
                  OverlayLayers(OverlayLayer::kLines) | OverlayLayer::kSnakes |
                      OverlayLayer::kTracks | OverlayLayer::kPlanes | OverlayLayer::kBoards |
                      OverlayLayer::kGravity)
    ->Unit(benchmark::kMillisecond);

double ThreadCpuSeconds() {
  timespec now;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return double(now.tv_sec) + double(now.tv_nsec) * 1e-9;
}

// Spins the event loop until `done` or `timeout_ms`; false on the timeout.
template <typename Done>
bool WaitFor(Done done, int timeout_ms) {
  QElapsedTimer clock;
  clock.start();
  while (!done()) {
    if (clock.elapsed() > timeout_ms) return false;
    QEventLoop loop;  // Waits 20 ms for events; processEvents alone would spin.
    QTimer::singleShot(20, &loop, &QEventLoop::quit);
    loop.exec();
  }
  return true;
}

void FollowPipeline(benchmark::State& state) {
  QTemporaryDir dir;
  const std::string folder = dir.filePath(QStringLiteral("vga")).toStdString();
  const auto recording =
      MakeSimulatedSequence(ParseScenarioSpec("office,seconds=8,resolution=640x480"));
  if (!WriteSequence(*recording, folder)) {
    state.SkipWithError("could not write the recording");
    return;
  }
  for (auto _ : state) {
    MainWindow window;
    window.resize(1400, 900);
    window.show();
    for (const OverlayLayer layer : kAllOverlayLayers) {
      window.overlayAction(layer)->setChecked(layer == OverlayLayer::kSnakes ||
                                              layer == OverlayLayer::kTracks ||
                                              layer == OverlayLayer::kPlanes);
    }
    window.followPipelineAction()->setChecked(true);
    window.open(QString::fromStdString(folder));
    PipelineController& pipeline = *window.pipelineController();
    // From the pipeline's 10th frame to its end, as gui_overlay_test follows it.
    if (!WaitFor([&] { return pipeline.framesDone() >= 10; }, 120'000)) {
      state.SkipWithError("the pipeline did not start");
      return;
    }
    VideoView& view = *window.videoView();
    QElapsedTimer clock;
    clock.start();
    const double cpu_before = ThreadCpuSeconds();
    const uint64_t painted_before = view.framesPainted();
    const int done_before = pipeline.framesDone();
    WaitFor([&] { return !pipeline.isRunning(); }, 600'000);
    const double seconds = clock.elapsed() * 1e-3;
    const double shown = double(view.framesPainted() - painted_before);
    state.SetIterationTime(seconds);
    state.counters["gui_ms_per_frame"] =
        1e3 * (ThreadCpuSeconds() - cpu_before) / std::max(1.0, shown);
    state.counters["display_fps"] = shown / seconds;
    state.counters["pipeline_fps"] = double(pipeline.framesDone() - done_before) / seconds;
  }
}
BENCHMARK(FollowPipeline)->UseManualTime()->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace
}  // namespace autocal

int main(int argc, char** argv) {
  QTemporaryDir settings;  // The window's settings stay out of the user's.
  QSettings::setDefaultFormat(QSettings::IniFormat);
  QSettings::setPath(QSettings::IniFormat, QSettings::UserScope, settings.path());
  QCoreApplication::setOrganizationName(QStringLiteral("autocal-bench"));
  QApplication app(argc, argv);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
