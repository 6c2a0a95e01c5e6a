// The vest check for field technicians (docs/vest_check.md): three pages in one dialog.
//   Connect: the source (camera and accelerometer, or the simulated vest), the pre-mission
//            calibration file (none: the source's own), the walk's length, the tolerances.
//   Walk:    what to do now in large type, the progress, the checklist of motions done and
//            missing, the time, a thumbnail of the camera.
//   Result:  PASS / FAIL / INCONCLUSIVE in large type, the table of parameter, pre-mission,
//            measured, difference, tolerance and verdict, the reasons; "Save Report…" writes
//            the PDF (widgets/vest_report.h).
// The work runs in a VestCheckController (its own runtime on its own threads); this dialog
// only shows what it reports.
//
// Opening it from the main window ("Tools > Vest Check…"):
//     VestCheckDialog dialog(QStringLiteral("camera:0"), QStringLiteral("usb"), this);
//     dialog.exec();
// `input` and `accel` are what OpenSource (devices/source.h) takes and only fill the connect
// page's fields, which the technician may change: "camera:0" with "usb" for a vest plugged
// in, "sim:office" with "" for the simulated vest (the default arguments).
#pragma once

#include <memory>
#include <optional>

#include <QDialog>
#include <QString>

#include "pipeline/vest_check.h"
#include "widgets/vest_report.h"

class QCheckBox;
class QDoubleSpinBox;
class QLabel;
class QLineEdit;
class QListWidget;
class QProgressBar;
class QPushButton;
class QStackedWidget;
class QTableWidget;

namespace autocal {

class CalibrationFileField;
class VestCheckController;

class VestCheckDialog : public QDialog {
  Q_OBJECT

 public:
  explicit VestCheckDialog(const QString& input = QStringLiteral("sim:office"),
                           const QString& accel = QString(), QWidget* parent = nullptr);
  ~VestCheckDialog() override;

  enum class Page { kConnect, kWalk, kResult };
  Page page() const;
  // The newest verdict (none before a walk ends).
  const std::optional<VestCheckResult>& result() const { return result_; }
  // The report of the newest verdict, dated now.
  VestReport report() const;

  // Fields of the connect page, for tests and the main window.
  QLineEdit* inputEdit() const { return input_; }
  QLineEdit* accelEdit() const { return accel_; }
  QLineEdit* premissionEdit() const;
  QDoubleSpinBox* durationSpin() const { return duration_; }
  // The camera's rolling-shutter readout (ms); at its minimum, "as the source states".
  QDoubleSpinBox* readoutSpin() const { return readout_; }

 public slots:
  // Starts the walk with the connect page's settings.
  void startCheck();
  // Writes the report of the newest verdict; false (with a message box unless `quiet`) when
  // it cannot be written.
  bool saveReport(const QString& path, bool quiet = false);

 signals:
  // The verdict is on the result page.
  void checkFinished();

 private:
  void ShowProgress();
  void ShowResult(const VestCheckResult& result);
  void ShowFailure(const QString& message);
  void BackToConnect();

  QStackedWidget* pages_ = nullptr;
  // Connect.
  QLineEdit* input_ = nullptr;
  QLineEdit* accel_ = nullptr;
  CalibrationFileField* premission_ = nullptr;
  QDoubleSpinBox* duration_ = nullptr;
  QDoubleSpinBox* readout_ = nullptr;
  QDoubleSpinBox* focal_tol_ = nullptr;
  QDoubleSpinBox* principal_tol_ = nullptr;
  QDoubleSpinBox* distortion_tol_ = nullptr;
  QLabel* connect_error_ = nullptr;
  // Walk.
  QLabel* source_label_ = nullptr;
  QLabel* guidance_ = nullptr;
  QProgressBar* progress_ = nullptr;
  QListWidget* checklist_ = nullptr;
  QLabel* elapsed_ = nullptr;
  QLabel* thumbnail_ = nullptr;
  QPushButton* finish_now_ = nullptr;
  // Result.
  QLabel* verdict_ = nullptr;
  QLabel* summary_ = nullptr;
  QTableWidget* table_ = nullptr;
  QLabel* reasons_ = nullptr;

  std::unique_ptr<VestCheckController> controller_;
  std::optional<VestCheckResult> result_;
  VestCheckOptions options_;  // Of the newest walk.
  QString source_description_, device_ids_;
};

}  // namespace autocal
