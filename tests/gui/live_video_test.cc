// The video view on a live source (run under Xvfb): connected from the Devices dock to a
// simulated source played in real time, the view shows the source's frames as they come,
// each with the overlays of its own snapshot drawn where its tracks are; side by side adds
// box 3's image of the live frame; disconnecting leaves the window working, and a recording
// opened afterwards is shown again.
#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include <QAction>
#include <QComboBox>
#include <QDockWidget>
#include <QLabel>
#include <QPushButton>
#include <QSettings>
#include <QSignalSpy>
#include <QTableWidget>
#include <QTemporaryDir>
#include <QtTest>

#include "devices/sequence.h"
#include "tests/gui/screenshot.h"
#include "widgets/accel_plot.h"
#include "widgets/device_panel.h"
#include "widgets/image_convert.h"
#include "widgets/live_session.h"
#include "widgets/main_window.h"
#include "widgets/pipeline_controller.h"
#include "widgets/playback_controller.h"
#include "widgets/timing_table.h"
#include "widgets/video_view.h"

namespace autocal {
namespace {

#if QT_VERSION < QT_VERSION_CHECK(6, 0, 0)
using QtCharts::QAbstractSeries;
#endif

// Small frames: the simulator renders them faster than real time on a loaded machine.
const QString kSimSource = QStringLiteral("sim:office,seconds=30,resolution=320x240");
constexpr int kTimeoutMs = 60000;

QImage Grab(VideoView& view) { return view.grab().toImage().convertToFormat(QImage::Format_RGB32); }

// Mean absolute difference of two images' grey levels; infinite when their sizes differ.
double MeanGreyDifference(const QImage& a, const QImage& b) {
  if (a.size() != b.size()) return INFINITY;
  const QImage ga = a.convertToFormat(QImage::Format_Grayscale8);
  const QImage gb = b.convertToFormat(QImage::Format_Grayscale8);
  double sum = 0.0;
  for (int y = 0; y < ga.height(); ++y) {
    for (int x = 0; x < ga.width(); ++x) {
      sum += std::abs(qGray(ga.pixel(x, y)) - qGray(gb.pixel(x, y)));
    }
  }
  return sum / (ga.width() * ga.height());
}

}  // namespace

class LiveVideoTest : public QObject {
  Q_OBJECT

 private slots:
  void initTestCase();
  void showsLiveFramesWithTheirOverlays();

 private:
  QTemporaryDir settings_dir_;
};

void LiveVideoTest::initTestCase() {
  QVERIFY(settings_dir_.isValid());
  QSettings::setDefaultFormat(QSettings::IniFormat);
  QSettings::setPath(QSettings::IniFormat, QSettings::UserScope, settings_dir_.path());
  QCoreApplication::setOrganizationName(QStringLiteral("autocal-test"));
  QCoreApplication::setApplicationName(QStringLiteral("live_video_test"));
}

void LiveVideoTest::showsLiveFramesWithTheirOverlays() {
  MainWindow window;
  window.resize(1400, 900);
  window.show();
  window.activateWindow();
  QVERIFY(QTest::qWaitForWindowActive(&window));
  OverlayLayers all;
  for (const OverlayLayer layer : kAllOverlayLayers) {
    window.overlayAction(layer)->setChecked(true);
    all |= layer;
  }
  auto* dock = window.findChild<QDockWidget*>(QStringLiteral("devices_dock"));
  QVERIFY(dock);
  dock->show();
  auto* panel = qobject_cast<DevicePanel*>(dock->widget());
  QVERIFY(panel);

  // No recording open: the live source alone, connected as a technician would.
  LiveSession& session = *window.liveSession();
  QSignalSpy connected(&session, &LiveSession::connected);
  panel->findChild<QComboBox*>(QStringLiteral("input"))->setCurrentText(kSimSource);
  QTest::mouseClick(panel->findChild<QPushButton*>(QStringLiteral("connect")), Qt::LeftButton);
  QTRY_COMPARE_WITH_TIMEOUT(connected.count(), 1, kTimeoutMs);

  // Frames arrive, each with its own snapshot.
  VideoView& view = *window.videoView();
  const auto showsTrackedFrame = [&] {
    const FrameOverlays& overlays = view.overlays();
    return overlays.live && overlays.index == view.frameIndex() && overlays.snapshot &&
           overlays.raw && overlays.raw->tracks.size() >= 10;
  };
  QTRY_VERIFY_WITH_TIMEOUT(showsTrackedFrame(), kTimeoutMs);
  const int first = view.frameIndex();
  const QImage first_image = view.image();
  QTRY_VERIFY_WITH_TIMEOUT(view.frameIndex() >= first + 10 && showsTrackedFrame(), kTimeoutMs);
  QVERIFY(view.image() != first_image);  // The pixels move on.
  // The status bar's display rate counts live frames as it counts played ones.
  QTRY_VERIFY_WITH_TIMEOUT(window.displayFps() > 1.0, kTimeoutMs);
  qInfo("live frames %d to %d shown (%llu painted)", first, view.frameIndex(),
        static_cast<unsigned long long>(view.framesPainted()));

  // The frame on screen is the source's frame at its snapshot's time: the simulator renders
  // the same image again.
  const FrameOverlays overlays = view.overlays();
  const QImage image = view.image();
  const auto simulated = OpenSequence(kSimSource.toStdString());
  int simulated_index = -1;
  for (size_t i = 0; i < simulated->frame_count(); ++i) {
    if (simulated->frame_time_ns(i) == overlays.snapshot->t_ns) simulated_index = int(i);
  }
  QVERIFY2(simulated_index >= 0, "no simulated frame at the snapshot's time");
  const double difference =
      MeanGreyDifference(image, MatToQImage(simulated->LoadFrame(size_t(simulated_index))));
  qInfo("live frame %d is simulated frame %d (mean difference %.2f grey levels)", overlays.index,
        simulated_index, difference);
  QVERIFY(difference < 1.0);

  // Its overlays are drawn on it: with the layers on and off (no event in between, so the
  // same frame), pixels change at its tracks and nowhere outside the image.
  const QImage drawn = Grab(view);
  view.setLayers({});
  const QImage bare = Grab(view);
  view.setLayers(all);
  QVERIFY(drawn != bare);
  const QRectF area = view.imageRect();
  int outside = 0;
  for (int y = 0; y < drawn.height(); ++y) {
    for (int x = 0; x < drawn.width(); ++x) {
      if (drawn.pixel(x, y) != bare.pixel(x, y) && !area.contains(QPointF(x + 0.5, y + 0.5))) {
        ++outside;
      }
    }
  }
  QCOMPARE(outside, 0);
  int anchors = 0, hit = 0;
  const QTransform to_widget = view.imageToWidget();
  for (const OverlayGeometry::TrackMark& track : overlays.raw->tracks) {
    const QPointF p = to_widget.map(QPointF(track.now.x(), track.now.y()));
    if (!area.adjusted(3, 3, -3, -3).contains(p)) continue;
    ++anchors;
    bool found = false;
    for (int dy = -2; dy <= 2 && !found; ++dy) {
      for (int dx = -2; dx <= 2 && !found; ++dx) {
        const QPoint q(int(p.x()) + dx, int(p.y()) + dy);
        found = drawn.rect().contains(q) && drawn.pixel(q) != bare.pixel(q);
      }
    }
    hit += found;
  }
  qInfo("tracks drawn at %d of %d", hit, anchors);
  QVERIFY(anchors >= 10);
  QVERIFY(hit >= 0.9 * anchors);
  QVERIFY(drawn.save(ScreenshotPath(QStringLiteral("live_video.png"))));
  QVERIFY(window.grab().save(ScreenshotPath(QStringLiteral("workbench_live.png"))));

  // The accelerometer plot follows the live source: each point drawn is one of the source's
  // samples (the simulator's, same time and value), the newest at the right edge.
  AccelPlot& plot = *window.accelPlot();
  QTRY_VERIFY_WITH_TIMEOUT(plot.durationSeconds() > 1.0, kTimeoutMs);
  {
    const int64_t start_ns = session.recentAccel().start_ns;
    const std::vector<AccelSample>& truth = simulated->accel();
    int checked = 0;
    for (QAbstractSeries* series : plot.chart()->series()) {
      const int axis = series->name() == QStringLiteral("a_x")   ? 0
                       : series->name() == QStringLiteral("a_y") ? 1
                       : series->name() == QStringLiteral("a_z") ? 2
                                                                 : -1;
      if (axis < 0) continue;
      for (const QPointF& point : static_cast<QLineSeries*>(series)->points()) {
        const int64_t t_ns = start_ns + std::llround(point.x() * 1e9);
        const auto at =
            std::lower_bound(truth.begin(), truth.end(), t_ns,
                             [](const AccelSample& sample, int64_t t) { return sample.t_ns < t; });
        QVERIFY(at != truth.end());
        QVERIFY2(std::abs(at->t_ns - t_ns) < 1000, qPrintable(QString::number(point.x())));
        QVERIFY(std::abs(at->specific_force[axis] - point.y()) < 1e-9);
        ++checked;
      }
    }
    qInfo("%d plotted accelerometer points checked against the source", checked);
    QVERIFY(checked >= 100);
    QVERIFY(std::abs(plot.visibleEnd() - plot.durationSeconds()) < 1e-9);
  }

  // The Timing dock follows the live pipeline: its frames since connecting, as the session
  // measured them, within the once-a-second refresh.
  const QTableWidget* timing = window.timingTable()->table();
  const auto* caption = window.findChild<QLabel*>(QStringLiteral("timing_caption"));
  QVERIFY(caption);
  const auto shown_frames = [&] {
    return timing->rowCount() > 0 ? timing->item(0, TimingTable::kFrames)->text().toInt() : 0;
  };
  QTRY_VERIFY_WITH_TIMEOUT(
      caption->text().contains(QStringLiteral("of the live source")) && shown_frames() >= 10,
      kTimeoutMs);
  QVERIFY(timing->rowCount() >= 8);
  QCOMPARE(timing->item(0, TimingTable::kBox)->data(Qt::UserRole).toString(),
           QStringLiteral("frame"));
  const int live_frames = shown_frames();
  QVERIFY(live_frames <= session.timingStats().at("frame").count);
  QVERIFY(timing->item(0, TimingTable::kMedian)->text().toDouble() > 0.0);

  // Side by side: box 3's image of the live frame beside it.
  window.viewModeAction(VideoView::ViewMode::kSideBySide)->trigger();
  QTRY_VERIFY_WITH_TIMEOUT(!view.rectifiedImage().isNull() && showsTrackedFrame() &&
                               view.overlays().rectified != nullptr,
                           kTimeoutMs);
  QVERIFY(Grab(view).save(ScreenshotPath(QStringLiteral("live_side_by_side.png"))));
  window.viewModeAction(VideoView::ViewMode::kRaw)->trigger();

  // Disconnected: no more frames, the last one stays, nothing breaks.
  QSignalSpy disconnected(&session, &LiveSession::disconnected);
  QTest::mouseClick(panel->findChild<QPushButton*>(QStringLiteral("disconnect")), Qt::LeftButton);
  QTRY_COMPARE_WITH_TIMEOUT(disconnected.count(), 1, kTimeoutMs);
  QTest::qWait(300);
  const int last = view.frameIndex();
  QTest::qWait(700);
  QCOMPARE(view.frameIndex(), last);
  QVERIFY(!view.image().isNull());

  // A recording opened afterwards is shown again.
  QSignalSpy opened(&window, &MainWindow::opened);
  window.open(QStringLiteral("sim:office,seconds=2,resolution=320x240"));
  QVERIFY(opened.wait(kTimeoutMs));
  QTRY_VERIFY_WITH_TIMEOUT(!window.pipelineController()->current().live && view.frameIndex() >= 0 &&
                               view.image().size() == QSize(320, 240),
                           kTimeoutMs);
  // The recording's accelerometer again: the plot spans it, from its start to its end.
  const Sequence& recording = *window.sequence();
  const int64_t recording_end_ns =
      std::max(recording.frame_time_ns(recording.frame_count() - 1), recording.accel().back().t_ns);
  QCOMPARE(plot.durationSeconds(),
           static_cast<double>(recording_end_ns - RecordingStartNs(recording)) * 1e-9);
}

}  // namespace autocal

QTEST_MAIN(autocal::LiveVideoTest)
#include "live_video_test.moc"
