// The device panel (issue 8, item 5): what is plugged in, connect and disconnect, each
// device's state and measured rate, what was dropped or came late, the accelerometer's
// time offset, and the Record button that writes the connected stream to a native recording
// folder while capture goes on. It draws and binds only; widgets/live_session.h does the
// work.
//
// Wiring it into the main window (widgets/main_window.*):
//   auto* session = new LiveSession(this);
//   auto* panel = new DevicePanel(session);
//   auto* dock = new QDockWidget(tr("Devices"), this);
//   dock->setObjectName("devicesDock");  // For saveState / restoreState.
//   dock->setWidget(panel);
//   addDockWidget(Qt::RightDockWidgetArea, dock);
//   // The live video: on each status tick draw the newest processed frame, if it is new.
//   connect(session, &LiveSession::statusChanged, this, [=] {
//     if (auto snapshot = session->latestSnapshot()) { /* show snapshot->... */ }
//   });
//   connect(session, &LiveSession::connected, this, /* leave playback: live now */);
//   connect(session, &LiveSession::disconnected, this, /* back to the opened recording */);
//   connect(session, &LiveSession::recordingStopped, this,
//           [=](const QString& dir, const QString&) { /* offer to open `dir` */ });
// The panel sets its own minimum width; the session is the main window's child, so that
// closing the window stops a recording cleanly (its files complete) and then the devices.
#pragma once

#include <QWidget>

class QComboBox;
class QDoubleSpinBox;
class QLabel;
class QLineEdit;
class QPlainTextEdit;
class QPushButton;

namespace autocal {

class CalibrationFileField;
class FittedLabel;
class LiveSession;

class DevicePanel : public QWidget {
  Q_OBJECT

 public:
  // `session` must outlive the panel.
  explicit DevicePanel(LiveSession* session, QWidget* parent = nullptr);

  LiveSession* session() const { return session_; }
  // The calibration a connection starts from (empty: the source's own).
  CalibrationFileField* premissionField() const { return premission_; }

 public slots:
  // Lists the cameras and the USB accelerometer again (`autocal devices`).
  void refreshDevices();

 private:
  void connectClicked();
  void recordClicked();
  void showStatus();
  void showMessage(const QString& text, bool error);

  LiveSession* session_;
  QComboBox* input_;
  QComboBox* accel_;
  CalibrationFileField* premission_;
  QPushButton* refresh_;
  QPushButton* connect_;
  QPushButton* disconnect_;
  QPlainTextEdit* found_;  // What `autocal devices` prints.
  FittedLabel* message_;        // The last error, or what to do without hardware.
  FittedLabel* camera_;
  FittedLabel* accelerometer_;
  FittedLabel* frames_;
  FittedLabel* reports_;
  FittedLabel* calibration_;
  QDoubleSpinBox* offset_;
  QLineEdit* folder_;
  QPushButton* record_;
  FittedLabel* recording_;
};

}  // namespace autocal
