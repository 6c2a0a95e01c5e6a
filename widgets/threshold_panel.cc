#include "widgets/threshold_panel.h"

#include <algorithm>
#include <climits>
#include <limits>

#include <QCheckBox>
#include <QComboBox>
#include <QDir>
#include <QDoubleSpinBox>
#include <QFile>
#include <QFileInfo>
#include <QFileDialog>
#include <QGridLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QInputDialog>
#include <QLabel>
#include <QLineEdit>
#include <QPushButton>
#include <QSaveFile>
#include <QScrollArea>
#include <QSpinBox>
#include <QStandardPaths>
#include <QToolButton>
#include <QVBoxLayout>

#include "pipeline/error.h"
#include "pipeline/option_fields.h"
#include "pipeline/text_format.h"

namespace autocal {
namespace {

// Real options span 1e-9 to 1e6 and more: shown in their shortest form, typed in any form
// (1e-6 included), never rounded to a fixed number of decimals.
class RealSpinBox : public QDoubleSpinBox {
 public:
  explicit RealSpinBox(QWidget* parent) : QDoubleSpinBox(parent) {
    setDecimals(15);
    setStepType(QAbstractSpinBox::AdaptiveDecimalStepType);
  }

  QString textFromValue(double value) const override {
    return QString::fromStdString(ShortestDecimal(value));
  }
  double valueFromText(const QString& text) const override { return text.toDouble(); }
  QValidator::State validate(QString& text, int& /*pos*/) const override {
    bool ok = false;
    const double value = text.toDouble(&ok);
    if (!ok) return QValidator::Intermediate;
    return value >= minimum() && value <= maximum() ? QValidator::Acceptable
                                                    : QValidator::Intermediate;
  }
};

// The group of a field, from its name's first part.
QString GroupTitle(const std::string& group) {
  if (group == "lens") return QObject::tr("Boxes 1-3: lines, distortion, rectification");
  if (group == "motion") return QObject::tr("Boxes 4-6: features, flow, planes");
  if (group == "inertial") return QObject::tr("Box 7: accelerometer");
  if (group == "board") return QObject::tr("Box 8: virtual boards");
  if (group == "material") return QObject::tr("Box 9: window of material");
  if (group == "calibration") return QObject::tr("Box 10: calibration solve");
  if (group == "acceptance") return QObject::tr("History: acceptance (fixed during a run)");
  return QString::fromStdString(group);
}

QString RangeText(const OptionField& field) {
  if (field.kind == OptionField::Kind::kFlag) return QObject::tr("on or off");
  const auto bound = [&](double value) {
    if (value == std::numeric_limits<double>::max()) return QStringLiteral("inf");
    return field.kind == OptionField::Kind::kInteger ? QString::number(qint64(value))
                                                     : QString::fromStdString(ShortestDecimal(value));
  };
  return QStringLiteral("[%1, %2]").arg(bound(field.min), bound(field.max));
}

QString DefaultText(const OptionField& field) {
  const double value = field.get(PipelineOptions{});
  if (field.kind == OptionField::Kind::kFlag) return value != 0 ? "on" : "off";
  return QString::fromStdString(ShortestDecimal(value));
}

QString PresetPath(const QString& dir, const QString& name) {
  return QDir(dir).filePath(name + ".txt");
}

}  // namespace

ThresholdPanel::ThresholdPanel(QWidget* parent, const QString& presets_dir)
    : QWidget(parent),
      presets_dir_(presets_dir.isEmpty()
                       ? QDir(QStandardPaths::writableLocation(QStandardPaths::AppConfigLocation))
                             .filePath("presets")
                       : presets_dir) {
  auto* layout = new QVBoxLayout(this);

  auto* top = new QHBoxLayout;
  search_ = new QLineEdit(this);
  search_->setPlaceholderText(tr("Search options"));
  search_->setClearButtonEnabled(true);
  connect(search_, &QLineEdit::textChanged, this, &ThresholdPanel::setFilter);
  top->addWidget(search_, 1);
  auto* defaults = new QPushButton(tr("All Defaults"), this);
  defaults->setToolTip(tr("Every field back to its default"));
  connect(defaults, &QPushButton::clicked, this, [this] {
    setOptions(PipelineOptions{});
    emit optionsChanged(options_);
  });
  top->addWidget(defaults);
  layout->addLayout(top);

  auto* presets = new QHBoxLayout;
  presets->addWidget(new QLabel(tr("Preset:"), this));
  presets_ = new QComboBox(this);
  presets_->setMinimumContentsLength(12);
  presets->addWidget(presets_, 1);
  const auto button = [&](const QString& text, const QString& tip, void (ThresholdPanel::*slot)()) {
    auto* b = new QToolButton(this);
    b->setText(text);
    b->setToolTip(tip);
    connect(b, &QToolButton::clicked, this, slot);
    presets->addWidget(b);
  };
  button(tr("Load"), tr("Load the chosen preset"), &ThresholdPanel::onLoadPreset);
  button(tr("Save As…"), tr("Keep the options shown as a named preset"),
         &ThresholdPanel::onSavePreset);
  button(tr("Delete"), tr("Delete the chosen preset"), &ThresholdPanel::onRemovePreset);
  button(tr("Open…"), tr("Load a settings file (as autocal run --settings reads)"),
         &ThresholdPanel::onOpenFile);
  button(tr("Save…"), tr("Save the options shown as a settings file for autocal run --settings"),
         &ThresholdPanel::onSaveFile);
  layout->addLayout(presets);

  message_ = new QLabel(this);
  message_->setWordWrap(true);
  message_->setStyleSheet("color: #b00020");
  message_->hide();
  layout->addWidget(message_);

  scroll_ = new QScrollArea(this);
  QScrollArea* scroll = scroll_;
  scroll->setWidgetResizable(true);
  auto* body = new QWidget(scroll);
  auto* groups = new QVBoxLayout(body);
  scroll->setWidget(body);
  layout->addWidget(scroll, 1);

  const std::vector<OptionField>& fields = PipelineOptionFields();
  std::string group_name;
  QVBoxLayout* group_layout = nullptr;
  for (size_t i = 0; i < fields.size(); ++i) {
    const OptionField& field = fields[i];
    const std::string field_group = field.name.substr(0, field.name.find('.'));
    if (!group_layout || field_group != group_name) {
      group_name = field_group;
      auto* box = new QGroupBox(GroupTitle(group_name), body);
      group_layout = new QVBoxLayout(box);
      groups->addWidget(box);
      groups_.push_back(box);
    }
    Row row;
    row.field = i;
    row.group = groups_.back();
    row.row = new QWidget(row.group);
    auto* grid = new QGridLayout(row.row);
    grid->setContentsMargins(0, 2, 0, 2);
    const QString name = QString::fromStdString(field.name);
    const QString tip = QStringLiteral("%1\n%2\nrange %3, default %4")
                            .arg(name, QString::fromStdString(field.help), RangeText(field),
                                 DefaultText(field));
    row.name = new QLabel(name.mid(name.indexOf('.') + 1), row.row);
    row.name->setToolTip(tip);
    grid->addWidget(row.name, 0, 0);

    const size_t index = rows_.size();
    if (field.kind == OptionField::Kind::kFlag) {
      auto* check = new QCheckBox(row.row);
      connect(check, &QCheckBox::toggled, this, [this, index](bool on) { edit(index, on ? 1 : 0); });
      row.editor = check;
    } else if (field.kind == OptionField::Kind::kInteger) {
      auto* spin = new QSpinBox(row.row);
      spin->setRange(int(std::max<double>(field.min, INT_MIN)),
                     int(std::min<double>(field.max, INT_MAX)));
      spin->setKeyboardTracking(false);
      connect(spin, qOverload<int>(&QSpinBox::valueChanged), this,
              [this, index](int value) { edit(index, value); });
      row.editor = spin;
    } else {
      auto* spin = new RealSpinBox(row.row);
      spin->setRange(field.min, field.max);
      spin->setKeyboardTracking(false);
      connect(spin, qOverload<double>(&QDoubleSpinBox::valueChanged), this,
              [this, index](double value) { edit(index, value); });
      row.editor = spin;
    }
    // One width for every number, room for 0.0000001 whatever the range (an unbounded one
    // would otherwise size the box for 1.8e+308).
    if (field.kind != OptionField::Kind::kFlag) {
      row.editor->setFixedWidth(row.editor->fontMetrics().horizontalAdvance("0.0000001") + 40);
    }
    row.editor->setToolTip(tip);
    row.editor->setObjectName(name);
    grid->addWidget(row.editor, 0, 1);

    auto* reset = new QToolButton(row.row);
    reset->setText(tr("Reset"));
    reset->setToolTip(tr("Back to the default, %1").arg(DefaultText(field)));
    connect(reset, &QToolButton::clicked, this, [this, index] {
      edit(index, PipelineOptionFields()[rows_[index].field].get(PipelineOptions{}));
    });
    row.reset = reset;
    grid->addWidget(reset, 0, 2);

    auto* help = new QLabel(QStringLiteral("%1  %2").arg(QString::fromStdString(field.help),
                                                         RangeText(field)),
                            row.row);
    help->setWordWrap(true);
    help->setStyleSheet("color: palette(mid)");
    grid->addWidget(help, 1, 0, 1, 3);
    row.error = new QLabel(row.row);
    row.error->setWordWrap(true);
    row.error->setStyleSheet("color: #b00020");
    row.error->hide();
    grid->addWidget(row.error, 2, 0, 1, 3);
    grid->setColumnStretch(0, 1);

    group_layout->addWidget(row.row);
    rows_.push_back(row);
  }
  groups->addStretch(1);

  showValues();
  refreshPresets();
}

const ThresholdPanel::Row* ThresholdPanel::find(const QString& name) const {
  const std::string wanted = name.toStdString();
  for (const Row& row : rows_) {
    if (PipelineOptionFields()[row.field].name == wanted) return &row;
  }
  return nullptr;
}

QWidget* ThresholdPanel::editor(const QString& name) const {
  const Row* row = find(name);
  return row ? row->editor : nullptr;
}

QString ThresholdPanel::fieldError(const QString& name) const {
  const Row* row = find(name);
  return row && !row->error->isHidden() ? row->error->text() : QString();
}

bool ThresholdPanel::isChanged(const QString& name) const {
  const Row* row = find(name);
  return row && row->reset->isEnabled();
}

QAbstractButton* ThresholdPanel::resetButton(const QString& name) const {
  const Row* row = find(name);
  return row ? row->reset : nullptr;
}

bool ThresholdPanel::isFieldVisible(const QString& name) const {
  const Row* row = find(name);
  return row && !row->row->isHidden() && !row->group->isHidden();
}

void ThresholdPanel::setOptions(const PipelineOptions& options) {
  options_ = options;
  for (const Row& row : rows_) row.error->hide();
  message_->hide();
  showValues();
}

void ThresholdPanel::showValues() {
  showing_ = true;
  const PipelineOptions defaults;
  for (const Row& row : rows_) {
    const OptionField& field = PipelineOptionFields()[row.field];
    const double value = field.get(options_);
    if (auto* check = qobject_cast<QCheckBox*>(row.editor)) {
      check->setChecked(value != 0);
    } else if (auto* spin = qobject_cast<QSpinBox*>(row.editor)) {
      spin->setValue(int(value));
    } else if (auto* real = qobject_cast<QDoubleSpinBox*>(row.editor)) {
      real->setValue(value);
    }
    const bool changed = value != field.get(defaults);
    QFont font = row.name->font();
    font.setBold(changed);
    row.name->setFont(font);
    row.reset->setEnabled(changed);
  }
  showing_ = false;
}

void ThresholdPanel::edit(size_t index, double value) {
  if (showing_) return;
  const Row& row = rows_[index];
  const OptionField& field = PipelineOptionFields()[row.field];
  PipelineOptions candidate = options_;
  field.set(&candidate, value);
  std::string why;
  if (!candidate.Check(&why)) {
    row.error->setText(QString::fromStdString(why));
    row.error->show();
    return;
  }
  for (const Row& other : rows_) other.error->hide();
  message_->hide();
  options_ = candidate;
  showValues();
  emit optionsChanged(options_);
}

void ThresholdPanel::showError(const QString& message) {
  for (const Row& row : rows_) {
    if (message.contains(QString::fromStdString(PipelineOptionFields()[row.field].name))) {
      row.error->setText(message);
      row.error->show();
      return;
    }
  }
  report(message);
}

void ThresholdPanel::setRunning(bool running) {
  for (const Row& row : rows_) {
    if (PipelineOptionFields()[row.field].name.starts_with("acceptance.")) {
      row.editor->setEnabled(!running);
      row.reset->setVisible(!running);
    }
  }
}

void ThresholdPanel::setFilter(const QString& text) {
  if (search_->text() != text) search_->setText(text);  // Comes back here once.
  for (const Row& row : rows_) {
    const OptionField& field = PipelineOptionFields()[row.field];
    const bool shown = text.isEmpty() ||
                       QString::fromStdString(field.name).contains(text, Qt::CaseInsensitive) ||
                       QString::fromStdString(field.help).contains(text, Qt::CaseInsensitive);
    row.row->setHidden(!shown);
  }
  for (QGroupBox* group : groups_) {
    const bool any = std::any_of(rows_.begin(), rows_.end(), [&](const Row& row) {
      return row.group == group && !row.row->isHidden();
    });
    group->setHidden(!any);
  }
  scroll_->ensureVisible(0, 0);  // What matches starts at the top.
}

bool ThresholdPanel::loadSettingsFile(const QString& path, QString* error) {
  try {
    const PipelineOptions options = ReadPipelineSettings(path.toStdString());
    setOptions(options);
  } catch (const Error& e) {
    if (error) *error = QString::fromStdString(e.what());
    return false;
  }
  emit optionsChanged(options_);
  return true;
}

bool ThresholdPanel::saveSettingsFile(const QString& path, QString* error) const {
  QSaveFile file(path);
  const QByteArray text = QByteArray::fromStdString(PipelineSettingsText(options_));
  if (!file.open(QIODevice::WriteOnly) || file.write(text) != text.size() || !file.commit()) {
    if (error) *error = tr("%1: cannot be written: %2").arg(path, file.errorString());
    return false;
  }
  return true;
}

QStringList ThresholdPanel::presetNames() const {
  QStringList names;
  for (const QFileInfo& file :
       QDir(presets_dir_).entryInfoList({"*.txt"}, QDir::Files, QDir::Name | QDir::IgnoreCase)) {
    names << file.completeBaseName();
  }
  return names;
}

bool ThresholdPanel::savePreset(const QString& name, QString* error) {
  const QString trimmed = name.trimmed();
  if (trimmed.isEmpty() || trimmed.contains('/') || trimmed.contains('\\') ||
      trimmed.startsWith('.')) {
    if (error) *error = tr("'%1' cannot name a preset (no slashes, not empty)").arg(name);
    return false;
  }
  if (!QDir().mkpath(presets_dir_)) {
    if (error) *error = tr("%1: the presets folder cannot be made").arg(presets_dir_);
    return false;
  }
  if (!saveSettingsFile(PresetPath(presets_dir_, trimmed), error)) return false;
  refreshPresets();
  presets_->setCurrentText(trimmed);
  return true;
}

bool ThresholdPanel::loadPreset(const QString& name, QString* error) {
  return loadSettingsFile(PresetPath(presets_dir_, name), error);
}

bool ThresholdPanel::removePreset(const QString& name, QString* error) {
  QFile file(PresetPath(presets_dir_, name));
  if (!file.remove()) {
    if (error) *error = tr("%1: cannot be deleted: %2").arg(file.fileName(), file.errorString());
    return false;
  }
  refreshPresets();
  return true;
}

void ThresholdPanel::refreshPresets() {
  const QString current = presets_->currentText();
  presets_->clear();
  presets_->addItems(presetNames());
  presets_->setCurrentText(current);
}

void ThresholdPanel::report(const QString& message) {
  message_->setText(message);
  message_->setVisible(!message.isEmpty());
}

void ThresholdPanel::onSavePreset() {
  bool ok = false;
  const QString name = QInputDialog::getText(this, tr("Save Preset"), tr("Preset name:"),
                                             QLineEdit::Normal, presets_->currentText(), &ok);
  QString error;
  if (ok && !savePreset(name, &error)) report(error);
}

void ThresholdPanel::onLoadPreset() {
  QString error;
  if (presets_->currentText().isEmpty()) return;
  if (!loadPreset(presets_->currentText(), &error)) report(error);
}

void ThresholdPanel::onRemovePreset() {
  QString error;
  if (presets_->currentText().isEmpty()) return;
  if (!removePreset(presets_->currentText(), &error)) report(error);
}

void ThresholdPanel::onOpenFile() {
  const QString path = QFileDialog::getOpenFileName(this, tr("Open Settings File"), {},
                                                    tr("Settings (*.txt *.conf);;All files (*)"));
  QString error;
  if (!path.isEmpty() && !loadSettingsFile(path, &error)) report(error);
}

void ThresholdPanel::onSaveFile() {
  const QString path = QFileDialog::getSaveFileName(this, tr("Save Settings File"), {},
                                                    tr("Settings (*.txt *.conf);;All files (*)"));
  QString error;
  if (!path.isEmpty() && !saveSettingsFile(path, &error)) report(error);
}

}  // namespace autocal
