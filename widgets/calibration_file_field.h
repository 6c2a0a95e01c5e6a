// A calibration file chosen by hand: a path field with a Browse… button, read on demand
// with pipeline/calibration_io.h (any format `autocal` writes). Empty means "none given":
// the source's own pre-mission calibration. Used wherever the workbench starts a pipeline
// on a source (the Devices dock, the vest check).
#pragma once

#include <optional>

#include <QString>
#include <QWidget>

#include "pipeline/camera_model.h"

class QLineEdit;

namespace autocal {

// The calibration in the file at `path` (none when `path` is empty). False, with the
// reader's message (file, line, what was expected) in `error`, when it cannot be read.
bool ReadCalibrationFile(const QString& path, std::optional<CameraIntrinsics>* calibration,
                         QString* error);

class CalibrationFileField : public QWidget {
  Q_OBJECT

 public:
  explicit CalibrationFileField(QWidget* parent = nullptr);

  QLineEdit* edit() const { return edit_; }
  QString path() const;
  void setPath(const QString& path);
  // ReadCalibrationFile of path().
  bool read(std::optional<CameraIntrinsics>* calibration, QString* error) const;

 private:
  QLineEdit* edit_;
};

}  // namespace autocal
