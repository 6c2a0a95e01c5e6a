#include "devices/recorder.h"

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <exception>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <thread>

#include <opencv2/core/utility.hpp>

#include "devices/recording_writer.h"
#include "devices/session_io.h"
#include "pipeline/error.h"
#include "pipeline/self_calibration.h"

namespace fs = std::filesystem;

namespace autocal {
namespace {

// Frames the writer encodes at once, in parallel.
constexpr size_t kFramesPerBatch = 4;

// A CSV field: quoted, with quotes doubled, when it holds a separator or a quote.
std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (const char c : text) {
    if (c == '"') quoted += '"';
    quoted += c == '\n' ? ' ' : c;
  }
  return quoted + "\"";
}

const char* EventKindName(SourceEvent::Kind kind) {
  switch (kind) {
    case SourceEvent::Kind::kConnected:
      return "connected";
    case SourceEvent::Kind::kDisconnected:
      return "disconnected";
    case SourceEvent::Kind::kError:
      return "error";
  }
  return "error";
}

// Owns the RecordingWriter on its own thread and takes items through a queue.
class WriterThread {
 public:
  WriterThread(RecordingWriter* writer, size_t frame_capacity, bool drop_when_full)
      : writer_(writer), frame_capacity_(frame_capacity), drop_when_full_(drop_when_full) {
    thread_ = std::thread(&WriterThread::Run, this);
  }
  ~WriterThread() { Close(); }

  // Queues an item; for a frame with the queue full, drops the oldest queued frame or
  // waits, as configured. Returns false once the writer has failed.
  bool Push(SourceItem item) {
    std::unique_lock lock(mutex_);
    if (item.kind == SourceItem::Kind::kFrame) {
      if (drop_when_full_ && queued_frames_ >= frame_capacity_) {
        for (auto it = queue_.begin(); it != queue_.end(); ++it) {
          if (it->kind == SourceItem::Kind::kFrame) {
            queue_.erase(it);
            --queued_frames_;
            ++progress_.frames_dropped;
            break;
          }
        }
      }
      space_.wait(lock, [&] { return queued_frames_ < frame_capacity_ || failure_; });
      ++queued_frames_;
    }
    if (failure_) return false;
    queue_.push_back(std::move(item));
    ready_.notify_one();
    return true;
  }

  // Writes what is queued and ends the thread.
  void Close() {
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
    }
    ready_.notify_one();
    if (thread_.joinable()) thread_.join();
  }

  // Counts so far; the writer's failure, if any.
  RecorderProgress progress() const {
    std::lock_guard lock(mutex_);
    return progress_;
  }
  std::exception_ptr failure() const {
    std::lock_guard lock(mutex_);
    return failure_;
  }

 private:
  // Takes what is queued, encodes its frames in parallel (PNG encoding is most of the
  // writer's time, tens of ms a frame), then appends every row in order.
  void Run() {
    while (true) {
      std::vector<SourceItem> batch;
      {
        std::unique_lock lock(mutex_);
        ready_.wait(lock, [&] { return !queue_.empty() || closed_; });
        if (queue_.empty()) return;
        size_t frames = 0;
        while (!queue_.empty() && frames < kFramesPerBatch) {
          if (queue_.front().kind == SourceItem::Kind::kFrame) {
            --queued_frames_;
            ++frames;
          }
          batch.push_back(std::move(queue_.front()));
          queue_.pop_front();
        }
      }
      space_.notify_all();
      try {
        Write(&batch);
      } catch (...) {
        std::lock_guard lock(mutex_);
        failure_ = std::current_exception();
        queue_.clear();
        queued_frames_ = 0;
        space_.notify_all();
        return;
      }
    }
  }

  void Write(std::vector<SourceItem>* batch) {
    // The writer refuses times that do not increase: such an item is skipped, and counted.
    std::vector<const SourceItem*> frames;
    std::optional<int64_t> last_ns = last_frame_ns_;
    for (SourceItem& item : *batch) {
      if (item.kind != SourceItem::Kind::kFrame) continue;
      if (last_ns && item.t_ns <= *last_ns) {
        item.image.release();  // Marks it refused.
        continue;
      }
      last_ns = item.t_ns;
      frames.push_back(&item);
    }
    std::vector<std::exception_ptr> failures(frames.size());
    cv::parallel_for_(cv::Range(0, static_cast<int>(frames.size())), [&](const cv::Range& range) {
      for (int i = range.start; i < range.end; ++i) {
        try {
          writer_->WriteFrameImage(frames[i]->t_ns, frames[i]->image);
        } catch (...) {
          failures[i] = std::current_exception();
        }
      }
    });
    for (const std::exception_ptr& failure : failures) {
      if (failure) std::rethrow_exception(failure);
    }

    for (const SourceItem& item : *batch) {
      switch (item.kind) {
        case SourceItem::Kind::kFrame:
          if (item.image.empty()) {
            Refuse();
            break;
          }
          writer_->AppendFrameRow(item.t_ns);
          last_frame_ns_ = item.t_ns;
          if (!first_frame_ns_) first_frame_ns_ = item.t_ns;
          {
            std::lock_guard lock(mutex_);
            ++progress_.frames_written;
            progress_.recorded_s = 1e-9 * static_cast<double>(item.t_ns - *first_frame_ns_);
          }
          break;
        case SourceItem::Kind::kAccel:
          if (last_accel_ns_ && item.t_ns <= *last_accel_ns_) {
            Refuse();
            break;
          }
          writer_->AddAccel(item.accel);
          last_accel_ns_ = item.t_ns;
          {
            std::lock_guard lock(mutex_);
            ++progress_.accel_written;
          }
          break;
        case SourceItem::Kind::kEvent:
          WriteEvent(item.event);
          break;
      }
    }
  }

  void Refuse() {
    std::lock_guard lock(mutex_);
    ++progress_.items_refused;
  }

  void WriteEvent(const SourceEvent& event) {
    const fs::path path = fs::path(writer_->dir()) / "events.csv";
    if (!events_.is_open()) {
      events_.open(path, std::ios::binary | std::ios::trunc);
      events_ << "#timestamp [ns],device,event,message\n";
    }
    events_ << event.t_ns << ','
            << (event.device == SourceEvent::Device::kCamera ? "camera" : "accelerometer") << ','
            << EventKindName(event.kind) << ',' << CsvField(event.message) << '\n';
    events_.flush();
    if (!events_) throw Error(path.string(), 0, "cannot be written");
  }

  RecordingWriter* writer_;
  const size_t frame_capacity_;
  const bool drop_when_full_;
  std::thread thread_;
  // Writer thread only.
  std::ofstream events_;
  std::optional<int64_t> first_frame_ns_, last_frame_ns_, last_accel_ns_;

  mutable std::mutex mutex_;  // The members below.
  std::condition_variable ready_, space_;
  std::deque<SourceItem> queue_;
  size_t queued_frames_ = 0;
  bool closed_ = false;
  std::exception_ptr failure_;
  RecorderProgress progress_;
};

}  // namespace

bool RecorderOptions::Check(std::string* error) const {
  if (!(seconds >= 0) || !std::isfinite(seconds)) {
    *error = "seconds: must be 0 (until stopped) or positive";
  } else if (writer_queue_frames == 0) {
    *error = "writer_queue_frames: at least 1";
  } else if (!(progress_interval_s > 0)) {
    *error = "progress_interval_s: must be positive";
  } else if (readout_ms && !IsReadoutMs(*readout_ms)) {
    *error = "readout_ms: must be in [0, " + std::to_string(int(kMaxReadoutMs)) + "]";
  } else {
    return true;
  }
  return false;
}

RecorderProgress Record(FrameSource& source, const std::string& dir, const RecorderOptions& options,
                        const RecorderCallback& progress, const std::atomic<bool>* stop) {
  std::string why;
  if (!options.Check(&why)) throw Error("recorder options: " + why);
  std::error_code ignored;
  if (fs::exists(dir, ignored) && !fs::is_empty(dir, ignored)) {
    throw Error(dir, 0, "already exists and is not empty: a recording needs a new folder");
  }

  source.Start();
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  const auto session = [&] {
    SessionInfo stated = source.session();
    if (options.readout_ms) stated.readout_ms = *options.readout_ms;
    return stated;
  };
  std::optional<RecordingWriter> writer;
  try {
    writer.emplace(dir, session());
  } catch (...) {
    source.Stop();
    throw;
  }
  WriterThread writer_thread(&*writer, options.writer_queue_frames, source.live());

  // A recorded source ends at a time of its own: `seconds` after its first frame.
  std::optional<int64_t> end_ns;
  if (!source.live() && options.seconds > 0) {
    if (const Sequence* sequence = source.sequence(); sequence && sequence->frame_count() > 0) {
      end_ns = sequence->frame_time_ns(0) + std::llround(options.seconds * 1e9);
    }
  }
  const auto live_end = start + std::chrono::duration_cast<Clock::duration>(
                                    std::chrono::duration<double>(options.seconds));
  std::vector<SourceEvent> events;
  const auto report = [&] {
    RecorderProgress now = writer_thread.progress();
    now.elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
    now.source = source.stats();
    now.events = events;
    return now;
  };
  const auto interval = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(options.progress_interval_s));
  Clock::time_point next_report = start + interval;

  SourceItem item;
  while (!(stop && stop->load())) {
    if (source.live() && options.seconds > 0 && Clock::now() >= live_end) break;
    if (progress && Clock::now() >= next_report) {
      progress(report());
      next_report += interval;
    }
    const FrameSource::Status status = source.Next(&item, std::chrono::milliseconds(100));
    if (status == FrameSource::Status::kEnd) break;
    if (status == FrameSource::Status::kTimeout) continue;
    if (!source.live() && end_ns && item.t_ns >= *end_ns) break;
    if (item.kind == SourceItem::Kind::kEvent) events.push_back(item.event);
    if (!writer_thread.Push(std::move(item))) break;
    item = SourceItem();
  }
  source.Stop();
  writer_thread.Close();
  if (const std::exception_ptr failure = writer_thread.failure()) std::rethrow_exception(failure);
  // A live accelerometer's rate is known only now; the file is replaced whole.
  if (source.live()) WriteSessionFile((fs::path(dir) / "session.json").string(), session());
  const RecorderProgress last = report();
  if (progress) progress(last);
  return last;
}

}  // namespace autocal
