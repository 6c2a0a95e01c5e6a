#include "widgets/history_table.h"

#include <algorithm>
#include <exception>
#include <utility>

#include <QBrush>
#include <QComboBox>
#include <QFile>
#include <QFileDialog>
#include <QFileInfo>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QLineEdit>
#include <QMessageBox>
#include <QPushButton>
#include <QTableView>
#include <QVBoxLayout>

#include "pipeline/history_replay.h"

namespace autocal {
namespace {

// A pale background per verdict, so that a long table reads at a glance.
QColor VerdictTint(Verdict verdict) {
  switch (verdict) {
    case Verdict::kAccepted:
      return {230, 245, 230};
    case Verdict::kRejected:
      return {252, 228, 228};
    case Verdict::kAlarm:
    case Verdict::kNewRegime:
      return {255, 236, 214};
    case Verdict::kNoUpdate:
      break;
  }
  return {242, 242, 242};
}

// What each calibration format is called in the save dialog.
struct CalibrationFilter {
  CalibrationFormat format;
  const char* filter;
};
constexpr CalibrationFilter kCalibrationFilters[] = {
    {CalibrationFormat::kOpenCv, "OpenCV FileStorage YAML (*.yaml *.yml)"},
    {CalibrationFormat::kRos, "ROS camera_info YAML (*.yaml)"},
    {CalibrationFormat::kKalibr, "Kalibr camchain YAML (*.yaml)"},
    {CalibrationFormat::kColmap, "COLMAP cameras.txt (*.txt)"},
    {CalibrationFormat::kJson, "autocal JSON (*.json)"},
};

std::string FileName(const QString& path) { return QFile::encodeName(path).toStdString(); }

}  // namespace

HistoryTableModel::HistoryTableModel(QObject* parent) : QAbstractTableModel(parent) {}

void HistoryTableModel::setSeries(std::shared_ptr<const CalibrationSeries> series) {
  beginResetModel();
  series_ = std::move(series);
  if (!origin_set_) {
    origin_ns_ =
        series_ && !series_->stored.attempts.empty() ? series_->stored.attempts.front().t_ns : 0;
  }
  endResetModel();
}

void HistoryTableModel::setTimeOrigin(int64_t origin_ns) {
  beginResetModel();
  origin_ns_ = origin_ns;
  origin_set_ = true;
  endResetModel();
}

double HistoryTableModel::seconds(int64_t t_ns) const {
  return static_cast<double>(t_ns - origin_ns_) * 1e-9;
}

int HistoryTableModel::rowCount(const QModelIndex& parent) const {
  return parent.isValid() || !series_ ? 0 : static_cast<int>(series_->stored.attempts.size());
}

int HistoryTableModel::columnCount(const QModelIndex& parent) const {
  return parent.isValid() ? 0 : kNumColumns;
}

QVariant HistoryTableModel::data(const QModelIndex& index, int role) const {
  if (!series_ || !index.isValid()) return {};
  const AttemptRecord& record = series_->stored.attempts[static_cast<size_t>(index.row())];
  const int column = index.column();
  // A no-update attempt carries its prior, not an estimate: its numbers stay blank.
  const bool estimated = record.verdict != Verdict::kNoUpdate;
  switch (role) {
    case kVerdictRole:
      return static_cast<int>(record.verdict);
    case kAttemptRole:
      return record.id;
    case Qt::BackgroundRole:
      return QBrush(VerdictTint(record.verdict));
    case Qt::ForegroundRole: {
      // Parameters the attempt held at its prior are greyed: they were not estimated.
      const int intrinsic = column - kFirstIntrinsic;
      const bool held = intrinsic >= 0 && intrinsic < kNumIntrinsics &&
                        std::find(record.free_parameters.begin(), record.free_parameters.end(),
                                  intrinsic) == record.free_parameters.end();
      return held ? QVariant(QBrush(QColor(150, 150, 150))) : QVariant();
    }
    case Qt::ToolTipRole:
      return QString::fromStdString(record.reason + "\n" + record.material);
    case Qt::TextAlignmentRole:
      return column == kVerdict || column == kReason ? QVariant(Qt::AlignLeft | Qt::AlignVCenter)
                                                     : QVariant(Qt::AlignRight | Qt::AlignVCenter);
    case Qt::DisplayRole:
    case kSortRole:
      break;
    default:
      return {};
  }
  const bool display = role == Qt::DisplayRole;
  if (column == kTime) {
    return display ? QVariant(QString::number(seconds(record.t_ns), 'f', 3))
                   : QVariant(static_cast<qlonglong>(record.t_ns));
  }
  if (column == kVerdict) return QString::fromStdString(VerdictName(record.verdict));
  if (column == kReason) return QString::fromStdString(record.reason);
  if (!estimated) return display ? QVariant(QString()) : QVariant(0.0);
  const double value =
      column == kRms ? record.rms_px : record.estimate.Packed()[column - kFirstIntrinsic];
  if (!display) return value;
  // Pixels to a thousandth; distortion coefficients to six significant digits.
  const int intrinsic = column - kFirstIntrinsic;
  return column == kRms || intrinsic < kK1 ? QString::number(value, 'f', 3)
                                           : QString::number(value, 'g', 6);
}

QVariant HistoryTableModel::headerData(int section, Qt::Orientation orientation, int role) const {
  if (role != Qt::DisplayRole) return {};
  if (orientation == Qt::Vertical) return section;
  switch (section) {
    case kTime:
      return tr("Time (s)");
    case kVerdict:
      return tr("Verdict");
    case kRms:
      return tr("RMS (px)");
    case kReason:
      return tr("Reason");
    default:
      return QString::fromStdString(IntrinsicName(section - kFirstIntrinsic));
  }
}

HistoryFilterModel::HistoryFilterModel(QObject* parent) : QSortFilterProxyModel(parent) {
  setSortRole(HistoryTableModel::kSortRole);
  setFilterKeyColumn(-1);  // The text may be in any column (verdict, reason, a number).
  setFilterCaseSensitivity(Qt::CaseInsensitive);
}

void HistoryFilterModel::setVerdict(std::optional<Verdict> verdict) {
  verdict_ = verdict;
  invalidateFilter();
}

bool HistoryFilterModel::filterAcceptsRow(int source_row, const QModelIndex& source_parent) const {
  if (verdict_) {
    const QModelIndex index = sourceModel()->index(source_row, 0, source_parent);
    if (index.data(HistoryTableModel::kVerdictRole).toInt() != static_cast<int>(*verdict_)) {
      return false;
    }
  }
  return QSortFilterProxyModel::filterAcceptsRow(source_row, source_parent);
}

HistoryTable::HistoryTable(QWidget* parent)
    : QWidget(parent), model_(new HistoryTableModel(this)), filter_(new HistoryFilterModel(this)) {
  filter_->setSourceModel(model_);

  verdict_box_ = new QComboBox;
  verdict_box_->setToolTip(tr("Show the attempts of one verdict"));
  verdict_box_->addItem(tr("All verdicts"), -1);
  for (int v = 0; v < kNumVerdicts; ++v) {
    verdict_box_->addItem(QString::fromStdString(VerdictName(static_cast<Verdict>(v))), v);
  }
  connect(verdict_box_, QOverload<int>::of(&QComboBox::currentIndexChanged), this, [this] {
    const int v = verdict_box_->currentData().toInt();
    filter_->setVerdict(v < 0 ? std::nullopt : std::optional(static_cast<Verdict>(v)));
    updateCount();
  });
  text_box_ = new QLineEdit;
  text_box_->setPlaceholderText(tr("Filter: text in any column (reason, verdict, value)"));
  text_box_->setClearButtonEnabled(true);
  connect(text_box_, &QLineEdit::textChanged, this, [this](const QString& text) {
    filter_->setFilterFixedString(text);
    updateCount();
  });
  count_label_ = new QLabel;
  auto* export_history = new QPushButton(tr("Export History\u2026"));
  export_history->setToolTip(tr("Save the rows shown as CSV or JSON"));
  connect(export_history, &QPushButton::clicked, this, &HistoryTable::exportHistoryDialog);
  auto* export_calibration = new QPushButton(tr("Export Calibration\u2026"));
  export_calibration->setToolTip(
      tr("Save the current filtered calibration for OpenCV, ROS, Kalibr, COLMAP or as JSON"));
  connect(export_calibration, &QPushButton::clicked, this, &HistoryTable::exportCalibrationDialog);

  view_ = new QTableView;
  view_->setModel(filter_);
  view_->setSortingEnabled(true);
  view_->sortByColumn(HistoryTableModel::kTime, Qt::AscendingOrder);
  view_->setSelectionBehavior(QAbstractItemView::SelectRows);
  view_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  view_->setWordWrap(false);
  view_->verticalHeader()->setDefaultSectionSize(view_->fontMetrics().height() + 6);
  view_->horizontalHeader()->setStretchLastSection(true);
  view_->setToolTip(tr("Double-click a row to go to its time"));
  connect(view_, &QTableView::doubleClicked, this, [this](const QModelIndex& index) {
    const int id = index.data(HistoryTableModel::kAttemptRole).toInt();
    emit seekRequested(model_->seconds(model_->series()->stored.attempts[id].t_ns));
  });

  auto* controls = new QHBoxLayout;
  controls->setContentsMargins(6, 4, 6, 2);
  controls->addWidget(verdict_box_);
  controls->addWidget(text_box_, 1);
  controls->addWidget(count_label_);
  controls->addWidget(export_history);
  controls->addWidget(export_calibration);
  auto* layout = new QVBoxLayout(this);
  layout->setContentsMargins(0, 0, 0, 0);
  layout->setSpacing(0);
  layout->addLayout(controls);
  layout->addWidget(view_, 1);
  updateCount();
}

void HistoryTable::setSeries(std::shared_ptr<const CalibrationSeries> series) {
  // A newer read of the same file keeps the widths the user may have set.
  const bool same_file = model_->series() && series && model_->series()->path == series->path;
  model_->setSeries(std::move(series));
  if (!same_file) view_->resizeColumnsToContents();
  updateCount();
}

void HistoryTable::setTimeOrigin(int64_t origin_ns) { model_->setTimeOrigin(origin_ns); }

void HistoryTable::setVerdictFilter(std::optional<Verdict> verdict) {
  verdict_box_->setCurrentIndex(verdict_box_->findData(verdict ? static_cast<int>(*verdict) : -1));
}

void HistoryTable::setTextFilter(const QString& text) { text_box_->setText(text); }

void HistoryTable::updateCount() {
  count_label_->setText(tr("%1 of %2 attempts").arg(filter_->rowCount()).arg(model_->rowCount()));
}

std::vector<HistoryEntry> HistoryTable::shownEntries() const {
  std::vector<HistoryEntry> entries;
  if (model_->series() == nullptr) return entries;
  const std::vector<AttemptRecord>& attempts = model_->series()->stored.attempts;
  entries.reserve(static_cast<size_t>(filter_->rowCount()));
  for (int row = 0; row < filter_->rowCount(); ++row) {
    const int id = filter_->index(row, 0).data(HistoryTableModel::kAttemptRole).toInt();
    entries.push_back(ToHistoryEntry(attempts[static_cast<size_t>(id)]));
  }
  return entries;
}

CameraIntrinsics HistoryTable::currentCalibration() const {
  return model_->series() ? model_->series()->current.calibration : CameraIntrinsics{};
}

bool HistoryTable::exportHistory(const QString& path, HistoryFormat format, QString* error) const {
  try {
    WriteHistory(FileName(path), shownEntries(), format);
    return true;
  } catch (const std::exception& e) {
    *error = QString::fromStdString(e.what());
    return false;
  }
}

bool HistoryTable::exportCalibration(const QString& path, CalibrationFormat format,
                                     QString* error) const {
  if (model_->series() == nullptr) {
    *error = tr("no calibration history is open");
    return false;
  }
  try {
    WriteCalibration(FileName(path), currentCalibration(), format);
    return true;
  } catch (const std::exception& e) {
    *error = QString::fromStdString(e.what());
    return false;
  }
}

void HistoryTable::exportHistoryDialog() {
  QString filter;
  QString path =
      QFileDialog::getSaveFileName(this, tr("Export History"), QStringLiteral("history.csv"),
                                   tr("CSV (*.csv);;JSON (*.json)"), &filter);
  if (path.isEmpty()) return;
  const bool json = filter.startsWith(QLatin1String("JSON"));
  if (QFileInfo(path).suffix().isEmpty())
    path += json ? QLatin1String(".json") : QLatin1String(".csv");
  QString error;
  if (!exportHistory(path, json ? HistoryFormat::kJson : HistoryFormat::kCsv, &error)) {
    QMessageBox::warning(this, tr("Export failed"), error);
  }
}

void HistoryTable::exportCalibrationDialog() {
  QStringList filters;
  for (const CalibrationFilter& f : kCalibrationFilters) filters << tr(f.filter);
  QString chosen;
  const QString path = QFileDialog::getSaveFileName(this, tr("Export Calibration"),
                                                    QStringLiteral("calibration.yaml"),
                                                    filters.join(QStringLiteral(";;")), &chosen);
  if (path.isEmpty()) return;
  const qsizetype index = std::max<qsizetype>(filters.indexOf(chosen), 0);
  QString error;
  if (!exportCalibration(path, kCalibrationFilters[index].format, &error)) {
    QMessageBox::warning(this, tr("Export failed"), error);
  }
}

}  // namespace autocal
