// Every attempt of a calibration history in a table (time, verdict, estimate, reprojection
// error, reason), filtered by verdict and by text, with export of the rows shown and of the
// current (filtered) calibration in every format calibration_export.h and calibration_io.h
// write.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>

#include <QAbstractTableModel>
#include <QSortFilterProxyModel>
#include <QWidget>

#include "pipeline/calibration_export.h"
#include "pipeline/calibration_io.h"
#include "widgets/calibration_series.h"

class QComboBox;
class QLabel;
class QLineEdit;
class QTableView;

namespace autocal {

class HistoryTableModel : public QAbstractTableModel {
  Q_OBJECT

 public:
  enum Column {
    kTime = 0,
    kVerdict,
    kFirstIntrinsic,
    kRms = kFirstIntrinsic + kNumIntrinsics,
    kReason,
    kNumColumns
  };
  // Raw values for sorting and filtering (DisplayRole is rounded text).
  static constexpr int kSortRole = Qt::UserRole;
  static constexpr int kVerdictRole = Qt::UserRole + 1;  // The Verdict, as an int.
  static constexpr int kAttemptRole = Qt::UserRole + 2;  // The attempt's id.

  explicit HistoryTableModel(QObject* parent = nullptr);

  void setSeries(std::shared_ptr<const CalibrationSeries> series);
  const CalibrationSeries* series() const { return series_.get(); }
  // Times are shown in seconds since `origin_ns` (as the plots do).
  void setTimeOrigin(int64_t origin_ns);
  double seconds(int64_t t_ns) const;

  int rowCount(const QModelIndex& parent = {}) const override;
  int columnCount(const QModelIndex& parent = {}) const override;
  QVariant data(const QModelIndex& index, int role = Qt::DisplayRole) const override;
  QVariant headerData(int section, Qt::Orientation orientation,
                      int role = Qt::DisplayRole) const override;

 private:
  std::shared_ptr<const CalibrationSeries> series_;
  int64_t origin_ns_ = 0;
  bool origin_set_ = false;
};

// Keeps the rows of one verdict (or all), whose text contains the filter string.
class HistoryFilterModel : public QSortFilterProxyModel {
  Q_OBJECT

 public:
  explicit HistoryFilterModel(QObject* parent = nullptr);
  void setVerdict(std::optional<Verdict> verdict);

 protected:
  bool filterAcceptsRow(int source_row, const QModelIndex& source_parent) const override;

 private:
  std::optional<Verdict> verdict_;
};

class HistoryTable : public QWidget {
  Q_OBJECT

 public:
  explicit HistoryTable(QWidget* parent = nullptr);

  void setSeries(std::shared_ptr<const CalibrationSeries> series);
  void setTimeOrigin(int64_t origin_ns);

  HistoryTableModel* model() const { return model_; }
  HistoryFilterModel* filter() const { return filter_; }
  QTableView* view() const { return view_; }
  // Filters as the controls do (and sets the controls).
  void setVerdictFilter(std::optional<Verdict> verdict);
  void setTextFilter(const QString& text);

  // The rows shown (after filtering, in the order shown), as exported.
  std::vector<HistoryEntry> shownEntries() const;
  // The calibration in effect after the last attempt (the pre-mission one before any).
  CameraIntrinsics currentCalibration() const;
  // Write the shown rows, or the current calibration; false with the reason in `error`.
  bool exportHistory(const QString& path, HistoryFormat format, QString* error) const;
  bool exportCalibration(const QString& path, CalibrationFormat format, QString* error) const;

 signals:
  // A row was double-clicked: go to its time (seconds since the origin).
  void seekRequested(double seconds);

 private:
  void updateCount();
  void exportHistoryDialog();
  void exportCalibrationDialog();

  HistoryTableModel* model_;
  HistoryFilterModel* filter_;
  QComboBox* verdict_box_;
  QLineEdit* text_box_;
  QLabel* count_label_;
  QTableView* view_;
};

}  // namespace autocal
