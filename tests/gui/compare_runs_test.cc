// Compare runs in the calibration plots (under Xvfb): two real histories of the same short
// simulated walk, written by RunSequence (what `autocal run --history` runs) with the
// default settings and with a settings file, are opened and drawn over each other; the
// compared run's attempts and trend are checked at the pixels the chart maps them to.
#include <cmath>
#include <memory>

#include <QAction>
#include <QFile>
#include <QLabel>
#include <QSignalSpy>
#include <QTemporaryDir>
#include <QtTest>

#include "devices/offline_runner.h"
#include "devices/sim/simulator.h"
#include "pipeline/option_fields.h"
#include "widgets/calibration_plots.h"
#include "widgets/calibration_series.h"
#include "pixels.h"
#include "screenshot.h"

namespace autocal {
namespace {

constexpr int kOpenTimeoutMs = 30000;
constexpr char kWalk[] = "office,lens=tessar,resolution=320x240,seconds=4";

std::shared_ptr<const CalibrationSeries> Open(const QString& path) {
  HistoryOpener opener;
  std::shared_ptr<const CalibrationSeries> series;
  QObject::connect(&opener, &HistoryOpener::opened,
                   [&](const QString&, std::shared_ptr<const CalibrationSeries> opened) {
                     series = std::move(opened);
                   });
  opener.open(path);
  if (!QTest::qWaitFor([&] { return series != nullptr; }, kOpenTimeoutMs)) return nullptr;
  return series;
}

}  // namespace

class CompareRunsTest : public QObject {
  Q_OBJECT

 private slots:
  void initTestCase();
  void bothRunsAreDrawnAndNamed();
  void aBadFileIsRefused();

 private:
  QTemporaryDir dir_;
  QString a_, b_;
};

void CompareRunsTest::initTestCase() {
  QVERIFY(dir_.isValid());
  const std::unique_ptr<Sequence> sequence = MakeSimulatedSequence(ParseScenarioSpec(kWalk));
  a_ = dir_.filePath("default.sqlite");
  b_ = dir_.filePath("no_distortion.sqlite");
  RunSettings a;
  a.history_path = a_.toStdString();
  RunSequence(*sequence, a);

  // The second run's settings come from a settings file, as `autocal run --settings` reads.
  const QString settings = dir_.filePath("no_distortion.txt");
  QFile file(settings);
  QVERIFY(file.open(QIODevice::WriteOnly));
  file.write("calibration.estimate_distortion = false\nmaterial.attempt_every_s = 0.7\n");
  file.close();
  RunSettings b;
  b.pipeline = ReadPipelineSettings(settings.toStdString());
  b.history_path = b_.toStdString();
  RunSequence(*sequence, b);
}

void CompareRunsTest::bothRunsAreDrawnAndNamed() {
  const auto a = Open(a_);
  const auto b = Open(b_);
  QVERIFY(a && b);
  QVERIFY(!a->stored.attempts.empty() && !b->stored.attempts.empty());

  CalibrationPlots plots;
  plots.resize(1400, 1000);
  plots.setSeries(a);
  QSignalSpy failed(&plots, &CalibrationPlots::compareFailed);
  QVERIFY(!plots.clearCompareAction()->isEnabled());
  plots.openCompare(b_);  // As File › Compare With History… does after its dialog.
  QTRY_VERIFY_WITH_TIMEOUT(plots.compareSeries() != nullptr, kOpenTimeoutMs);
  QCOMPARE(failed.count(), 0);
  QCOMPARE(plots.compareSeries()->stored.attempts.size(), b->stored.attempts.size());
  QVERIFY(plots.clearCompareAction()->isEnabled());
  plots.show();
  QVERIFY(QTest::qWaitForWindowExposed(&plots));
  plots.redrawNow();
  QTest::qWait(50);

  // Both runs named, the compared one on its own legend line.
  bool named_a = false, named_b = false;
  for (const QLabel* label : plots.findChildren<QLabel*>()) {
    named_a |= label->text().contains("default.sqlite");
    named_b |= label->text().contains("compared with") && label->text().contains("no_distortion.sqlite");
  }
  QVERIFY(named_a && named_b);

  // fx: the compared run's taken attempts as hollow circles and its trend, over the first's.
  CalibrationChart& fx = *plots.chart(kFx);
  int taken = 0;
  for (const AttemptRecord& r : b->stored.attempts) {
    taken += r.verdict == Verdict::kAccepted || r.verdict == Verdict::kAlarm ||
             r.verdict == Verdict::kNewRegime;
  }
  QVERIFY2(taken > 0, "the compared run took an attempt");
  QCOMPARE(fx.compareMarkers()->count(), taken);
  QCOMPARE(fx.compareTrend()->count(), int(b->trend.size()));
  QVERIFY(fx.trend()->count() > 0);
  // k1: the compared run held the distortion, so it marks nothing there.
  QCOMPARE(plots.chart(kK1)->compareMarkers()->count(), 0);

  const QImage image = fx.grab().toImage();
  plots.grab().save(ScreenshotPath("compare_runs.png"));
  for (const QPointF& p : fx.compareMarkers()->points()) {
    QVERIFY2(DrawnNear(image, fx.positionOf(p.x(), p.y()), CompareColor(), 6),
             qPrintable(QString("compared attempt at %1 s").arg(p.x())));
  }
  const QPointF mid = fx.compareTrend()->at(fx.compareTrend()->count() / 2);
  const QPointF first_mid = fx.trend()->at(fx.trend()->count() / 2);
  QVERIFY(DrawnNear(image, fx.positionOf(mid.x(), mid.y()), CompareColor(), 2) ||
          DrawnNear(image, fx.positionOf(mid.x(), mid.y()), TrendColor(), 2));
  QVERIFY(DrawnNear(image, fx.positionOf(first_mid.x(), first_mid.y()), TrendColor(), 2));

  // Cleared: the first run alone.
  plots.clearCompareAction()->trigger();
  QVERIFY(!plots.compareSeries());
  plots.redrawNow();
  QCOMPARE(fx.compareMarkers()->count(), 0);
  QCOMPARE(fx.compareTrend()->count(), 0);
  QVERIFY(fx.trend()->count() > 0);
}

void CompareRunsTest::aBadFileIsRefused() {
  CalibrationPlots plots;
  plots.setSeries(Open(a_));
  QSignalSpy failed(&plots, &CalibrationPlots::compareFailed);
  const QString missing = dir_.filePath("missing.sqlite");
  plots.openCompare(missing);
  QVERIFY(failed.wait(kOpenTimeoutMs));
  QVERIFY2(failed.at(0).at(1).toString().contains(missing),
           qPrintable(failed.at(0).at(1).toString()));
  QVERIFY(!plots.compareSeries());
}

}  // namespace autocal

QTEST_MAIN(autocal::CompareRunsTest)
#include "compare_runs_test.moc"
