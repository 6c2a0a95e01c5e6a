// The calibration history in a SQLite file: one row per judged attempt, the alarms and the
// regimes, and the pre-mission calibration and acceptance options they were judged with.
// Rows are appended as attempts come, each batch in its own transaction, in WAL mode with
// full sync: a process killed at any moment leaves every committed row readable. The schema
// is in docs/history.md.
#pragma once

#include <cstddef>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "pipeline/calibration_history.h"

struct sqlite3;

namespace autocal {

// The schema this build writes, and the newest it reads.
inline constexpr int kHistorySchemaVersion = 1;

// A calibration history as kept in a file.
struct StoredHistory {
  CameraIntrinsics premission;  // Zero when nothing was recorded yet.
  AcceptanceOptions options;
  std::vector<AttemptRecord> attempts;
  std::vector<Alarm> alarms;
  std::vector<Regime> regimes;
};

// The rows of one history from given indices on (the ids of its attempts, alarms and
// regimes are their indices): a part of it to append to a file.
struct HistoryRows {
  CameraIntrinsics premission;
  AcceptanceOptions options;
  size_t first_attempt = 0, first_alarm = 0, first_regime = 0;
  std::vector<AttemptRecord> attempts;
  std::vector<Alarm> alarms;
  std::vector<Regime> regimes;
};

// What `history` holds from these indices on.
HistoryRows RowsSince(const CalibrationHistory& history, size_t attempt, size_t alarm,
                      size_t regime);

class HistoryStore {
 public:
  enum class Mode {
    kOpenOrCreate,  // Creates the file and its schema when missing or empty.
    kOpenExisting,  // The file must exist and hold a history.
  };

  // Throws Error naming the file when it cannot be opened, is not an autocal history
  // database, or has a newer schema than this build reads.
  explicit HistoryStore(const std::string& path, Mode mode = Mode::kOpenOrCreate);
  ~HistoryStore();
  HistoryStore(HistoryStore&&) noexcept;
  HistoryStore& operator=(HistoryStore&&) noexcept;

  // Appends what `history` holds beyond what the file holds (after each Judge: the attempt,
  // and the alarm and the regime it raised), in one transaction. The file must hold the
  // beginning of this same history, or nothing; throws Error otherwise or on a write error.
  void Record(const CalibrationHistory& history);
  // The same for a part of a history: the file must hold every row before the first of
  // each table's rows here (and those of these it holds must be the same attempts), so
  // that parts recorded in turn, each overlapping the one before, make up the history.
  void Record(const HistoryRows& rows);

  // Everything in the file. Throws Error naming the file on malformed rows.
  StoredHistory Load() const;

  const std::string& path() const { return path_; }

 private:
  void Append(const CameraIntrinsics& premission, const AcceptanceOptions& options,
              std::span<const AttemptRecord> attempts, size_t first_attempt,
              std::span<const Alarm> alarms, size_t first_alarm,
              std::span<const Regime> regimes, size_t first_regime);

  struct Closer {
    void operator()(sqlite3* db) const;
  };

  std::string path_;
  std::unique_ptr<sqlite3, Closer> db_;
};

}  // namespace autocal
