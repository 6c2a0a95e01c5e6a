// Frames box 9's image-quality gate found unfit, in a real window (run under Xvfb), on the
// simulator's transient scenario (fog from 8 to 11 s, a noise burst from 11 to 12 s): the
// video view frames a fogged or noisy frame in orange and says why over it, and leaves a
// clear frame as it is; the Calibration dock marks the attempts that made no update because
// of them at their times, with their reason.
#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include <QAction>
#include <QSettings>
#include <QSignalSpy>
#include <QTemporaryDir>
#include <QtTest>

#include "devices/sequence.h"
#include "tests/gui/pixels.h"
#include "tests/gui/screenshot.h"
#include "widgets/calibration_plots.h"
#include "widgets/calibration_series.h"
#include "widgets/main_window.h"
#include "widgets/pipeline_controller.h"
#include "widgets/playback_controller.h"
#include "widgets/video_view.h"

namespace autocal {
namespace {

// 15 fps halves the pipeline's work; the gate's baseline (3 s of good frames) still fills.
const QString kTransient = QStringLiteral("sim:transient,seconds=13,fps=15,resolution=320x240");
constexpr int kOpenTimeoutMs = 60000;
constexpr int kFrameTimeoutMs = 20000;
constexpr int kPipelineTimeoutMs = 280000;

QImage Grab(VideoView& view) { return view.grab().toImage().convertToFormat(QImage::Format_RGB32); }

// Of points every 8 px along the frame's edges, 1 px inside, the fraction in `color`.
double BorderFraction(const QImage& image, const QRectF& frame, const QColor& color) {
  const QRect r = frame.toAlignedRect().adjusted(1, 1, -2, -2);
  int points = 0, matching = 0;
  const auto look = [&](int x, int y) {
    ++points;
    matching += ColorDistance(image.pixel(x, y), color) < 30;
  };
  for (int x = r.left(); x <= r.right(); x += 8) {
    look(x, r.top());
    look(x, r.bottom());
  }
  for (int y = r.top(); y <= r.bottom(); y += 8) {
    look(r.left(), y);
    look(r.right(), y);
  }
  return double(matching) / points;
}

}  // namespace

class UnfitFramesTest : public QObject {
  Q_OBJECT

 private slots:
  void initTestCase();
  void unfitFramesAndTheirNoUpdatesAreShown();

 private:
  bool ShowFrame(MainWindow& window, int index);

  QTemporaryDir settings_dir_;
};

void UnfitFramesTest::initTestCase() {
  QVERIFY(settings_dir_.isValid());
  QSettings::setDefaultFormat(QSettings::IniFormat);
  QSettings::setPath(QSettings::IniFormat, QSettings::UserScope, settings_dir_.path());
  QCoreApplication::setOrganizationName(QStringLiteral("autocal-test"));
  QCoreApplication::setApplicationName(QStringLiteral("unfit_frames_test"));
}

bool UnfitFramesTest::ShowFrame(MainWindow& window, int index) {
  window.playback()->pause();
  window.playback()->seekToIndex(index);
  return QTest::qWaitFor(
      [&] {
        return window.videoView()->frameIndex() == index &&
               window.videoView()->overlays().index == index &&
               window.videoView()->overlays().snapshot != nullptr;
      },
      kFrameTimeoutMs);
}

void UnfitFramesTest::unfitFramesAndTheirNoUpdatesAreShown() {
  MainWindow window;
  window.resize(1400, 900);
  window.show();
  window.activateWindow();
  QVERIFY(QTest::qWaitForWindowActive(&window));
  QSignalSpy opened(&window, &MainWindow::opened);
  window.open(kTransient);
  QVERIFY(opened.wait(kOpenTimeoutMs));
  PipelineController& pipeline = *window.pipelineController();
  QSignalSpy finished(&pipeline, &PipelineController::finished);
  QVERIFY(finished.wait(kPipelineTimeoutMs));
  window.playback()->pause();
  const int frames = pipeline.framesDone();
  QCOMPARE(frames, int(window.sequence()->frame_count()));

  // A fogged frame, a noisy one and a clear one, as the gate judged them.
  int fogged = -1, noisy = -1, clear = -1;
  for (int index = 0; index < frames; ++index) {
    const auto snapshot = pipeline.snapshot(index);
    QVERIFY(snapshot);
    const double t = double(snapshot->t_ns - pipeline.snapshot(0)->t_ns) * 1e-9;
    const QString degraded = QString::fromStdString(snapshot->degraded);
    if (fogged < 0 && t > 9.0 && degraded.contains(QStringLiteral("fogged"))) fogged = index;
    if (noisy < 0 && t > 11.0 && degraded.contains(QStringLiteral("noisy"))) noisy = index;
    if (clear < 0 && t > 5.0 && degraded.isEmpty()) clear = index;
  }
  qInfo("fogged frame %d, noisy frame %d, clear frame %d", fogged, noisy, clear);
  QVERIFY(fogged >= 0 && noisy >= 0 && clear >= 0);

  // The default layers are on: the unfit frame is framed in orange and says why.
  VideoView& view = *window.videoView();
  QVERIFY(view.layers() != OverlayLayers());
  QVERIFY(ShowFrame(window, fogged));
  const QString fog_note = view.unfitNote();
  qInfo("fogged: %s", qPrintable(fog_note));
  QVERIFY2(fog_note.startsWith(QStringLiteral("Unfit to measure from: fogged (blur ")),
           qPrintable(fog_note));
  QVERIFY(fog_note.contains(QStringLiteral("contrast")));
  const QImage fogged_image = Grab(view);
  fogged_image.save(ScreenshotPath(QStringLiteral("unfit_fogged.png")));
  const double fogged_border = BorderFraction(fogged_image, view.imageRect(), VideoView::UnfitColor());
  qInfo("fogged frame: %.0f%% of its border orange", 100.0 * fogged_border);
  QVERIFY(fogged_border > 0.95);
  // The banner at the top left: dark orange under the text, whatever the frame holds.
  const QPointF corner = view.imageRect().topLeft();
  int banner = 0, looked = 0;
  for (int x = 8; x < 200; x += 4) {
    const QRgb pixel = fogged_image.pixel(int(corner.x()) + x, int(corner.y()) + 9);
    ++looked;
    banner += qRed(pixel) > 110 && qBlue(pixel) < 60 && qRed(pixel) - qGreen(pixel) > 50;
  }
  QVERIFY2(banner > 0.8 * looked, qPrintable(QString::number(banner)));
  QVERIFY(window.grab().save(ScreenshotPath(QStringLiteral("workbench_unfit.png"))));

  QVERIFY(ShowFrame(window, noisy));
  QVERIFY2(view.unfitNote().contains(QStringLiteral("noisy (")), qPrintable(view.unfitNote()));
  QVERIFY(BorderFraction(Grab(view), view.imageRect(), VideoView::UnfitColor()) > 0.95);

  QVERIFY(ShowFrame(window, clear));
  QVERIFY(view.unfitNote().isEmpty());
  const double clear_border = BorderFraction(Grab(view), view.imageRect(), VideoView::UnfitColor());
  QVERIFY2(clear_border < 0.1, qPrintable(QString::number(clear_border)));

  // With every layer off the frame is shown bare, unfit or not.
  for (const OverlayLayer layer : kAllOverlayLayers) window.overlayAction(layer)->setChecked(false);
  QVERIFY(ShowFrame(window, fogged));
  QVERIFY(view.unfitNote().isEmpty());
  QVERIFY(BorderFraction(Grab(view), view.imageRect(), VideoView::UnfitColor()) < 0.1);

  // The attempts the fog and noise left without an update are marked on the plots, at their
  // times, with their reason.
  CalibrationPlots& plots = *window.calibrationPlots();
  const auto unfit_attempts = [&] {
    std::vector<AttemptRecord> found;
    if (!plots.series()) return found;
    for (const AttemptRecord& record : plots.series()->stored.attempts) {
      if (record.verdict == Verdict::kNoUpdate &&
          record.reason.find("no update: unfit images in the window") == 0) {
        found.push_back(record);
      }
    }
    return found;
  };
  size_t judged = 0;
  for (int index = 0; index < frames; ++index) judged += pipeline.snapshot(index)->attempt != nullptr;
  // The dock follows the run's history file: it catches up within a second or two.
  QTRY_VERIFY_WITH_TIMEOUT(plots.series() && plots.series()->stored.attempts.size() == judged,
                           kFrameTimeoutMs);
  QVERIFY(!unfit_attempts().empty());
  plots.redrawNow();
  CalibrationChart& fx = *plots.chart(kFx);
  const QImage fx_image = fx.grab().toImage();
  const QVector<QPointF> marks = fx.noUpdates()->pointsVector();
  const std::vector<AttemptRecord> unfit = unfit_attempts();
  qInfo("%zu attempts without an update for unfit images, of %zu; %d no-update marks on fx",
        unfit.size(), plots.series()->stored.attempts.size(), marks.size());
  for (const AttemptRecord& record : unfit) {
    const double t = double(record.t_ns - plots.timeOrigin()) * 1e-9;
    // Fog from 8 s and noise to 12 s: windows of 2 s that hold one end by 14 s.
    QVERIFY2(t > 8.0 && t < 14.0, qPrintable(QString::number(t)));
    const auto mark = std::find_if(marks.begin(), marks.end(),
                                   [&](const QPointF& p) { return p.x() == t; });
    QVERIFY(mark != marks.end());
    bool grey = false;
    const QPoint at = fx.positionOf(mark->x(), mark->y());
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        grey = grey || ColorDistance(fx_image.pixel(at + QPoint(dx, dy)), NoUpdateColor()) < 40;
      }
    }
    QVERIFY(grey);
    QCOMPARE(plots.noUpdateAt(t), record.id);
    QVERIFY(plots.describeAttempt(record.id, kFx).contains(QStringLiteral("unfit images")));
  }
  // For a person to look at: the same history at a readable size.
  CalibrationPlots shown;
  shown.resize(1400, 1000);
  shown.setTimeOrigin(plots.timeOrigin());
  shown.setSeries(std::make_shared<const CalibrationSeries>(*plots.series()));
  shown.show();
  QVERIFY(QTest::qWaitForWindowExposed(&shown));
  shown.redrawNow();
  QVERIFY(shown.grab().save(ScreenshotPath(QStringLiteral("calibration_plots_unfit.png"))));
}

}  // namespace autocal

QTEST_MAIN(autocal::UnfitFramesTest)
#include "unfit_frames_test.moc"
