#include "widgets/device_panel.h"

#include <optional>

#include <QComboBox>
#include <QDateTime>
#include <QDir>
#include <QDoubleSpinBox>
#include <QFormLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QLabel>
#include <QLineEdit>
#include <QPlainTextEdit>
#include <QPushButton>
#include <QScrollArea>
#include <QVBoxLayout>

#include "devices/device_list.h"
#include "widgets/calibration_file_field.h"
#include "widgets/live_session.h"

namespace autocal {
namespace {

// A simulated source, offered so the panel can be tried without hardware.
const char* const kSimulatedInput = "sim:office";

QString NewRecordingFolder() {
  return QDir::home().filePath("autocal-" +
                               QDateTime::currentDateTime().toString("yyyyMMdd-HHmmss"));
}

QString StateText(const LiveSession::DeviceStatus& device, const char* rate_unit) {
  QString state;
  switch (device.state) {
    case LiveSession::DeviceState::kAbsent:
      state = "none";
      break;
    case LiveSession::DeviceState::kConnecting:
      state = "connecting";
      break;
    case LiveSession::DeviceState::kConnected:
      state = "connected";
      break;
    case LiveSession::DeviceState::kDisconnected:
      state = "disconnected";
      break;
    case LiveSession::DeviceState::kError:
      state = "error";
      break;
  }
  QString text = state;
  if (!device.message.isEmpty()) text += ": " + device.message;
  if (device.state == LiveSession::DeviceState::kConnected) {
    text += QString(" (%1 %2)").arg(device.rate_hz, 0, 'f', 1).arg(rate_unit);
  }
  return text;
}

}  // namespace

// A word-wrapped label that claims, as its minimum height, what its text needs at its
// width. Qt's form layout sized a row for the line count the label had when it was laid
// out, so a status that grew to a second line was cut in half.
class FittedLabel : public QLabel {
 public:
  explicit FittedLabel(const QString& name) {
    setObjectName(name);
    setWordWrap(true);
    setTextInteractionFlags(Qt::TextSelectableByMouse);
  }
  void setFittedText(const QString& text) {
    setText(text);
    fit();
  }

 protected:
  void resizeEvent(QResizeEvent* event) override {
    QLabel::resizeEvent(event);
    fit();
  }

 private:
  // Not before the layout has given a width: a few pixels wide, a sentence is a column.
  static constexpr int kMinFittedWidth = 60;

  void fit() {
    if (width() < kMinFittedWidth) return;
    const int needed = heightForWidth(width());
    if (needed > 0 && needed != minimumHeight()) setMinimumHeight(needed);
  }
};

DevicePanel::DevicePanel(LiveSession* session, QWidget* parent)
    : QWidget(parent),
      session_(session),
      input_(new QComboBox),
      accel_(new QComboBox),
      premission_(new CalibrationFileField),
      refresh_(new QPushButton(tr("Refresh"))),
      connect_(new QPushButton(tr("Connect"))),
      disconnect_(new QPushButton(tr("Disconnect"))),
      found_(new QPlainTextEdit),
      message_(new FittedLabel("message")),
      camera_(new FittedLabel("camera")),
      accelerometer_(new FittedLabel("accelerometer")),
      frames_(new FittedLabel("frames")),
      reports_(new FittedLabel("reports")),
      calibration_(new FittedLabel("calibration")),
      offset_(new QDoubleSpinBox),
      folder_(new QLineEdit(NewRecordingFolder())),
      record_(new QPushButton(tr("Record"))),
      recording_(new FittedLabel("recording")) {
  input_->setObjectName("input");
  input_->setEditable(true);
  input_->setToolTip(
      tr("camera:N, camera:/dev/videoN,size=WxH,fps=F, sim:SCENARIO, or a "
         "recording (played in real time)"));
  accel_->setObjectName("accel");
  accel_->setEditable(true);
  accel_->addItems({"", "usb", "none"});
  accel_->setToolTip(
      tr("Empty: the input's own; usb, usb:VID:PID, usb:mapping=FILE, a CSV "
         "file, or none"));
  premission_->setObjectName("premission");
  refresh_->setObjectName("refresh");
  connect_->setObjectName("connect");
  disconnect_->setObjectName("disconnect");
  found_->setObjectName("found");
  found_->setReadOnly(true);
  found_->setMaximumHeight(110);
  offset_->setObjectName("offset");
  offset_->setRange(-1.0, 1.0);
  offset_->setDecimals(4);
  offset_->setSingleStep(0.001);
  offset_->setSuffix(" s");
  offset_->setToolTip(
      tr("Added to accelerometer timestamps to put them on the camera's clock; "
         "applies to the samples read from now on"));
  offset_->setValue(session_->accelTimeOffset());
  folder_->setObjectName("folder");
  record_->setObjectName("record");
  record_->setCheckable(true);

  auto* source_row = new QHBoxLayout;
  source_row->addWidget(connect_);
  source_row->addWidget(disconnect_);
  source_row->addWidget(refresh_);
  auto* source_box = new QGroupBox(tr("Source"));
  auto* source_form = new QFormLayout(source_box);
  source_form->addRow(tr("Input"), input_);
  source_form->addRow(tr("Accelerometer"), accel_);
  source_form->addRow(tr("Pre-mission"), premission_);
  source_form->addRow(source_row);
  source_form->addRow(tr("Found"), found_);
  source_form->addRow(message_);

  auto* status_box = new QGroupBox(tr("Status"));
  auto* status_form = new QFormLayout(status_box);
  status_form->addRow(tr("Camera"), camera_);
  status_form->addRow(tr("Accelerometer"), accelerometer_);
  status_form->addRow(tr("Frames"), frames_);
  status_form->addRow(tr("Reports"), reports_);
  status_form->addRow(tr("Calibration"), calibration_);
  status_form->addRow(tr("Time offset"), offset_);

  auto* record_box = new QGroupBox(tr("Recording"));
  auto* record_form = new QFormLayout(record_box);
  record_form->addRow(tr("Folder"), folder_);
  record_form->addRow(record_);
  record_form->addRow(recording_);

  // In a scroll area: a dock shorter than the panel scrolls it rather than squeezing its
  // lines or making the window taller than a laptop's screen.
  auto* content = new QWidget;
  auto* layout = new QVBoxLayout(content);
  layout->addWidget(source_box);
  layout->addWidget(status_box);
  layout->addWidget(record_box);
  layout->addStretch();
  auto* scroll = new QScrollArea;
  scroll->setWidget(content);
  scroll->setWidgetResizable(true);
  scroll->setFrameShape(QFrame::NoFrame);
  scroll->setHorizontalScrollBarPolicy(Qt::ScrollBarAlwaysOff);
  auto* outer = new QVBoxLayout(this);
  outer->setContentsMargins(0, 0, 0, 0);
  outer->addWidget(scroll);
  setMinimumWidth(320);

  connect(refresh_, &QPushButton::clicked, this, &DevicePanel::refreshDevices);
  connect(connect_, &QPushButton::clicked, this, &DevicePanel::connectClicked);
  connect(disconnect_, &QPushButton::clicked, session_, &LiveSession::disconnectSource);
  connect(record_, &QPushButton::clicked, this, &DevicePanel::recordClicked);
  connect(offset_, qOverload<double>(&QDoubleSpinBox::valueChanged), session_,
          &LiveSession::setAccelTimeOffset);
  connect(session_, &LiveSession::statusChanged, this, &DevicePanel::showStatus);
  connect(session_, &LiveSession::connected, this, [this](const QString& description) {
    showMessage(tr("Connected to %1").arg(description), false);
  });
  connect(session_, &LiveSession::connectFailed, this,
          [this](const QString& why) { showMessage(why, true); });
  connect(session_, &LiveSession::deviceEvent, this,
          [this](const QString& text) { showMessage(text, false); });
  connect(session_, &LiveSession::recordingFailed, this,
          [this](const QString& why) { showMessage(tr("Recording failed: %1").arg(why), true); });
  connect(session_, &LiveSession::recordingStopped, this,
          [this](const QString& dir, const QString& summary) {
            recording_->setFittedText(tr("Recorded %1 to %2").arg(summary, dir));
            folder_->setText(NewRecordingFolder());
          });

  refreshDevices();
  showStatus();
}

void DevicePanel::refreshDevices() {
  const DeviceListing listing = ListDevices();
  found_->setPlainText(QString::fromStdString(listing.Text()));
  const QString typed = input_->currentText();
  input_->clear();
  for (const std::string& camera : listing.CameraInputs()) {
    input_->addItem(QString::fromStdString(camera));
  }
  input_->addItem(kSimulatedInput);
  if (!typed.isEmpty()) input_->setCurrentText(typed);
  if (listing.CameraInputs().empty() && !session_->isConnected()) {
    showMessage(
        tr("No camera found (%1). Plug one in and press Refresh, or connect to a "
           "simulated source (%2) or a recording.")
            .arg(QString::fromStdString(SummarizeVideoDevices(listing.cameras)), kSimulatedInput),
        true);
  }
}

void DevicePanel::connectClicked() {
  QString error;
  std::optional<CameraIntrinsics> premission;
  if (!premission_->read(&premission, &error) ||
      !session_->connectSource(input_->currentText().trimmed(), accel_->currentText().trimmed(),
                               premission, &error)) {
    showMessage(error, true);
    return;
  }
  showMessage(tr("Connecting to %1 ...").arg(input_->currentText()), false);
}

void DevicePanel::recordClicked() {
  if (session_->isRecording()) {
    session_->stopRecording();
    recording_->setFittedText(tr("Stopping: writing the last frames ..."));
    return;
  }
  QString error;
  if (!session_->startRecording(folder_->text().trimmed(), &error)) {
    showMessage(error, true);
  }
  showStatus();
}

void DevicePanel::showMessage(const QString& text, bool error) {
  message_->setFittedText(text);
  message_->setStyleSheet(error ? "color: #b00020;" : "");
}

void DevicePanel::showStatus() {
  const LiveSession::Status status = session_->status();
  const bool busy =
      status.connected || status.camera.state == LiveSession::DeviceState::kConnecting;
  connect_->setEnabled(!busy && !status.recording);
  disconnect_->setEnabled(busy);
  input_->setEnabled(!busy);
  accel_->setEnabled(!busy);
  premission_->setEnabled(!busy);  // Read when connecting: a change would not apply.
  camera_->setFittedText(StateText(status.camera, "frames/s"));
  accelerometer_->setFittedText(StateText(status.accelerometer, "samples/s"));
  frames_->setFittedText(tr("%1 received, %2 processed, %3 dropped")
                             .arg(status.frames_received)
                             .arg(status.frames_done)
                             .arg(status.frames_dropped));
  reports_->setFittedText(
      tr("%1 samples dropped, %2 late reports (%3 missing), %4 items out of order")
          .arg(status.accel_dropped)
          .arg(status.accel_late_reports)
          .arg(status.accel_missing_reports)
          .arg(status.late_items));
  calibration_->setFittedText(
      status.calibration_note.isEmpty() && status.connected
          ? tr("running (live: frames the pipeline cannot take are dropped)")
          : status.calibration_note);
  record_->setEnabled(status.connected || status.recording);
  record_->setChecked(status.recording);
  record_->setText(status.recording ? tr("Stop recording") : tr("Record"));
  folder_->setEnabled(!status.recording);
  if (status.recording) {
    const RecorderProgress& p = status.recorded;
    recording_->setFittedText(
        tr("Recording to %1: %2 s, %3 frames, %4 samples written%5")
            .arg(status.recording_dir)
            .arg(p.recorded_s, 0, 'f', 1)
            .arg(p.frames_written)
            .arg(p.accel_written)
            .arg(p.frames_dropped > 0
                     ? tr(", %1 frames dropped (disk too slow)").arg(p.frames_dropped)
                     : QString()));
  }
}

}  // namespace autocal
