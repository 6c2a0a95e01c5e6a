// The workbench in a real window (run under Xvfb): playback, seeking, stepping, the plot's
// cursor, what the video view shows, error reporting and settings.
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <QAction>
#include <QComboBox>
#include <QDockWidget>
#include <QDoubleSpinBox>
#include <QElapsedTimer>
#include <QFile>
#include <QImage>
#include <QLabel>
#include <QLineEdit>
#include <QMessageBox>
#include <QPlainTextEdit>
#include <QSettings>
#include <QSignalSpy>
#include <QSlider>
#include <QStatusBar>
#include <QTableWidget>
#include <QTemporaryDir>
#include <QWheelEvent>
#include <QtTest>
#include <opencv2/core.hpp>

#include "devices/recording_writer.h"
#include "devices/sequence.h"
#include "devices/session_io.h"
#include "pipeline/calibration_io.h"
#include "tests/gui/screenshot.h"
#include "widgets/accel_plot.h"
#include "widgets/elided_label.h"
#include "widgets/frame_loader.h"
#include "widgets/image_convert.h"
#include "widgets/main_window.h"
#include "widgets/pipeline_controller.h"
#include "widgets/playback_controller.h"
#include "widgets/plot_decimation.h"
#include "widgets/threshold_panel.h"
#include "widgets/timing_table.h"
#include "widgets/video_view.h"

namespace autocal {
namespace {

const QString kSimSource = QStringLiteral("sim:office,seconds=3,resolution=320x240");
// Simulated frames can take a while on a loaded machine.
constexpr int kOpenTimeoutMs = 60000;
constexpr int kFrameTimeoutMs = 20000;

// Mean absolute difference (grey levels, over channels) between what `view` shows and the
// BGR `frame`, sampled at pixel centres of the frame mapped into the view. With
// `swap_red_blue` the frame's red and blue are exchanged first.
double ShownDifference(VideoView& view, const cv::Mat& frame, bool swap_red_blue = false) {
  const QImage shown = view.grab().toImage().convertToFormat(QImage::Format_RGB32);
  const QTransform to_view = view.imageToWidget();
  double sum = 0.0;
  int count = 0;
  for (int v = 6; v < frame.rows - 6; v += 9) {
    for (int u = 6; u < frame.cols - 6; u += 9) {
      const QPointF p = to_view.map(QPointF(u, v));
      const QRgb got = shown.pixel(static_cast<int>(p.x()), static_cast<int>(p.y()));
      const cv::Vec3b bgr = frame.at<cv::Vec3b>(v, u);
      const int red = swap_red_blue ? bgr[0] : bgr[2];
      const int blue = swap_red_blue ? bgr[2] : bgr[0];
      sum +=
          std::abs(qRed(got) - red) + std::abs(qGreen(got) - bgr[1]) + std::abs(qBlue(got) - blue);
      count += 3;
    }
  }
  return count > 0 ? sum / count : 1e9;
}

// The frame nearest to `seconds` after the recording's start, found independently of
// the controller.
int NearestFrame(const Sequence& sequence, double seconds) {
  const double t = static_cast<double>(RecordingStartNs(sequence)) + seconds * 1e9;
  int best = 0;
  for (size_t i = 0; i < sequence.frame_count(); ++i) {
    if (std::abs(static_cast<double>(sequence.frame_time_ns(i)) - t) <
        std::abs(static_cast<double>(sequence.frame_time_ns(best)) - t)) {
      best = static_cast<int>(i);
    }
  }
  return best;
}

// kSimSource as rendered, written as a native recording into a temporary folder.
struct SimRecording {
  QTemporaryDir dir;
  QString folder = dir.filePath(QStringLiteral("recording"));
  std::unique_ptr<Sequence> simulated = OpenSequence(kSimSource.toStdString());
  bool written = dir.isValid() && WriteSequence(*simulated, folder.toStdString());
};

// Frames whose red channel is their index, slow to decode; counts the decodes. Frame 7
// cannot be read.
class SlowSequence : public Sequence {
 public:
  std::string Describe() const override { return "slow test sequence"; }
  const SessionInfo& session() const override { return session_; }
  size_t frame_count() const override { return 100; }
  int64_t frame_time_ns(size_t index) const override {
    return static_cast<int64_t>(index) * 10'000'000;
  }
  cv::Mat LoadFrame(size_t index) const override {
    ++loads;
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    if (index == kDamagedFrame) throw std::runtime_error("frame 7 is damaged");
    return cv::Mat(8, 16, CV_8UC3, cv::Scalar(0, 0, static_cast<double>(index)));
  }
  const std::vector<AccelSample>& accel() const override { return accel_; }
  const std::vector<std::string>& warnings() const override { return warnings_; }

  static constexpr size_t kDamagedFrame = 7;
  mutable std::atomic<int> loads{0};

 private:
  SessionInfo session_;
  std::vector<AccelSample> accel_;
  std::vector<std::string> warnings_;
};

}  // namespace

// ExpectShown, and stop the test at its first failure.
#define EXPECT_SHOWN(window, index)   \
  do {                                \
    ExpectShown(window, index);       \
    if (QTest::currentTestFailed()) { \
      return;                         \
    }                                 \
  } while (false)

class WorkbenchTest : public QObject {
  Q_OBJECT

 private slots:
  void initTestCase();
  void init();
  void convertsBgrFramesWithPaddedRows();
  void decimationKeepsPeaks();
  void controllerPacesByTimestamps();
  void loaderDropsStaleRequests();
  void playsSeeksAndSteps();
  void opensRecordingFolder();
  void damagedFirstFrameStillPlays();
  void badPathKeepsRecordingOpen();
  void settingsPersist();
  void screenshotIsNotBlank();
  void statusTextFitsAtDefaultSize();
  void showsBox2sVerdictOnTheLens();
  void timingDockShowsTheRunsBoxTimes();
  void runsFromThePremissionCalibrationGiven();
  void takesTheRecordingsRollingShutter();
  void reopeningHidesTheLastPicture();

 private:
  // A shown main window with `source` open and its first frame on screen.
  // `before_open` may connect to the window before the source is opened.
  std::unique_ptr<MainWindow> OpenWindow(const QString& source,
                                         const std::function<void(MainWindow&)>& before_open = {});
  // Waits until `window` shows frame `index`, then checks its pixels against the frame.
  void ExpectShown(const MainWindow& window, int index);

  QTemporaryDir settings_dir_;
};

void WorkbenchTest::initTestCase() {
  // Settings go to a temporary folder, never to the user's.
  QVERIFY(settings_dir_.isValid());
  QSettings::setDefaultFormat(QSettings::IniFormat);
  QSettings::setPath(QSettings::IniFormat, QSettings::UserScope, settings_dir_.path());
  QCoreApplication::setOrganizationName(QStringLiteral("autocal-test"));
  QCoreApplication::setApplicationName(QStringLiteral("workbench_test"));
}

// Every test starts from the default settings.
void WorkbenchTest::init() { QSettings().clear(); }

std::unique_ptr<MainWindow> WorkbenchTest::OpenWindow(
    const QString& source, const std::function<void(MainWindow&)>& before_open) {
  auto window = std::make_unique<MainWindow>();
  // The frames as decoded: the overlay layers on by default (gui_overlay_test) are off.
  for (const OverlayLayer layer : kAllOverlayLayers) window->overlayAction(layer)->setChecked(false);
  window->resize(1200, 800);
  window->show();
  window->activateWindow();  // Shortcuts only reach the active window.
  if (!QTest::qWaitForWindowActive(window.get())) return nullptr;
  QSignalSpy opened(window.get(), &MainWindow::opened);
  if (before_open) before_open(*window);
  window->open(source);
  if (!opened.wait(kOpenTimeoutMs) || window->sequence() == nullptr) return nullptr;
  if (!QTest::qWaitFor([&] { return window->videoView()->frameIndex() >= 0; }, kFrameTimeoutMs)) {
    return nullptr;
  }
  return window;
}

void WorkbenchTest::ExpectShown(const MainWindow& window, int index) {
  QTRY_COMPARE_WITH_TIMEOUT(window.videoView()->frameIndex(), index, kFrameTimeoutMs);
  const Sequence& sequence = *window.sequence();
  const cv::Mat expected = sequence.LoadFrame(static_cast<size_t>(index));
  QCOMPARE(window.videoView()->image().size(), QSize(expected.cols, expected.rows));
  const double right = ShownDifference(*window.videoView(), expected);
  // The comparison must be able to tell: another frame and swapped colours differ more.
  const int other_index = (index + static_cast<int>(sequence.frame_count()) / 2) %
                          static_cast<int>(sequence.frame_count());
  const double other =
      ShownDifference(*window.videoView(), sequence.LoadFrame(static_cast<size_t>(other_index)));
  const double swapped = ShownDifference(*window.videoView(), expected, true);
  qInfo("frame %d: difference %.2f, to frame %d %.2f, with red/blue swapped %.2f", index, right,
        other_index, other, swapped);
  QVERIFY2(right < 6.0, qPrintable(QStringLiteral("shown frame differs by %1").arg(right)));
  QVERIFY(other > right + 6.0);
  QVERIFY(swapped > right + 2.0);
}

void WorkbenchTest::convertsBgrFramesWithPaddedRows() {
  // 5 pixels of 3 bytes: QImage pads each row to 16 bytes, cv::Mat does not.
  cv::Mat bgr(3, 5, CV_8UC3);
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 5; ++x) bgr.at<cv::Vec3b>(y, x) = cv::Vec3b(x * 50, y * 100, 7);
  }
  const QImage image = MatToQImage(bgr);
  bgr.setTo(cv::Scalar::all(0));  // The QImage must own a copy.
  QCOMPARE(image.size(), QSize(5, 3));
  QCOMPARE(image.format(), QImage::Format_RGB888);
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 5; ++x) {
      QCOMPARE(image.pixel(x, y), qRgb(7, y * 100, x * 50));
    }
  }

  cv::Mat grey(2, 3, CV_8UC1);
  for (int i = 0; i < 6; ++i) grey.data[i] = static_cast<uchar>(i * 40);
  const QImage grey_image = MatToQImage(grey);
  QCOMPARE(grey_image.pixel(2, 1), qRgb(200, 200, 200));

  const cv::Mat bgra(1, 1, CV_8UC4, cv::Scalar(10, 20, 30, 255));
  QCOMPARE(MatToQImage(bgra).pixel(0, 0), qRgba(30, 20, 10, 255));

  QVERIFY(MatToQImage(cv::Mat()).isNull());
  QVERIFY(MatToQImage(cv::Mat(2, 2, CV_32FC1)).isNull());
}

void WorkbenchTest::decimationKeepsPeaks() {
  std::vector<double> t(100000), v(100000);
  for (size_t i = 0; i < t.size(); ++i) {
    t[i] = static_cast<double>(i) * 1e-3;
    v[i] = std::sin(t[i]);
  }
  v[54321] = 50.0;
  v[77777] = -40.0;

  const SampleRange range = VisibleRange(t, 10.0, 90.0);
  QCOMPARE(range.begin, size_t{9999});  // One sample before the window.
  QCOMPARE(range.end, size_t{90002});   // One after.

  const QVector<QPointF> points = DecimateMinMax(t, v, range, 400);
  QVERIFY(points.size() <= 800);
  QVERIFY(points.size() >= 400);
  double lo = 0.0, hi = 0.0;
  for (int i = 0; i < points.size(); ++i) {
    if (i > 0) QVERIFY(points[i].x() > points[i - 1].x());
    lo = std::min(lo, points[i].y());
    hi = std::max(hi, points[i].y());
  }
  QCOMPARE(hi, 50.0);
  QCOMPARE(lo, -40.0);
  QCOMPARE(points.front().x(), t[range.begin]);
  QCOMPARE(points.back().x(), t[range.end - 1]);

  // Few samples: all of them.
  QCOMPARE(DecimateMinMax(t, v, {0, 10}, 400).size(), 10);
}

void WorkbenchTest::controllerPacesByTimestamps() {
  constexpr int kFrames = 200;
  constexpr int64_t kStart = 5'000'000'000;
  constexpr int64_t kStep = 20'000'000;  // 50 Hz.
  std::vector<int64_t> times(kFrames);
  for (int i = 0; i < kFrames; ++i) times[static_cast<size_t>(i)] = kStart + i * kStep;

  PlaybackController playback;
  QSignalSpy frames(&playback, &PlaybackController::frameChanged);
  QSignalSpy seconds(&playback, &PlaybackController::timeChanged);
  playback.setTimeline(times, kStart - 100'000'000);  // Accelerometer starts 0.1 s earlier.
  QCOMPARE(playback.frameIndex(), 0);
  QCOMPARE(frames.count(), 1);
  QCOMPARE(seconds.takeLast().at(0).toDouble(), 0.1);

  QCOMPARE(playback.frameAtTime(0.1 + 0.509), 25);
  QCOMPARE(playback.frameAtTime(0.1 + 0.511), 26);
  QCOMPARE(playback.frameAtTime(-3.0), 0);
  QCOMPARE(playback.frameAtTime(1000.0), kFrames - 1);

  playback.setSpeed(10.0);
  QCOMPARE(playback.speed(), PlaybackController::kMaxSpeed);
  playback.setSpeed(2.0);

  QElapsedTimer clock;
  clock.start();
  playback.play();
  QVERIFY(playback.isPlaying());
  QTest::qWait(500);
  const int index = playback.frameIndex();
  const double elapsed_s = static_cast<double>(clock.nsecsElapsed()) * 1e-9;
  // Real time at double speed is 100 frames per second: never ahead of the clock, and
  // behind it by no more than a late timer (the controller catches up by skipping).
  qInfo("after %.3f s at 2x: frame %d", elapsed_s, index);
  QVERIFY(index <= static_cast<int>(elapsed_s * 100.0) + 1);
  QVERIFY(index >= static_cast<int>(elapsed_s * 100.0) - 15);
  QCOMPARE(seconds.last().at(0).toDouble(), playback.frameTime(index));
  QCOMPARE(playback.frameTime(index), 0.1 + index * 0.02);

  // Slower than real time: 25 frames per second at 0.5x.
  playback.setSpeed(0.5);
  const int slow_from = playback.frameIndex();
  clock.restart();
  QTest::qWait(400);
  const int slow_frames = playback.frameIndex() - slow_from;
  const double slow_s = static_cast<double>(clock.nsecsElapsed()) * 1e-9;
  qInfo("after %.3f s at 0.5x: %d frames on", slow_s, slow_frames);
  QVERIFY(slow_frames <= static_cast<int>(slow_s * 25.0) + 1);
  QVERIFY(slow_frames >= static_cast<int>(slow_s * 25.0) - 6);

  playback.pause();
  const int paused_at = playback.frameIndex();
  QTest::qWait(200);
  QCOMPARE(playback.frameIndex(), paused_at);

  playback.seekToIndex(kFrames - 3);
  QCOMPARE(playback.frameIndex(), kFrames - 3);
  playback.stepForward();
  playback.stepForward();
  playback.stepForward();  // Stays on the last frame.
  QCOMPARE(playback.frameIndex(), kFrames - 1);
  playback.seekToStart();
  playback.stepBackward();
  QCOMPARE(playback.frameIndex(), 0);

  // Playing stops at the end; playing again starts over.
  QSignalSpy playing(&playback, &PlaybackController::playingChanged);
  playback.seekToIndex(kFrames - 5);
  playback.play();
  QTRY_VERIFY(!playback.isPlaying());
  QCOMPARE(playback.frameIndex(), kFrames - 1);
  QCOMPARE(playing.count(), 2);
  playback.play();
  QVERIFY(playback.frameIndex() < 5);
  playback.pause();
}

void WorkbenchTest::loaderDropsStaleRequests() {
  const auto sequence = std::make_shared<SlowSequence>();
  FrameLoader loader;
  loader.setSequence(sequence);
  QSignalSpy ready(&loader, &FrameLoader::frameReady);
  QSignalSpy failed(&loader, &FrameLoader::frameFailed);

  // Fast seeking: frame 0 starts decoding at once, 1..49 are replaced by newer requests
  // before they start, 50 is decoded last.
  for (int i = 0; i <= 50; ++i) loader.request(i);
  QTRY_COMPARE(ready.count(), 2);
  QTest::qWait(100);
  QCOMPARE(ready.count(), 2);
  QCOMPARE(sequence->loads.load(), 2);
  QCOMPARE(ready.at(0).at(0).toInt(), 0);
  QCOMPARE(ready.at(1).at(0).toInt(), 50);
  const QImage fifty = ready.at(1).at(1).value<QImage>();
  QCOMPARE(fifty.size(), QSize(16, 8));
  QCOMPARE(fifty.pixel(3, 2), qRgb(50, 0, 0));

  // Cached frames come back at once, without decoding.
  loader.request(0);
  QCOMPARE(ready.count(), 3);
  QCOMPARE(ready.at(2).at(0).toInt(), 0);
  QCOMPARE(sequence->loads.load(), 2);

  // A frame that cannot be read is reported with the reader's message.
  loader.request(7);
  QTRY_COMPARE(failed.count(), 1);
  QCOMPARE(failed.at(0).at(0).toInt(), 7);
  QCOMPARE(failed.at(0).at(1).toString(), QStringLiteral("frame 7 is damaged"));
  QCOMPARE(ready.count(), 3);

  // Another sequence: nothing cached from the first one is served.
  const auto second = std::make_shared<SlowSequence>();
  loader.setSequence(second);
  loader.request(0);
  QCOMPARE(ready.count(), 3);
  QTRY_COMPARE(ready.count(), 4);

  // A frame still decoding when a cached one is asked for is not shown after it: the view
  // stays on the frame asked for last.
  loader.request(60);
  loader.request(0);
  QCOMPARE(ready.count(), 5);
  QCOMPARE(ready.at(4).at(0).toInt(), 0);
  QTRY_COMPARE(second->loads.load(), 2);  // 60 is decoding...
  QTest::qWait(300);                       // ...and done (it takes 30 ms).
  QCOMPARE(ready.count(), 5);
}

void WorkbenchTest::playsSeeksAndSteps() {
  // Opening plays, from the first picture on: the simulator builds its scene on the first
  // frame it renders (a second or more), and no frame is played past unseen meanwhile.
  int plays = 0, plays_unseen = 0;
  const auto window = OpenWindow(kSimSource, [&](MainWindow& opening) {
    connect(opening.playback(), &PlaybackController::playingChanged, this, [&](bool playing) {
      plays += playing;
      plays_unseen += playing && opening.videoView()->frameIndex() < 0;
    });
  });
  QVERIFY(window);
  QCOMPARE(plays, 1);
  QCOMPARE(plays_unseen, 0);
  PlaybackController& playback = *window->playback();
  AccelPlot& plot = *window->accelPlot();
  const Sequence& sequence = *window->sequence();
  QCOMPARE(playback.frameCount(), static_cast<int>(sequence.frame_count()));
  QVERIFY(sequence.frame_count() >= 60);

  // The frame index, the shown frame and the plot's cursor all advance.
  QVERIFY(playback.isPlaying());
  QTRY_VERIFY_WITH_TIMEOUT(window->videoView()->frameIndex() >= 10, kFrameTimeoutMs);
  QTRY_VERIFY(plot.drawnCursorTime() > 0.3);

  QTest::keyClick(window.get(), Qt::Key_Space);
  QVERIFY(!playback.isPlaying());
  const int paused_at = playback.frameIndex();
  QTest::qWait(300);
  QCOMPARE(playback.frameIndex(), paused_at);
  QTRY_COMPARE(plot.drawnCursorTime(), playback.currentTime());
  QVERIFY(plot.visibleStart() <= plot.drawnCursorTime());
  QVERIFY(plot.visibleEnd() >= plot.drawnCursorTime());
  EXPECT_SHOWN(*window, paused_at);

  // Seek to a time: the nearest frame, on screen and under the cursor.
  playback.seekToTime(1.5);
  const int at_1_5 = NearestFrame(sequence, 1.5);
  QCOMPARE(playback.frameIndex(), at_1_5);
  EXPECT_SHOWN(*window, at_1_5);
  QTRY_COMPARE(plot.drawnCursorTime(), playback.frameTime(at_1_5));

  // Keyboard: right, left, home, end.
  QTest::keyClick(window.get(), Qt::Key_Right);
  QTest::keyClick(window.get(), Qt::Key_Right);
  QCOMPARE(playback.frameIndex(), at_1_5 + 2);
  QTest::keyClick(window.get(), Qt::Key_Left);
  QCOMPARE(playback.frameIndex(), at_1_5 + 1);
  EXPECT_SHOWN(*window, at_1_5 + 1);
  QTest::keyClick(window.get(), Qt::Key_End);
  QCOMPARE(playback.frameIndex(), playback.frameCount() - 1);
  QTest::keyClick(window.get(), Qt::Key_Home);
  QCOMPARE(playback.frameIndex(), 0);
  EXPECT_SHOWN(*window, 0);

  // The timeline slider seeks.
  auto* slider = window->findChild<QSlider*>();
  QVERIFY(slider);
  QCOMPARE(slider->maximum(), playback.frameCount() - 1);
  slider->setValue(40);
  QCOMPARE(playback.frameIndex(), 40);
  EXPECT_SHOWN(*window, 40);

  // The mouse wheel zooms the plot's time window; the window box follows.
  QCOMPARE(plot.windowSeconds(), 10.0);
  QWheelEvent wheel(QPointF(plot.viewport()->rect().center()),
                    QPointF(plot.viewport()->mapToGlobal(plot.viewport()->rect().center())),
                    QPoint(), QPoint(0, 120), Qt::NoButton, Qt::NoModifier, Qt::NoScrollPhase,
                    false);
  QApplication::sendEvent(plot.viewport(), &wheel);
  QCOMPARE(plot.windowSeconds(), 8.0);
  QCOMPARE(window->findChild<QDoubleSpinBox*>(QStringLiteral("plot_window"))->value(), 8.0);
  // The recording (3 s of video, its accelerometer samples a little longer) is shorter than
  // the window: it is shown whole, filling the plot.
  QVERIFY(plot.durationSeconds() > 2.9 && plot.durationSeconds() < 8.0);
  QTRY_COMPARE(plot.visibleStart(), 0.0);
  QTRY_COMPARE(plot.visibleEnd(), plot.durationSeconds());

  // A click on the plot seeks to the time under the mouse.
  QTRY_COMPARE(plot.drawnCursorTime(), playback.frameTime(40));
  const double click_s = playback.frameTime(40) + 0.8;
  QVERIFY(click_s < plot.visibleEnd());
  QChart& chart = *plot.chart();
  const QPointF in_chart = chart.mapToPosition(QPointF(click_s, 0.0), chart.series().front());
  const QPoint in_view = plot.mapFromScene(chart.mapToScene(in_chart));
  QTest::mouseClick(plot.viewport(), Qt::LeftButton, Qt::NoModifier, in_view);
  const int clicked = NearestFrame(sequence, click_s);
  QVERIFY(std::abs(playback.frameIndex() - clicked) <= 1);  // Within a pixel's time.
  EXPECT_SHOWN(*window, playback.frameIndex());
  QTRY_VERIFY(std::abs(plot.drawnCursorTime() - click_s) < 0.05);
}

void WorkbenchTest::opensRecordingFolder() {
  const SimRecording recording;
  QVERIFY(recording.written);
  const QString& folder = recording.folder;
  const Sequence* simulated = recording.simulated.get();

  const auto window = OpenWindow(folder);
  QVERIFY(window);
  QCOMPARE(window->source(), folder);
  QCOMPARE(window->sequence()->frame_count(), simulated->frame_count());
  QVERIFY(window->windowTitle().contains(QString::fromStdString(window->sequence()->Describe())));
  QTest::keyClick(window.get(), Qt::Key_Space);  // Pause.
  window->playback()->seekToTime(2.0);
  const int index = NearestFrame(*window->sequence(), 2.0);
  EXPECT_SHOWN(*window, index);
  // The recording holds exactly what the simulator rendered (lossless PNG).
  QCOMPARE(ShownDifference(*window->videoView(), simulated->LoadFrame(static_cast<size_t>(index))),
           ShownDifference(*window->videoView(),
                           window->sequence()->LoadFrame(static_cast<size_t>(index))));
}

void WorkbenchTest::damagedFirstFrameStillPlays() {
  const SimRecording recording;
  QVERIFY(recording.written);
  const QString& folder = recording.folder;
  const Sequence* simulated = recording.simulated.get();
  QFile first(QStringLiteral("%1/cam0/data/%2.png").arg(folder).arg(simulated->frame_time_ns(0)));
  QVERIFY2(first.open(QIODevice::WriteOnly | QIODevice::Truncate), qPrintable(first.fileName()));
  first.write("not a PNG");
  first.close();

  // Playback does not wait for a picture that will never come: later frames are shown.
  const auto window = OpenWindow(folder);
  QVERIFY(window);
  QVERIFY(window->playback()->isPlaying() || window->playback()->frameIndex() > 0);
  QTRY_VERIFY(window->videoView()->frameIndex() > 0);
  // The log says which frame could not be read, and the run, which stops at it, says so too.
  const auto* log = window->findChild<QPlainTextEdit*>(QStringLiteral("log"));
  QVERIFY(log);
  QTRY_VERIFY2(log->toPlainText().contains(QStringLiteral("Frame 0 could not be read")),
               qPrintable(log->toPlainText()));
  QTRY_VERIFY2(log->toPlainText().contains(QStringLiteral("Pipeline not running")),
               qPrintable(log->toPlainText()));
}

void WorkbenchTest::badPathKeepsRecordingOpen() {
  const auto window = OpenWindow(kSimSource);
  QVERIFY(window);
  const Sequence* before = window->sequence();
  const int frames_before = window->playback()->frameCount();

  QSignalSpy failed(window.get(), &MainWindow::openFailed);
  const QString bad = QStringLiteral("/nonexistent/autocal/walk42");
  window->open(bad);
  QVERIFY(failed.wait(kOpenTimeoutMs));
  const QString message = failed.front().at(1).toString();
  QVERIFY2(message.contains(bad), qPrintable(message));

  // A dialog with the whole message, the log, and the recording as it was.
  QMessageBox* box = nullptr;
  QTRY_VERIFY((box = window->findChild<QMessageBox*>()) != nullptr && box->isVisible());
  QCOMPARE(box->informativeText(), message);
  QVERIFY(box->text().contains(bad));
  const auto* log = window->findChild<QPlainTextEdit*>(QStringLiteral("log"));
  QVERIFY(log);
  QVERIFY(log->toPlainText().contains(message));
  QCOMPARE(window->sequence(), before);
  QCOMPARE(window->playback()->frameCount(), frames_before);
  QCOMPARE(window->source(), kSimSource);
  box->close();

  // Still usable.
  window->playback()->pause();
  window->playback()->seekToIndex(12);
  EXPECT_SHOWN(*window, 12);
}

// A recording that states its camera's rolling shutter sets calibration.readout_ms for its
// runs, in the pipeline and in the thresholds panel; the next recording that states none
// takes it back, but not a readout set by hand.
void WorkbenchTest::takesTheRecordingsRollingShutter() {
  const auto window = OpenWindow(kSimSource + QStringLiteral(",readout_ms=25"));
  QVERIFY(window);
  const auto readouts = [&] {
    return std::pair{window->pipelineController()->options().calibration.readout_ms,
                     window->thresholdPanel()->options().calibration.readout_ms};
  };
  QCOMPARE(readouts(), std::pair(25.0, 25.0));
  const auto reopen = [&](const QString& source) {
    QSignalSpy opened(window.get(), &MainWindow::opened);
    window->open(source);
    return opened.wait(kOpenTimeoutMs);
  };
  QVERIFY(reopen(kSimSource));
  QCOMPARE(readouts(), std::pair(0.0, 0.0));

  PipelineOptions by_hand = window->thresholdPanel()->options();
  by_hand.calibration.readout_ms = 12.0;
  window->thresholdPanel()->setOptions(by_hand);
  emit window->thresholdPanel()->optionsChanged(by_hand);
  QVERIFY(reopen(kSimSource + QStringLiteral(",seed=2")));
  QCOMPARE(readouts(), std::pair(12.0, 12.0));
  const auto* log = window->findChild<QPlainTextEdit*>(QStringLiteral("log"));
  QVERIFY(log);
  QVERIFY2(log->toPlainText().contains(QStringLiteral("rows read over 25 ms")),
           qPrintable(log->toPlainText()));
}

void WorkbenchTest::runsFromThePremissionCalibrationGiven() {
  // A recording without a pre-mission calibration, as a video with its CSV would be.
  const SimRecording recording;
  QVERIFY(recording.written);
  const QString& folder = recording.folder;
  const QTemporaryDir& dir = recording.dir;
  const std::string session_file = (folder + QStringLiteral("/session.json")).toStdString();
  SessionInfo session = ReadSessionFile(session_file);
  const CameraIntrinsics own = *session.premission_calibration;
  session.premission_calibration.reset();
  WriteSessionFile(session_file, session);

  auto window = std::make_unique<MainWindow>();
  window->show();
  PipelineController& pipeline = *window->pipelineController();
  QSignalSpy failed(&pipeline, &PipelineController::failed);
  QSignalSpy started(&pipeline, &PipelineController::started);
  window->open(folder);
  QVERIFY(failed.wait(kOpenTimeoutMs));
  const QString why = failed.front().at(0).toString();
  QVERIFY2(why.contains(QStringLiteral("no pre-mission calibration")) &&
               why.contains(QStringLiteral("Pre-mission Calibration")),
           qPrintable(why));
  QCOMPARE(started.count(), 0);

  // A file that is no calibration: refused with the reader's message, nothing changes.
  const QString bad = dir.filePath(QStringLiteral("bad.yaml"));
  {
    QFile file(bad);
    QVERIFY(file.open(QIODevice::WriteOnly));
    file.write("%YAML:1.0\nimage_width: 320\n");
  }
  QVERIFY(!window->setPremissionFile(bad));
  QVERIFY(window->premissionFile().isEmpty());
  QMessageBox* box = nullptr;
  QTRY_VERIFY((box = window->findChild<QMessageBox*>()) != nullptr && box->isVisible());
  QVERIFY2(box->informativeText().contains(QStringLiteral("bad.yaml")),
           qPrintable(box->informativeText()));
  box->close();
  QCOMPARE(started.count(), 0);

  // The calibration given, 3% longer in focal length than the simulator's own: the run
  // starts again, from it.
  CameraIntrinsics given = own;
  given.fx *= 1.03;
  given.fy *= 1.03;
  const QString good = dir.filePath(QStringLiteral("vest.yaml"));
  WriteCalibration(good.toStdString(), given, CalibrationFormat::kOpenCv);
  QVERIFY(window->setPremissionFile(good));
  QCOMPARE(window->premissionFile(), good);
  QCOMPARE(started.count(), 1);
  QTRY_VERIFY_WITH_TIMEOUT(pipeline.snapshot(0) != nullptr, kOpenTimeoutMs);
  QVERIFY(std::abs(pipeline.snapshot(0)->working.fx - given.fx) < 1e-6);
  QVERIFY(std::abs(pipeline.snapshot(0)->working.cy - given.cy) < 1e-6);
  // The Devices dock connects with it too.
  const auto* field = window->findChild<QLineEdit*>(QStringLiteral("premission_path"));
  QVERIFY(field);
  QCOMPARE(field->text(), good);

  // Back to the recording's own: there is none, so the run cannot start.
  failed.clear();
  QVERIFY(window->setPremissionFile(QString()));
  QTRY_COMPARE_WITH_TIMEOUT(failed.count(), 1, kOpenTimeoutMs);
  QCOMPARE(started.count(), 1);
  QVERIFY(field->text().isEmpty());
}

void WorkbenchTest::settingsPersist() {
  const SimRecording recording;
  QVERIFY(recording.written);
  const QString& folder = recording.folder;
  {
    const auto window = OpenWindow(folder);
    QVERIFY(window);
    auto* speed = window->findChild<QComboBox*>(QStringLiteral("speed"));
    QVERIFY(speed);
    speed->setCurrentIndex(speed->findData(2.0));
    QCOMPARE(window->playback()->speed(), 2.0);
    auto* plot_window = window->findChild<QDoubleSpinBox*>(QStringLiteral("plot_window"));
    QVERIFY(plot_window);
    plot_window->setValue(4.5);
    QCOMPARE(window->accelPlot()->windowSeconds(), 4.5);
    window->resize(1000, 700);
    QTRY_COMPARE(window->size(), QSize(1000, 700));
    window->close();
  }
  MainWindow window;
  window.show();
  QVERIFY(QTest::qWaitForWindowExposed(&window));
  QCOMPARE(window.playback()->speed(), 2.0);
  QCOMPARE(window.accelPlot()->windowSeconds(), 4.5);
  QCOMPARE(window.findChild<QDoubleSpinBox*>(QStringLiteral("plot_window"))->value(), 4.5);
  QCOMPARE(window.findChild<QComboBox*>(QStringLiteral("speed"))->currentData().toDouble(), 2.0);
  QCOMPARE(window.size(), QSize(1000, 700));
  QCOMPARE(QSettings().value(QStringLiteral("files/last_path")).toString(), folder);
}

void WorkbenchTest::screenshotIsNotBlank() {
  const auto window = OpenWindow(kSimSource);
  QVERIFY(window);
  QTest::qWait(1500);  // Let it play, so the plot has a history behind the cursor.
  const QImage shot = window->grab().toImage();
  const QString path = ScreenshotPath(QStringLiteral("workbench.png"));
  QVERIFY(shot.save(path, "PNG"));
  qInfo("screenshot: %s", qPrintable(path));

  std::set<QRgb> colours;
  for (int y = 0; y < shot.height(); y += 2) {
    for (int x = 0; x < shot.width(); x += 2) colours.insert(shot.pixel(x, y));
  }
  QVERIFY2(colours.size() > 1000, qPrintable(QString::number(colours.size())));

  // The video area shows a picture, not a flat fill.
  const QImage video =
      window->videoView()->grab(window->videoView()->imageRect().toRect()).toImage();
  QVERIFY(video.width() > 300);
  double sum = 0.0, sum2 = 0.0;
  int n = 0;
  for (int y = 0; y < video.height(); y += 3) {
    for (int x = 0; x < video.width(); x += 3) {
      const double grey = qGray(video.pixel(x, y));
      sum += grey;
      sum2 += grey * grey;
      ++n;
    }
  }
  const double stddev = std::sqrt(sum2 / n - (sum / n) * (sum / n));
  QVERIFY2(stddev > 15.0, qPrintable(QString::number(stddev)));
}

// At the size a new window opens with (90% of a 1600x1000 screen under Xvfb), while the
// pipeline runs: the status bar's source and every other label show their whole text, and
// no two of them overlap (the source was cut to "simulator scenario office (office, tessa",
// and what was found ran into the pipeline's progress).
void WorkbenchTest::statusTextFitsAtDefaultSize() {
  MainWindow window;
  window.show();
  QVERIFY(QTest::qWaitForWindowExposed(&window));
  QSignalSpy opened(&window, &MainWindow::opened);
  window.open(kSimSource);
  QVERIFY(opened.wait(60000));
  QTRY_VERIFY_WITH_TIMEOUT(window.pipelineController()->framesDone() > 10, 60000);
  window.playback()->pause();
  window.playback()->seekToIndex(5);  // A frame the pipeline has done: what it found shows.
  const auto* found = window.findChild<QLabel*>(QStringLiteral("status_found"));
  QVERIFY(found);
  QTRY_VERIFY_WITH_TIMEOUT(!found->text().isEmpty(), 20000);
  QTest::qWait(1200);  // The display rate's label is cleared on the next tick.
  const auto* source = window.findChild<QLabel*>(QStringLiteral("status_source"));
  QVERIFY(source);
  QVERIFY(source->text().startsWith(QStringLiteral("simulator scenario office (")));
  std::vector<const QLabel*> labels;
  for (const QLabel* label : window.statusBar()->findChildren<QLabel*>()) {
    if (label->isVisible() && !label->text().isEmpty()) labels.push_back(label);
  }
  labels.push_back(found);
  QVERIFY(labels.size() >= 5);
  for (const QLabel* label : labels) {
    const int needed = label->fontMetrics().horizontalAdvance(label->text());
    qInfo("%-70s %4d px of %4d", qPrintable(label->text()), needed, label->contentsRect().width());
    QVERIFY2(needed <= label->contentsRect().width(), qPrintable(label->text()));
  }
  for (size_t i = 0; i < labels.size(); ++i) {
    for (size_t j = i + 1; j < labels.size(); ++j) {
      const QRect a(labels[i]->mapTo(&window, QPoint(0, 0)), labels[i]->size());
      const QRect b(labels[j]->mapTo(&window, QPoint(0, 0)), labels[j]->size());
      QVERIFY2(!a.intersects(b), qPrintable(labels[i]->text() + " / " + labels[j]->text()));
    }
  }
  QVERIFY(window.grab().save(ScreenshotPath(QStringLiteral("workbench_default_size.png"))));

  // Narrower, the source's text ends in an ellipsis where it stops, not mid-word.
  window.resize(1000, window.height());
  const auto* elided = qobject_cast<const ElidedLabel*>(source);
  QVERIFY(elided);
  QTRY_VERIFY(elided->shownText() != elided->text());
  QVERIFY2(elided->shownText().endsWith(QChar(0x2026)), qPrintable(elided->shownText()));
  QVERIFY(elided->fontMetrics().horizontalAdvance(elided->shownText()) <=
          elided->contentsRect().width());
  QVERIFY(window.grab().save(ScreenshotPath(QStringLiteral("workbench_narrow.png"))));
}

// What box 2's newest estimate is sure of, above the video, as the pipeline worded it (the
// widget only shows it); nothing before the first estimate.
void WorkbenchTest::showsBox2sVerdictOnTheLens() {
  MainWindow window;
  window.resize(1200, 800);
  window.show();
  QVERIFY(QTest::qWaitForWindowExposed(&window));
  QSignalSpy finished(window.pipelineController(), &PipelineController::finished);
  QSignalSpy opened(&window, &MainWindow::opened);
  window.open(kSimSource);
  QVERIFY(opened.wait(60000));
  const auto* lens = window.findChild<ElidedLabel*>(QStringLiteral("status_lens"));
  QVERIFY(lens);
  QVERIFY(finished.wait(120000));
  window.playback()->pause();
  window.playback()->seekToIndex(0);
  const auto* found = window.findChild<QLabel*>(QStringLiteral("status_found"));
  QTRY_VERIFY_WITH_TIMEOUT(!found->text().isEmpty(), 20000);
  QCOMPARE(lens->text(), QString());  // The first frame has no estimate yet.
  window.playback()->seekToIndex(int(window.sequence()->frame_count()) - 1);
  QTRY_VERIFY_WITH_TIMEOUT(!lens->text().isEmpty(), 20000);
  QVERIFY2(lens->text().startsWith(QStringLiteral("lens: ")), qPrintable(lens->text()));
  QVERIFY2(lens->text().contains(QStringLiteral(" px to ")), qPrintable(lens->text()));
  QVERIFY2(lens->text().endsWith(QStringLiteral(" lines)")), qPrintable(lens->text()));
  // The estimate's whole message, for a closer look.
  QVERIFY2(lens->toolTip().startsWith(QStringLiteral("k1=")), qPrintable(lens->toolTip()));
  QVERIFY2(lens->styleSheet().isEmpty(), "an observable lens is not shown as a fault");
  QVERIFY(window.grab().save(ScreenshotPath(QStringLiteral("workbench_lens_verdict.png"))));
}

// Issue 6: each box's median and 95th percentile in the workbench, as in the summary. Once
// the run over the recording is done, the Timing dock lists the boxes that ran, in box
// order, with the figures of the pipeline controller's log (the widget computes nothing),
// counted over every frame.
void WorkbenchTest::timingDockShowsTheRunsBoxTimes() {
  MainWindow window;
  window.resize(1200, 800);
  window.show();
  QVERIFY(QTest::qWaitForWindowExposed(&window));
  const QTableWidget* table = window.timingTable()->table();
  QCOMPARE(table->rowCount(), 0);  // Nothing run yet.
  QSignalSpy finished(window.pipelineController(), &PipelineController::finished);
  QSignalSpy opened(&window, &MainWindow::opened);
  window.open(kSimSource);
  QVERIFY(opened.wait(60000));
  QVERIFY(finished.wait(120000));
  const int frames = window.pipelineController()->framesDone();
  QCOMPARE(frames, static_cast<int>(window.sequence()->frame_count()));

  const std::map<std::string, TimingStats> stats = window.pipelineController()->timingStats();
  std::vector<std::string> shown;
  for (int row = 0; row < table->rowCount(); ++row) {
    const std::string box =
        table->item(row, TimingTable::kBox)->data(Qt::UserRole).toString().toStdString();
    shown.push_back(box);
    QVERIFY2(stats.count(box), box.c_str());
    const TimingStats& expected = stats.at(box);
    QCOMPARE(table->item(row, TimingTable::kMedian)->text(),
             QString::number(expected.median_ms, 'f', 2));
    QCOMPARE(table->item(row, TimingTable::kP95)->text(), QString::number(expected.p95_ms, 'f', 2));
    const double median = table->item(row, TimingTable::kMedian)->text().toDouble();
    const double p95 = table->item(row, TimingTable::kP95)->text().toDouble();
    QCOMPARE(table->item(row, TimingTable::kFrames)->text().toInt(), expected.count);
    QVERIFY2(expected.median_ms > 0.0 && p95 >= median, box.c_str());
  }
  QCOMPARE(shown.size(), stats.size());
  QVERIFY(shown.size() >= 8);
  QCOMPARE(shown.front(), std::string("frame"));
  QCOMPARE(stats.at("frame").count, frames);
  QCOMPARE(stats.at("lines").count, frames);  // Boxes 1 and 5 run on every frame.
  QCOMPARE(stats.at("flow").count, frames);
  QVERIFY(stats.at("frame").median_ms > stats.at("flow").median_ms);
  const auto* caption = window.findChild<QLabel*>(QStringLiteral("timing_caption"));
  QVERIFY(caption);
  QVERIFY2(caption->text().contains(QStringLiteral("over %1 frames of the recording").arg(frames)),
           qPrintable(caption->text()));

  auto* dock = window.findChild<QDockWidget*>(QStringLiteral("timing_dock"));
  QVERIFY(dock);
  dock->raise();
  QTest::qWait(200);
  QVERIFY(window.grab().save(ScreenshotPath(QStringLiteral("workbench_timing.png"))));
}

// Opening another recording: until its first frame is decoded, the view shows that it is
// loading, not the last recording's picture under the new title.
void WorkbenchTest::reopeningHidesTheLastPicture() {
  const auto window = OpenWindow(kSimSource);
  QVERIFY(window);
  QVERIFY(window->videoView()->frameIndex() >= 0);
  int shown_when_opened = -2;
  connect(window.get(), &MainWindow::opened, this,
          [&] { shown_when_opened = window->videoView()->frameIndex(); });
  QSignalSpy opened(window.get(), &MainWindow::opened);
  window->open(kSimSource + QStringLiteral(",seed=2"));
  QVERIFY(opened.wait(kOpenTimeoutMs));
  QCOMPARE(shown_when_opened, -1);
  QTRY_VERIFY_WITH_TIMEOUT(window->videoView()->frameIndex() >= 0, kFrameTimeoutMs);
  QVERIFY(window->sequence()->Describe().find("seed 2") != std::string::npos);
}

}  // namespace autocal

QTEST_MAIN(autocal::WorkbenchTest)
#include "workbench_test.moc"
