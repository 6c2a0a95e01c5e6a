#include "widgets/calibration_series.h"

#include <algorithm>
#include <exception>

#include <QDateTime>
#include <QFile>
#include <QFileInfo>
#include <QtConcurrent/QtConcurrentRun>

#include "pipeline/history_replay.h"

namespace autocal {

QString ChannelName(int channel) {
  return channel == kRmsChannel ? QStringLiteral("rms")
                                : QString::fromStdString(IntrinsicName(channel));
}

double ChannelValue(const AttemptRecord& record, int channel) {
  return channel == kRmsChannel ? record.rms_px : record.estimate.Packed()[channel];
}

CalibrationSeries MakeCalibrationSeries(StoredHistory stored) {
  CalibrationSeries series;
  if (stored.attempts.empty()) {
    series.current.calibration = stored.premission;
    series.stored = std::move(stored);
    return series;
  }
  const CalibrationHistory history = ReplayHistory(stored, &series.differing);
  const int64_t from_ns = stored.attempts.front().t_ns;
  const int64_t to_ns = stored.attempts.back().t_ns;
  const int64_t steps = (to_ns - from_ns + kTrendStepNs - 1) / kTrendStepNs;
  const int samples = static_cast<int>(std::clamp<int64_t>(steps + 1, 2, kMaxTrendSamples));
  series.trend = history.TrendCurve(from_ns, to_ns, samples);
  series.current = history.Current(to_ns);
  series.stored = std::move(stored);
  return series;
}

HistoryOpener::HistoryOpener(QObject* parent) : QObject(parent) {
  connect(&watcher_, &QFutureWatcher<Result>::finished, this, &HistoryOpener::onFinished);
  follow_timer_.setInterval(kFollowIntervalMs);
  connect(&follow_timer_, &QTimer::timeout, this, &HistoryOpener::poll);
}

HistoryOpener::~HistoryOpener() { watcher_.waitForFinished(); }

QString HistoryOpener::Signature(const QString& path) {
  QString signature;
  for (const QString& file : {path, path + QStringLiteral("-wal")}) {
    const QFileInfo info(file);
    signature += QStringLiteral("%1@%2;")
                     .arg(info.exists() ? info.size() : -1)
                     .arg(info.exists() ? info.lastModified().toMSecsSinceEpoch() : 0);
  }
  return signature;
}

void HistoryOpener::open(const QString& path) {
  follow_timer_.stop();
  followed_.clear();
  start(path, false);
}

void HistoryOpener::poll() {
  if (followed_.isEmpty() || watcher_.isRunning()) return;
  if (Signature(followed_) != signature_) start(followed_, true);
}

void HistoryOpener::start(const QString& path, bool update) {
  // Taken before reading: a change during the read is seen at the next look.
  const QString signature = Signature(path);
  watcher_.setFuture(QtConcurrent::run([path, signature, update]() -> Result {
    Result result{path, signature, update, nullptr, {}};
    try {
      const std::string file = QFile::encodeName(path).toStdString();
      auto series = std::make_shared<CalibrationSeries>(
          MakeCalibrationSeries(HistoryStore(file, HistoryStore::Mode::kOpenExisting).Load()));
      series->path = file;
      result.series = std::move(series);
    } catch (const std::exception& e) {
      result.error = QString::fromStdString(e.what());
    }
    return result;
  }));
}

void HistoryOpener::onFinished() {
  const Result result = watcher_.result();
  if (result.update) {
    // The file was opened again meanwhile (or another one): this read is stale.
    if (result.path != followed_) return;
    signature_ = result.signature;
    if (result.series) emit updated(result.path, result.series);
    return;
  }
  if (!result.series) {
    emit failed(result.path, result.error);
    return;
  }
  followed_ = result.path;
  signature_ = result.signature;
  follow_timer_.start();
  emit opened(result.path, result.series);
}

}  // namespace autocal
