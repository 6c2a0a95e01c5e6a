#include "widgets/calibration_file_field.h"

#include <exception>

#include <QFile>
#include <QFileDialog>
#include <QHBoxLayout>
#include <QLineEdit>
#include <QPushButton>

#include "pipeline/calibration_io.h"

namespace autocal {

CalibrationFileField::CalibrationFileField(QWidget* parent)
    : QWidget(parent), edit_(new QLineEdit(this)) {
  edit_->setObjectName(QStringLiteral("premission_path"));
  edit_->setPlaceholderText(tr("the source's own (session.json)"));
  edit_->setToolTip(
      tr("The calibration to start from and to judge against: a file `autocal export` or "
         "`autocal run --export` wrote (OpenCV YAML or XML, JSON, ROS, Kalibr, COLMAP)"));
  auto* browse = new QPushButton(tr("Browse…"), this);
  browse->setObjectName(QStringLiteral("browse"));
  connect(browse, &QPushButton::clicked, this, [this] {
    const QString path =
        QFileDialog::getOpenFileName(this, tr("Pre-mission calibration"), edit_->text());
    if (!path.isEmpty()) edit_->setText(path);
  });
  auto* layout = new QHBoxLayout(this);
  layout->setContentsMargins(0, 0, 0, 0);
  layout->addWidget(edit_, 1);
  layout->addWidget(browse);
}

QString CalibrationFileField::path() const { return edit_->text().trimmed(); }

void CalibrationFileField::setPath(const QString& path) { edit_->setText(path); }

bool ReadCalibrationFile(const QString& path, std::optional<CameraIntrinsics>* calibration,
                         QString* error) {
  calibration->reset();
  if (path.isEmpty()) return true;
  try {
    *calibration = ReadCalibration(QFile::encodeName(path).toStdString());
  } catch (const std::exception& e) {
    *error = QString::fromStdString(e.what());
    return false;
  }
  return true;
}

bool CalibrationFileField::read(std::optional<CameraIntrinsics>* calibration,
                                QString* error) const {
  return ReadCalibrationFile(path(), calibration, error);
}

}  // namespace autocal
