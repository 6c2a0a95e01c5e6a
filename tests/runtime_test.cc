// The threaded runtime: its queues, offline runs that repeat to the last digit, snapshots
// read from another thread while the pipeline runs, and live mode with a source faster
// than the pipeline. Short 320x240 simulated walks.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "devices/in_memory_sequence.h"
#include "devices/offline_runner.h"
#include "devices/runtime.h"
#include "devices/sim/simulator.h"
#include "devices/source.h"
#include "pipeline/calibration_error.h"
#include "pipeline/history_store.h"
#include "test_util.h"

namespace autocal {
namespace {

TEST(BoundedQueue, LiveDropsTheOldestAndCountsIt) {
  BoundedQueue<int> queue(2);
  EXPECT_EQ(queue.PushDroppingOldest(1), 0);
  EXPECT_EQ(queue.PushDroppingOldest(2), 0);
  EXPECT_EQ(queue.PushDroppingOldest(3), 1);
  queue.Close();
  EXPECT_EQ(queue.Pop(), 2);
  EXPECT_EQ(queue.Pop(), 3);
  EXPECT_EQ(queue.Pop(), std::nullopt);
  EXPECT_FALSE(queue.Push(4)) << "closed";
}

TEST(BoundedQueue, OfflineWaitsAndLosesNothing) {
  BoundedQueue<int> queue(1);
  std::thread producer([&] {
    for (int i = 0; i < 100; ++i) ASSERT_TRUE(queue.Push(i));
    queue.Close();
  });
  std::vector<int> got;
  while (std::optional<int> item = queue.Pop()) got.push_back(*item);
  producer.join();
  ASSERT_EQ(got.size(), 100u);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(got[size_t(i)], i);
}

TEST(RuntimeOptions, DefaultsAreValidAndBadOnesNamed) {
  std::string why;
  EXPECT_TRUE(RuntimeOptions{}.Check(&why)) << why;
  RuntimeOptions options;
  options.calibration_lag_frames = 0;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("calibration_lag_frames"), std::string::npos);
}

std::unique_ptr<Sequence> Walk(double seconds) {
  return MakeSimulatedSequence(ParseScenarioSpec(
      "office,lens=sonnar,resolution=320x240,seconds=" + std::to_string(seconds)));
}

// The accelerometer's mounting on the camera, as the walk was recorded.
AccelCalibration AccelOf(const Sequence& sequence) {
  AccelCalibration accel;
  accel.cam_from_accel = sequence.session().cam_from_accel;
  return accel;
}

// The summary without what depends on the machine: wall-clock time, frames per second and
// the timings (the only lines indented by four spaces, inside "timing_ms").
std::string WithoutTiming(const std::string& summary) {
  std::istringstream lines(summary);
  std::string kept, line;
  while (std::getline(lines, line)) {
    if (line.starts_with("  \"wall_seconds\"") || line.starts_with("  \"fps\"") ||
        line.starts_with("    ")) {
      continue;
    }
    kept += line + "\n";
  }
  return kept;
}

// A stand-in for box 10 whose estimate is a fixed function of everything in the job (the
// truth moved by a checksum of the material and the prior), slowed down by a different
// amount on each attempt and in each run so that the runs' threads meet in different
// orders. Any difference between the runs in what reaches box 10, or in the frame an
// attempt is judged on, shows in the summary. (SelfCalibrate itself is not used: on the
// same material it varies in its last digits from call to call; see docs/runtime.md.)
Runtime::Solver JitteredStandIn(const CameraIntrinsics& truth, int run) {
  auto attempt = std::make_shared<int>(0);
  return [=](const CalibrationJob& job) {
    std::this_thread::sleep_for(std::chrono::milliseconds((++*attempt * 37 + run * 53) % 90));
    double checksum = job.prior.fx + job.prior.cx + 1e3 * job.prior.k1 + double(job.t_ns) * 1e-9;
    int observations = 0;
    for (const PlaneTrack& plane : job.material.planes) {
      for (const PlaneObservation& o : plane.observations) {
        checksum += (o.pixel.x() + 2.0 * o.pixel.y()) * (o.frame + 1) + o.point;
        ++observations;
      }
    }
    for (const LineObservation& line : job.material.lines) {
      for (const Eigen::Vector2d& point : line.points) checksum += point.x() - point.y();
    }
    for (const GravityObservation& g : job.material.gravity) checksum += g.down_cam.sum();
    SelfCalibrationResult result;
    result.usable = true;
    result.reason = "stand-in";
    result.estimate = truth;
    result.estimate.fx *= 1.0 + 1e-3 * std::sin(checksum);
    result.estimate.fy *= 1.0 + 1e-3 * std::cos(checksum);
    result.estimate.cx += 0.5 * std::sin(3.0 * checksum);
    result.free_parameters = {kFx, kFy, kCx, kCy, kK1, kK2};
    result.covariance = Eigen::Vector<double, 6>(0.04, 0.04, 0.25, 0.25, 1e-6, 1e-6).asDiagonal();
    result.rms_px = 0.15;
    result.rotation_spread_deg = 20.0;
    result.frames_used = job.material.frame_count;
    result.planes_used = int(job.material.planes.size());
    result.observations_used = observations;
    result.lines_used = int(job.material.lines.size());
    return result;
  };
}

TEST(Runtime, TwoOfflineRunsGiveTheSameSummary) {
  const std::unique_ptr<Sequence> sequence = Walk(8.0);
  RunSettings settings;
  // The start 2% off in focal length, so that the attempts have something to change.
  CameraIntrinsics prior = *sequence->session().premission_calibration;
  prior.fx *= 1.02;
  prior.fy *= 1.02;
  settings.prior = prior;
  const CameraIntrinsics truth = sequence->ground_truth()->front().intrinsics;
  settings.solve = JitteredStandIn(truth, 0);
  const RunReport first = RunSequence(*sequence, settings);
  settings.solve = JitteredStandIn(truth, 1);
  const RunReport second = RunSequence(*sequence, settings);
  ASSERT_GT(first.attempts, 3) << "attempts judged, so that the comparison means something";
  ASSERT_GT(first.verdicts.count(Verdict::kAccepted), 0u);
  const std::string a = WithoutTiming(SummaryJson(first));
  EXPECT_EQ(a.find("wall_seconds"), std::string::npos);
  EXPECT_EQ(a.find("\"median\""), std::string::npos);
  EXPECT_NE(a.find("\"final\""), std::string::npos);
  EXPECT_EQ(a, WithoutTiming(SummaryJson(second)));
  // And frame by frame, the output after every frame.
  ASSERT_TRUE(first.truth && second.truth);
  ASSERT_EQ(first.truth->errors.size(), second.truth->errors.size());
  for (size_t i = 0; i < first.truth->errors.size(); ++i) {
    ASSERT_EQ(first.truth->errors[i].fx_percent, second.truth->errors[i].fx_percent) << i;
    ASSERT_EQ(first.truth->errors[i].cx_px, second.truth->errors[i].cx_px) << i;
  }
}

// Live, the history is written on a thread of its own: with the file's write lock held by
// another program for the first 4 s of a walk played as a camera, boxes 4-9 go on judging
// and the pipeline keeps up (written on their thread, the first attempt waited there for
// the lock and 66 frames were dropped), and every attempt is in the file once the
// lock is let go.
TEST(Runtime, LiveRunKeepsUpWhileTheHistoryFileIsLocked) {
  auto walk = std::make_unique<InMemorySequence>(Walk(6.0));
  const CameraIntrinsics truth = walk->ground_truth()->front().intrinsics;
  const int64_t walk_start_ns = walk->frame_time_ns(0);
  const test::TempDir dir;
  RunSettings settings;
  settings.history_path = dir / "history.sqlite";
  settings.solve = JitteredStandIn(truth, 0);
  { HistoryStore created(settings.history_path); }
  SourceOptions play;
  play.real_time = true;
  const std::unique_ptr<FrameSource> source = PlaySequence(std::move(walk), play);

  std::promise<void> release;
  test::HoldSqliteWriteLock(settings.history_path, release.get_future().share()).wait();
  std::thread releaser([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(4000));
    release.set_value();
  });
  const RunReport report = RunSource(*source, settings, {});
  releaser.join();

  ASSERT_TRUE(report.live);
  EXPECT_EQ(report.live->ended_by, "the source ended");
  const StoredHistory stored = HistoryStore(settings.history_path).Load();
  ASSERT_GE(stored.attempts.size(), 2u);
  EXPECT_LT(stored.attempts[1].t_ns - walk_start_ns, 3'500'000'000)
      << "two attempts judged while the file was locked";
  EXPECT_LT(report.live->pipeline_dropped, 10u) << "frames the pipeline dropped";
  EXPECT_EQ(stored.attempts.size(), size_t(report.attempts));
}

// Live, the history's start is handed to the writer as the run starts, without waiting for
// it: the file holds it long before the first attempt (2 s into the walk), so a run killed
// then leaves a file that says what it started from.
TEST(Runtime, LiveRunWritesTheStartBeforeItsFirstAttempt) {
  auto walk = std::make_unique<InMemorySequence>(Walk(3.0));
  const CameraIntrinsics truth = walk->ground_truth()->front().intrinsics;
  const CameraIntrinsics premission = *walk->session().premission_calibration;
  const test::TempDir dir;
  RunSettings settings;
  settings.history_path = dir / "history.sqlite";
  settings.solve = JitteredStandIn(truth, 0);
  SourceOptions play;
  play.real_time = true;
  const std::unique_ptr<FrameSource> source = PlaySequence(std::move(walk), play);
  std::optional<StoredHistory> early;
  LiveRunControl control;
  control.progress_interval_s = 0.1;
  control.progress = [&](const RunProgress&) {
    if (early) return;
    // The writer's commit takes milliseconds; a second is the limit, not the expectation.
    const auto limit = std::chrono::steady_clock::now() + std::chrono::seconds(1);
    do {
      early = HistoryStore(settings.history_path).Load();
    } while (!(early->premission == premission) && std::chrono::steady_clock::now() < limit);
  };
  const RunReport report = RunSource(*source, settings, control);
  ASSERT_TRUE(early);
  EXPECT_TRUE(early->premission == premission);
  EXPECT_TRUE(early->attempts.empty()) << "read before the first attempt";
  EXPECT_GT(report.attempts, 0);
}

// Offline, boxes 1-3 run ahead of boxes 4-9 as far as calibration_lag_frames lets them,
// not only as far as the queue between them holds in live mode: held on frame 0, boxes 4-9
// leave boxes 1-3 frames 1-6 to do, and one more waits for frame 1's calibration.
TEST(Runtime, OfflineBoxes1To3RunAheadAsFarAsTheLag) {
  const std::unique_ptr<Sequence> sequence = Walk(1.0);
  const AccelCalibration accel = AccelOf(*sequence);
  const RuntimeOptions options;
  ASSERT_GT(size_t(options.calibration_lag_frames), options.lens_queue);
  std::mutex mutex;
  std::condition_variable released_changed;
  bool released = false;
  Runtime runtime(*sequence->session().premission_calibration, accel, {}, options,
                  [&](const std::shared_ptr<const FrameSnapshot>& snapshot) {
                    if (snapshot->index != 0) return;
                    std::unique_lock lock(mutex);
                    released_changed.wait(lock, [&] { return released; });
                  });
  std::atomic<int> pushed{0};
  std::thread pusher([&] {
    for (size_t i = 0; i < sequence->frame_count(); ++i) {
      runtime.PushFrame(sequence->frame_time_ns(i), sequence->LoadFrame(i));
      ++pushed;
    }
    runtime.Finish();
  });
  // Frame 0 with boxes 4-9, the lag's frames queued after it, one with boxes 1-3 waiting
  // for its calibration, and the frame queue full: the next push waits.
  const int expected = 1 + options.calibration_lag_frames + 1 + int(options.frame_queue);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (pushed < expected && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(pushed, expected);
  {
    std::lock_guard lock(mutex);
    released = true;
  }
  released_changed.notify_all();
  pusher.join();
  EXPECT_EQ(runtime.stats().frames_done, sequence->frame_count());
}

// The names of this process's threads (/proc/self/task/*/comm).
std::set<std::string> ThreadNames() {
  std::set<std::string> names;
  for (const auto& task : std::filesystem::directory_iterator("/proc/self/task")) {
    std::ifstream comm(task.path() / "comm");
    std::string name;
    if (std::getline(comm, name)) names.insert(name);  // Else it ended meanwhile.
  }
  return names;
}

// The threads say which boxes they run, for `top -H` and `perf`.
TEST(Runtime, ThreadsAreNamedByTheirBoxes) {
  const std::unique_ptr<Sequence> sequence = Walk(1.0);
  const AccelCalibration accel = AccelOf(*sequence);
  std::set<std::string> seen;
  Runtime runtime(*sequence->session().premission_calibration, accel, {}, {},
                  [&](const std::shared_ptr<const FrameSnapshot>& snapshot) {
                    if (snapshot->index == 1) seen = ThreadNames();
                  });
  PushSequence(*sequence, &runtime);
  for (const char* name : {kLensThreadName, kMotionThreadName, kSolveThreadName}) {
    EXPECT_EQ(seen.count(name), 1u) << name;
  }
}

// Each thread's CPU time is in the stats once the run has ended: some for each, all three
// together no more than the whole process used meanwhile.
TEST(Runtime, EachThreadsCpuTimeIsCounted) {
  const std::unique_ptr<Sequence> sequence = Walk(3.0);
  const AccelCalibration accel = AccelOf(*sequence);
  const std::clock_t before = std::clock();  // The whole process's CPU time.
  Runtime runtime(*sequence->session().premission_calibration, accel, {}, {});
  PushSequence(*sequence, &runtime);
  const double process_s = double(std::clock() - before) / CLOCKS_PER_SEC;
  const RuntimeStats stats = runtime.stats();
  ASSERT_GT(stats.solves, 0);
  EXPECT_GT(stats.lens_cpu_s, 0.0);
  EXPECT_GT(stats.motion_cpu_s, 0.0);
  EXPECT_GT(stats.solve_cpu_s, 0.0);
  EXPECT_LE(stats.lens_cpu_s + stats.motion_cpu_s + stats.solve_cpu_s, process_s);
}

// What each per-frame thread waited for is counted where it waited: frames that come in
// slowly leave boxes 1-3 waiting for them, and boxes 4-9 for boxes 1-3; boxes 4-9 held up
// leave boxes 1-3 waiting for them; a slow box 10 judged a frame after its attempt leaves
// boxes 4-9 waiting for it. Lower bounds only: a loaded machine adds waits of every kind.
TEST(Runtime, EachThreadsWaitsAreCounted) {
  const std::unique_ptr<Sequence> sequence = Walk(2.0);
  const AccelCalibration accel = AccelOf(*sequence);
  const CameraIntrinsics truth = sequence->ground_truth()->front().intrinsics;
  const auto frames = double(sequence->frame_count());
  {
    SCOPED_TRACE("a frame every 40 ms");
    constexpr double kGapS = 0.04;
    Runtime runtime(*sequence->session().premission_calibration, accel, {}, {});
    for (size_t i = 0; i < sequence->frame_count(); ++i) {
      runtime.PushFrame(sequence->frame_time_ns(i), sequence->LoadFrame(i));
      std::this_thread::sleep_for(std::chrono::duration<double>(kGapS));
    }
    runtime.Finish();
    const RuntimeStats stats = runtime.stats();
    EXPECT_GT(stats.lens_wait_input_s, 0.25 * kGapS * (frames - 1));
    EXPECT_GT(stats.motion_wait_lens_s, 0.25 * kGapS * (frames - 1));
  }
  {
    SCOPED_TRACE("boxes 4-9 held 0.6 s on the first frame, box 10 taking 0.2 s");
    constexpr double kHeldS = 0.6, kSolveS = 0.2;
    RuntimeOptions options;
    options.judge_after_frames = 1;
    const Runtime::Solver stand_in = JitteredStandIn(truth, 0);
    Runtime runtime(
        *sequence->session().premission_calibration, accel, {}, options,
        [&](const std::shared_ptr<const FrameSnapshot>& snapshot) {
          if (snapshot->index == 0)
            std::this_thread::sleep_for(std::chrono::duration<double>(kHeldS));
        },
        [&](const CalibrationJob& job) {
          std::this_thread::sleep_for(std::chrono::duration<double>(kSolveS));
          return stand_in(job);
        });
    PushSequence(*sequence, &runtime);
    const RuntimeStats stats = runtime.stats();
    ASSERT_GT(stats.judged, 0);
    // Boxes 1-3 run ahead by the lag, then wait for the rest of the hold.
    EXPECT_GT(stats.lens_wait_motion_s, 0.5 * kHeldS);
    // Each judgement comes a frame after its attempt, well within the solve's time.
    EXPECT_GT(stats.motion_wait_solve_s, 0.5 * kSolveS * stats.judged);
  }
}

// Offline, an attempt is judged judge_after_frames after the frame it was made on, or on
// the frame before the next attempt is due if that comes sooner: an attempt interval
// shorter than the judging delay is kept, not stretched to it.
TEST(Runtime, OfflineJudgesBeforeTheNextAttemptIsDue) {
  const std::unique_ptr<Sequence> sequence = Walk(6.0);
  const CameraIntrinsics truth = sequence->ground_truth()->front().intrinsics;
  const AccelCalibration accel = AccelOf(*sequence);
  std::vector<int64_t> frame_times;
  for (size_t i = 0; i < sequence->frame_count(); ++i) {
    frame_times.push_back(sequence->frame_time_ns(i));
  }
  const auto index_of = [&](int64_t t_ns) {
    return int(std::find(frame_times.begin(), frame_times.end(), t_ns) - frame_times.begin());
  };
  const RuntimeOptions options;
  for (const double every_s : {0.5, 0.25}) {
    SCOPED_TRACE("attempts every " + std::to_string(every_s) + " s");
    PipelineOptions pipeline;
    pipeline.material.attempt_every_s = every_s;
    std::mutex mutex;
    std::vector<int64_t> made;             // Each attempt's frame time, in order.
    std::map<int64_t, int64_t> judged_on;  // Attempt's frame time -> the frame judging it.
    const Runtime::Solver stand_in = JitteredStandIn(truth, 0);
    Runtime runtime(
        *sequence->session().premission_calibration, accel, pipeline, options,
        [&](const std::shared_ptr<const FrameSnapshot>& snapshot) {
          std::lock_guard lock(mutex);
          if (snapshot->attempt) judged_on[snapshot->attempt->record.t_ns] = snapshot->t_ns;
        },
        [&](const CalibrationJob& job) {
          {
            std::lock_guard lock(mutex);
            made.push_back(job.t_ns);
          }
          return stand_in(job);
        });
    PushSequence(*sequence, &runtime);
    ASSERT_GE(made.size(), 4u);
    for (size_t k = 0; k + 1 < made.size(); ++k) {
      const int at = index_of(made[k]);
      ASSERT_TRUE(judged_on.count(made[k])) << "attempt " << k << " judged";
      const int judged = index_of(judged_on[made[k]]);
      // The first frame on which the next attempt is due.
      int due = at + 1;
      while (due < int(frame_times.size()) && double(frame_times[due] - made[k]) < every_s * 1e9) {
        ++due;
      }
      EXPECT_EQ(judged, std::min(at + options.judge_after_frames, due - 1)) << "attempt " << k;
      EXPECT_GT(index_of(made[k + 1]), judged) << "attempt " << k + 1;
      // Attempts come on views (every third frame) once due: not put off by a verdict.
      EXPECT_LE(index_of(made[k + 1]), due + 2) << "attempt " << k + 1;
    }
  }
}

// An attempt made a few frames before the end is judged offline however long its solve
// takes (before, it was dropped when the solve outlasted the frames left, and kept when it
// did not), and its verdict reaches the history file though no frame's snapshot carries it.
TEST(Runtime, OfflineJudgesTheLastAttemptWhateverItsSolveTakes) {
  // 141 frames: attempts every 15 frames, the last within judge_after_frames of the end.
  const std::unique_ptr<Sequence> sequence = Walk(4.7);
  const CameraIntrinsics truth = sequence->ground_truth()->front().intrinsics;
  const test::TempDir dir;
  for (const int solve_ms : {0, 250}) {
    SCOPED_TRACE("solves taking " + std::to_string(solve_ms) + " ms");
    RunSettings settings;
    settings.history_path = dir / ("h" + std::to_string(solve_ms) + ".sqlite");
    const Runtime::Solver stand_in = JitteredStandIn(truth, 0);
    auto made = std::make_shared<std::vector<int64_t>>();  // Only the solve thread adds.
    settings.solve = [=](const CalibrationJob& job) {
      made->push_back(job.t_ns);
      std::this_thread::sleep_for(std::chrono::milliseconds(solve_ms));
      return stand_in(job);
    };
    const RunReport report = RunSequence(*sequence, settings);
    ASSERT_GE(made->size(), 3u);
    const int64_t last_frame_ns = sequence->frame_time_ns(sequence->frame_count() - 1);
    const int64_t frame_ns = sequence->frame_time_ns(1) - sequence->frame_time_ns(0);
    ASSERT_LT(last_frame_ns - made->back(), RuntimeOptions{}.judge_after_frames * frame_ns)
        << "the premise: the last attempt is judged after the last frame";
    EXPECT_EQ(report.attempts, int(made->size()));
    const StoredHistory stored = HistoryStore(settings.history_path).Load();
    ASSERT_EQ(stored.attempts.size(), made->size());
    EXPECT_EQ(stored.attempts.back().t_ns, made->back());
  }
}

// What the workbench shows boards from: every judged attempt, the snapshots' and then the
// one judged after the last frame.
TEST(Runtime, TheAttemptJudgedAfterTheLastFrameIsHandedOver) {
  const std::unique_ptr<Sequence> sequence = Walk(4.7);  // As above: the last one is.
  const CameraIntrinsics truth = sequence->ground_truth()->front().intrinsics;
  std::vector<std::shared_ptr<const AttemptOutcome>> from_snapshots;
  Runtime runtime(
      *sequence->session().premission_calibration, AccelOf(*sequence), {}, {},
      [&](const std::shared_ptr<const FrameSnapshot>& snapshot) {
        if (snapshot->attempt) from_snapshots.push_back(snapshot->attempt);
      },
      JitteredStandIn(truth, 0));
  PushSequence(*sequence, &runtime);
  const std::vector<AttemptRecord>& judged = runtime.history().attempts();
  ASSERT_EQ(from_snapshots.size() + 1, judged.size()) << "the premise: one has no snapshot";
  const std::shared_ptr<const AttemptOutcome>& last = runtime.attempt_after_last_frame();
  ASSERT_TRUE(last);
  EXPECT_EQ(last->record.t_ns, judged.back().t_ns);
  EXPECT_GT(last->record.t_ns, from_snapshots.back()->record.t_ns);
}

TEST(Runtime, SnapshotsAreReadWhileThePipelineRuns) {
  const std::unique_ptr<Sequence> sequence = Walk(3.0);
  const AccelCalibration accel = AccelOf(*sequence);
  Runtime runtime(*sequence->session().premission_calibration, accel, {}, {});
  std::atomic<bool> done{false};
  int64_t reads = 0, backwards = 0;
  std::thread reader([&] {
    int64_t last = -1;
    while (!done) {
      if (const std::shared_ptr<const FrameSnapshot> snapshot = runtime.latest()) {
        ++reads;
        if (snapshot->index < last) ++backwards;
        last = snapshot->index;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });
  PushSequence(*sequence, &runtime);
  done = true;
  reader.join();
  EXPECT_GT(reads, 0);
  EXPECT_EQ(backwards, 0) << "snapshots are published in frame order";
  const std::shared_ptr<const FrameSnapshot> last = runtime.latest();
  ASSERT_TRUE(last);
  EXPECT_EQ(last->index, int64_t(sequence->frame_count()) - 1);
  EXPECT_EQ(last->t_ns, sequence->frame_time_ns(sequence->frame_count() - 1));
  EXPECT_FALSE(last->motion.tracks.empty());
  EXPECT_EQ(runtime.stats().frames_dropped, 0u) << "offline drops nothing";
}

TEST(Runtime, LiveDropsFramesItCannotKeepUpWithAndStillCalibrates) {
  const std::unique_ptr<Sequence> sequence = Walk(10.0);
  const CameraIntrinsics truth = sequence->ground_truth()->front().intrinsics;
  CameraIntrinsics prior = *sequence->session().premission_calibration;
  prior.fx *= 1.02;
  prior.fy *= 1.02;
  const AccelCalibration accel = AccelOf(*sequence);
  RuntimeOptions options;
  options.live = true;
  // Box 10's stand-in answers near the truth: what is tested is that live attempts are
  // made, solved on the worker, judged and followed while frames are dropped (the real
  // solve's accuracy is the end-to-end tests' business).
  Runtime runtime(prior, accel, {}, options, {}, JitteredStandIn(truth, 0));
  // A source that delivers two frames for every one the pipeline takes on: frames pile up
  // and must be dropped, and the source must never be made to wait.
  const std::vector<AccelSample>& samples = sequence->accel();
  std::vector<cv::Mat> frames;
  for (size_t i = 0; i < sequence->frame_count(); ++i) frames.push_back(sequence->LoadFrame(i));
  size_t fed = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    const int64_t t_ns = sequence->frame_time_ns(i);
    const size_t first = fed;
    while (fed < samples.size() && samples[fed].t_ns <= t_ns + runtime.accel_lead_ns()) ++fed;
    runtime.PushAccel(std::span(samples).subspan(first, fed - first));
    runtime.PushFrame(t_ns, frames[i]);
    while (true) {
      const RuntimeStats stats = runtime.stats();
      const bool idle = stats.frames_done + stats.frames_dropped == stats.frames_pushed;
      if (idle || 2 * stats.frames_done + 16 >= stats.frames_pushed) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  runtime.Finish();
  const RuntimeStats stats = runtime.stats();
  EXPECT_EQ(stats.frames_pushed, frames.size());
  EXPECT_GT(stats.frames_dropped, frames.size() / 4) << "about half the frames are dropped";
  EXPECT_EQ(stats.frames_done + stats.frames_dropped, stats.frames_pushed)
      << "every frame processed or counted as dropped";
  EXPECT_GT(stats.judged, 0);
  const CalibrationError start = CompareCalibration(prior, truth);
  const CalibrationError end = CompareCalibration(runtime.latest()->calibration.calibration, truth);
  EXPECT_GT(std::abs(start.fx_percent), 1.5);
  EXPECT_LT(std::abs(end.fx_percent), 0.5) << "fx within 0.5% of the truth";
  EXPECT_LT(std::abs(end.fy_percent), 0.5) << "fy within 0.5% of the truth";
  EXPECT_LT(std::abs(end.cx_px), 2.0) << "cx within 2 px";
}

// Live, a solve's calibration goes in effect the moment the solve ends, not at the next
// frame (which at 30 frames a second is up to 33 ms and that frame's boxes 1-9 later).
TEST(Runtime, LiveJudgesTheMomentTheSolveEnds) {
  const std::unique_ptr<Sequence> sequence = Walk(4.0);
  const CameraIntrinsics truth = sequence->ground_truth()->front().intrinsics;
  const AccelCalibration accel = AccelOf(*sequence);
  RuntimeOptions options;
  options.live = true;
  std::mutex gate_mutex;
  std::condition_variable gate_changed;
  bool open = false;
  const auto open_gate = [&] {
    {
      std::lock_guard lock(gate_mutex);
      open = true;
    }
    gate_changed.notify_all();
  };
  const Runtime::Solver stand_in = JitteredStandIn(truth, 0);
  Runtime runtime(*sequence->session().premission_calibration, accel, {}, options, {},
                  [&](const CalibrationJob& job) {
                    std::unique_lock lock(gate_mutex);
                    gate_changed.wait(lock, [&] { return open; });
                    return stand_in(job);
                  });
  // A failed assertion leaves the test with the gate shut: the runtime could not stop.
  const std::shared_ptr<void> open_at_exit(nullptr, [&](void*) { open_gate(); });
  const std::vector<AccelSample>& samples = sequence->accel();
  size_t fed = 0, pushed = 0;
  // One frame, waiting until boxes 1-9 are done with it.
  const auto push_one = [&] {
    const int64_t t_ns = sequence->frame_time_ns(pushed);
    const size_t first = fed;
    while (fed < samples.size() && samples[fed].t_ns <= t_ns + runtime.accel_lead_ns()) ++fed;
    runtime.PushAccel(std::span(samples).subspan(first, fed - first));
    runtime.PushFrame(t_ns, sequence->LoadFrame(pushed++));
    while (runtime.stats().frames_done < pushed) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  };
  while (runtime.stats().solves == 0 && pushed < sequence->frame_count()) push_one();
  // A few frames more while box 10 is held: nothing is judged without its result.
  for (int more = 0; more < 5 && pushed + 1 < sequence->frame_count(); ++more) push_one();
  RuntimeStats stats = runtime.stats();
  ASSERT_EQ(stats.solves, 1);
  EXPECT_EQ(stats.judged, 0);
  ASSERT_LT(pushed, sequence->frame_count()) << "a frame left for after the verdict";

  // No frame comes; the solve ends: the verdict is in within the time it takes to judge.
  open_gate();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (runtime.stats().judged == 0 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  stats = runtime.stats();
  EXPECT_EQ(stats.judged, 1) << "judged with no frame after the solve";
  EXPECT_EQ(stats.frames_done, pushed);
  // The next frame's snapshot carries the verdict.
  EXPECT_FALSE(runtime.latest()->attempt);
  push_one();
  const std::shared_ptr<const AttemptOutcome> attempt = runtime.latest()->attempt;
  ASSERT_TRUE(attempt);
  runtime.Finish();
  ASSERT_FALSE(runtime.history().attempts().empty());
  EXPECT_EQ(attempt->record.reason, runtime.history().attempts().front().reason);
}

}  // namespace
}  // namespace autocal
