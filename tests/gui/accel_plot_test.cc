// The accelerometer plot in a real window: its curves are the samples in the time window
// around the cursor, replaced when the window scrolls and left alone while only the cursor
// moves (a replaced curve is stroked again, which cost the GUI thread more than the video).
#include <cmath>
#include <vector>

#include <QSignalSpy>
#include <QtTest>

#include "devices/sequence.h"
#include "widgets/accel_plot.h"

namespace autocal {

namespace {

constexpr double kRateHz = 100.0;

// a_x(t) = slope t, so a curve point's value says which sample, of which recording, it is.
std::vector<AccelSample> Ramp(double seconds, double slope) {
  std::vector<AccelSample> samples;
  for (int i = 0; i <= static_cast<int>(seconds * kRateHz); ++i) {
    const double t = i / kRateHz;
    samples.push_back({static_cast<int64_t>(std::llround(t * 1e9)), {slope * t, 0.0, 9.81}});
  }
  return samples;
}

QLineSeries* Curve(AccelPlot& plot, int axis) {
  return qobject_cast<QLineSeries*>(plot.chart()->series().at(axis));
}

}  // namespace

class AccelPlotTest : public QObject {
  Q_OBJECT

 private slots:
  void curvesFollowTheWindowAndHoldStillWithIt();
};

void AccelPlotTest::curvesFollowTheWindowAndHoldStillWithIt() {
  AccelPlot plot;
  plot.resize(900, 300);
  plot.show();
  QVERIFY(QTest::qWaitForWindowExposed(&plot));
  plot.setSamples(Ramp(60.0, 1.0), 0, 60.0);
  QCOMPARE(plot.windowSeconds(), 10.0);
  QLineSeries& a_x = *Curve(plot, 0);
  QSignalSpy replaced(&a_x, &QLineSeries::pointsReplaced);

  // A 60 s recording in a 10 s window: the window scrolls with the cursor, and the curve is
  // the samples inside it and the one beyond each edge, their values their times (min and
  // max per pixel column).
  for (const double cursor : {30.0, 45.0}) {
    const int before = replaced.count();
    plot.setCursorTime(cursor);
    QTRY_COMPARE(plot.drawnCursorTime(), cursor);
    QCOMPARE(plot.visibleStart(), cursor - 5.0);
    QCOMPARE(plot.visibleEnd(), cursor + 5.0);
    QCOMPARE(replaced.count(), before + 1);
    QVERIFY(a_x.count() > 100);
    for (const QPointF& point : a_x.points()) {
      QVERIFY2(
          point.x() >= cursor - 5.0 - 1.5 / kRateHz && point.x() <= cursor + 5.0 + 1.5 / kRateHz,
          qPrintable(QString::number(point.x())));
      QCOMPARE(point.y(), point.x());
    }
  }

  // Near the end the window holds at [50, 60]: the cursor moves, the curves stay as drawn.
  plot.setCursorTime(57.0);
  QTRY_COMPARE(plot.drawnCursorTime(), 57.0);
  QCOMPARE(plot.visibleStart(), 50.0);
  const int at_end = replaced.count();
  for (const double cursor : {58.0, 59.0, 60.0}) {
    plot.setCursorTime(cursor);
    QTRY_COMPARE(plot.drawnCursorTime(), cursor);
  }
  QCOMPARE(replaced.count(), at_end);
  QCOMPARE(plot.visibleStart(), 50.0);

  // A narrower window, or a narrower plot, draws the curves again.
  plot.setWindowSeconds(5.0);
  // (The axis keeps its range to within rounding: QTRY_COMPARE would wait for exactness.)
  QTRY_VERIFY(std::abs(plot.visibleStart() - 55.0) < 1e-9);
  QCOMPARE(replaced.count(), at_end + 1);
  QCOMPARE(a_x.points().front().y(), a_x.points().front().x());
  QVERIFY(a_x.points().front().x() >= 55.0 - 1.5 / kRateHz);
  plot.resize(600, 300);
  QTRY_COMPARE(replaced.count(), at_end + 2);

  // New samples (a live source's, a minute of them each time) are drawn even where the
  // window holds still.
  plot.setSamples(Ramp(8.0, 2.0), 0, 8.0);
  plot.setCursorTime(2.0);
  QTRY_COMPARE(plot.drawnCursorTime(), 2.0);
  QCOMPARE(plot.visibleStart(), 0.0);
  QCOMPARE(plot.visibleEnd(), 5.0);
  QCOMPARE(a_x.points().back().y(), 2.0 * a_x.points().back().x());
  const int before_new = replaced.count();
  plot.setSamples(Ramp(8.0, 3.0), 0, 8.0);
  plot.setCursorTime(2.0);
  QTRY_COMPARE(replaced.count(), before_new + 1);
  QCOMPARE(plot.visibleStart(), 0.0);
  QCOMPARE(plot.visibleEnd(), 5.0);
  QCOMPARE(a_x.points().back().y(), 3.0 * a_x.points().back().x());
  QVERIFY(a_x.points().back().x() <= 5.0 + 1.5 / kRateHz);
}

}  // namespace autocal

QTEST_MAIN(autocal::AccelPlotTest)
#include "accel_plot_test.moc"
