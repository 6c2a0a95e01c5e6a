// The device panel in a real window (run under Xvfb) on a real live session: with no camera
// on this machine it says so and what it found; connected to a simulated source played in
// real time it shows the devices' rates and the frames going through the pipeline; Record
// writes a native recording folder while the session runs, which passes the checks
// `autocal info` makes; Disconnect ends the session.
#include <cmath>
#include <memory>

#include <QComboBox>
#include <QDoubleSpinBox>
#include <QFile>
#include <QLabel>
#include <QLineEdit>
#include <QPlainTextEdit>
#include <QPushButton>
#include <QSignalSpy>
#include <QTemporaryDir>
#include <QtTest>

#include "devices/device_list.h"
#include "devices/inspect.h"
#include "devices/sequence.h"
#include "pipeline/calibration_io.h"
#include "tests/gui/screenshot.h"
#include "widgets/calibration_file_field.h"
#include "widgets/device_panel.h"
#include "widgets/live_session.h"

namespace autocal {
namespace {

// Small frames: the simulator renders them faster than real time on a loaded machine.
const QString kSimSource = QStringLiteral("sim:office,seconds=30,resolution=320x240");
constexpr int kTimeoutMs = 30000;

template <typename T>
T* Find(const DevicePanel& panel, const char* name) {
  T* child = panel.findChild<T*>(name);
  if (!child) qFatal("the panel has no %s", name);
  return child;
}

QString Text(const DevicePanel& panel, const char* label) {
  return Find<QLabel>(panel, label)->text();
}

}  // namespace

class DevicePanelTest : public QObject {
  Q_OBJECT

 private slots:
  void saysWhatIsMissingWithoutHardware();
  void connectsRecordsAndDisconnects();
  void startsFromThePremissionCalibrationGiven();
};

void DevicePanelTest::saysWhatIsMissingWithoutHardware() {
  if (!ListDevices().CameraInputs().empty()) QSKIP("a camera is plugged in");
  LiveSession session;
  DevicePanel panel(&session);
  panel.show();
  QVERIFY(QTest::qWaitForWindowExposed(&panel));
  QVERIFY2(Text(panel, "message").contains("No camera found"), qPrintable(Text(panel, "message")));
  QVERIFY(Find<QPlainTextEdit>(panel, "found")->toPlainText().contains("cameras:"));
  QCOMPARE(Find<QComboBox>(panel, "input")->findText("sim:office"), 0);  // Offered instead.

  // Asking for the camera anyway: the session's own message, naming what was found.
  QSignalSpy failed(&session, &LiveSession::connectFailed);
  Find<QComboBox>(panel, "input")->setCurrentText("camera:0");
  QTest::mouseClick(Find<QPushButton>(panel, "connect"), Qt::LeftButton);
  QTRY_COMPARE_WITH_TIMEOUT(failed.count(), 1, kTimeoutMs);
  QVERIFY2(Text(panel, "message").contains("no camera at /dev/video0; found:"),
           qPrintable(Text(panel, "message")));
  QVERIFY(Text(panel, "camera").startsWith("error"));
  QTRY_VERIFY(Find<QPushButton>(panel, "connect")->isEnabled());
  QVERIFY(!Find<QPushButton>(panel, "record")->isEnabled());
}

void DevicePanelTest::connectsRecordsAndDisconnects() {
  LiveSession session;
  DevicePanel panel(&session);
  panel.show();
  QVERIFY(QTest::qWaitForWindowExposed(&panel));

  QSignalSpy connected(&session, &LiveSession::connected);
  Find<QComboBox>(panel, "input")->setCurrentText(kSimSource);
  QTest::mouseClick(Find<QPushButton>(panel, "connect"), Qt::LeftButton);
  QTRY_COMPARE_WITH_TIMEOUT(connected.count(), 1, kTimeoutMs);
  QVERIFY(session.isConnected());
  QVERIFY(!Find<QPushButton>(panel, "connect")->isEnabled());

  // Rates measured and shown; the simulator's pre-mission calibration starts the pipeline.
  QTRY_VERIFY_WITH_TIMEOUT(session.status().camera.rate_hz > 5.0, kTimeoutMs);
  QTRY_VERIFY_WITH_TIMEOUT(session.status().accelerometer.rate_hz > 100.0, kTimeoutMs);
  QTRY_VERIFY_WITH_TIMEOUT(session.status().frames_done > 5, kTimeoutMs);
  QVERIFY(session.latestSnapshot() != nullptr);
  QVERIFY2(Text(panel, "camera").contains("frames/s"), qPrintable(Text(panel, "camera")));
  QVERIFY2(Text(panel, "accelerometer").startsWith("connected"),
           qPrintable(Text(panel, "accelerometer")));
  QVERIFY2(Text(panel, "calibration").startsWith("running"),
           qPrintable(Text(panel, "calibration")));
  // Every status line whole at the dock's narrowest: each label as tall as its wrapped text.
  panel.resize(panel.minimumWidth(), panel.height());
  for (const char* name :
       {"message", "camera", "accelerometer", "frames", "reports", "calibration"}) {
    const QLabel* label = Find<QLabel>(panel, name);
    QTRY_VERIFY2(label->height() >= label->heightForWidth(label->width()),
                 qPrintable(QString("%1: %2 px for %3 (%4)")
                                .arg(name)
                                .arg(label->height())
                                .arg(label->heightForWidth(label->width()))
                                .arg(label->text())));
  }

  // The time offset goes to the session at once.
  Find<QDoubleSpinBox>(panel, "offset")->setValue(0.012);
  QCOMPARE(session.accelTimeOffset(), 0.012);

  // Record for a while, then stop: a complete native recording.
  QTemporaryDir temp;
  QVERIFY(temp.isValid());
  const QString dir = temp.filePath("take1");
  Find<QLineEdit>(panel, "folder")->setText(dir);
  QSignalSpy started(&session, &LiveSession::recordingStarted);
  QSignalSpy stopped(&session, &LiveSession::recordingStopped);
  QTest::mouseClick(Find<QPushButton>(panel, "record"), Qt::LeftButton);
  QTRY_COMPARE_WITH_TIMEOUT(started.count(), 1, kTimeoutMs);
  QTRY_VERIFY_WITH_TIMEOUT(session.status().recorded.frames_written >= 15, kTimeoutMs);
  QVERIFY2(Text(panel, "recording").contains(dir), qPrintable(Text(panel, "recording")));
  // For a person to look at: the panel connected and recording.
  QVERIFY(panel.grab().save(ScreenshotPath(QStringLiteral("device_panel.png"))));
  QVERIFY(session.status().frames_done > 5);  // The pipeline kept going while recording.
  QTest::mouseClick(Find<QPushButton>(panel, "record"), Qt::LeftButton);
  QTRY_COMPARE_WITH_TIMEOUT(stopped.count(), 1, kTimeoutMs);
  QCOMPARE(stopped.first().at(0).toString(), dir);
  QVERIFY(!session.isRecording());
  QVERIFY(session.isConnected());  // Recording ends, the session does not.
  QVERIFY2(Text(panel, "recording").startsWith("Recorded"), qPrintable(Text(panel, "recording")));

  const RecorderProgress written = session.status().recorded;
  const std::unique_ptr<Sequence> recording = OpenSequence(dir.toStdString());
  const SequenceReport report = InspectSequence(*recording);
  QVERIFY2(!HasErrors(report), FormatReport(report).c_str());
  QCOMPARE(uint64_t(recording->frame_count()), written.frames_written);
  QCOMPARE(uint64_t(recording->accel().size()), written.accel_written);
  QVERIFY(recording->accel().size() > 100);
  QCOMPARE(recording->session().width, 320);

  QSignalSpy disconnected(&session, &LiveSession::disconnected);
  QTest::mouseClick(Find<QPushButton>(panel, "disconnect"), Qt::LeftButton);
  QTRY_COMPARE_WITH_TIMEOUT(disconnected.count(), 1, kTimeoutMs);
  QVERIFY(!session.isConnected());
  QTRY_VERIFY(Text(panel, "camera").startsWith("disconnected"));
  QVERIFY(Find<QPushButton>(panel, "connect")->isEnabled());
  QVERIFY(!Find<QPushButton>(panel, "record")->isEnabled());
}

void DevicePanelTest::startsFromThePremissionCalibrationGiven() {
  LiveSession session;
  DevicePanel panel(&session);
  panel.show();
  QVERIFY(QTest::qWaitForWindowExposed(&panel));
  Find<QComboBox>(panel, "input")->setCurrentText(kSimSource);
  QTemporaryDir temp;
  QVERIFY(temp.isValid());

  // A file that is no calibration: the reader's message naming it, and no connection.
  const QString bad = temp.filePath("bad.yaml");
  {
    QFile file(bad);
    QVERIFY(file.open(QIODevice::WriteOnly));
    file.write("%YAML:1.0\nimage_width: 320\n");
  }
  panel.premissionField()->setPath(bad);
  QTest::mouseClick(Find<QPushButton>(panel, "connect"), Qt::LeftButton);
  QVERIFY2(Text(panel, "message").contains(bad), qPrintable(Text(panel, "message")));
  QVERIFY(!session.isConnected());

  // A calibration 3% longer in focal length than the simulator's own: the live pipeline
  // starts from it (the first frames' working calibration is the one it starts from).
  const CameraIntrinsics own =
      *OpenSequence(kSimSource.toStdString())->session().premission_calibration;
  CameraIntrinsics given = own;
  given.fx *= 1.03;
  given.fy *= 1.03;
  const QString good = temp.filePath("vest.yaml");
  WriteCalibration(good.toStdString(), given, CalibrationFormat::kOpenCv);
  panel.premissionField()->setPath(good);
  QSignalSpy connected(&session, &LiveSession::connected);
  QTest::mouseClick(Find<QPushButton>(panel, "connect"), Qt::LeftButton);
  QTRY_COMPARE_WITH_TIMEOUT(connected.count(), 1, kTimeoutMs);
  QTRY_VERIFY_WITH_TIMEOUT(session.latestSnapshot() != nullptr, kTimeoutMs);
  const double fx = session.latestSnapshot()->working.fx;
  QVERIFY2(std::abs(fx - given.fx) < std::abs(fx - own.fx),
           qPrintable(QString("fx %1, given %2, own %3").arg(fx).arg(given.fx).arg(own.fx)));
  QSignalSpy disconnected(&session, &LiveSession::disconnected);
  session.disconnectSource();
  QTRY_COMPARE_WITH_TIMEOUT(disconnected.count(), 1, kTimeoutMs);
}

}  // namespace autocal

QTEST_MAIN(autocal::DevicePanelTest)
#include "device_panel_test.moc"
