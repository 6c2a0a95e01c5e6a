// Writes a calibration history to its SQLite file on a thread of its own, so that the
// thread judging attempts (the runtime's boxes 4-9) never waits for the disk: a commit
// with full sync waits for the storage to flush (2.6 ms median, 301 ms at worst on the
// 60 s office walk here), and for another program's write lock on the file up to the
// store's 5 s busy timeout. See docs/history.md.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "pipeline/history_store.h"

namespace autocal {

class HistoryWriter {
 public:
  // Called on the writer's thread after each commit.
  using Committed = std::function<void()>;

  // Starts the thread that owns `store`.
  explicit HistoryWriter(std::unique_ptr<HistoryStore> store, Committed committed = {});
  // Writes what was submitted, then stops; an error then is lost (Finish reports it).
  ~HistoryWriter();
  HistoryWriter(const HistoryWriter&) = delete;
  HistoryWriter& operator=(const HistoryWriter&) = delete;

  // On the thread that judges `history`'s attempts, after each: copies the rows submitted
  // nothing of yet and hands them to the writer, without waiting for the disk. Rows
  // submitted while a commit is under way go into the next one. Throws the Error an earlier
  // write stopped on: nothing is written after it.
  void Submit(const CalibrationHistory& history);
  // Waits until everything submitted is in the file. Throws the Error a write stopped on.
  void Finish();
  // Submit(history), then Finish(). At the start of a run, so that the file holds the
  // calibration it starts from before any frame; and at its end, once the runtime has
  // finished: the runtime judges an attempt after the last frame (offline, one made within
  // judge_after_frames of the end; live, one whose solve ended after it) with no snapshot
  // to carry it to a frame callback.
  void Finish(const CalibrationHistory& history);

 private:
  void Write();  // The writer thread.

  const std::unique_ptr<HistoryStore> store_;
  const Committed committed_;
  // Rows of the history handed over so far, per table.
  size_t attempts_ = 0, alarms_ = 0, regimes_ = 0;

  std::mutex mutex_;
  std::condition_variable changed_;
  std::optional<HistoryRows> pending_;  // Submitted, not yet being written.
  bool writing_ = false;
  bool stopping_ = false;
  std::exception_ptr failure_;
  std::thread thread_;
};

}  // namespace autocal
