#include "devices/runtime.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <utility>

#include <pthread.h>
#include <time.h>

#include "pipeline/error.h"
#include "pipeline/option_fields.h"
#include "pipeline/stopwatch.h"

namespace autocal {

bool RuntimeOptions::Check(std::string* error) const {
  const auto fail = [&](const char* why) {
    if (error) *error = why;
    return false;
  };
  if (frame_queue < 1) return fail("frame_queue must be at least 1");
  if (lens_queue < 1) return fail("lens_queue must be at least 1");
  if (judge_after_frames < 0) return fail("judge_after_frames must not be negative");
  if (calibration_lag_frames < 1) return fail("calibration_lag_frames must be at least 1");
  if (!std::isfinite(accel_time_offset_s)) return fail("accel_time_offset_s must be finite");
  return true;
}

namespace {

void NameThread(const char* name) { pthread_setname_np(pthread_self(), name); }

// Runs `wait` (a call that may block) and adds the wall-clock seconds it took to `*waited`.
template <typename Wait>
auto Timed(double* waited, Wait&& wait) {
  const auto start = std::chrono::steady_clock::now();
  auto result = wait();
  *waited += 1e-3 * MillisecondsSince(start);
  return result;
}

const RuntimeOptions& Checked(const RuntimeOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw Error("runtime options: " + why);
  return options;
}

}  // namespace

Runtime::Runtime(const CameraIntrinsics& premission, const AccelCalibration& accel,
                 const PipelineOptions& pipeline, const RuntimeOptions& options,
                 FrameCallback on_frame, Solver solve)
    : options_(Checked(options)),
      solve_(std::move(solve)),
      // Box 7 tests rest over a window centred on each frame: readings run half of it ahead.
      lead_ns_(static_cast<int64_t>(0.5 * pipeline.inertial.quasi_static.window_s * 1e9)),
      offset_ns_(static_cast<int64_t>(std::llround(options.accel_time_offset_s * 1e9))),
      on_frame_(std::move(on_frame)),
      changes_{{0, 0, pipeline}},
      lens_(pipeline, options.live),
      motion_(premission, accel, pipeline),
      input_(options.frame_queue),
      between_(options.live ? options.lens_queue
                            : std::max(options.lens_queue,
                                       static_cast<size_t>(options.calibration_lag_frames))) {
  newest_state_ = motion_.state();
  lens_thread_ = std::thread(&Runtime::LensLoop, this);
  motion_thread_ = std::thread(&Runtime::MotionLoop, this);
  solve_thread_ = std::thread(&Runtime::SolveLoop, this);
}

Runtime::~Runtime() { Stop(); }

void Runtime::WakeAll() {
  stopping_ = true;
  input_.Close();
  between_.Close();
  {
    // Under the locks the waits test `stopping_` with, so that no wait misses it.
    std::lock_guard state_lock(state_mutex_);
    std::lock_guard solve_lock(solve_mutex_);
  }
  state_changed_.notify_all();
  solve_changed_.notify_all();
}

void Runtime::Stop() {
  WakeAll();
  for (std::thread* thread : {&lens_thread_, &motion_thread_, &solve_thread_}) {
    if (thread->joinable()) thread->join();
  }
}

void Runtime::Fail(std::exception_ptr error) {
  {
    std::lock_guard lock(failure_mutex_);
    if (!failure_) failure_ = error;
  }
  WakeAll();
}

void Runtime::RethrowFailure() {
  std::lock_guard lock(failure_mutex_);
  if (failure_) std::rethrow_exception(failure_);
}

void Runtime::PushAccel(std::span<const AccelSample> samples) {
  std::lock_guard lock(accel_mutex_);
  for (const AccelSample& sample : samples) {
    accel_.push_back({sample.t_ns + offset_ns_, sample.specific_force});
  }
}

void Runtime::PushFrame(int64_t t_ns, const cv::Mat& raw) {
  RethrowFailure();
  RawFrame frame{0, t_ns, raw, Clock::now()};
  {
    std::lock_guard lock(options_mutex_);
    frame.index = next_index_++;
  }
  {
    std::lock_guard lock(stats_mutex_);
    ++stats_.frames_pushed;
  }
  if (options_.live) {
    if (const int dropped = input_.PushDroppingOldest(std::move(frame))) {
      std::lock_guard lock(stats_mutex_);
      stats_.frames_dropped += uint64_t(dropped);
    }
  } else if (!input_.Push(std::move(frame))) {
    RethrowFailure();  // Closed by a worker's failure.
  }
}

void Runtime::Finish() {
  if (!finished_) {
    finished_ = true;
    // The threads drain the queues in turn and end.
    input_.Close();
    if (lens_thread_.joinable()) lens_thread_.join();
    if (motion_thread_.joinable()) motion_thread_.join();
    Stop();
  }
  RethrowFailure();
}

void Runtime::SetOptions(const PipelineOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw Error("pipeline options: " + why);
  std::lock_guard lock(options_mutex_);
  for (const OptionField& field : PipelineOptionFields()) {
    if (field.name.starts_with("acceptance.") &&
        field.get(options) != field.get(changes_.back().options)) {
      throw Error("pipeline options: " + field.name +
                  " cannot change during a run: the history judges every attempt by the "
                  "same acceptance thresholds");
    }
  }
  const int64_t id = changes_.back().id + 1;
  // A change no frame has reached yet is replaced (a spin box dragged while paused).
  if (changes_.back().from_index == next_index_) changes_.pop_back();
  // Changes both threads have gone past, all but the one in effect there.
  const auto current = std::find_if(changes_.rbegin(), changes_.rend(), [&](const auto& c) {
    return c.from_index <= motion_index_;
  });
  if (current != changes_.rend()) changes_.erase(changes_.begin(), std::prev(current.base()));
  changes_.push_back({id, next_index_, options});
}

PipelineOptions Runtime::options() const {
  std::lock_guard lock(options_mutex_);
  return changes_.back().options;
}

std::optional<PipelineOptions> Runtime::OptionsFor(int64_t index, int64_t* applied) const {
  std::lock_guard lock(options_mutex_);
  const auto change = std::find_if(changes_.rbegin(), changes_.rend(), [&](const auto& c) {
    return c.from_index <= index;
  });
  if (change == changes_.rend() || change->id == *applied) return std::nullopt;
  *applied = change->id;
  return change->options;
}

std::shared_ptr<const FrameSnapshot> Runtime::latest() const {
  std::lock_guard lock(snapshot_mutex_);
  return latest_;
}

RuntimeStats Runtime::stats() const {
  std::lock_guard lock(stats_mutex_);
  return stats_;
}

CalibrationState Runtime::StateFor(int64_t frame) {
  std::unique_lock lock(state_mutex_);
  if (options_.live) return newest_state_;
  const int64_t after = frame - options_.calibration_lag_frames;  // Frame -1: the start.
  if (after < 0) return newest_state_;
  state_changed_.wait(lock, [&] { return stopping_ || frames_done_ > after; });
  const auto found = states_.find(after);
  if (found == states_.end()) return newest_state_;  // Stopping.
  CalibrationState state = found->second;
  states_.erase(states_.begin(), std::next(found));  // Later frames need later states.
  return state;
}

void Runtime::LensLoop() {
  NameThread(kLensThreadName);
  double waited_input_s = 0.0, waited_motion_s = 0.0;
  try {
    int64_t frame = 0;
    int64_t applied = 0;
    while (std::optional<RawFrame> raw = Timed(&waited_input_s, [&] { return input_.Pop(); })) {
      if (stopping_) break;
      if (auto options = OptionsFor(raw->index, &applied)) lens_.set_options(*options);
      const CalibrationState state = Timed(&waited_motion_s, [&] { return StateFor(frame++); });
      LensFrame done = lens_.Process(raw->t_ns, raw->raw, state);
      if (!Timed(&waited_motion_s, [&] {
            return between_.Push({raw->index, std::move(done), raw->pushed});
          })) {
        break;
      }
    }
  } catch (...) {
    Fail(std::current_exception());
  }
  between_.Close();
  CountThreadCpu(&RuntimeStats::lens_cpu_s);
  std::lock_guard lock(stats_mutex_);
  stats_.lens_wait_input_s = waited_input_s;
  stats_.lens_wait_motion_s = waited_motion_s;
}

void Runtime::CountThreadCpu(double RuntimeStats::*field) {
  timespec used{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &used);
  std::lock_guard lock(stats_mutex_);
  stats_.*field = double(used.tv_sec) + 1e-9 * double(used.tv_nsec);
}

void Runtime::FeedAccel(int64_t t_ns) {
  std::vector<SpecificForceSample> batch;
  {
    std::lock_guard lock(accel_mutex_);
    while (!accel_.empty() && accel_.front().t_ns <= t_ns + lead_ns_) {
      batch.push_back(accel_.front());
      accel_.pop_front();
    }
  }
  if (!batch.empty()) motion_.AddAccel(batch);
}

std::optional<Runtime::Judgement> Runtime::Judge(const Pending& pending,
                                                 std::unique_lock<std::mutex>* solve_lock,
                                                 double* waited) {
  const bool solved = Timed(waited, [&] {
    solve_changed_.wait(*solve_lock, [&] { return stopping_ || solve_result_.has_value(); });
    return solve_result_.has_value();
  });
  if (!solved) return std::nullopt;  // Stopping.
  const SelfCalibrationResult result = std::move(*solve_result_);
  solve_result_.reset();
  solved_ = false;
  Judgement judged;
  judged.solve_ms = solve_ms_;
  solve_lock->unlock();
  const auto start = Clock::now();
  judged.attempt = motion_.Judge(pending.job, result);
  judged.history_ms = MillisecondsSince(start);
  const double latency_ms = MillisecondsSince(pending.pushed);
  std::lock_guard stats_lock(stats_mutex_);
  ++stats_.judged;
  stats_.update_latency_ms.Add(latency_ms);
  return judged;
}

void Runtime::MotionLoop() {
  NameThread(kMotionThreadName);
  double waited_lens_s = 0.0, waited_solve_s = 0.0;
  try {
    std::optional<Pending> pending;
    std::optional<Judgement> judged_between;  // Live, while idle: for the next snapshot.
    int64_t frame = 0;
    int64_t applied = 0;
    std::optional<int64_t> previous_t_ns;
    while (true) {
      std::optional<HalfDone> half = Timed(&waited_lens_s, [&] {
        return options_.live ? between_.PopUnless([&] { return pending && solved_; })
                             : between_.Pop();
      });
      if (stopping_) break;
      if (!half) {
        // The queue closed. Offline the last attempt is judged whenever its solve ends, so
        // that the run's results do not depend on how fast the solve was.
        if (!pending || (options_.live && !solved_)) {
          if (judged_between) attempt_after_last_frame_ = std::move(judged_between->attempt);
          break;
        }
        // Live, idle and the solve ended: its calibration goes in effect now, not at the
        // next frame (up to a frame interval and that frame's boxes 1-9 later).
        std::unique_lock lock(solve_mutex_);
        judged_between = Judge(*pending, &lock, &waited_solve_s);
        if (!judged_between) break;  // Stopping.
        pending.reset();
        {
          std::lock_guard state_lock(state_mutex_);
          newest_state_ = motion_.state();
        }
        state_changed_.notify_all();
        continue;
      }
      {
        std::lock_guard lock(options_mutex_);
        motion_index_ = half->index;
      }
      if (auto options = OptionsFor(half->index, &applied)) motion_.set_options(*options);
      FeedAccel(half->frame.t_ns);
      const int64_t t_ns = half->frame.t_ns;
      const int64_t frame_interval_ns = previous_t_ns ? t_ns - *previous_t_ns : 0;
      previous_t_ns = t_ns;
      std::optional<CalibrationJob> job;
      auto snapshot =
          std::make_shared<FrameSnapshot>(motion_.Process(std::move(half->frame), &job));
      const auto attach = [&](Judgement judged) {
        snapshot->attempt = std::move(judged.attempt);
        snapshot->calibration = motion_.state().filtered;
        snapshot->timing.calibration_ms = judged.solve_ms;
        snapshot->timing.history_ms = judged.history_ms;
      };
      if (judged_between) {
        attach(std::move(*judged_between));
        judged_between.reset();
      }
      if (job) {
        pending = Pending{*job, frame, half->pushed};
        {
          std::lock_guard lock(solve_mutex_);
          solve_job_ = std::move(job);
          solve_options_ = motion_.options().calibration;
        }
        solve_changed_.notify_all();
        std::lock_guard lock(stats_mutex_);
        ++stats_.solves;
      }
      if (pending) {
        std::unique_lock lock(solve_mutex_);
        // Offline, no later than the last frame before the next attempt is due (a frame
        // interval on): a shorter attempt interval than judge_after_frames is kept.
        const auto next_attempt_due = [&] {
          return double(t_ns + frame_interval_ns - pending->job.t_ns) >=
                 motion_.options().material.attempt_every_s * 1e9;
        };
        const bool judge = options_.live ? solve_result_.has_value()
                                         : frame >= pending->frame + options_.judge_after_frames ||
                                               next_attempt_due();
        if (judge) {
          std::optional<Judgement> judged = Judge(*pending, &lock, &waited_solve_s);
          if (!judged) break;  // Stopping.
          pending.reset();
          attach(std::move(*judged));
        }
      }
      {
        std::lock_guard lock(state_mutex_);
        newest_state_ = motion_.state();
        if (!options_.live) states_[frame] = newest_state_;
        frames_done_ = ++frame;
      }
      state_changed_.notify_all();
      {
        std::lock_guard lock(snapshot_mutex_);
        latest_ = snapshot;
      }
      {
        std::lock_guard lock(stats_mutex_);
        ++stats_.frames_done;
      }
      if (on_frame_) on_frame_(snapshot);
    }
  } catch (...) {
    Fail(std::current_exception());
  }
  CountThreadCpu(&RuntimeStats::motion_cpu_s);
  std::lock_guard lock(stats_mutex_);
  stats_.motion_wait_lens_s = waited_lens_s;
  stats_.motion_wait_solve_s = waited_solve_s;
}

void Runtime::SolveLoop() {
  NameThread(kSolveThreadName);
  try {
    while (true) {
      std::unique_lock lock(solve_mutex_);
      solve_changed_.wait(lock, [&] { return stopping_ || solve_job_.has_value(); });
      if (!solve_job_) break;  // Stopping with nothing to solve.
      const CalibrationJob job = std::move(*solve_job_);
      const SelfCalibrationOptions options = solve_options_;
      solve_job_.reset();
      lock.unlock();
      const auto start = Clock::now();
      SelfCalibrationResult result =
          solve_ ? solve_(job) : SelfCalibrate(job.material, job.prior, options);
      const double ms = MillisecondsSince(start);
      lock.lock();
      solve_result_ = std::move(result);
      solve_ms_ = ms;
      solved_ = true;
      lock.unlock();
      solve_changed_.notify_all();
      between_.Wake();
    }
  } catch (...) {
    Fail(std::current_exception());
  }
  CountThreadCpu(&RuntimeStats::solve_cpu_s);
}

bool PushSequence(const Sequence& sequence, Runtime* runtime, const std::atomic<bool>* stop) {
  const auto stopped = [stop] { return stop && stop->load(); };
  const std::vector<AccelSample>& samples = sequence.accel();
  size_t fed = 0;
  for (size_t i = 0; i < sequence.frame_count() && !stopped(); ++i) {
    const int64_t t_ns = sequence.frame_time_ns(i);
    const size_t first = fed;
    while (fed < samples.size() &&
           samples[fed].t_ns + runtime->accel_offset_ns() <= t_ns + runtime->accel_lead_ns()) {
      ++fed;
    }
    runtime->PushAccel(std::span(samples).subspan(first, fed - first));
    runtime->PushFrame(t_ns, sequence.LoadFrame(i));
  }
  if (stopped()) return false;
  runtime->Finish();
  return true;
}

}  // namespace autocal
