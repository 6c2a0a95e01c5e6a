// The calibration history in a SQLite file: one row per judged attempt, the alarms and the
// regimes, and the pre-mission calibration and acceptance options they were judged with.
// Rows are appended as attempts come, each batch in its own transaction, in WAL mode with
// full sync: a process killed at any moment leaves every committed row readable. The schema
// is in docs/history.md.
#pragma once

#include <memory>
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

  // Everything in the file. Throws Error naming the file on malformed rows.
  StoredHistory Load() const;

  const std::string& path() const { return path_; }

 private:
  struct Closer {
    void operator()(sqlite3* db) const;
  };

  std::string path_;
  std::unique_ptr<sqlite3, Closer> db_;
};

}  // namespace autocal
