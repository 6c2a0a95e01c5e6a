// The threshold panel in a real window (under Xvfb): one editor per option field with its
// range and explanation, edits emitted only when the options stay valid, changed-from-default
// marks and resets, the search filter, settings files (read back by ReadPipelineSettings,
// the reader `autocal run --settings` uses) and named presets.
#include <QCheckBox>
#include <QDoubleSpinBox>
#include <QFile>
#include <QLineEdit>
#include <QSignalSpy>
#include <QSpinBox>
#include <QTemporaryDir>
#include <QtTest>

#include "pipeline/option_fields.h"
#include "widgets/threshold_panel.h"
#include "screenshot.h"

namespace autocal {
class ThresholdPanelTest : public QObject {
  Q_OBJECT

 private slots:
  void initTestCase() { qRegisterMetaType<PipelineOptions>(); }
  void everyFieldHasAnEditorWithRangeAndHelp();
  void validEditsAreEmittedInvalidOnesShownNotEmitted();
  void changedFieldsAreMarkedAndReset();
  void searchFilters();
  void settingsFilesAndPresets();
};

void ThresholdPanelTest::everyFieldHasAnEditorWithRangeAndHelp() {
  ThresholdPanel panel;
  panel.resize(600, 900);
  panel.show();
  QVERIFY(QTest::qWaitForWindowExposed(&panel));
  const PipelineOptions defaults;
  for (const OptionField& field : PipelineOptionFields()) {
    const QString name = QString::fromStdString(field.name);
    QWidget* editor = panel.editor(name);
    QVERIFY2(editor, qPrintable(name));
    QVERIFY2(editor->toolTip().contains(QString::fromStdString(field.help)), qPrintable(name));
    QVERIFY(!panel.isChanged(name));
    const double value = field.get(defaults);
    switch (field.kind) {
      case OptionField::Kind::kFlag:
        QCOMPARE(qobject_cast<QCheckBox*>(editor)->isChecked(), value != 0);
        break;
      case OptionField::Kind::kInteger: {
        auto* spin = qobject_cast<QSpinBox*>(editor);
        QVERIFY2(spin, qPrintable(name));
        QCOMPARE(spin->value(), int(value));
        QCOMPARE(spin->minimum(), int(field.min));
        break;
      }
      case OptionField::Kind::kReal: {
        auto* spin = qobject_cast<QDoubleSpinBox*>(editor);
        QVERIFY2(spin, qPrintable(name));
        QCOMPARE(spin->value(), value);  // Not rounded, however small.
        QCOMPARE(spin->minimum(), field.min);
        QCOMPARE(spin->maximum(), field.max);
        break;
      }
    }
  }
  QVERIFY(panel.grab().save(ScreenshotPath("threshold_panel.png")));
}

void ThresholdPanelTest::validEditsAreEmittedInvalidOnesShownNotEmitted() {
  ThresholdPanel panel;
  QSignalSpy changed(&panel, &ThresholdPanel::optionsChanged);

  // Typed in and confirmed, as a user does.
  auto* tracks = qobject_cast<QSpinBox*>(panel.editor("motion.flow.target_tracks"));
  tracks->selectAll();
  QTest::keyClicks(tracks, "120");
  QTest::keyClick(tracks, Qt::Key_Return);
  QCOMPARE(changed.count(), 1);
  QCOMPARE(changed.at(0).at(0).value<PipelineOptions>().motion.flow.target_tracks, 120);
  QCOMPARE(panel.options().motion.flow.target_tracks, 120);

  qobject_cast<QDoubleSpinBox*>(panel.editor("calibration.prior_distortion"))->setValue(2.5e-7);
  QCOMPARE(changed.count(), 2);
  QCOMPARE(panel.options().calibration.prior_distortion, 2.5e-7);

  qobject_cast<QCheckBox*>(panel.editor("calibration.estimate_k3"))->toggle();
  QCOMPARE(changed.count(), 3);
  QCOMPARE(panel.options().calibration.estimate_k3, !PipelineOptions{}.calibration.estimate_k3);

  // In its range but not valid with the others: refused, the reason shown, nothing emitted.
  const int quadratic = panel.options().acceptance.min_points_quadratic;
  qobject_cast<QSpinBox*>(panel.editor("acceptance.min_points_linear"))->setValue(quadratic + 5);
  QCOMPARE(changed.count(), 3);
  QCOMPARE(panel.options().acceptance.min_points_linear,
           PipelineOptions{}.acceptance.min_points_linear);
  QVERIFY2(panel.fieldError("acceptance.min_points_linear").contains("min_points_quadratic"),
           qPrintable(panel.fieldError("acceptance.min_points_linear")));
  panel.resize(600, 700);
  panel.show();
  QVERIFY(QTest::qWaitForWindowExposed(&panel));
  panel.setFilter("acceptance");
  QCoreApplication::processEvents();  // The layout follows the filter.
  QVERIFY(panel.grab().save(ScreenshotPath("threshold_panel_refused.png")));
  panel.setFilter({});
  // Fixed from the other side: taken, the error gone.
  qobject_cast<QSpinBox*>(panel.editor("acceptance.min_points_quadratic"))->setValue(quadratic + 6);
  QCOMPARE(changed.count(), 4);
  QCOMPARE(panel.options().acceptance.min_points_quadratic, quadratic + 6);
  QVERIFY(panel.fieldError("acceptance.min_points_linear").isEmpty());

  // During a run the acceptance thresholds are fixed; the rest stay editable.
  panel.setRunning(true);
  QVERIFY(!panel.editor("acceptance.max_rms_px")->isEnabled());
  QVERIFY(panel.editor("calibration.loss_px")->isEnabled());
  panel.setRunning(false);
  QVERIFY(panel.editor("acceptance.max_rms_px")->isEnabled());

  // A refusal from the runtime is shown under the field it names.
  panel.showError("pipeline options: acceptance.max_rms_px cannot change during a run");
  QVERIFY(panel.fieldError("acceptance.max_rms_px").contains("cannot change"));
}

void ThresholdPanelTest::changedFieldsAreMarkedAndReset() {
  ThresholdPanel panel;
  QSignalSpy changed(&panel, &ThresholdPanel::optionsChanged);
  auto* window = qobject_cast<QDoubleSpinBox*>(panel.editor("material.window_s"));
  window->setValue(window->value() * 2);
  QVERIFY(panel.isChanged("material.window_s"));
  QVERIFY(!panel.isChanged("material.attempt_every_s"));
  QVERIFY(panel.resetButton("material.window_s")->isEnabled());
  QVERIFY(!panel.resetButton("material.attempt_every_s")->isEnabled());
  QTest::mouseClick(panel.resetButton("material.window_s"), Qt::LeftButton);
  QCOMPARE(changed.count(), 2);
  QCOMPARE(panel.options().material.window_s, PipelineOptions{}.material.window_s);
  QCOMPARE(window->value(), PipelineOptions{}.material.window_s);
  QVERIFY(!panel.isChanged("material.window_s"));

  // setOptions shows without emitting.
  PipelineOptions options;
  options.board.squares_x = 9;
  panel.setOptions(options);
  QCOMPARE(changed.count(), 2);
  QVERIFY(panel.isChanged("board.squares_x"));
  QCOMPARE(qobject_cast<QSpinBox*>(panel.editor("board.squares_x"))->value(), 9);
}

void ThresholdPanelTest::searchFilters() {
  ThresholdPanel panel;
  panel.show();
  QVERIFY(QTest::qWaitForWindowExposed(&panel));
  panel.findChild<QLineEdit*>()->setText("RMS");  // The search box; any case.
  int shown = 0;
  for (const OptionField& field : PipelineOptionFields()) {
    const QString name = QString::fromStdString(field.name);
    const bool match = name.contains("rms", Qt::CaseInsensitive) ||
                       QString::fromStdString(field.help).contains("rms", Qt::CaseInsensitive);
    QCOMPARE(panel.isFieldVisible(name), match);
    shown += match;
  }
  QVERIFY(shown >= 1);
  QVERIFY(!panel.isFieldVisible("motion.flow.target_tracks"));
  panel.setFilter({});
  QVERIFY(panel.isFieldVisible("motion.flow.target_tracks"));
}

void ThresholdPanelTest::settingsFilesAndPresets() {
  QTemporaryDir dir;
  QVERIFY(dir.isValid());
  ThresholdPanel panel(nullptr, dir.filePath("presets"));
  QSignalSpy changed(&panel, &ThresholdPanel::optionsChanged);
  qobject_cast<QSpinBox*>(panel.editor("motion.flow.target_tracks"))->setValue(77);
  qobject_cast<QDoubleSpinBox*>(panel.editor("calibration.loss_px"))->setValue(3.25);

  // A settings file as autocal run --settings reads it.
  const QString file = dir.filePath("tuned.txt");
  QString error;
  QVERIFY2(panel.saveSettingsFile(file, &error), qPrintable(error));
  const PipelineOptions read = ReadPipelineSettings(file.toStdString());
  QCOMPARE(read.motion.flow.target_tracks, 77);
  QCOMPARE(read.calibration.loss_px, 3.25);

  // Named presets.
  QVERIFY2(panel.savePreset("fast walk", &error), qPrintable(error));
  QCOMPARE(panel.presetNames(), QStringList{"fast walk"});
  panel.setOptions(PipelineOptions{});
  const int before = changed.count();
  QVERIFY2(panel.loadPreset("fast walk", &error), qPrintable(error));
  QCOMPARE(changed.count(), before + 1);
  QCOMPARE(panel.options().motion.flow.target_tracks, 77);
  QCOMPARE(qobject_cast<QSpinBox*>(panel.editor("motion.flow.target_tracks"))->value(), 77);
  QVERIFY(!panel.savePreset("a/b", &error));
  QVERIFY2(panel.removePreset("fast walk", &error), qPrintable(error));
  QVERIFY(panel.presetNames().isEmpty());

  // A bad file: refused with its name and line, the options kept, nothing emitted.
  const QString bad = dir.filePath("bad.txt");
  QFile out(bad);
  QVERIFY(out.open(QIODevice::WriteOnly));
  out.write("# tuned\nmotion.flow.target_tracks = 50\nmaterial.window_s = fast\n");
  out.close();
  const int count = changed.count();
  QVERIFY(!panel.loadSettingsFile(bad, &error));
  QVERIFY2(error.contains(bad) && error.contains("3") && error.contains("material.window_s"),
           qPrintable(error));
  QCOMPARE(changed.count(), count);
  QCOMPARE(panel.options().motion.flow.target_tracks, 77);
}

}  // namespace autocal

QTEST_MAIN(autocal::ThresholdPanelTest)
#include "threshold_panel_test.moc"
