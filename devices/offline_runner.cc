#include "devices/offline_runner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <span>

#include "devices/history_writer.h"
#include "pipeline/error.h"
#include "pipeline/history_store.h"
#include "pipeline/stopwatch.h"
#include "pipeline/text_format.h"

namespace autocal {

namespace {

// The largest magnitude of each field over `errors`, signs kept.
CalibrationError Worst(const std::vector<CalibrationError>& errors) {
  CalibrationError worst;
  const auto keep = [](double* kept, double value) {
    if (std::abs(value) > std::abs(*kept)) *kept = value;
  };
  for (const CalibrationError& e : errors) {
    keep(&worst.fx_percent, e.fx_percent);
    keep(&worst.fy_percent, e.fy_percent);
    keep(&worst.cx_px, e.cx_px);
    keep(&worst.cy_px, e.cy_px);
    keep(&worst.distortion_px, e.distortion_px);
  }
  return worst;
}

}  // namespace

GroundTruthReport CompareWithTruth(const std::vector<int64_t>& times,
                                   const std::vector<CameraIntrinsics>& outputs,
                                   const std::vector<GroundTruthFrame>& truth,
                                   const CalibrationTolerance& tolerance) {
  GroundTruthReport report;
  report.t_ns = times;
  for (size_t i = 0; i < outputs.size(); ++i) {
    report.errors.push_back(CompareCalibration(outputs[i], truth[i].intrinsics));
  }
  if (report.errors.empty()) return report;
  report.final = report.errors.back();
  // Converged at the first frame within the tolerance; the worst error after it says
  // whether the output stayed there.
  for (size_t i = 0; i < report.errors.size(); ++i) {
    if (!tolerance.Admits(report.errors[i])) continue;
    report.converged_at_s = 1e-9 * double(times[i] - times.front());
    report.worst_after_convergence =
        Worst({report.errors.begin() + static_cast<std::ptrdiff_t>(i), report.errors.end()});
    break;
  }
  return report;
}

namespace {

std::string ErrorJson(const CalibrationError& e) {
  return "{\"fx_percent\": " + JsonNumber(e.fx_percent) +
         ", \"fy_percent\": " + JsonNumber(e.fy_percent) + ", \"cx_px\": " + JsonNumber(e.cx_px) +
         ", \"cy_px\": " + JsonNumber(e.cy_px) +
         ", \"distortion_px\": " + JsonNumber(e.distortion_px) + "}";
}

}  // namespace

CameraIntrinsics StartingCalibration(const std::string& input, const SessionInfo& session,
                                     const std::optional<CameraIntrinsics>& given,
                                     const std::string& how_to_give) {
  if (!given && !session.premission_calibration) {
    throw Error(input + " has no pre-mission calibration: give one with " + how_to_give);
  }
  const CameraIntrinsics& prior = given ? *given : *session.premission_calibration;
  if (prior.width != session.width || prior.height != session.height) {
    throw Error("the calibration is for " + std::to_string(prior.width) + "x" +
                std::to_string(prior.height) + " images, " + input + " has " +
                std::to_string(session.width) + "x" + std::to_string(session.height));
  }
  return prior;
}

std::unique_ptr<HistoryStore> OpenNewHistory(const RunSettings& settings) {
  if (settings.history_path.empty()) return nullptr;
  auto store = std::make_unique<HistoryStore>(settings.history_path);
  // A history is one run's: refused before the work, not after it.
  if (const size_t held = store->Load().attempts.size()) {
    throw Error(settings.history_path, 0,
                "already holds a calibration history (" + std::to_string(held) +
                    " attempts); give a new file");
  }
  return store;
}

namespace {

// The writer of settings.history_path, opened for a new run; null when there is none.
std::unique_ptr<HistoryWriter> StartHistoryWriter(const RunSettings& settings) {
  std::unique_ptr<HistoryStore> store = OpenNewHistory(settings);
  return store ? std::make_unique<HistoryWriter>(std::move(store)) : nullptr;
}

}  // namespace

void SummarizeHistory(const CalibrationHistory& history, int64_t end_ns, RunReport* report) {
  report->final = history.Current(end_ns);
  report->attempts = static_cast<int>(history.attempts().size());
  for (const AttemptRecord& attempt : history.attempts()) {
    ++report->verdicts[attempt.verdict];
    if (attempt.verdict == Verdict::kAccepted || attempt.verdict == Verdict::kNewRegime) {
      report->final_rms_px = attempt.rms_px;
    }
    if (attempt.verdict != Verdict::kNoUpdate) continue;
    const std::string cause = NoUpdateCause(attempt.reason);
    auto& causes = report->no_update_causes;
    auto counted = std::find_if(causes.begin(), causes.end(),
                                [&](const RunReport::CauseCount& c) { return c.cause == cause; });
    if (counted == causes.end()) counted = causes.insert(causes.end(), {cause, 0, {}});
    ++counted->count;
    counted->latest = attempt.reason;
  }
  report->alarms = history.alarms();
}

namespace {

// What the runtime's frames say, gathered on its boxes 4-9 thread. Memory stays flat over
// a session of any length: the timings go into histograms, and each frame's output is kept
// only where it is to be compared with the truth (whose frames are held anyway).
struct FrameLog {
  explicit FrameLog(bool keep) : keep_outputs(keep) {}

  bool keep_outputs;
  BoxTimingLog times;
  size_t frames = 0;
  int64_t first_ns = 0, last_ns = 0;
  std::vector<int64_t> t_ns;  // With keep_outputs only.
  std::vector<CameraIntrinsics> outputs;
  std::optional<PlumbLineResult> plumb_line;  // Box 2's newest.

  void Add(const FrameSnapshot& snapshot) {
    times.Add(snapshot.timing);
    if (snapshot.lens.distortion) plumb_line = snapshot.lens.distortion;
    if (frames++ == 0) first_ns = snapshot.t_ns;
    last_ns = snapshot.t_ns;
    if (keep_outputs) {
      t_ns.push_back(snapshot.t_ns);
      outputs.push_back(snapshot.calibration.calibration);
    }
  }
};

// Everything after the last frame: counts, verdicts, timings, and the error against the
// truth (`truth` one entry per processed frame, or null).
void CompleteReport(const Runtime& runtime, FrameLog log,
                    const std::vector<GroundTruthFrame>* truth, const RunSettings& settings,
                    std::chrono::steady_clock::time_point start, RunReport* report) {
  report->wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (log.frames > 1) report->seconds = 1e-9 * double(log.last_ns - log.first_ns);
  report->fps = report->wall_seconds > 0 ? double(report->frames) / report->wall_seconds : 0.0;

  SummarizeHistory(runtime.history(), log.frames == 0 ? 0 : log.last_ns, report);
  report->plumb_line = std::move(log.plumb_line);
  report->timing = log.times.Stats();
  const RuntimeStats stats = runtime.stats();
  if (stats.update_latency_ms.count() > 0) {
    report->timing["update_latency"] = stats.update_latency_ms.Stats();
  }
  report->thread_cpu_s = {{kLensThreadName, stats.lens_cpu_s},
                          {kMotionThreadName, stats.motion_cpu_s},
                          {kSolveThreadName, stats.solve_cpu_s}};
  const auto waiting = [](const char* thread, const char* on) {
    return std::string(thread) + " for " + on;
  };
  report->thread_wait_s = {
      {waiting(kLensThreadName, "frames"), stats.lens_wait_input_s},
      {waiting(kLensThreadName, kMotionThreadName), stats.lens_wait_motion_s},
      {waiting(kMotionThreadName, kLensThreadName), stats.motion_wait_lens_s},
      {waiting(kMotionThreadName, kSolveThreadName), stats.motion_wait_solve_s}};
  if (truth && truth->size() == log.t_ns.size() && !truth->empty()) {
    report->truth = CompareWithTruth(log.t_ns, log.outputs, *truth, settings.convergence);
  }
}

}  // namespace

PipelineOptions RecordingDefaults(const SessionInfo& session) {
  PipelineOptions options;
  options.calibration.readout_ms = session.readout_ms;
  return options;
}

RunReport RunSequence(const Sequence& sequence, const RunSettings& settings,
                      const std::function<void(const RunProgress&)>& progress,
                      const std::atomic<bool>* stop) {
  const SessionInfo& session = sequence.session();
  RunReport report;
  report.input = sequence.Describe();
  report.prior = StartingCalibration(report.input, session, settings.prior);
  AccelCalibration accel;
  accel.cam_from_accel = session.cam_from_accel;
  const std::unique_ptr<HistoryWriter> history = StartHistoryWriter(settings);

  const std::vector<GroundTruthFrame>* truth = sequence.ground_truth();
  if (truth && truth->size() != sequence.frame_count()) truth = nullptr;
  FrameLog log(truth != nullptr);
  report.frames_in_input = sequence.frame_count();
  const auto start = std::chrono::steady_clock::now();
  RuntimeOptions runtime_options = settings.runtime;
  runtime_options.accel_time_offset_s = settings.accel_time_offset_s;
  std::unique_ptr<Runtime> runtime;
  // Runs on the runtime's boxes 4-9 thread, frame after frame.
  const auto on_frame = [&](const std::shared_ptr<const FrameSnapshot>& snapshot) {
    log.Add(*snapshot);
    if (snapshot->attempt && history) history->Submit(runtime->history());
    if (progress) {
      progress({log.frames, report.frames_in_input,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                snapshot.get()});
    }
  };
  runtime = std::make_unique<Runtime>(report.prior, accel, settings.pipeline, runtime_options,
                                      on_frame, settings.solve);
  // The start (the calibration and options the attempts are judged against) is in the file
  // before the first frame: a run killed before its first attempt leaves one that says it.
  if (history) history->Finish(runtime->history());
  // Stopped, the frames already fed are finished all the same.
  if (!PushSequence(sequence, runtime.get(), stop)) runtime->Finish();
  if (history) history->Finish(runtime->history());
  report.frames = log.frames;
  report.stopped = report.frames < report.frames_in_input;
  // Frames are processed in order, none dropped: those done have the truth's first entries.
  std::vector<GroundTruthFrame> truth_done;
  if (truth && report.stopped) {
    truth_done.assign(truth->begin(), truth->begin() + static_cast<std::ptrdiff_t>(log.frames));
    truth = &truth_done;
  }
  CompleteReport(*runtime, std::move(log), truth, settings, start, &report);
  return report;
}

RunReport RunSource(FrameSource& source, const RunSettings& settings,
                    const LiveRunControl& control) {
  source.Start();  // A missing device is the news: before any file is made.
  RunReport report;
  report.input = source.Describe();
  report.live.emplace();
  LiveRunReport& live = *report.live;
  try {
    const SessionInfo session = source.session();
    report.prior = StartingCalibration(report.input, session, settings.prior);
    AccelCalibration accel;
    accel.cam_from_accel = session.cam_from_accel;
    const std::unique_ptr<HistoryWriter> history = StartHistoryWriter(settings);

    // A recording played in real time keeps its times: each processed frame's truth is the
    // recorded frame at that time.
    const Sequence* recorded = source.sequence();
    const std::vector<GroundTruthFrame>* truth = recorded ? recorded->ground_truth() : nullptr;
    std::map<int64_t, size_t> truth_index;
    if (truth && truth->size() == recorded->frame_count()) {
      for (size_t i = 0; i < recorded->frame_count(); ++i) {
        truth_index[recorded->frame_time_ns(i)] = i;
      }
    }
    std::vector<GroundTruthFrame> processed_truth;

    FrameLog log(!truth_index.empty());
    const auto start = std::chrono::steady_clock::now();
    RuntimeOptions runtime_options = settings.runtime;
    runtime_options.accel_time_offset_s = settings.accel_time_offset_s;
    runtime_options.live = source.live();
    std::mutex latest_mutex;  // The newest snapshot, for progress on the caller's thread.
    std::shared_ptr<const FrameSnapshot> latest;
    // Declared after everything its frame callback touches, so destroyed (its threads
    // stopped) first.
    std::unique_ptr<Runtime> runtime;
    const auto on_frame = [&](const std::shared_ptr<const FrameSnapshot>& snapshot) {
      log.Add(*snapshot);
      if (const auto found = truth_index.find(snapshot->t_ns); found != truth_index.end()) {
        processed_truth.push_back((*truth)[found->second]);
      }
      if (snapshot->attempt && history) history->Submit(runtime->history());
      std::lock_guard lock(latest_mutex);
      latest = snapshot;
    };
    runtime = std::make_unique<Runtime>(report.prior, accel, settings.pipeline, runtime_options,
                                        on_frame, settings.solve);
    // The start, as in RunSequence, but not waited for: a live camera is never held up by
    // the disk or by another program's lock on the file.
    if (history) history->Submit(runtime->history());

    using Clock = std::chrono::steady_clock;
    const auto seconds = [](double s) {
      return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
    };
    const Clock::time_point end =
        control.seconds > 0 ? start + seconds(control.seconds) : Clock::time_point::max();
    Clock::time_point next_progress = start + seconds(control.progress_interval_s);
    const auto report_progress = [&] {
      if (!control.progress) return;
      const SourceStats stats = source.stats();
      std::shared_ptr<const FrameSnapshot> newest;
      {
        std::lock_guard lock(latest_mutex);
        newest = latest;
      }
      // One copy of the runtime's counters (they carry the latency histogram).
      const RuntimeStats run = runtime->stats();
      RunProgress progress{size_t(run.frames_done),
                           size_t(live.frames_received),
                           std::chrono::duration<double>(Clock::now() - start).count(),
                           newest.get(),
                           run.frames_dropped + stats.frames_dropped,
                           &stats};
      control.progress(progress);
    };
    SourceItem item;
    while (true) {
      if (control.stop && control.stop->load()) {
        live.ended_by = "a stop request";
        break;
      }
      const Clock::time_point now = Clock::now();
      if (now >= end) {
        live.ended_by = "--seconds";
        break;
      }
      if (now >= next_progress) {
        report_progress();
        next_progress = now + seconds(control.progress_interval_s);
      }
      const auto wait = std::min<Clock::duration>(std::chrono::milliseconds(100), end - now);
      const FrameSource::Status status =
          source.Next(&item, std::chrono::duration_cast<std::chrono::milliseconds>(wait));
      if (status == FrameSource::Status::kEnd) {
        live.ended_by = "the source ended";
        break;
      }
      if (status == FrameSource::Status::kTimeout) continue;
      switch (item.kind) {
        case SourceItem::Kind::kFrame:
          ++live.frames_received;
          runtime->PushFrame(item.t_ns, item.image);  // Live: never waits.
          break;
        case SourceItem::Kind::kAccel:
          runtime->PushAccel(std::span(&item.accel, 1));
          break;
        case SourceItem::Kind::kEvent:
          live.events.push_back(item.event);
          if (control.on_event) control.on_event(item.event);
          break;
      }
    }
    source.Stop();
    runtime->Finish();
    if (history) history->Finish(runtime->history());
    report_progress();

    const SourceStats stats = source.stats();
    live.pipeline_dropped = runtime->stats().frames_dropped;
    live.source_dropped = stats.frames_dropped;
    live.accel_dropped = stats.accel_dropped;
    live.camera_rate_hz = stats.camera_rate_hz;
    live.accel_rate_hz = stats.accel_rate_hz;
    live.camera_gaps = stats.camera_gaps;
    live.camera_disconnections = stats.camera_disconnections;
    live.accel_disconnections = stats.accel_disconnections;
    report.frames = log.frames;
    CompleteReport(*runtime, std::move(log),
                   processed_truth.size() == report.frames ? &processed_truth : nullptr, settings,
                   start, &report);
  } catch (...) {
    source.Stop();
    throw;
  }
  return report;
}

std::string SummaryJson(const RunReport& report) {
  const auto count = [&](Verdict v) {
    const auto found = report.verdicts.find(v);
    return found == report.verdicts.end() ? 0 : found->second;
  };
  const CameraIntrinsics& c = report.final.calibration;
  std::string json = "{\n";
  json += "  \"input\": " + JsonString(report.input) + ",\n";
  json += "  \"frames\": " + std::to_string(report.frames) + ",\n";
  if (!report.live) {
    json += "  \"stopped\": " + std::string(report.stopped ? "true" : "false") + ",\n";
    if (report.stopped) {
      json += "  \"frames_in_input\": " + std::to_string(report.frames_in_input) + ",\n";
    }
  }
  json += "  \"seconds\": " + JsonNumber(report.seconds) + ",\n";
  json += "  \"wall_seconds\": " + JsonNumber(report.wall_seconds) + ",\n";
  json += "  \"fps\": " + JsonNumber(report.fps) + ",\n";
  json += "  \"final\": {\"width\": " + std::to_string(c.width) +
          ", \"height\": " + std::to_string(c.height);
  const auto packed = c.Packed();
  for (int i = 0; i < kNumIntrinsics; ++i) {
    json += ", " + JsonString(IntrinsicName(i)) + ": " + JsonNumber(packed[i]);
  }
  json += ", \"rms_px\": " + JsonNumber(report.final_rms_px) +
          ", \"regime\": " + std::to_string(report.final.regime) + "},\n";
  json += "  \"updates\": {\"attempted\": " + std::to_string(report.attempts) +
          ", \"accepted\": " + std::to_string(count(Verdict::kAccepted)) +
          ", \"rejected\": " + std::to_string(count(Verdict::kRejected)) +
          ", \"no_update\": " + std::to_string(count(Verdict::kNoUpdate)) +
          ", \"alarm\": " + std::to_string(count(Verdict::kAlarm)) +
          ", \"new_regime\": " + std::to_string(count(Verdict::kNewRegime)) + "},\n";
  if (report.plumb_line) {
    const PlumbLineResult& p = *report.plumb_line;
    json += "  \"plumb_line\": {\"usable\": " + std::string(p.usable ? "true" : "false") +
            ", \"message\": " + JsonString(p.message) +
            ", \"lines_used\": " + std::to_string(p.lines_used) +
            ", \"rms_before_px\": " + JsonNumber(p.rms_before_px) +
            ", \"rms_after_px\": " + JsonNumber(p.rms_after_px) +
            ", \"observability\": " + ObservabilityJson(p.observability) + "},\n";
  }
  json += "  \"no_update_causes\": [";
  for (size_t i = 0; i < report.no_update_causes.size(); ++i) {
    const RunReport::CauseCount& counted = report.no_update_causes[i];
    json += std::string(i ? ", " : "") + "{\"cause\": " + JsonString(counted.cause) +
            ", \"count\": " + std::to_string(counted.count) +
            ", \"latest\": " + JsonString(counted.latest) + "}";
  }
  json += "],\n  \"alarms\": [";
  for (size_t i = 0; i < report.alarms.size(); ++i) {
    const Alarm& alarm = report.alarms[i];
    json += std::string(i ? ", " : "") + "{\"t\": " + JsonNumber(1e-9 * double(alarm.t_ns)) +
            ", \"kind\": " + JsonString(alarm.kind) +
            ", \"description\": " + JsonString(alarm.description) + "}";
  }
  json += "],\n  \"timing_ms\": {";
  bool first = true;
  for (const auto& [box, stats] : report.timing) {
    json += std::string(first ? "\n" : ",\n") + "    " + JsonString(box) +
            ": {\"median\": " + JsonNumber(stats.median_ms) +
            ", \"p95\": " + JsonNumber(stats.p95_ms) +
            ", \"count\": " + std::to_string(stats.count) + "}";
    first = false;
  }
  json += "\n  }";
  if (report.truth) {
    const GroundTruthReport& truth = *report.truth;
    json += ",\n  \"error\": {\"final\": " + ErrorJson(truth.final) + ", \"converged_at_s\": " +
            (truth.converged_at_s ? JsonNumber(*truth.converged_at_s) : "null") +
            ", \"worst_after_convergence\": " +
            (truth.worst_after_convergence ? ErrorJson(*truth.worst_after_convergence) : "null") +
            "}";
  }
  if (report.live) {
    const LiveRunReport& live = *report.live;
    json +=
        ",\n  \"live\": {\"frames_received\": " + std::to_string(live.frames_received) +
        ", \"frames_dropped\": " + std::to_string(live.frames_dropped()) +
        ", \"frames_dropped_by_pipeline\": " + std::to_string(live.pipeline_dropped) +
        ", \"frames_dropped_by_source\": " + std::to_string(live.source_dropped) +
        ", \"accel_dropped\": " + std::to_string(live.accel_dropped) +
        ", \"camera_rate_hz\": " + JsonNumber(live.camera_rate_hz) +
        ", \"accel_rate_hz\": " + JsonNumber(live.accel_rate_hz) +
        ",\n    \"disconnections\": {\"camera\": " + std::to_string(live.camera_disconnections) +
        ", \"accelerometer\": " + std::to_string(live.accel_disconnections) +
        "}, \"camera_gaps\": [";
    for (size_t i = 0; i < live.camera_gaps.size(); ++i) {
      const TimeGap& gap = live.camera_gaps[i];
      json += std::string(i ? ", " : "") +
              "{\"start\": " + JsonNumber(1e-9 * double(gap.start_ns)) +
              ", \"end\": " + JsonNumber(1e-9 * double(gap.end_ns)) +
              ", \"seconds\": " + JsonNumber(gap.seconds()) + "}";
    }
    json += "],\n    \"events\": [";
    for (size_t i = 0; i < live.events.size(); ++i) {
      json += std::string(i ? ", " : "") +
              "{\"t\": " + JsonNumber(1e-9 * double(live.events[i].t_ns)) +
              ", \"event\": " + JsonString(FormatSourceEvent(live.events[i])) + "}";
    }
    json += "],\n    \"ended_by\": " + JsonString(live.ended_by) + "}";
  }
  json += "\n}\n";
  return json;
}

void WriteSummary(const std::string& path, const RunReport& report) {
  WriteTextFile(path, SummaryJson(report));
}

}  // namespace autocal
