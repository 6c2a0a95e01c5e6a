#include "devices/offline_runner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

#include "pipeline/error.h"
#include "pipeline/history_store.h"
#include "pipeline/stopwatch.h"
#include "pipeline/text_format.h"

namespace autocal {
namespace {

TimingStats Stats(std::vector<double> values) {
  TimingStats stats;
  stats.count = static_cast<int>(values.size());
  if (values.empty()) return stats;
  std::sort(values.begin(), values.end());
  const auto at = [&](double q) {
    return values[std::min(values.size() - 1, static_cast<size_t>(q * double(values.size())))];
  };
  stats.median_ms = at(0.5);
  stats.p95_ms = at(0.95);
  return stats;
}

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

std::string ErrorJson(const CalibrationError& e) {
  return "{\"fx_percent\": " + JsonNumber(e.fx_percent) +
         ", \"fy_percent\": " + JsonNumber(e.fy_percent) + ", \"cx_px\": " + JsonNumber(e.cx_px) +
         ", \"cy_px\": " + JsonNumber(e.cy_px) +
         ", \"distortion_px\": " + JsonNumber(e.distortion_px) + "}";
}

}  // namespace

RunReport RunSequence(const Sequence& sequence, const RunSettings& settings,
                      const std::function<void(const RunProgress&)>& progress) {
  const SessionInfo& session = sequence.session();
  RunReport report;
  report.input = sequence.Describe();
  if (settings.prior) {
    report.prior = *settings.prior;
  } else if (session.premission_calibration) {
    report.prior = *session.premission_calibration;
  } else {
    throw Error(report.input + " has no pre-mission calibration: give one with --prior");
  }
  if (report.prior.width != session.width || report.prior.height != session.height) {
    throw Error("the calibration is for " + std::to_string(report.prior.width) + "x" +
                std::to_string(report.prior.height) + " images, " + report.input + " has " +
                std::to_string(session.width) + "x" + std::to_string(session.height));
  }

  AccelCalibration accel;
  accel.cam_from_accel = session.cam_from_accel;
  std::unique_ptr<HistoryStore> store;
  if (!settings.history_path.empty()) {
    store = std::make_unique<HistoryStore>(settings.history_path);
    // A history is one run's: refused before the work, not after it.
    if (const size_t held = store->Load().attempts.size()) {
      throw Error(settings.history_path, 0,
                  "already holds a calibration history (" + std::to_string(held) +
                      " attempts); give a new file");
    }
  }

  std::map<std::string, std::vector<double>> times;
  std::vector<int64_t> frame_times;
  std::vector<CameraIntrinsics> outputs;
  report.frames = sequence.frame_count();
  const auto start = std::chrono::steady_clock::now();
  RuntimeOptions runtime_options = settings.runtime;
  runtime_options.accel_time_offset_s = settings.accel_time_offset_s;
  std::unique_ptr<Runtime> runtime;
  // Runs on the runtime's boxes 4-9 thread, frame after frame.
  const auto on_frame = [&](const std::shared_ptr<const FrameSnapshot>& snapshot) {
    double frame_ms = 0.0;
    for (const auto& [box, ms] : snapshot->timing.Named()) {
      if (ms > 0.0) times[box].push_back(ms);
      if (box != "calibration") frame_ms += ms;
    }
    times["frame"].push_back(frame_ms);
    if (snapshot->attempt && store) store->Record(runtime->history());
    frame_times.push_back(snapshot->t_ns);
    outputs.push_back(snapshot->calibration.calibration);
    if (progress) {
      progress({frame_times.size(), report.frames,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                snapshot.get()});
    }
  };
  runtime = std::make_unique<Runtime>(report.prior, accel, settings.pipeline, runtime_options,
                                      on_frame, settings.solve);
  PushSequence(sequence, runtime.get());
  times["update_latency"] = runtime->stats().update_latency_ms;
  report.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (report.frames > 1) {
    report.seconds = 1e-9 * double(frame_times.back() - frame_times.front());
  }
  report.fps = report.wall_seconds > 0 ? double(report.frames) / report.wall_seconds : 0.0;

  const CalibrationHistory& history = runtime->history();
  report.final = history.Current(frame_times.empty() ? 0 : frame_times.back());
  report.attempts = static_cast<int>(history.attempts().size());
  for (const AttemptRecord& attempt : history.attempts()) {
    ++report.verdicts[attempt.verdict];
    if (attempt.verdict == Verdict::kAccepted || attempt.verdict == Verdict::kNewRegime) {
      report.final_rms_px = attempt.rms_px;
    }
    if (attempt.verdict == Verdict::kNoUpdate &&
        std::find(report.no_update_reasons.begin(), report.no_update_reasons.end(),
                  attempt.reason) == report.no_update_reasons.end()) {
      report.no_update_reasons.push_back(attempt.reason);
    }
  }
  report.alarms = history.alarms();
  for (auto& [box, values] : times) {
    if (!values.empty()) report.timing[box] = Stats(std::move(values));
  }
  if (const auto* truth = sequence.ground_truth(); truth && truth->size() == report.frames) {
    report.truth = CompareWithTruth(frame_times, outputs, *truth, settings.convergence);
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
  json += "  \"no_update_reasons\": [";
  for (size_t i = 0; i < report.no_update_reasons.size(); ++i) {
    json += (i ? ", " : "") + JsonString(report.no_update_reasons[i]);
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
            ", \"p95\": " + JsonNumber(stats.p95_ms) + ", \"count\": " +
            std::to_string(stats.count) + "}";
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
  json += "\n}\n";
  return json;
}

void WriteSummary(const std::string& path, const RunReport& report) {
  WriteTextFile(path, SummaryJson(report));
}

}  // namespace autocal
