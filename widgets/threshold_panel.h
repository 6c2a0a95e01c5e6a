// The threshold panel: every field of PipelineOptionFields() (pipeline/option_fields.h)
// bound to an editor of its own, grouped by box, with its range and its one-line
// explanation, a search filter, "changed from the default" marks with a reset per field,
// and presets (settings files, the same files `autocal run --settings` reads). The panel
// computes nothing: it edits a PipelineOptions, checks it with PipelineOptions::Check and
// hands it on.
//
// Wiring it into the main window: connect
//   ThresholdPanel::optionsChanged(const autocal::PipelineOptions&)
// to the pipeline controller's setOptions slot, which calls Runtime::SetOptions
// (devices/runtime.h): the options apply from the next frame pushed. Call setRunning(true)
// when a run starts (acceptance.* cannot change during one) and false when it ends; show an
// Error of Runtime::SetOptions with showError(). When a run starts with other options (say
// from `--settings`), call setOptions() to show them.
#pragma once

#include <vector>

#include <QString>
#include <QMetaType>
#include <QStringList>
#include <QWidget>

#include "pipeline/calibration_pipeline.h"

class QComboBox;
class QLabel;
class QLineEdit;
class QGroupBox;
class QScrollArea;
class QAbstractButton;

namespace autocal {

class ThresholdPanel : public QWidget {
  Q_OBJECT

 public:
  // `presets_dir`: where named presets are kept, one settings file each (NAME.txt);
  // empty: "presets" in the application's configuration folder.
  explicit ThresholdPanel(QWidget* parent = nullptr, const QString& presets_dir = {});

  // The options shown, last valid ones (an invalid edit is not taken).
  const PipelineOptions& options() const { return options_; }
  // Shows `options` without emitting optionsChanged. They must pass Check().
  void setOptions(const PipelineOptions& options);

  // While a run goes on the acceptance.* fields are disabled: the history judges all its
  // attempts by one set, and Runtime::SetOptions refuses a change to them.
  void setRunning(bool running);

  // Shows only the fields whose name or explanation contains `text` (any case).
  void setFilter(const QString& text);

  // Settings files. Loading emits optionsChanged; errors name the file and the line.
  bool loadSettingsFile(const QString& path, QString* error);
  bool saveSettingsFile(const QString& path, QString* error) const;

  // Named presets: settings files in presetsDir().
  QString presetsDir() const { return presets_dir_; }
  QStringList presetNames() const;
  bool savePreset(const QString& name, QString* error);
  bool loadPreset(const QString& name, QString* error);
  bool removePreset(const QString& name, QString* error);

  // For tests and for the controller's own refusals: the editor of a field (by name),
  // the message shown under it (empty when none), and whether it differs from its default.
  QWidget* editor(const QString& name) const;
  QString fieldError(const QString& name) const;
  bool isChanged(const QString& name) const;
  QAbstractButton* resetButton(const QString& name) const;
  bool isFieldVisible(const QString& name) const;
  // Shows `message` under the field it names (else at the top), e.g. Runtime::SetOptions's.
  void showError(const QString& message);

 signals:
  // Valid options (PipelineOptions::Check passed) after an edit, a reset or a load.
  void optionsChanged(const autocal::PipelineOptions& options);

 private:
  struct Row {
    size_t field = 0;  // Index in PipelineOptionFields().
    QWidget* row = nullptr;
    QWidget* editor = nullptr;
    QLabel* name = nullptr;
    QLabel* error = nullptr;
    QAbstractButton* reset = nullptr;
    QGroupBox* group = nullptr;
  };

  const Row* find(const QString& name) const;
  // An editor's new value: taken and emitted when the options stay valid.
  void edit(size_t row, double value);
  void showValues();
  void refreshPresets();
  // Asks for a name / a file; reports failures in the top line.
  void onSavePreset();
  void onLoadPreset();
  void onRemovePreset();
  void onOpenFile();
  void onSaveFile();
  void report(const QString& message);

  PipelineOptions options_;
  QString presets_dir_;
  std::vector<Row> rows_;
  std::vector<QGroupBox*> groups_;
  QLineEdit* search_ = nullptr;
  QComboBox* presets_ = nullptr;
  QScrollArea* scroll_ = nullptr;
  QLabel* message_ = nullptr;
  bool showing_ = false;  // Editors being set from options_: not edits.
};

}  // namespace autocal

// optionsChanged carries it across threads too.
Q_DECLARE_METATYPE(autocal::PipelineOptions)
