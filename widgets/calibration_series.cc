#include "widgets/calibration_series.h"

#include <algorithm>
#include <exception>

#include <QFile>
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
}

HistoryOpener::~HistoryOpener() { watcher_.waitForFinished(); }

void HistoryOpener::open(const QString& path) {
  watcher_.setFuture(QtConcurrent::run([path]() -> Result {
    Result result{path, nullptr, {}};
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
  if (result.series) {
    emit opened(result.path, result.series);
  } else {
    emit failed(result.path, result.error);
  }
}

}  // namespace autocal
