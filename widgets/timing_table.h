// Each box's time per frame, median and 95th percentile over the run so far, as
// `autocal run --summary` reports it (timing_ms): the Timing dock. It shows what the
// pipeline's controllers measured (devices/timing_stats.h); it computes nothing.
#pragma once

#include <map>
#include <string>

#include <QWidget>

#include "devices/timing_stats.h"

class QLabel;
class QTableWidget;

namespace autocal {

class TimingTable : public QWidget {
  Q_OBJECT

 public:
  enum Column { kBox = 0, kMedian, kP95, kFrames, kNumColumns };

  explicit TimingTable(QWidget* parent = nullptr);

  // `stats` by box name (BoxTimingLog::Stats), measured over `source` ("the recording",
  // "the live source"); rows in box order, "frame" first.
  void setStats(const std::map<std::string, TimingStats>& stats, const QString& source);

  const QTableWidget* table() const { return table_; }

 private:
  QLabel* caption_;
  QTableWidget* table_;
};

}  // namespace autocal
