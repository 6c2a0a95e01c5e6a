// Boxes 1-10 on threads, as the paper runs them: boxes 1-3 (LensHalf) on one thread,
// boxes 4-9 and the judging of attempts (MotionHalf) on another, joined by frame
// timestamps through a bounded queue, and box 10's solve on a worker of its own so that
// per-frame work never waits for it. Frames and accelerometer samples are pushed in by
// the caller; every processed frame is published as an immutable snapshot that any thread
// may take without locking the pipeline. See docs/runtime.md.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <exception>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "devices/sequence.h"
#include "devices/timing_stats.h"
#include "pipeline/calibration_pipeline.h"

namespace autocal {

// A queue between two threads that holds at most `capacity` items.
template <typename T>
class BoundedQueue {
 public:
  explicit BoundedQueue(size_t capacity) : capacity_(capacity) {}

  // Waits while the queue is full. False (and the item dropped) once closed.
  bool Push(T item) {
    std::unique_lock lock(mutex_);
    not_full_.wait(lock, [&] { return closed_ || items_.size() < capacity_; });
    if (closed_) return false;
    items_.push_back(std::move(item));
    not_empty_.notify_one();
    return true;
  }
  // Never waits: when the queue is full its oldest item makes room. Returns the number of
  // items dropped (0 or 1; the new item too when closed).
  int PushDroppingOldest(T item) {
    std::lock_guard lock(mutex_);
    if (closed_) return 1;
    int dropped = 0;
    if (items_.size() >= capacity_) {
      items_.pop_front();
      dropped = 1;
    }
    items_.push_back(std::move(item));
    not_empty_.notify_one();
    return dropped;
  }
  // Waits for an item; nothing once the queue is closed and empty.
  std::optional<T> Pop() {
    return PopUnless([] { return false; });
  }
  // Waits for an item, or for `woken()` to hold (tested on entry and at each Wake()):
  // nothing when woken with the queue empty, or once closed and empty.
  template <typename Predicate>
  std::optional<T> PopUnless(Predicate woken) {
    std::unique_lock lock(mutex_);
    not_empty_.wait(lock, [&] { return closed_ || !items_.empty() || woken(); });
    if (items_.empty()) return std::nullopt;
    T item = std::move(items_.front());
    items_.pop_front();
    not_full_.notify_one();
    return item;
  }
  // Makes a waiting PopUnless test its predicate again (set what it tests first).
  void Wake() {
    std::lock_guard lock(mutex_);
    not_empty_.notify_all();
  }
  // Items already queued can still be taken; pushes fail from now on.
  void Close() {
    std::lock_guard lock(mutex_);
    closed_ = true;
    not_empty_.notify_all();
    not_full_.notify_all();
  }

 private:
  const size_t capacity_;
  std::mutex mutex_;
  std::condition_variable not_empty_, not_full_;
  std::deque<T> items_;
  bool closed_ = false;
};

struct RuntimeOptions {
  // Live: the camera must never wait. When the pipeline falls behind, the oldest frame not
  // yet started is dropped (and counted), boxes 1-3 take the newest calibration there is,
  // and each attempt is judged as soon as its solve ends (on the boxes 4-9 thread, between
  // frames if it is idle; the next frame's snapshot carries the verdict). Offline: every
  // frame is processed, and what each frame sees is fixed by frame counts, not by thread
  // timing, so that two runs give the same results.
  bool live = false;
  size_t frame_queue = 4;  // Frames waiting for boxes 1-3 (live: the oldest dropped beyond).
  // Live: frames done by boxes 1-3 waiting for boxes 4-9 (each one waiting adds a frame
  // interval to the latency). Offline the queue holds at least calibration_lag_frames, so
  // that the lag alone says how far ahead boxes 1-3 run: with 2, they stalled on the full
  // queue 3 frames ahead while a core stood idle (bench/README.md, session 37).
  size_t lens_queue = 2;
  // Offline: an attempt made on frame i is judged on frame i + this, waiting for its solve
  // if it has not ended. Boxes 1-9 go on meanwhile, so the solve overlaps them; the
  // verdicts come that much later. 0 judges on frame i itself, as
  // CalibrationPipeline::Process does. It is judged sooner if the next attempt would be
  // due on the next frame: no attempt waits for its predecessor's verdict.
  int judge_after_frames = 13;
  // Offline: boxes 1-3 on frame i work with the calibration as it was after frame
  // i - this, waiting for it if needed; boxes 1-3 run at most this many frames ahead.
  // With 2, boxes 1-3 stalled while boxes 4-9 shared the cores with a solve; 6 with
  // judge_after_frames 13 kept 1.8 cores busy instead of 1.65 (bench/README.md).
  int calibration_lag_frames = 6;
  // Added to accelerometer timestamps to put them on the camera's clock.
  double accel_time_offset_s = 0.0;

  bool Check(std::string* error) const;
};

// The threads' names, as `top -H`, `ps -L` and `perf` show them (15 characters at most).
inline constexpr char kLensThreadName[] = "boxes 1-3";
inline constexpr char kMotionThreadName[] = "boxes 4-9";
inline constexpr char kSolveThreadName[] = "box 10";

struct RuntimeStats {
  uint64_t frames_pushed = 0;
  uint64_t frames_dropped = 0;  // Live: frames the pipeline never started.
  uint64_t frames_done = 0;
  int solves = 0;              // Attempts handed to box 10.
  int judged = 0;              // Attempts judged (a solve still running at the end is not).
  // Per judged attempt, wall-clock ms from the moment the frame that closed its window was
  // pushed to the moment its judgement was in effect.
  TimingHistogram update_latency_ms;
  // CPU seconds each thread used, filled in as it ends (after Finish): boxes 1-3 (box 2's
  // estimates, on threads of their own, not counted), boxes 4-9, box 10's worker.
  // Against the wall-clock time they tell which thread limits the frames per second.
  double lens_cpu_s = 0.0, motion_cpu_s = 0.0, solve_cpu_s = 0.0;
  // Wall-clock seconds the per-frame threads spent blocked, by what they waited for, filled
  // in as they end: boxes 1-3 for frames to come in, and for boxes 4-9 (offline the
  // calibration of the frame calibration_lag_frames back, or room in the queue between
  // them); boxes 4-9 for boxes 1-3's next frame, and for box 10's result to judge. Beside
  // the CPU times they say which thread holds the others up.
  double lens_wait_input_s = 0.0, lens_wait_motion_s = 0.0;
  double motion_wait_lens_s = 0.0, motion_wait_solve_s = 0.0;
};

class Runtime {
 public:
  // Called on the boxes 4-9 thread after every frame, in frame order.
  using FrameCallback = std::function<void(const std::shared_ptr<const FrameSnapshot>&)>;
  // Box 10 on a job, on the solve worker.
  using Solver = std::function<SelfCalibrationResult(const CalibrationJob& job)>;

  // Starts the threads. `solve`: box 10; when empty, SelfCalibrate with the box 10 options
  // in effect when the job was made. Throws Error when the options or the calibration are
  // not valid.
  Runtime(const CameraIntrinsics& premission, const AccelCalibration& accel,
          const PipelineOptions& pipeline, const RuntimeOptions& options,
          FrameCallback on_frame = {}, Solver solve = {});
  // Stops the threads; frames still queued are not processed.
  ~Runtime();
  Runtime(const Runtime&) = delete;
  Runtime& operator=(const Runtime&) = delete;

  // Samples in time order, stamped on the accelerometer's clock (the offset puts them on
  // the camera's). Box 7 of a frame at t takes every sample up to t + accel_lead_ns() on
  // the camera's clock that has arrived by then; offline, push them before the frame for
  // results that do not depend on timing (PushSequence does).
  void PushAccel(std::span<const AccelSample> samples);
  int64_t accel_lead_ns() const { return lead_ns_; }
  int64_t accel_offset_ns() const { return offset_ns_; }
  // An 8-bit BGR or grey frame (shared, not copied: do not write to it afterwards).
  // Offline: waits while the queue is full. Live: never waits. Throws the Error a worker
  // stopped on.
  void PushFrame(int64_t t_ns, const cv::Mat& raw);
  // Processes every frame pushed, then stops the threads. Offline it first judges an
  // attempt made within judge_after_frames of the last frame, waiting for its solve (live
  // only if its solve has ended); no snapshot carries that verdict: it is in history() and
  // attempt_after_last_frame().
  // Throws the Error a worker stopped on.
  void Finish();

  // New options for boxes 1-10, from any thread: they apply from the next frame pushed
  // (the next PushFrame call to begin after this returns) on, in both halves and for the
  // attempts made from then on, so that offline where they apply does not depend on thread
  // timing; live, from the first frame after it that is not dropped. Throws Error with the
  // reason, the options in effect unchanged, when they fail PipelineOptions::Check or
  // change the acceptance thresholds (the history judges every attempt by one set).
  // The accelerometer's lead (accel_lead_ns) stays as the options at construction set it.
  void SetOptions(const PipelineOptions& options);
  // The options set last (those in effect from the next frame pushed); safe from any thread.
  PipelineOptions options() const;

  // The newest frame's snapshot (null before the first); safe from any thread.
  std::shared_ptr<const FrameSnapshot> latest() const;
  // Safe from any thread.
  RuntimeStats stats() const;
  // The history of attempts: from the frame callback, or after Finish.
  const CalibrationHistory& history() const { return motion_.history(); }
  // After Finish: the attempt judged after the last frame's snapshot, which no snapshot
  // carries (null if none was).
  const std::shared_ptr<const AttemptOutcome>& attempt_after_last_frame() const {
    return attempt_after_last_frame_;
  }

 private:
  using Clock = std::chrono::steady_clock;
  struct RawFrame {
    int64_t index = 0;  // Pushed before it.
    int64_t t_ns = 0;
    cv::Mat raw;
    Clock::time_point pushed;
  };
  struct HalfDone {
    int64_t index = 0;
    LensFrame frame;
    Clock::time_point pushed;
  };
  // Options set by SetOptions, to apply from the frame pushed as `from_index` on.
  struct OptionsChange {
    int64_t id = 0;  // Counts SetOptions calls: which change a thread applied last.
    int64_t from_index = 0;
    PipelineOptions options;
  };
  struct Pending {
    CalibrationJob job;
    int64_t frame = 0;  // Frames done by boxes 4-9 when it was made.
    Clock::time_point pushed;
  };
  // An attempt judged, and what it took, for the snapshot of the frame it is judged on.
  struct Judgement {
    std::shared_ptr<const AttemptOutcome> attempt;
    double solve_ms = 0.0;
    double history_ms = 0.0;
  };

  // The options for the frame pushed as `index`, if not those a thread applied last (the
  // change `*applied`, updated).
  std::optional<PipelineOptions> OptionsFor(int64_t index, int64_t* applied) const;
  void LensLoop();
  void MotionLoop();
  // Takes box 10's result (waiting for it while `solve_lock`, held, is released), judges
  // `pending` by it and puts the new calibration in effect. Nothing when stopping. The
  // wait's wall-clock seconds are added to `*waited`.
  std::optional<Judgement> Judge(const Pending& pending, std::unique_lock<std::mutex>* solve_lock,
                                 double* waited);
  void SolveLoop();
  CalibrationState StateFor(int64_t frame);
  void FeedAccel(int64_t t_ns);
  // Puts the calling thread's CPU time so far in `field` of the stats (as the thread ends).
  void CountThreadCpu(double RuntimeStats::*field);
  void Fail(std::exception_ptr error);
  // Makes every thread stop at its next wait.
  void WakeAll();
  void RethrowFailure();
  void Stop();

  const RuntimeOptions options_;
  const Solver solve_;
  const int64_t lead_ns_;
  const int64_t offset_ns_;
  FrameCallback on_frame_;

  // Frame indices and the option changes waiting for the threads (SetOptions).
  mutable std::mutex options_mutex_;
  int64_t next_index_ = 0;
  std::vector<OptionsChange> changes_;  // In index order; the last is options().
  int64_t motion_index_ = 0;            // The frame boxes 4-9 are on: older changes are done.

  LensHalf lens_;
  MotionHalf motion_;
  BoundedQueue<RawFrame> input_;
  BoundedQueue<HalfDone> between_;

  // Accelerometer samples not yet given to box 7, on the camera's clock.
  std::mutex accel_mutex_;
  std::deque<SpecificForceSample> accel_;

  // The calibration after each frame done by boxes 4-9, for boxes 1-3.
  std::mutex state_mutex_;
  std::condition_variable state_changed_;
  std::map<int64_t, CalibrationState> states_;  // Offline: by frame, those still needed.
  CalibrationState newest_state_;
  int64_t frames_done_ = 0;

  // Box 10's worker: one job at a time.
  std::mutex solve_mutex_;
  std::condition_variable solve_changed_;
  std::optional<CalibrationJob> solve_job_;
  SelfCalibrationOptions solve_options_;  // Box 10's options for solve_job_.
  std::optional<SelfCalibrationResult> solve_result_;
  std::atomic<bool> solved_{false};  // solve_result_ holds a result: live, wakes boxes 4-9.
  double solve_ms_ = 0.0;

  mutable std::mutex snapshot_mutex_;  // Held only to copy the pointer.
  std::shared_ptr<const FrameSnapshot> latest_;
  // Set by the boxes 4-9 thread as it ends; read after Finish has joined it.
  std::shared_ptr<const AttemptOutcome> attempt_after_last_frame_;

  mutable std::mutex stats_mutex_;
  RuntimeStats stats_;

  std::atomic<bool> stopping_{false};
  std::mutex failure_mutex_;
  std::exception_ptr failure_;
  bool finished_ = false;

  std::thread lens_thread_, motion_thread_, solve_thread_;
};

// Feeds a recorded sequence to `runtime` frame by frame, each frame's accelerometer
// samples (up to the frame's time plus the runtime's lead) ahead of it, then finishes.
// When `stop` is given and becomes true, feeding ends before the next frame and the
// runtime is left unfinished (to be destroyed). Returns whether the runtime was finished
// (so its history and attempt_after_last_frame may be read).
bool PushSequence(const Sequence& sequence, Runtime* runtime,
                  const std::atomic<bool>* stop = nullptr);

}  // namespace autocal
