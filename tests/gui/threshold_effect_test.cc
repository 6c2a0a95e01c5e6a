// A threshold changed in the workbench's panel while the pipeline runs changes the
// pipeline's output from a frame shortly after, and not before (issue 8: "change a
// threshold and see the pipeline's output change").
#include <algorithm>
#include <memory>
#include <optional>
#include <vector>

#include <QImage>
#include <QSettings>
#include <QSignalSpy>
#include <QTemporaryDir>
#include <QtTest>

#include "pipeline/calibration_pipeline.h"
#include "tests/gui/screenshot.h"
#include "widgets/main_window.h"
#include "widgets/pipeline_controller.h"
#include "widgets/threshold_panel.h"

namespace autocal {
namespace {

constexpr int kOpenTimeoutMs = 120000;
constexpr int kRunTimeoutMs = 600000;

double ShortestLine(const FrameSnapshot& snapshot) {
  double shortest = 1e9;
  for (const LineSegment& line : snapshot.lens.lines) shortest = std::min(shortest, line.Length());
  return shortest;
}

}  // namespace

class ThresholdEffectTest : public QObject {
  Q_OBJECT

 private slots:
  void initTestCase() {
    QVERIFY(settings_dir_.isValid());
    QSettings::setDefaultFormat(QSettings::IniFormat);
    QSettings::setPath(QSettings::IniFormat, QSettings::UserScope, settings_dir_.path());
    QCoreApplication::setOrganizationName(QStringLiteral("autocal-test"));
    QCoreApplication::setApplicationName(QStringLiteral("threshold_effect_test"));
  }

  void aChangeReachesTheRunningPipeline() {
    MainWindow window;
    window.resize(1400, 900);
    window.show();
    QVERIFY(QTest::qWaitForWindowExposed(&window));

    std::vector<std::shared_ptr<const FrameSnapshot>> snapshots;
    std::optional<int64_t> changed_after;  // The newest frame seen when the change was made.
    const double before = window.pipelineController()->options().lens.lines.min_length_px;
    const double longer = before + 40.0;
    // A segment's ends come from the edge points fitted along it, a pixel or two inside the
    // run that passed the minimum: lines under halfway to the new minimum must vanish.
    const double vanishing = before + 20.0;
    connect(&window, &MainWindow::snapshotReady, &window,
            [&](const std::shared_ptr<const FrameSnapshot>& snapshot) {
              snapshots.push_back(snapshot);
              if (changed_after || snapshot->index < 10) return;
              // What a user does in the Thresholds dock: the panel emits checked options.
              PipelineOptions tuned = window.pipelineController()->options();
              tuned.lens.lines.min_length_px = longer;
              changed_after = snapshot->index;
              emit window.thresholdPanel()->optionsChanged(tuned);
            });
    QSignalSpy finished(window.pipelineController(), &PipelineController::finished);
    QSignalSpy opened(&window, &MainWindow::opened);
    window.open(QStringLiteral("sim:office,seconds=8,resolution=320x240"));
    QVERIFY(opened.wait(kOpenTimeoutMs));
    QVERIFY(finished.wait(kRunTimeoutMs));
    QVERIFY(changed_after.has_value());
    window.grab().toImage().save(ScreenshotPath(QStringLiteral("threshold_effect.png")));

    // The change reaches the runtime while the GUI is some frames behind it, so where it
    // takes effect is found: the first frame from which no line is that short. Before the
    // change there were such lines; from that frame on there are none.
    std::sort(snapshots.begin(), snapshots.end(),
              [](const auto& a, const auto& b) { return a->index < b->index; });
    int64_t effective = -1;  // None yet.
    for (const auto& snapshot : snapshots) {
      if (ShortestLine(*snapshot) < vanishing) {
        effective = -1;
      } else if (effective < 0) {
        effective = snapshot->index;
      }
    }
    const int shorter_before = static_cast<int>(
        std::count_if(snapshots.begin(), snapshots.end(), [&](const auto& snapshot) {
          return snapshot->index <= *changed_after && ShortestLine(*snapshot) < vanishing;
        }));
    QVERIFY(effective >= 0);
    qInfo("changed when the GUI had frame %lld; in effect from frame %lld of %zu; %d frames "
          "before the change had shorter lines",
          static_cast<long long>(*changed_after), static_cast<long long>(effective),
          snapshots.size(), shorter_before);
    QVERIFY(shorter_before > 0);
    QVERIFY(effective > *changed_after);
    QVERIFY2(static_cast<int64_t>(snapshots.size()) - effective >= 60,
             "the change took effect while the run still had most of its frames to go");
  }

 private:
  QTemporaryDir settings_dir_;
};

}  // namespace autocal

QTEST_MAIN(autocal::ThresholdEffectTest)
#include "threshold_effect_test.moc"
