// What the workbench's GUI thread spends. `VideoViewPaint`: one paint of the video view (a
// 640x480 frame of the simulated office walk, scaled into 1000x750, with the pipeline's own
// overlay of that frame, boards included) by overlay layers. `FollowPipeline`: the whole
// window following boxes 1-10 over an 8 s 640x480 recording (Playback › Follow the
// Pipeline, snakes, tracks and planes on), the GUI thread's CPU per distinct frame shown;
// 33 ms leaves room for the 30 frames a second the workbench issue asks for.
// `CalibrationPlotsRedraw`: the calibration plots over two hours of history.
// `AccelPlotLiveUpdate`: the accelerometer plot fed as a live source feeds it. Run it with
// a display (xvfb-run) or QT_QPA_PLATFORM=offscreen.
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
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "devices/recording_writer.h"
#include "devices/sequence.h"
#include "devices/sim/simulator.h"
#include "pipeline/calibration_history.h"
#include "pipeline/calibration_pipeline.h"
#include "pipeline/history_store.h"
#include "pipeline/overlay_geometry.h"
#include "widgets/accel_plot.h"
#include "widgets/calibration_plots.h"
#include "widgets/calibration_series.h"
#include "widgets/image_convert.h"
#include "widgets/main_window.h"
#include "widgets/pipeline_controller.h"
#include "widgets/playback_controller.h"
#include "widgets/video_view.h"

namespace autocal {
namespace {

// 2.5 s into the walk: lines, snakes, tracks, planes, and the boards of the first attempt.
constexpr int kOverlayFrame = 75;

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
    std::vector<std::shared_ptr<const AttemptOutcome>> attempts;
    for (int i = 0; i <= kOverlayFrame; ++i) {
      const cv::Mat raw = sequence->LoadFrame(i);
      auto snapshot =
          std::make_shared<const FrameSnapshot>(pipeline.Process(sequence->frame_time_ns(i), raw));
      if (snapshot->attempt) attempts.push_back(snapshot->attempt);
      if (i < kOverlayFrame) continue;
      result.image = MatToQImage(raw);
      result.overlays.index = i;
      result.overlays.raw = std::make_shared<const OverlayGeometry>(
          MakeOverlayGeometry(*snapshot, PlaceNewestBoards(attempts, snapshot->t_ns),
                              pipeline.options().board, OverlaySpace::kRaw));
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
  state.counters["boards"] = static_cast<double>(geometry.boards.size());
}
BENCHMARK_CAPTURE(VideoViewPaint, no_layers, OverlayLayers())->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(VideoViewPaint, snakes_tracks_planes,
                  OverlayLayers(OverlayLayer::kSnakes | OverlayLayer::kTracks |
                                OverlayLayer::kPlanes))
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(VideoViewPaint, defaults, kDefaultOverlayLayers)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(VideoViewPaint, tracks, OverlayLayers(OverlayLayer::kTracks))
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(VideoViewPaint, all_layers,
                  OverlayLayers(OverlayLayer::kLines) | OverlayLayer::kSnakes |
                      OverlayLayer::kTracks | OverlayLayer::kPlanes | OverlayLayer::kBoards |
                      OverlayLayer::kGravity)
    ->Unit(benchmark::kMillisecond);

// The calibration plots over two hours of history (an attempt a second, fx jittered by
// 0.3 px with an outlier every 97): one redraw of all ten charts and a repaint, as when
// the cursor jumps; 66 ms would be two frames at 30 Hz.
void CalibrationPlotsRedraw(benchmark::State& state) {
  constexpr int kAttempts = 2 * 3600;
  constexpr int64_t kSecondNs = 1'000'000'000;
  CameraIntrinsics premission;
  premission.width = 640;
  premission.height = 480;
  premission.fx = premission.fy = 500.0;
  premission.cx = 320.0;
  premission.cy = 240.0;
  CalibrationHistory history(premission);
  std::mt19937 random(3);
  std::normal_distribution<double> normal;
  for (int i = 0; i < kAttempts; ++i) {
    SelfCalibrationResult result;
    result.usable = true;
    result.estimate = premission;
    result.estimate.fx += 0.3 * normal(random) + (i % 97 == 0 ? 30.0 : 0.0);
    result.estimate.cx += 0.5 * normal(random);
    result.covariance = Eigen::MatrixXd::Identity(3, 3) * 0.25;
    result.free_parameters = {kFx, kFy, kCx};
    result.rms_px = 0.4;
    history.Judge(i * kSecondNs, result);
  }
  StoredHistory stored;
  stored.premission = premission;
  stored.attempts = history.attempts();
  stored.alarms = history.alarms();
  stored.regimes = history.regimes();
  CalibrationPlots plots;
  plots.resize(1400, 1000);
  plots.show();
  plots.setSeries(std::make_shared<CalibrationSeries>(MakeCalibrationSeries(std::move(stored))));
  plots.redrawNow();
  int step = 0;
  for (auto _ : state) {
    plots.setCursorTime(60.0 * (++step % 120));
    plots.redrawNow();
    plots.repaint();
  }
}
BENCHMARK(CalibrationPlotsRedraw)->Unit(benchmark::kMillisecond);

// The accelerometer plot as a live source feeds it (MainWindow::showLiveAccel): the last
// minute of 400 Hz samples, new ones each time, redrawn whole and painted at 1400x300.
void AccelPlotLiveUpdate(benchmark::State& state) {
  constexpr double kRateHz = 400.0;
  constexpr int kMinute = static_cast<int>(60 * kRateHz);
  std::vector<AccelSample> stream;
  for (int i = 0; i < 2 * kMinute; ++i) {
    const double t = i / kRateHz;
    stream.push_back({static_cast<int64_t>(t * 1e9),
                      {std::sin(7.0 * t), 0.3 * std::cos(3.0 * t), 9.81 + std::sin(13.0 * t)}});
  }
  AccelPlot plot;
  plot.resize(1400, 300);
  plot.show();
  QImage target(plot.size(), QImage::Format_ARGB32_Premultiplied);
  int newest = kMinute;
  for (auto _ : state) {
    newest = newest % kMinute + kMinute;  // A window sliding over the stream, 1/15 s a step.
    newest += static_cast<int>(kRateHz / 15);
    const std::vector<AccelSample> minute(stream.begin() + (newest - kMinute),
                                          stream.begin() + newest);
    plot.setSamples(minute, minute.front().t_ns, 60.0);
    plot.setCursorTime(60.0);
    static_cast<QWidget&>(plot).render(&target);  // QGraphicsView hides it.
    benchmark::DoNotOptimize(target.constBits());
  }
}
BENCHMARK(AccelPlotLiveUpdate)->Unit(benchmark::kMillisecond);

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
    if (!WaitFor([&] { return !pipeline.isRunning(); }, 600'000)) {
      state.SkipWithError("the pipeline did not finish in 10 minutes");
      return;
    }
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
