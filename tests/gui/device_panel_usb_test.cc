// The device panel with a USB HID Sensor accelerometer emulated by umockdev
// (tests/usb/emulated_usb.h) and a video file as the camera: the accelerometer's state and
// rate on the panel follow it streaming, unplugged and plugged back. ctest runs this binary
// through umockdev-wrapper, under Xvfb; without the wrapper the test skips.
#include <atomic>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include <QComboBox>
#include <QLabel>
#include <QPushButton>
#include <QSignalSpy>
#include <QTemporaryDir>
#include <QtTest>
#include <opencv2/videoio.hpp>

#include "tests/usb/emulated_usb.h"
#include "widgets/device_panel.h"
#include "widgets/live_session.h"

namespace autocal {
namespace {

constexpr int kTimeoutMs = 20000;

QString Text(const DevicePanel& panel, const char* label) {
  return panel.findChild<QLabel*>(label)->text();
}

// Sends accelerometer reports to the emulated device every 5 ms while it lives.
class Feeder {
 public:
  Feeder(test::UsbTestbed* bed, int device)
      : thread_([this, bed, device] {
          while (!stop_) {
            bed->SendReport(device, test::HidSensorAccelReport(0, 0, 100),
                            std::chrono::milliseconds(200));
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
          }
        }) {}
  ~Feeder() {
    stop_ = true;
    thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace

class DevicePanelUsbTest : public QObject {
  Q_OBJECT

 private slots:
  void accelerometerUnpluggedAndBack();
};

void DevicePanelUsbTest::accelerometerUnpluggedAndBack() {
  if (!test::RunningUnderUmockdevWrapper()) QSKIP("needs umockdev-wrapper (ctest runs it so)");
  test::UsbTestbed bed;  // Before libusb_init, which connecting calls.
  const int first = bed.Plug(test::HidSensorHub());
  QTemporaryDir temp;
  QVERIFY(temp.isValid());
  const std::string video = temp.filePath("camera.avi").toStdString();
  {
    cv::VideoWriter writer(video, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                           30.0, cv::Size(64, 48));
    QVERIFY(writer.isOpened());
    for (int i = 0; i < 30; ++i) writer.write(cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(8 * i)));
  }

  LiveSession session;
  DevicePanel panel(&session);
  panel.show();
  QVERIFY(QTest::qWaitForWindowExposed(&panel));
  QSignalSpy connected(&session, &LiveSession::connected);
  panel.findChild<QComboBox*>("input")->setCurrentText(QString::fromStdString("camera:" + video));
  panel.findChild<QComboBox*>("accel")->setCurrentText("usb:1234:5678");
  QTest::mouseClick(panel.findChild<QPushButton*>("connect"), Qt::LeftButton);
  QTRY_COMPARE_WITH_TIMEOUT(connected.count(), 1, kTimeoutMs);
  // A camera has no pre-mission calibration: the session records only, and says so.
  QVERIFY2(Text(panel, "calibration").contains("no calibration to start from"),
           qPrintable(Text(panel, "calibration")));

  {
    const Feeder feeder(&bed, first);
    QTRY_VERIFY_WITH_TIMEOUT(session.status().accelerometer.rate_hz > 10.0, kTimeoutMs);
    QTRY_VERIFY2_WITH_TIMEOUT(Text(panel, "accelerometer").contains("1234:5678") &&
                                  Text(panel, "accelerometer").contains("samples/s"),
                              qPrintable(Text(panel, "accelerometer")), kTimeoutMs);
    QVERIFY(Text(panel, "accelerometer").startsWith("connected"));
  }
  bed.Unplug(first);
  QTRY_VERIFY2_WITH_TIMEOUT(Text(panel, "accelerometer").startsWith("disconnected"),
                            qPrintable(Text(panel, "accelerometer")), kTimeoutMs);
  QVERIFY(session.isConnected());  // The session goes on without it.

  const int second = bed.Plug(test::HidSensorHub());
  {
    const Feeder feeder(&bed, second);
    QTRY_VERIFY2_WITH_TIMEOUT(Text(panel, "accelerometer").startsWith("connected"),
                              qPrintable(Text(panel, "accelerometer")), kTimeoutMs);
  }
  QSignalSpy disconnected(&session, &LiveSession::disconnected);
  QTest::mouseClick(panel.findChild<QPushButton*>("disconnect"), Qt::LeftButton);
  QTRY_COMPARE_WITH_TIMEOUT(disconnected.count(), 1, kTimeoutMs);
}

}  // namespace autocal

QTEST_MAIN(autocal::DevicePanelUsbTest)
#include "device_panel_usb_test.moc"
