// A calibration history as the workbench shows it: the stored records, and the trend curve
// and current calibration from replaying them (pipeline/history_replay.h). Built once, off
// the GUI thread, then shared read-only by the plots and the table; the widgets only read
// and reshape it.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <QFutureWatcher>
#include <QObject>
#include <QString>
#include <QTimer>

#include "pipeline/calibration_history.h"
#include "pipeline/history_store.h"

namespace autocal {

// What the plots draw: the nine intrinsics, then the reprojection error.
inline constexpr int kRmsChannel = kNumIntrinsics;
inline constexpr int kNumCalibrationChannels = kNumIntrinsics + 1;

// "fx", ..., "k3", "rms".
QString ChannelName(int channel);
// The channel's value in a record (its estimate, or its reprojection error).
double ChannelValue(const AttemptRecord& record, int channel);

struct CalibrationSeries {
  std::string path;                // The file it came from.
  StoredHistory stored;            // The records as the file holds them.
  std::vector<TrendSample> trend;  // The filtered calibration over the attempts' time span.
  FilteredCalibration current;     // The filtered calibration at the last attempt.
  std::vector<int> differing;      // Attempts whose replayed verdict is not the stored one.
};

// The trend is sampled this finely, with at most kMaxTrendSamples over the whole history.
inline constexpr int64_t kTrendStepNs = 250'000'000;
inline constexpr int kMaxTrendSamples = 20000;

// Replays `stored`. A history with no attempts has no trend; its current calibration is the
// pre-mission one. Throws Error when the history cannot be replayed.
CalibrationSeries MakeCalibrationSeries(StoredHistory stored);

// Opens a history file (HistoryStore) off the GUI thread and replays it. Once opened, the
// file is followed: when it changes (a run still appending to it), it is read again.
class HistoryOpener : public QObject {
  Q_OBJECT

 public:
  // How often a followed file is looked at.
  static constexpr int kFollowIntervalMs = 1000;

  explicit HistoryOpener(QObject* parent = nullptr);
  ~HistoryOpener() override;

  // A newer call supersedes one still running: only the newest path reports back.
  void open(const QString& path);

 signals:
  void opened(const QString& path, std::shared_ptr<const autocal::CalibrationSeries> series);
  // `message` is the full error text (it names the file).
  void failed(const QString& path, const QString& message);
  // The followed file changed and was read again. A failure to read it again is not
  // reported: the history shown stays, and the next change is tried.
  void updated(const QString& path, std::shared_ptr<const autocal::CalibrationSeries> series);

 private:
  struct Result {
    QString path;
    QString signature;  // Of the file when reading began.
    bool update = false;
    std::shared_ptr<const CalibrationSeries> series;
    QString error;
  };

  // Sizes and times of the file and its write-ahead log: they change with every commit.
  static QString Signature(const QString& path);
  void start(const QString& path, bool update);
  void poll();
  void onFinished();

  QFutureWatcher<Result> watcher_;
  QTimer follow_timer_;
  QString followed_;   // The file opened last; empty when none.
  QString signature_;  // Its signature when last read.
};

}  // namespace autocal
