#include "devices/history_writer.h"

#include <pthread.h>

#include <iterator>
#include <utility>

namespace autocal {
namespace {

template <typename Row>
void AppendRows(std::vector<Row>* to, std::vector<Row>&& rows) {
  to->insert(to->end(), std::make_move_iterator(rows.begin()),
             std::make_move_iterator(rows.end()));
}

}  // namespace

HistoryWriter::HistoryWriter(std::unique_ptr<HistoryStore> store, Committed committed)
    : store_(std::move(store)), committed_(std::move(committed)), thread_([this] { Write(); }) {}

HistoryWriter::~HistoryWriter() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void HistoryWriter::Submit(const CalibrationHistory& history) {
  {
    std::lock_guard lock(mutex_);
    if (failure_) std::rethrow_exception(failure_);
    if (pending_) {
      HistoryRows more = RowsSince(history, attempts_, alarms_, regimes_);
      AppendRows(&pending_->attempts, std::move(more.attempts));
      AppendRows(&pending_->alarms, std::move(more.alarms));
      AppendRows(&pending_->regimes, std::move(more.regimes));
    } else {
      // From the last attempt handed over: the file checks it holds that one, so that a
      // part is never appended to another history.
      pending_ = RowsSince(history, attempts_ > 0 ? attempts_ - 1 : 0, alarms_, regimes_);
    }
    attempts_ = history.attempts().size();
    alarms_ = history.alarms().size();
    regimes_ = history.regimes().size();
  }
  changed_.notify_all();
}

void HistoryWriter::Finish() {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return failure_ || (!pending_ && !writing_); });
  if (failure_) std::rethrow_exception(failure_);
}

void HistoryWriter::Finish(const CalibrationHistory& history) {
  Submit(history);
  Finish();
}

void HistoryWriter::Write() {
  pthread_setname_np(pthread_self(), "history writer");  // As top -H and perf show it.
  std::unique_lock lock(mutex_);
  while (true) {
    changed_.wait(lock, [&] { return stopping_ || pending_; });
    if (!pending_) return;  // Stopping, with everything written.
    const HistoryRows rows = std::move(*pending_);
    pending_.reset();
    if (failure_) continue;  // Nothing is written after a failed write.
    writing_ = true;
    lock.unlock();
    std::exception_ptr failure;
    try {
      store_->Record(rows);
      if (committed_) committed_();
    } catch (...) {
      failure = std::current_exception();
    }
    lock.lock();
    writing_ = false;
    if (failure) failure_ = failure;
    changed_.notify_all();
  }
}

}  // namespace autocal
