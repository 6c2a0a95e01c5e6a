// The calibration plots and the history table in real windows (run under Xvfb), on a real
// history: CalibrationHistory judges synthetic box-10 attempts with known values (drift, a
// high-RMS attempt, an outlier, a knock that raises an alarm and starts a new regime,
// no-updates), HistoryStore writes it to a SQLite file, and the widgets read that file.
#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <QComboBox>
#include <QElapsedTimer>
#include <QFile>
#include <QGraphicsTextItem>
#include <QImage>
#include <QLineEdit>
#include <QSettings>
#include <QSignalSpy>
#include <QSvgRenderer>
#include <QTabWidget>
#include <QTableView>
#include <QTemporaryDir>
#include <QToolTip>
#include <QWheelEvent>
#include <QGraphicsTextItem>
#include <QtTest>

#include "pipeline/calibration_export.h"
#include "pipeline/calibration_history.h"
#include "pipeline/calibration_io.h"
#include "pipeline/history_store.h"
#include "tests/gui/pixels.h"
#include "tests/gui/screenshot.h"
#include "widgets/calibration_plots.h"
#include "widgets/calibration_series.h"
#include "widgets/history_table.h"
#include "widgets/main_window.h"

namespace autocal {
namespace {

constexpr int64_t kSecond = 1'000'000'000;
constexpr int64_t kStartNs = 5 * kSecond;  // The history's clock does not start at 0.
constexpr int kOpenTimeoutMs = 30000;

// Attempt times (seconds after kStartNs) with something special about them.
constexpr int kHighRmsAt = 20;  // RMS 2.5 px: rejected for its RMS.
constexpr int kOutlierAt = 30;  // fx +25 px, cx +20 px, once: rejected off the trend.
constexpr int kKnockAt = 45;    // From here fx, fy drop 2% and cx moves +5 px, and stay.
// The attempts after the knock that raise the alarm and start the new regime.
const int kAlarmAt = kKnockAt + AcceptanceOptions{}.alarm_after - 1;
const int kNewRegimeAt = kKnockAt + AcceptanceOptions{}.confirm_after - 1;
constexpr int kLastAt = 60;

CameraIntrinsics Premission() {
  CameraIntrinsics c;
  c.width = 640;
  c.height = 480;
  c.fx = c.fy = 500.0;
  c.cx = 320.0;
  c.cy = 240.0;
  c.k1 = -0.12;
  c.k2 = 0.03;
  return c;
}

// The lens at `t_s`: a slow drift (fx +1% and cx +3 px over a minute), then the knock.
CameraIntrinsics Truth(double t_s) {
  CameraIntrinsics c = Premission();
  c.fx *= 1.0 + 0.01 * t_s / 60.0;
  c.fy *= 1.0 + 0.01 * t_s / 60.0;
  c.cx += 3.0 * t_s / 60.0;
  if (t_s >= kKnockAt) {
    c.fx *= 0.98;
    c.fy *= 0.98;
    c.cx += 5.0;
  }
  return c;
}

struct TestHistory {
  QString path;
  std::vector<std::pair<int64_t, CameraIntrinsics>> truth;
  std::map<Verdict, int> counts;
};

// Judges one attempt a second (and a no-update every ten seconds, half a second later) and
// records each in a SQLite file in `dir`.
TestHistory WriteTestHistory(const QTemporaryDir& dir) {
  TestHistory out;
  out.path = dir.filePath(QStringLiteral("history.sqlite"));
  CalibrationHistory history(Premission());
  HistoryStore store(out.path.toStdString());
  std::mt19937 random(7);
  std::normal_distribution<double> normal;
  const std::array<double, 6> sigma = {0.3, 0.3, 0.5, 0.5, 0.002, 0.002};
  Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(6, 6);
  for (int i = 0; i < 6; ++i)
    covariance(i, i) = sigma[static_cast<size_t>(i)] * sigma[static_cast<size_t>(i)];

  for (int second = 1; second <= kLastAt; ++second) {
    const CameraIntrinsics truth = Truth(second);
    out.truth.emplace_back(kStartNs + second * kSecond, truth);
    SelfCalibrationResult r;
    r.usable = true;
    r.estimate = truth;
    r.estimate.fx += sigma[0] * normal(random);
    r.estimate.fy += sigma[1] * normal(random);
    r.estimate.cx += sigma[2] * normal(random);
    r.estimate.cy += sigma[3] * normal(random);
    r.estimate.k1 += sigma[4] * normal(random);
    r.estimate.k2 += sigma[5] * normal(random);
    r.covariance = covariance;
    r.free_parameters = {kFx, kFy, kCx, kCy, kK1, kK2};
    r.rms_px = 0.35 + 0.001 * second;
    r.reason = "converged";
    r.frames_used = 10;
    if (second == kHighRmsAt) r.rms_px = 2.5;
    if (second == kOutlierAt) {
      r.estimate.fx += 25.0;
      r.estimate.cx += 20.0;
    }
    ++out.counts[history.Judge(kStartNs + second * kSecond, r)];
    store.Record(history);

    if (second % 10 == 0) {
      SelfCalibrationResult none;
      none.estimate = truth;
      none.reason = "no update: insufficient rotation (3.1 deg)";
      ++out.counts[history.Judge(kStartNs + second * kSecond + kSecond / 2, none)];
      store.Record(history);
    }
  }
  return out;
}

// A colour drawn within `radius` pixels of `at`; pixels of a colour.
bool DrawnNear(const QImage& image, QPoint at, const QColor& color, int radius = 1) {
  return autocal::DrawnNear(image, at, color, radius, 39);
}

int CountColor(const QImage& image, const QColor& color) {
  return autocal::CountColor(image, color, 39);
}

const AttemptRecord& AttemptAt(const CalibrationSeries& series, int second) {
  for (const AttemptRecord& r : series.stored.attempts) {
    if (r.t_ns == kStartNs + second * kSecond) return r;
  }
  qFatal("no attempt at %d s", second);
}

}  // namespace

class CalibrationPlotsTest : public QObject {
  Q_OBJECT

 private slots:
  void initTestCase();
  void replayReproducesTheFile();
  void markersDrawnWhereTheValuesAre();
  void hoverShowsVerdictAndReason();
  void noUpdatesMarkedAtTheFoot();
  void zoomPanSeekAndCursor();
  void exportsPngAndSvg();
  void tableFiltersAndSorts();
  void tableExportsHistoryAndCalibration();
  void mainWindowOpensHistory();
  void followsAHistoryBeingWritten();
  void drawsAttemptsThatComeWithinTheTimeRange();
  void decimatesHoursOfHistory();
  void valueLabelsAreWhole();
  void timeAxesLineUpDownEachColumn();

 private:
  // Plots showing the test history, shown and laid out.
  std::unique_ptr<CalibrationPlots> ShowPlots();

  QTemporaryDir dir_;
  QTemporaryDir settings_dir_;
  TestHistory history_;
  std::shared_ptr<const CalibrationSeries> series_;
};

void CalibrationPlotsTest::initTestCase() {
  QVERIFY(settings_dir_.isValid());
  QSettings::setDefaultFormat(QSettings::IniFormat);
  QSettings::setPath(QSettings::IniFormat, QSettings::UserScope, settings_dir_.path());
  QCoreApplication::setOrganizationName(QStringLiteral("autocal-test"));
  QCoreApplication::setApplicationName(QStringLiteral("calibration_plots_test"));

  QVERIFY(dir_.isValid());
  history_ = WriteTestHistory(dir_);
  // The history the test relies on: every kind of marker is there.
  QCOMPARE(history_.counts[Verdict::kAlarm], 1);
  QCOMPARE(history_.counts[Verdict::kNewRegime], 1);
  QCOMPARE(history_.counts[Verdict::kNoUpdate], 6);
  QVERIFY(history_.counts[Verdict::kRejected] >= 3);  // RMS, outlier, the knock's first.
  QVERIFY(history_.counts[Verdict::kAccepted] >= 50);

  HistoryOpener opener;
  connect(&opener, &HistoryOpener::opened, this,
          [this](const QString&, std::shared_ptr<const CalibrationSeries> series) {
            series_ = std::move(series);
          });
  opener.open(history_.path);
  QTRY_VERIFY_WITH_TIMEOUT(series_ != nullptr, kOpenTimeoutMs);
}

void CalibrationPlotsTest::replayReproducesTheFile() {
  const CalibrationSeries& s = *series_;
  QCOMPARE(s.stored.attempts.size(), size_t{66});
  QVERIFY(s.differing.empty());
  QCOMPARE(AttemptAt(s, kHighRmsAt).verdict, Verdict::kRejected);
  QCOMPARE(AttemptAt(s, kOutlierAt).verdict, Verdict::kRejected);
  QCOMPARE(AttemptAt(s, kAlarmAt).verdict, Verdict::kAlarm);
  QCOMPARE(AttemptAt(s, kNewRegimeAt).verdict, Verdict::kNewRegime);
  // The trend covers the attempts (the last is a no-update at 60.5 s) every quarter second,
  // and it follows the knock.
  QCOMPARE(s.trend.size(), size_t{(kLastAt - 1) * 4 + 3});
  QCOMPARE(s.trend.front().t_ns, kStartNs + kSecond);
  QCOMPARE(s.trend.back().t_ns, kStartNs + kLastAt * kSecond + kSecond / 2);
  QCOMPARE(s.trend[1].t_ns - s.trend[0].t_ns, kTrendStepNs);
  QVERIFY(std::abs(s.trend.back().value[kFx] - Truth(kLastAt).fx) < 1.0);
  QVERIFY(std::abs(s.current.calibration.fx - Truth(kLastAt).fx) < 1.0);
  QVERIFY(std::abs(s.trend[(kKnockAt - 5 - 1) * 4].value[kFx] - Truth(kKnockAt - 5).fx) < 1.0);

  // A file that is no history is refused with its name.
  const QString bad = dir_.filePath(QStringLiteral("not_a_history.sqlite"));
  QFile file(bad);
  QVERIFY(file.open(QIODevice::WriteOnly));
  file.write("hello");
  file.close();
  HistoryOpener opener;
  QSignalSpy failed(&opener, &HistoryOpener::failed);
  opener.open(bad);
  QVERIFY(failed.wait(kOpenTimeoutMs));
  QVERIFY2(failed.at(0).at(1).toString().contains(bad), qPrintable(failed.at(0).at(1).toString()));
}

std::unique_ptr<CalibrationPlots> CalibrationPlotsTest::ShowPlots() {
  auto plots = std::make_unique<CalibrationPlots>();
  plots->resize(1400, 1000);
  plots->setSeries(series_);
  plots->setGroundTruth(history_.truth);
  plots->setCursorTime(-100.0);  // Out of the way of the markers.
  plots->show();
  if (!QTest::qWaitForWindowExposed(plots.get())) return nullptr;
  QTest::qWait(50);  // Layout settles; the charts report their sizes.
  plots->redrawNow();
  return plots;
}

void CalibrationPlotsTest::markersDrawnWhereTheValuesAre() {
  const auto plots = ShowPlots();
  QVERIFY(plots);
  // Times count from the first attempt when no recording sets the origin.
  QCOMPARE(plots->timeOrigin(), kStartNs + kSecond);
  auto seconds = [&](int at) { return static_cast<double>(at - 1); };

  CalibrationChart& fx = *plots->chart(kFx);
  CalibrationChart& cx = *plots->chart(kCx);
  CalibrationChart& rms = *plots->chart(kRmsChannel);
  const QImage fx_image = fx.grab().toImage();
  const QImage cx_image = cx.grab().toImage();
  const QImage rms_image = rms.grab().toImage();
  const QColor accepted = MarkerColor(MarkerClass::kAccepted);
  const QColor rejected = MarkerColor(MarkerClass::kRejected);
  const QColor jump = MarkerColor(MarkerClass::kJump);

  const AttemptRecord& calm = AttemptAt(*series_, 10);
  const AttemptRecord& outlier = AttemptAt(*series_, kOutlierAt);
  const AttemptRecord& high_rms = AttemptAt(*series_, kHighRmsAt);
  const AttemptRecord& alarm = AttemptAt(*series_, kAlarmAt);
  QCOMPARE(calm.verdict, Verdict::kAccepted);

  const QPoint calm_at = fx.positionOf(seconds(10), calm.estimate.fx);
  const QPoint outlier_at = fx.positionOf(seconds(kOutlierAt), outlier.estimate.fx);
  const QPoint alarm_at = fx.positionOf(seconds(kAlarmAt), alarm.estimate.fx);
  qInfo("fx markers: accepted at (%d, %d), outlier at (%d, %d), alarm at (%d, %d)", calm_at.x(),
        calm_at.y(), outlier_at.x(), outlier_at.y(), alarm_at.x(), alarm_at.y());
  QVERIFY(fx.chart()->plotArea().contains(fx.chart()->mapFromScene(fx.mapToScene(outlier_at))));
  QVERIFY(outlier_at.y() < calm_at.y() - 50);  // 25 px higher in fx: far up the chart.
  QVERIFY(DrawnNear(fx_image, calm_at, accepted));
  QVERIFY(!DrawnNear(fx_image, calm_at, rejected));
  QVERIFY(DrawnNear(fx_image, outlier_at, rejected));
  QVERIFY(!DrawnNear(fx_image, outlier_at, accepted));
  QVERIFY(DrawnNear(fx_image, alarm_at, jump));
  QVERIFY(DrawnNear(cx_image, cx.positionOf(seconds(kOutlierAt), outlier.estimate.cx), rejected));
  // The high-RMS attempt is red in the RMS chart, at 2.5 px.
  QVERIFY(DrawnNear(rms_image, rms.positionOf(seconds(kHighRmsAt), high_rms.rms_px), rejected));
  QVERIFY(DrawnNear(rms_image, rms.positionOf(seconds(10), calm.rms_px), accepted));

  // The trend is drawn where the filtered calibration is, between the attempts.
  const TrendSample& between = series_->trend[static_cast<size_t>((15 - 1) * 4 + 2)];  // 15.5 s
  QVERIFY(DrawnNear(fx_image, fx.positionOf(seconds(15) + 0.5, between.value[kFx]), TrendColor()));
  // The alarm's line crosses the whole chart at its time.
  const QPoint alarm_top = fx.positionOf(seconds(kAlarmAt), fx.valueAxis()->max());
  const QPoint alarm_bottom = fx.positionOf(seconds(kAlarmAt), fx.valueAxis()->min());
  int alarm_pixels = 0;
  for (int y = alarm_top.y() + 1; y < alarm_bottom.y(); ++y) {
    alarm_pixels += DrawnNear(fx_image, QPoint(alarm_top.x(), y), AlarmColor(), 0);
  }
  QVERIFY2(alarm_pixels > (alarm_bottom.y() - alarm_top.y()) / 3,
           qPrintable(QString::number(alarm_pixels)));
  // The ground truth has a point per second, drawn as a line: across the knock (between
  // the attempts at 44 and 45 s) it runs from the old focal length to the new one, where
  // neither markers nor the trend are.
  QCOMPARE(fx.truth()->count(), kLastAt);
  int truth_hits = 0;
  for (double f = 0.1; f < 0.95; f += 0.1) {
    const double value = (1.0 - f) * Truth(kKnockAt - 1).fx + f * Truth(kKnockAt).fx;
    truth_hits +=
        DrawnNear(fx_image, fx.positionOf(seconds(kKnockAt - 1) + f, value), TruthColor());
  }
  QVERIFY2(truth_hits >= 5, qPrintable(QString::number(truth_hits)));
  // The cursor is a black line at its time.
  plots->setCursorTime(seconds(12) + 0.5);
  plots->redrawNow();
  const QImage with_cursor = fx.grab().toImage();
  const QPoint cursor_at =
      fx.positionOf(seconds(12) + 0.5,
                    fx.valueAxis()->min() + 0.9 * (fx.valueAxis()->max() - fx.valueAxis()->min()));
  QVERIFY(DrawnNear(with_cursor, cursor_at, QColor(20, 20, 20)));
  QVERIFY(!DrawnNear(fx_image, cursor_at, QColor(20, 20, 20)));
  plots->setCursorTime(-100.0);

  // Hiding the rejected attempts takes the red marker away and rescales to the rest.
  const double top_with_rejected = fx.valueAxis()->max();
  plots->setShowRejected(false);
  plots->redrawNow();
  QVERIFY(fx.valueAxis()->max() < outlier.estimate.fx);
  QVERIFY(fx.valueAxis()->max() < top_with_rejected);
  QCOMPARE(CountColor(fx.grab().toImage(), rejected), 0);
  QVERIFY(CountColor(fx_image, rejected) > 20);
  plots->setShowRejected(true);
  plots->redrawNow();
  // Parameters no attempt estimated (p1, p2, k3) have a trend but no markers.
  QCOMPARE(plots->chart(kP1)->markers(MarkerClass::kAccepted)->count(), 0);
  QVERIFY(plots->chart(kP1)->trend()->count() > 0);
  QCOMPARE(plots->chart(kK2)->markers(MarkerClass::kAccepted)->count(),
           history_.counts[Verdict::kAccepted]);

  QVERIFY(plots->grab().save(ScreenshotPath(QStringLiteral("calibration_plots.png")), "PNG"));
}

void CalibrationPlotsTest::hoverShowsVerdictAndReason() {
  const auto plots = ShowPlots();
  QVERIFY(plots);
  const AttemptRecord& outlier = AttemptAt(*series_, kOutlierAt);
  CalibrationChart& fx = *plots->chart(kFx);
  // The point as drawn (and as the hover reports it).
  const QVector<QPointF> drawn = fx.markers(MarkerClass::kRejected)->pointsVector();
  const auto point = std::find_if(drawn.begin(), drawn.end(),
                                  [&](const QPointF& p) { return p.y() == outlier.estimate.fx; });
  QVERIFY(point != drawn.end());
  const double t = point->x();
  QVERIFY(std::abs(t - (kOutlierAt - 1)) < 1e-9);
  const int id = plots->attemptAt(kFx, MarkerClass::kRejected, *point);
  QCOMPARE(id, outlier.id);
  QCOMPARE(plots->attemptAt(kFx, MarkerClass::kAccepted, *point), -1);
  const QString text = plots->describeAttempt(id, kFx);
  QVERIFY2(text.contains(QStringLiteral("rejected")), qPrintable(text));
  QVERIFY2(text.contains(QString::fromStdString(outlier.reason)), qPrintable(text));

  // A real hover over the marker brings the same text up.
  const QPoint at = fx.positionOf(t, outlier.estimate.fx);
  QTest::mouseMove(fx.viewport(), at + QPoint(0, 30));
  QTest::mouseMove(fx.viewport(), at);
  QTRY_VERIFY(QToolTip::isVisible());
  QCOMPARE(QToolTip::text(), text);
}

// Attempts that made no update have no value to plot: each chart marks them in a grey row
// along its foot at their times, and hovering one tells why.
void CalibrationPlotsTest::noUpdatesMarkedAtTheFoot() {
  const auto plots = ShowPlots();
  QVERIFY(plots);
  std::vector<const AttemptRecord*> none;
  for (const AttemptRecord& record : series_->stored.attempts) {
    if (record.verdict == Verdict::kNoUpdate) none.push_back(&record);
  }
  QCOMPARE(int(none.size()), history_.counts[Verdict::kNoUpdate]);
  for (const int channel : {int(kFx), int(kK2), kRmsChannel}) {
    CalibrationChart& chart = *plots->chart(channel);
    const QVector<QPointF> drawn = chart.noUpdates()->pointsVector();
    QCOMPARE(drawn.size(), int(none.size()));
    const QImage image = chart.grab().toImage();
    const double lo = chart.valueAxis()->min(), hi = chart.valueAxis()->max();
    for (size_t i = 0; i < none.size(); ++i) {
      const double t = double(none[i]->t_ns - plots->timeOrigin()) * 1e-9;
      QCOMPARE(drawn[int(i)].x(), t);
      // In the lowest tenth of the chart, whatever its values.
      QVERIFY(drawn[int(i)].y() >= lo && drawn[int(i)].y() < lo + 0.1 * (hi - lo));
      QVERIFY(DrawnNear(image, chart.positionOf(t, drawn[int(i)].y()), NoUpdateColor()));
      QCOMPARE(plots->noUpdateAt(t), none[i]->id);
    }
  }
  const QString text = plots->describeAttempt(none.front()->id, kFx);
  QVERIFY2(text.contains(QStringLiteral("no update: insufficient rotation")), qPrintable(text));

  // A real hover over the first one brings its reason up.
  CalibrationChart& fx = *plots->chart(kFx);
  const QPointF first = fx.noUpdates()->pointsVector().front();
  const QPoint at = fx.positionOf(first.x(), first.y());
  QTest::mouseMove(fx.viewport(), at + QPoint(0, -30));
  QTest::mouseMove(fx.viewport(), at);
  QTRY_VERIFY(QToolTip::isVisible());
  QCOMPARE(QToolTip::text(), text);
  QVERIFY(plots->grab().save(ScreenshotPath(QStringLiteral("calibration_plots_no_update.png"))));
}

void CalibrationPlotsTest::zoomPanSeekAndCursor() {
  const auto plots = ShowPlots();
  QVERIFY(plots);
  CalibrationChart& fx = *plots->chart(kFx);
  const double t0 = plots->visibleStart();
  const double t1 = plots->visibleEnd();
  QVERIFY(t0 < 0.0);
  QVERIFY(t1 > kLastAt - 1);

  // The wheel zooms in around the time under the mouse, in every chart.
  const QPoint at = fx.positionOf(
      30.0, fx.valueAxis()->min() + 0.5 * (fx.valueAxis()->max() - fx.valueAxis()->min()));
  QWheelEvent wheel(at, fx.viewport()->mapToGlobal(at), QPoint(), QPoint(0, 240), Qt::NoButton,
                    Qt::NoModifier, Qt::NoScrollPhase, false);
  QApplication::sendEvent(fx.viewport(), &wheel);
  const double zoomed = plots->visibleEnd() - plots->visibleStart();
  QVERIFY(std::abs(zoomed - (t1 - t0) / 1.5625) < 1e-6 * (t1 - t0));
  QVERIFY(plots->visibleStart() < 30.0 && plots->visibleEnd() > 30.0);
  plots->redrawNow();
  for (int channel = 0; channel < kNumCalibrationChannels; ++channel) {
    QCOMPARE(plots->chart(channel)->timeAxis()->min(), plots->visibleStart());
    QCOMPARE(plots->chart(channel)->timeAxis()->max(), plots->visibleEnd());
  }
  // Fewer attempts in view: fewer drawn.
  QVERIFY(fx.markers(MarkerClass::kAccepted)->count() < 45);

  // Dragging pans: what was under the mouse stays under it.
  const double before = plots->visibleStart();
  const QPoint from = fx.positionOf(30.0, 0.5 * (fx.valueAxis()->min() + fx.valueAxis()->max()));
  const QPoint to = from + QPoint(-120, 0);
  QTest::mousePress(fx.viewport(), Qt::LeftButton, Qt::NoModifier, from);
  QMouseEvent move(QEvent::MouseMove, to, fx.viewport()->mapToGlobal(to), Qt::NoButton,
                   Qt::LeftButton, Qt::NoModifier);
  QApplication::sendEvent(fx.viewport(), &move);
  QTest::mouseRelease(fx.viewport(), Qt::LeftButton, Qt::NoModifier, to);
  plots->redrawNow();
  QVERIFY(plots->visibleStart() > before);
  QVERIFY(std::abs(fx.chart()->mapToValue(fx.chart()->mapFromScene(fx.mapToScene(to))).x() - 30.0) <
          0.05 * zoomed);

  // A click asks to go to its time; the cursor is drawn where it is set, in every chart.
  QSignalSpy seek(plots.get(), &CalibrationPlots::seekRequested);
  const QPoint click = fx.positionOf(
      33.0, fx.valueAxis()->min() + 0.1 * (fx.valueAxis()->max() - fx.valueAxis()->min()));
  QTest::mouseClick(fx.viewport(), Qt::LeftButton, Qt::NoModifier, click);
  QCOMPARE(seek.count(), 1);
  const double asked = seek.at(0).at(0).toDouble();
  QVERIFY2(std::abs(asked - 33.0) < 0.2, qPrintable(QString::number(asked)));
  plots->setCursorTime(asked);
  plots->redrawNow();
  for (int channel = 0; channel < kNumCalibrationChannels; ++channel) {
    QCOMPARE(plots->chart(channel)->cursor()->at(0).x(), asked);
  }

  // A double-click shows everything again.
  QTest::mouseDClick(fx.viewport(), Qt::LeftButton, Qt::NoModifier, click);
  QCOMPARE(plots->visibleStart(), t0);
  QCOMPARE(plots->visibleEnd(), t1);
}

void CalibrationPlotsTest::exportsPngAndSvg() {
  const auto plots = ShowPlots();
  QVERIFY(plots);
  QString error;
  const QString png = dir_.filePath(QStringLiteral("plots.png"));
  QVERIFY2(plots->exportImage(png, &error), qPrintable(error));
  const QImage image(png);
  QVERIFY(!image.isNull());
  QVERIFY(image.width() > 1000);
  QVERIFY(CountColor(image, MarkerColor(MarkerClass::kAccepted)) > 500);
  QVERIFY(CountColor(image, MarkerColor(MarkerClass::kRejected)) > 50);

  const QString svg = dir_.filePath(QStringLiteral("plots.svg"));
  QVERIFY2(plots->exportImage(svg, &error), qPrintable(error));
  QFile file(svg);
  QVERIFY(file.open(QIODevice::ReadOnly));
  const QByteArray text = file.readAll();
  QVERIFY(text.contains("<svg"));
  QVERIFY(text.contains("fx (px)"));  // Axis titles are text, not pixels.
  QSvgRenderer renderer(svg);
  QVERIFY(renderer.isValid());
  QImage rendered(image.size(), QImage::Format_RGB32);
  rendered.fill(Qt::white);
  QPainter painter(&rendered);
  renderer.render(&painter);
  painter.end();
  QVERIFY(CountColor(rendered, MarkerColor(MarkerClass::kAccepted)) > 500);
  QVERIFY(CountColor(rendered, MarkerColor(MarkerClass::kRejected)) > 50);

  QVERIFY(!plots->exportImage(dir_.filePath(QStringLiteral("plots.bmpx")), &error));
  QVERIFY(error.contains(QStringLiteral(".svg")));
  QVERIFY(!plots->exportImage(QStringLiteral("/nonexistent/folder/plots.png"), &error));
}

void CalibrationPlotsTest::tableFiltersAndSorts() {
  HistoryTable table;
  table.resize(1400, 600);
  table.setSeries(series_);
  table.show();
  QVERIFY(QTest::qWaitForWindowExposed(&table));
  const int all = static_cast<int>(series_->stored.attempts.size());
  QCOMPARE(table.filter()->rowCount(), all);

  for (const auto& [verdict, count] : history_.counts) {
    table.setVerdictFilter(verdict);
    QCOMPARE(table.filter()->rowCount(), count);
    for (int row = 0; row < table.filter()->rowCount(); ++row) {
      QCOMPARE(table.filter()->index(row, HistoryTableModel::kVerdict).data().toString(),
               QString::fromStdString(VerdictName(verdict)));
    }
  }
  // Text and verdict together: the rejected attempts whose reason names the RMS.
  table.setVerdictFilter(Verdict::kRejected);
  table.setTextFilter(QStringLiteral("reprojection rms"));
  QCOMPARE(table.filter()->rowCount(), 1);
  QCOMPARE(table.filter()->index(0, HistoryTableModel::kRms).data().toString(),
           QStringLiteral("2.500"));
  // The combo box and the line edit are the filters' controls.
  QCOMPARE(table.findChild<QComboBox*>()->currentText(), QStringLiteral("rejected"));
  QCOMPARE(table.findChild<QLineEdit*>()->text(), QStringLiteral("reprojection rms"));
  table.setVerdictFilter(std::nullopt);
  table.setTextFilter(QStringLiteral("insufficient rotation"));
  QCOMPARE(table.filter()->rowCount(), history_.counts[Verdict::kNoUpdate]);
  // No-updates have no estimate to show.
  QCOMPARE(table.filter()->index(0, HistoryTableModel::kFirstIntrinsic).data().toString(),
           QString());
  table.setTextFilter(QString());
  QCOMPARE(table.filter()->rowCount(), all);

  // Sorted by RMS, largest first: the high-RMS attempt leads.
  table.view()->sortByColumn(HistoryTableModel::kRms, Qt::DescendingOrder);
  QCOMPARE(table.filter()->index(0, HistoryTableModel::kTime).data().toString(),
           QStringLiteral("%1.000").arg(kHighRmsAt - 1));
  table.view()->sortByColumn(HistoryTableModel::kTime, Qt::AscendingOrder);

  // Double-clicking a row asks to go to its time.
  QSignalSpy seek(&table, &HistoryTable::seekRequested);
  const QModelIndex row = table.filter()->index(3, HistoryTableModel::kVerdict);
  const QRect cell = table.view()->visualRect(row);
  // Qt 5's double-click needs the press of a first click on the same cell.
  QTest::mouseClick(table.view()->viewport(), Qt::LeftButton, Qt::NoModifier, cell.center());
  QTest::mouseDClick(table.view()->viewport(), Qt::LeftButton, Qt::NoModifier, cell.center());
  QCOMPARE(seek.count(), 1);
  QCOMPARE(seek.at(0).at(0).toDouble(), 3.0);  // Rows 0-2 are at 0, 1 and 2 s.

  table.setVerdictFilter(Verdict::kRejected);
  QVERIFY(table.grab().save(ScreenshotPath(QStringLiteral("history_table_rejected.png")), "PNG"));
  table.setVerdictFilter(std::nullopt);
  QVERIFY(table.grab().save(ScreenshotPath(QStringLiteral("history_table.png")), "PNG"));
}

void CalibrationPlotsTest::tableExportsHistoryAndCalibration() {
  HistoryTable table;
  table.setSeries(series_);
  QString error;

  // The rows shown, in CSV, read back as they were stored.
  table.setVerdictFilter(Verdict::kRejected);
  const QString csv = dir_.filePath(QStringLiteral("rejected.csv"));
  QVERIFY2(table.exportHistory(csv, HistoryFormat::kCsv, &error), qPrintable(error));
  const std::vector<HistoryEntry> read = ReadHistoryCsv(csv.toStdString());
  QCOMPARE(static_cast<int>(read.size()), history_.counts[Verdict::kRejected]);
  for (const HistoryEntry& entry : read) {
    QCOMPARE(entry.verdict, std::string("rejected"));
    const auto stored =
        std::find_if(series_->stored.attempts.begin(), series_->stored.attempts.end(),
                     [&](const AttemptRecord& r) { return r.t_ns == entry.t_ns; });
    QVERIFY(stored != series_->stored.attempts.end());
    QCOMPARE(entry.fx, stored->estimate.fx);
    QCOMPARE(entry.k1, stored->estimate.k1);
    QCOMPARE(entry.rms_px, stored->rms_px);
    QCOMPARE(entry.reason, stored->reason);
  }
  table.setVerdictFilter(std::nullopt);
  const QString json = dir_.filePath(QStringLiteral("history.json"));
  QVERIFY2(table.exportHistory(json, HistoryFormat::kJson, &error), qPrintable(error));
  QFile json_file(json);
  QVERIFY(json_file.open(QIODevice::ReadOnly));
  const QByteArray json_text = json_file.readAll();
  QVERIFY(json_text.contains("\"history\""));
  QCOMPARE(static_cast<size_t>(json_text.count("\"verdict\"")), series_->stored.attempts.size());

  // The current calibration in every format, read back.
  const CameraIntrinsics current = table.currentCalibration();
  QCOMPARE(current, series_->current.calibration);
  QVERIFY(std::abs(current.fx - Truth(kLastAt).fx) < 1.0);
  for (const std::string& name : CalibrationFormatNames()) {
    const QString path =
        dir_.filePath(QStringLiteral("calibration_%1.txt").arg(QString::fromStdString(name)));
    QVERIFY2(table.exportCalibration(path, CalibrationFormatFromName(name), &error),
             qPrintable(error));
    CalibrationFormat found{};
    const CameraIntrinsics back = ReadCalibration(path.toStdString(), &found);
    QCOMPARE(found, CalibrationFormatFromName(name));
    for (int i = 0; i < kNumIntrinsics; ++i) {
      QVERIFY2(std::abs(back.Packed()[i] - current.Packed()[i]) <=
                   1e-9 * (1.0 + std::abs(current.Packed()[i])),
               qPrintable(QStringLiteral("%1 %2").arg(QString::fromStdString(name)).arg(i)));
    }
    QCOMPARE(back.width, current.width);
  }
  QVERIFY(!table.exportCalibration(QStringLiteral("/nonexistent/folder/c.yaml"),
                                   CalibrationFormat::kOpenCv, &error));
  QVERIFY2(error.contains(QStringLiteral("/nonexistent/folder/c.yaml")), qPrintable(error));
}

void CalibrationPlotsTest::mainWindowOpensHistory() {
  MainWindow window;
  window.resize(1500, 1000);
  window.show();
  QVERIFY(QTest::qWaitForWindowExposed(&window));
  QSignalSpy failed(&window, &MainWindow::historyFailed);
  window.openHistory(dir_.filePath(QStringLiteral("missing.sqlite")));
  QVERIFY(failed.wait(kOpenTimeoutMs));
  QVERIFY(window.calibrationPlots()->series() == nullptr);

  QSignalSpy opened(&window, &MainWindow::historyOpened);
  window.openHistory(history_.path);
  QVERIFY(opened.wait(kOpenTimeoutMs));
  QCOMPARE(window.calibrationPlots()->series()->stored.attempts.size(),
           series_->stored.attempts.size());
  QCOMPARE(window.historyTable()->filter()->rowCount(),
           static_cast<int>(series_->stored.attempts.size()));
  // The plots are raised and drawn in the window.
  QTRY_VERIFY(window.calibrationPlots()->isVisible());
  QTest::qWait(200);
  const QImage shot = window.grab().toImage();
  QVERIFY(shot.save(ScreenshotPath(QStringLiteral("workbench_history.png")), "PNG"));
  QVERIFY(CountColor(shot, MarkerColor(MarkerClass::kAccepted)) > 300);

  // Without a recording, seeking in the plots moves their cursor.
  CalibrationChart& fx = *window.calibrationPlots()->chart(kFx);
  QTest::mouseClick(fx.viewport(), Qt::LeftButton, Qt::NoModifier,
                    fx.positionOf(12.0, fx.valueAxis()->min()) + QPoint(0, -5));
  QVERIFY(std::abs(window.calibrationPlots()->cursorTime() - 12.0) < 0.3);
}

void CalibrationPlotsTest::followsAHistoryBeingWritten() {
  // A run appending to its history while the workbench shows it.
  const QString path = dir_.filePath(QStringLiteral("growing.sqlite"));
  CalibrationHistory history(Premission());
  HistoryStore store(path.toStdString());
  int second = 0;
  auto append = [&](int count) {
    for (int i = 0; i < count; ++i) {
      ++second;
      SelfCalibrationResult r;
      r.usable = true;
      r.estimate = Truth(second);
      r.covariance = Eigen::MatrixXd::Identity(2, 2) * 0.09;
      r.free_parameters = {kFx, kCx};
      r.rms_px = 0.4;
      history.Judge(kStartNs + second * kSecond, r);
      store.Record(history);
    }
  };
  append(10);

  MainWindow window;
  window.resize(1500, 1000);
  window.show();
  QVERIFY(QTest::qWaitForWindowExposed(&window));
  QSignalSpy opened(&window, &MainWindow::historyOpened);
  window.openHistory(path);
  QVERIFY(opened.wait(kOpenTimeoutMs));
  CalibrationPlots& plots = *window.calibrationPlots();
  QCOMPARE(plots.series()->stored.attempts.size(), size_t{10});

  // Showing the whole history: the view grows with it.
  append(10);
  QTRY_COMPARE_WITH_TIMEOUT(plots.series()->stored.attempts.size(), size_t{20},
                            5 * HistoryOpener::kFollowIntervalMs);
  QCOMPARE(window.historyTable()->filter()->rowCount(), 20);
  QVERIFY(plots.visibleEnd() > 19.0);
  QCOMPARE(plots.chart(kFx)->markers(MarkerClass::kAccepted)->count() +
               plots.chart(kFx)->markers(MarkerClass::kRejected)->count(),
           20);

  // Zoomed in: the view stays where the user put it.
  plots.setVisibleRange(2.0, 8.0);
  append(5);
  QTRY_COMPARE_WITH_TIMEOUT(plots.series()->stored.attempts.size(), size_t{25},
                            5 * HistoryOpener::kFollowIntervalMs);
  QCOMPARE(plots.visibleStart(), 2.0);
  QCOMPARE(plots.visibleEnd(), 8.0);
  QCOMPARE(window.historyTable()->filter()->rowCount(), 25);
  // Opening was announced once; the updates are not new openings.
  QCOMPARE(opened.count(), 1);
}

// The workbench's own run: the recording sets the time origin and its ground truth the
// time range from the start, so the attempts that come in change neither; they must be
// drawn all the same (they were not: resetting to an unchanged range redrew nothing).
void CalibrationPlotsTest::drawsAttemptsThatComeWithinTheTimeRange() {
  CalibrationPlots plots;
  plots.resize(1400, 1000);
  plots.setTimeOrigin(kStartNs + kSecond);
  auto truth = history_.truth;  // The recording runs a little before and after the attempts.
  truth.insert(truth.begin(), {truth.front().first - 5 * kSecond, truth.front().second});
  truth.emplace_back(truth.back().first + 5 * kSecond, truth.back().second);
  plots.setGroundTruth(truth);
  auto started = std::make_shared<CalibrationSeries>(*series_);
  started->stored.attempts.clear();
  started->stored.alarms.clear();
  started->trend.clear();
  plots.setSeries(started);
  plots.show();
  QVERIFY(QTest::qWaitForWindowExposed(&plots));
  plots.redrawNow();
  QCOMPARE(plots.chart(kFx)->markers(MarkerClass::kAccepted)->count(), 0);
  const double start = plots.visibleStart(), end = plots.visibleEnd();

  plots.setSeries(series_);
  QCOMPARE(plots.visibleStart(), start);
  QCOMPARE(plots.visibleEnd(), end);
  const int accepted = static_cast<int>(std::count_if(
      series_->stored.attempts.begin(), series_->stored.attempts.end(),
      [](const AttemptRecord& r) { return r.verdict == Verdict::kAccepted; }));
  QVERIFY(accepted > 0);
  QTRY_COMPARE(plots.chart(kFx)->markers(MarkerClass::kAccepted)->count(), accepted);
}

void CalibrationPlotsTest::decimatesHoursOfHistory() {
  // Two hours at one attempt a second, judged in memory (the file adds nothing here).
  constexpr int kAttempts = 2 * 3600;
  CalibrationHistory history(Premission());
  std::mt19937 random(3);
  std::normal_distribution<double> normal;
  QElapsedTimer clock;
  clock.start();
  for (int i = 0; i < kAttempts; ++i) {
    SelfCalibrationResult r;
    r.usable = true;
    r.estimate = Truth(0);
    r.estimate.fx += 0.3 * normal(random) + (i % 97 == 0 ? 30.0 : 0.0);
    r.estimate.cx += 0.5 * normal(random);
    r.covariance = Eigen::MatrixXd::Identity(3, 3) * 0.25;
    r.free_parameters = {kFx, kFy, kCx};
    r.rms_px = 0.4;
    history.Judge(kStartNs + static_cast<int64_t>(i) * kSecond, r);
  }
  StoredHistory stored;
  stored.premission = Premission();
  stored.attempts = history.attempts();
  stored.alarms = history.alarms();
  stored.regimes = history.regimes();
  const qint64 judge_ms = clock.restart();
  auto series = std::make_shared<CalibrationSeries>(MakeCalibrationSeries(std::move(stored)));
  qInfo("%d attempts: judged in %lld ms, replayed with a %zu-point trend in %lld ms", kAttempts,
        judge_ms, series->trend.size(), clock.elapsed());
  QCOMPARE(series->trend.size(), static_cast<size_t>(kMaxTrendSamples));

  CalibrationPlots plots;
  plots.resize(1400, 1000);
  plots.show();
  QVERIFY(QTest::qWaitForWindowExposed(&plots));
  plots.setSeries(series);
  QTest::qWait(50);
  plots.redrawNow();
  // What a redraw costs is workbench_bench's CalibrationPlotsRedraw; what keeps it cheap is
  // that no chart draws more than two points a pixel column.
  CalibrationChart& fx = *plots.chart(kFx);
  const int columns = static_cast<int>(fx.chart()->plotArea().width());
  QVERIFY(fx.markers(MarkerClass::kAccepted)->count() <= 2 * columns);
  QVERIFY(fx.trend()->count() <= 2 * columns);
  // Decimation keeps the extremes: the outliers still set the top of the scale.
  double highest = 0.0;
  for (const AttemptRecord& r : series->stored.attempts) highest = std::max(highest, r.estimate.fx);
  QVERIFY(fx.valueAxis()->max() >= highest);
}

// The value axes' labels, read from the chart's scene: every one whole (Qt Charts elides a
// label its layout has no room for, "20..."), and at least two per chart. The history is
// one like a short simulated run's: fy and cy nearly flat (ticks 0.01 apart), the distortion
// small, p1, p2, k3 held at 0; shown at the Calibration dock's size in a new window.
void CalibrationPlotsTest::valueLabelsAreWhole() {
  CameraIntrinsics premission = Premission();
  premission.width = 320;
  premission.height = 240;
  premission.fx = 207.6;
  premission.fy = 208.02;
  premission.cx = 161.6;
  premission.cy = 112.03;
  premission.k1 = -0.0123;
  premission.k2 = 0.0005;
  CalibrationHistory history(premission);
  std::mt19937 random(11);
  std::normal_distribution<double> normal;
  for (int i = 0; i < 20; ++i) {
    SelfCalibrationResult r;
    r.usable = true;
    r.estimate = premission;
    r.estimate.fx = 207.5 + 0.5 * normal(random);
    r.estimate.fy = 208.02 + 0.01 * normal(random);
    r.estimate.cx = 162.0 + 0.5 * normal(random);
    r.estimate.cy = 112.03 + 0.01 * normal(random);
    r.estimate.k1 = -0.0123 + 0.0004 * normal(random);
    r.estimate.k2 = 0.00051 + 0.0001 * normal(random);
    r.covariance = Eigen::MatrixXd::Identity(6, 6) * 1e-4;
    r.free_parameters = {kFx, kFy, kCx, kCy, kK1, kK2};
    r.rms_px = 0.31 + 0.002 * normal(random);
    history.Judge(kStartNs + static_cast<int64_t>(i) * kSecond / 2, r);
  }
  StoredHistory stored;
  stored.premission = premission;
  stored.attempts = history.attempts();
  stored.alarms = history.alarms();
  stored.regimes = history.regimes();
  // A run's history is followed as it grows: first its opening attempt alone (a flat
  // series, whole-number ticks), then all of it.
  StoredHistory opening = stored;
  opening.attempts.resize(1);
  auto first = std::make_shared<CalibrationSeries>(MakeCalibrationSeries(std::move(opening)));
  auto series = std::make_shared<CalibrationSeries>(MakeCalibrationSeries(std::move(stored)));
  QStringList failures;
  for (const QSize size : {QSize(1440, 300), QSize(1400, 1000)}) {
    // In a tab behind another the plots are not redrawn; they are when brought forward.
    QTabWidget tabs;
    tabs.resize(size);
    auto* plots_owned = new CalibrationPlots;
    CalibrationPlots& plots = *plots_owned;
    tabs.addTab(new QWidget, QStringLiteral("in front"));
    tabs.addTab(plots_owned, QStringLiteral("Calibration"));
    tabs.show();
    QVERIFY(QTest::qWaitForWindowExposed(&tabs));
    plots.setSeries(first);
    QTest::qWait(50);
    plots.setSeries(series);
    QTest::qWait(50);
    tabs.setCurrentIndex(1);
    QTest::qWait(300);
    QVERIFY(plots.grab().save(ScreenshotPath(
        QStringLiteral("calibration_plots_%1x%2.png").arg(size.width()).arg(size.height()))));
    for (int channel = 0; channel < kNumCalibrationChannels; ++channel) {
      CalibrationChart& chart = *plots.chart(channel);
      const QRectF plot_area = chart.chart()->plotArea();
      QStringList labels;
      for (const QGraphicsItem* item : chart.scene()->items()) {
        const auto* text = dynamic_cast<const QGraphicsTextItem*>(item);
        if (!text || !text->isVisible() || text->toPlainText().isEmpty()) continue;
        // Value labels sit left of the plot area, within its height.
        const QRectF box = text->sceneBoundingRect();
        if (box.right() > plot_area.left() + 1 || box.center().y() < plot_area.top() - 1 ||
            box.center().y() > plot_area.bottom() + 1 || box.width() > box.height() * 12) {
          continue;
        }
        labels << text->toPlainText();
      }
      const QString where = QStringLiteral("%1 at %2x%3 (plot %5 px high): %4")
                                .arg(ChannelName(channel))
                                .arg(size.width())
                                .arg(size.height())
                                .arg(labels.join(QStringLiteral(", ")))
                                .arg(plot_area.height());
      qInfo("%s", qPrintable(where));
      const bool elided = std::any_of(labels.begin(), labels.end(), [](const QString& label) {
        return label.contains(QStringLiteral("...")) || label.contains(QChar(0x2026));
      });
      // Two values and the axis title at least.
      if (labels.size() < 3 || elided) failures << where;
    }
  }
  QVERIFY2(failures.isEmpty(), qPrintable(failures.join(QLatin1Char('\n'))));
}

// A time is one vertical line down a column of charts (the cursor, an alarm), however wide
// each chart's value labels are: fx's "417.2" against k1's "-0.0123".
void CalibrationPlotsTest::timeAxesLineUpDownEachColumn() {
  const auto plots = ShowPlots();
  QVERIFY(plots);
  const double t_s = 0.5 * (plots->visibleStart() + plots->visibleEnd());
  for (int column = 0; column < 2; ++column) {
    QList<int> xs;
    QStringList where;
    for (int channel = column; channel < kNumCalibrationChannels; channel += 2) {
      const CalibrationChart& chart = *plots->chart(channel);
      const int x = chart.mapTo(plots.get(), chart.positionOf(t_s, 0.0)).x();
      xs << x;
      where << QStringLiteral("%1 at %2 px").arg(ChannelName(channel)).arg(x);
    }
    const auto [lo, hi] = std::minmax_element(xs.begin(), xs.end());
    QVERIFY2(*hi - *lo <= 1, qPrintable(where.join(QStringLiteral(", "))));
  }
}

}  // namespace autocal

QTEST_MAIN(autocal::CalibrationPlotsTest)
#include "calibration_plots_test.moc"
