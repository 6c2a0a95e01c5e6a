// `autocal bench`: the whole pipeline on a simulated recording, timed. The recording is
// rendered into memory first so that rendering is not timed (or, with --stream, rendered
// as the pipeline asks for it, for sessions too long to hold: then memory is the point).
#include <sys/resource.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <QCommandLineParser>
#include <QTemporaryDir>

#include "app/cli_commands.h"
#include "app/cli_util.h"
#include "devices/in_memory_sequence.h"
#include "devices/offline_runner.h"
#include "devices/sim/simulator.h"
#include "devices/source.h"
#include "pipeline/error.h"
#include "pipeline/option_fields.h"
#include "pipeline/text_format.h"

namespace autocal::cli {
namespace {

// `source` played over and over, each pass's times (frames and accelerometer) shifted to
// follow the last: a long session from a short rendering, for memory over time. Each pass
// starts with a cut, as if the camera had been covered; there is no ground truth.
class LoopedSequence : public Sequence {
 public:
  LoopedSequence(const Sequence& source, size_t frame_count)
      : source_(source), frame_count_(frame_count) {
    const size_t n = source.frame_count();
    if (n < 2) throw Error("--loop needs a recording of at least two frames");
    // One pass lasts its frames' span plus one frame interval.
    period_ns_ = source.frame_time_ns(n - 1) - source.frame_time_ns(0) +
                 (source.frame_time_ns(n - 1) - source.frame_time_ns(0)) / int64_t(n - 1);
    const size_t passes = (frame_count + n - 1) / n;
    const int64_t end_ns = frame_time_ns(frame_count - 1);
    for (size_t pass = 0; pass < passes; ++pass) {
      for (AccelSample sample : source.accel()) {
        sample.t_ns += int64_t(pass) * period_ns_;
        if (sample.t_ns <= end_ns + period_ns_ / int64_t(n)) accel_.push_back(sample);
      }
    }
  }
  std::string Describe() const override { return source_.Describe() + ", looped"; }
  const SessionInfo& session() const override { return source_.session(); }
  size_t frame_count() const override { return frame_count_; }
  int64_t frame_time_ns(size_t index) const override {
    const size_t n = source_.frame_count();
    return source_.frame_time_ns(index % n) + int64_t(index / n) * period_ns_;
  }
  cv::Mat LoadFrame(size_t index) const override {
    return source_.LoadFrame(index % source_.frame_count());
  }
  const std::vector<AccelSample>& accel() const override { return accel_; }
  const std::vector<std::string>& warnings() const override { return source_.warnings(); }

 private:
  const Sequence& source_;
  size_t frame_count_;
  int64_t period_ns_ = 0;
  std::vector<AccelSample> accel_;
};

// A field of /proc/self/status in MB (VmHWM: peak resident size; VmRSS: now).
double StatusMegabytes(const std::string& field) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind(field + ":", 0) == 0) return std::stod(line.substr(field.size() + 1)) / 1024.0;
  }
  return 0.0;
}

std::string CpuModel() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string line;
  while (std::getline(cpuinfo, line)) {
    if (line.rfind("model name", 0) == 0) {
      const size_t colon = line.find(':');
      return colon == std::string::npos ? line : line.substr(colon + 2);
    }
  }
  return "unknown";
}

// User and system CPU time of the whole process, every thread.
double ProcessCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto seconds = [](const timeval& t) { return double(t.tv_sec) + 1e-6 * double(t.tv_usec); };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

double LoadAverage() {
  std::ifstream loadavg("/proc/loadavg");
  double one_minute = 0.0;
  loadavg >> one_minute;
  return one_minute;
}

std::string StatsJson(const TimingStats& stats) {
  return "{\"median\": " + JsonNumber(stats.median_ms) + ", \"p95\": " + JsonNumber(stats.p95_ms) +
         ", \"count\": " + std::to_string(stats.count) + "}";
}

// Seconds by name (a thread's, or a thread's wait), as a JSON object in the given order.
std::string SecondsJson(const std::vector<std::pair<std::string, double>>& seconds) {
  std::string json = "{";
  for (size_t i = 0; i < seconds.size(); ++i) {
    json += std::string(i ? ", " : "") + JsonString(seconds[i].first) + ": " +
            JsonNumber(seconds[i].second);
  }
  return json + "}";
}

}  // namespace

int Bench(const QStringList& arguments) {
  const QString name = "bench";
  QCommandLineParser parser;
  parser.setApplicationDescription(
      "Runs the whole pipeline (boxes 1-10, history written) offline on a simulated\n"
      "recording rendered into memory beforehand, and prints per-box median and 95th\n"
      "percentile times, end-to-end frames per second, calibration-update latency and peak\n"
      "memory.");
  parser.addOptions({
      {"scenario", "Simulator scenario, optionally with overrides: office,lens=sonnar.", "spec",
       "office"},
      {"resolution", "Frame size (default 640x480).", "WxH", "640x480"},
      {"seconds", "Seconds of recording (default 10).", "s", "10"},
      {"json", "Write the figures as JSON here too.", "file"},
      {"history",
       "Keep the history (every attempt, its verdict and solver report) in this SQLite file "
       "instead of a temporary one: to see which attempts made the latency's tail.",
       "file.sqlite"},
      {"judge-after",
       "Offline, judge each attempt this many frames after it is made (default " +
           QString::number(RuntimeOptions{}.judge_after_frames) + ", as autocal run; see "
           "docs/runtime.md).",
       "frames", QString::number(RuntimeOptions{}.judge_after_frames)},
      {"stream",
       "Render frames as the pipeline asks for them instead of beforehand (rendering is then "
       "timed): for long sessions, with the resident size sampled every 10% of the run."},
      {"live",
       "Play the rendered frames as a live camera at the recording's frame rate (live mode: "
       "frames the pipeline cannot take are dropped and counted, each attempt judged as its "
       "solve ends): the update latency then counts from the moment the camera delivers the "
       "frame, as on a vest."},
      {"loop",
       "Render only this many seconds and play them over and over for --seconds (each pass "
       "starts with a cut): a long session for memory, without the long rendering; the "
       "resident size is sampled every 10% of the run.",
       "s"},
  });
  AddPipelineSettingsOptions(parser);
  if (const auto code = Parse(parser, name, arguments)) return *code;
  if (const auto malformed = MalformedSetting(parser)) return UsageError(name, *malformed, parser);
  bool seconds_ok = false;
  const double seconds = parser.value("seconds").toDouble(&seconds_ok);
  if (!seconds_ok || seconds <= 0.0) {
    return UsageError(name, "--seconds takes a positive number, got " + parser.value("seconds"),
                      parser);
  }

  bool judge_ok = false;
  const int judge_after = parser.value("judge-after").toInt(&judge_ok);
  if (!judge_ok || judge_after < 0) {
    return UsageError(name, "--judge-after takes frames, got " + parser.value("judge-after"),
                      parser);
  }

  std::optional<double> loop_seconds;
  if (parser.isSet("loop")) {
    bool loop_ok = false;
    loop_seconds = parser.value("loop").toDouble(&loop_ok);
    if (!loop_ok || !(*loop_seconds > 0.0) || *loop_seconds > seconds) {
      return UsageError(name,
                        "--loop takes positive seconds, at most --seconds; got " +
                            parser.value("loop"),
                        parser);
    }
    if (parser.isSet("stream")) return UsageError(name, "--loop and --stream exclude each other", parser);
  }
  const bool live = parser.isSet("live");
  if (live && (parser.isSet("stream") || loop_seconds || parser.isSet("judge-after"))) {
    return UsageError(name, "--live goes without --stream, --loop and --judge-after", parser);
  }

  try {
    // A --history file that already holds a run is refused before the rendering too (the
    // run opens it again).
    const std::string history_path = parser.value("history").toStdString();
    if (!history_path.empty()) {
      RunSettings check;
      check.history_path = history_path;
      OpenNewHistory(check);
    }
    Scenario scenario = ParseScenarioSpec(parser.value("scenario").toStdString());
    ApplyScenarioOverride(&scenario, "resolution", parser.value("resolution").toStdString());
    ApplyScenarioOverride(&scenario, "seconds",
                          loop_seconds ? parser.value("loop").toStdString()
                                       : parser.value("seconds").toStdString());
    std::unique_ptr<Sequence> simulated = MakeSimulatedSequence(scenario);
    const PipelineOptions pipeline =
        PipelineOptionsFrom(parser, RecordingDefaults(simulated->session()));
    ReportRollingShutter("bench", simulated->session(), pipeline);
    const bool stream = parser.isSet("stream");
    std::unique_ptr<InMemorySequence> rendered;
    if (!stream) {
      std::fprintf(stderr, "autocal bench: rendering %zu frames...\n", simulated->frame_count());
      rendered = std::make_unique<InMemorySequence>(std::move(simulated));
    }
    std::unique_ptr<LoopedSequence> looped;
    if (loop_seconds) {
      looped = std::make_unique<LoopedSequence>(
          *rendered, size_t(std::lround(double(rendered->frame_count()) * seconds / *loop_seconds)));
    }
    const double frames_mb = rendered ? rendered->megabytes() : 0.0;

    const QTemporaryDir dir;
    if (!dir.isValid()) throw Error("cannot make a temporary folder for the history");
    RunSettings settings;
    settings.pipeline = pipeline;
    settings.history_path =
        history_path.empty() ? dir.filePath("history.sqlite").toStdString() : history_path;
    settings.runtime.judge_after_frames = judge_after;
    ProgressPrinter printer("bench", "frames");
    const double cpu_before_s = ProcessCpuSeconds();
    RunReport report;
    // Resident size at each tenth of the run, and after the first minute of recording.
    std::vector<std::pair<double, double>> rss;  // (recording s, MB)
    std::optional<double> rss_after_minute;
    if (live) {
      SourceOptions play;
      play.real_time = true;
      const std::unique_ptr<FrameSource> camera = PlaySequence(std::move(rendered), play);
      LiveRunControl control;
      control.progress = [&](const RunProgress& progress) {
        printer(progress.frame, progress.frames);
      };
      report = RunSource(*camera, settings, control);
    } else {
      const Sequence& sequence = stream   ? *simulated
                                 : looped ? static_cast<const Sequence&>(*looped)
                                          : *rendered;
      const int64_t first_ns = sequence.frame_count() ? sequence.frame_time_ns(0) : 0;
      report = RunSequence(sequence, settings, [&](const RunProgress& progress) {
        printer(progress.frame, progress.frames);
        const double at_s = 1e-9 * double(progress.snapshot->t_ns - first_ns);
        if (!rss_after_minute && at_s >= 60.0) rss_after_minute = StatusMegabytes("VmRSS");
        if (progress.frame * 10 / progress.frames != (progress.frame - 1) * 10 / progress.frames) {
          rss.emplace_back(at_s, StatusMegabytes("VmRSS"));
        }
      });
    }
    // Of both cores, how much the run kept busy: below 2, threads waited on each other.
    const double process_cpu_s = ProcessCpuSeconds() - cpu_before_s;
    const double cores_busy = process_cpu_s / report.wall_seconds;
    // What the process used beside the pipeline's threads: box 2's estimates, OpenCV's TBB
    // worker, the thread feeding frames.
    double other_cpu_s = process_cpu_s;
    for (const auto& [thread, cpu_s] : report.thread_cpu_s) other_cpu_s -= cpu_s;
    const double peak_mb = StatusMegabytes("VmHWM");

    const auto latency = report.timing.find("update_latency");
    const TimingStats update = latency == report.timing.end() ? TimingStats{} : latency->second;

    std::printf("%s, %s, %.1f s of recording: %zu frames\n", report.input.c_str(),
                parser.value("resolution").toUtf8().constData(), report.seconds, report.frames);
    std::printf("machine: %u cores, %s, load average %.2f\n", std::thread::hardware_concurrency(),
                CpuModel().c_str(), LoadAverage());
    const auto changed = ChangedPipelineOptions(pipeline);
    std::string changed_text;
    for (const auto& [option, value] : changed) {
      changed_text += (changed_text.empty() ? "" : ", ") + option + " = " + value;
    }
    std::printf("settings: %s\n", changed.empty() ? "the defaults" : changed_text.c_str());
    std::printf("%-16s %10s %10s %8s\n", "box", "median ms", "p95 ms", "frames");
    for (const auto& [box, stats] : report.timing) {
      if (box == "update_latency") continue;
      std::printf("%-16s %10.3f %10.3f %8d\n", box.c_str(), stats.median_ms, stats.p95_ms,
                  stats.count);
    }
    std::printf("end to end: %.1f frames/s (%.2f s wall)%s\n", report.fps, report.wall_seconds,
                stream ? ", rendering included" : live ? ", paced by the camera" : "");
    std::printf("cores busy: %.2f on average (CPU time over wall time)\n", cores_busy);
    // The pipeline thread nearest to the wall-clock time is what limits the frames per
    // second; the other threads' line is a sum over several and limits nothing alone.
    std::string by_thread;
    auto rows = report.thread_cpu_s;
    rows.emplace_back("other threads", other_cpu_s);
    for (const auto& [thread, cpu_s] : rows) {
      char part[128];
      std::snprintf(part, sizeof part, "%s%s %.2f s (%.2f ms a frame)",
                    by_thread.empty() ? "" : ", ", thread.c_str(), cpu_s,
                    report.frames ? 1e3 * cpu_s / double(report.frames) : 0.0);
      by_thread += part;
    }
    std::printf("CPU by thread: %s\n", by_thread.c_str());
    // Where the per-frame threads stood still: the one that waits least holds the others up.
    std::string waits;
    for (const auto& [what, wait_s] : report.thread_wait_s) {
      char part[128];
      std::snprintf(part, sizeof part, "%s%s %.2f s", waits.empty() ? "" : ", ", what.c_str(),
                    wait_s);
      waits += part;
    }
    std::printf("waited: %s\n", waits.c_str());
    if (report.live) {
      std::printf("live: %llu frames delivered, %llu dropped\n",
                  static_cast<unsigned long long>(report.live->frames_received),
                  static_cast<unsigned long long>(report.live->frames_dropped()));
    }
    std::printf("calibration updates: %d judged, latency median %.1f ms, p95 %.1f ms\n",
                update.count, update.median_ms, update.p95_ms);
    std::printf("peak memory (VmHWM): %.1f MB, of which rendered frames %.1f MB\n", peak_mb,
                frames_mb);
    if ((stream || looped) && rss_after_minute && !rss.empty()) {
      std::printf("resident size: %.1f MB after 1 min, %.1f MB at the end (%+.1f%%)\n",
                  *rss_after_minute, rss.back().second,
                  100.0 * (rss.back().second / *rss_after_minute - 1.0));
      // The frames held in memory dilute the growth; what the pipeline holds is the rest.
      if (frames_mb > 0.0) {
        const double own_before = *rss_after_minute - frames_mb;
        const double own_end = rss.back().second - frames_mb;
        std::printf("  without the rendered frames: %.1f MB -> %.1f MB (%+.1f%%)\n", own_before,
                    own_end, 100.0 * (own_end / own_before - 1.0));
      }
    }

    if (parser.isSet("json")) {
      std::string json = "{\n";
      json += "  \"scenario\": " + JsonString(parser.value("scenario").toStdString()) + ",\n";
      json += "  \"resolution\": " + JsonString(parser.value("resolution").toStdString()) + ",\n";
      json += "  \"frames\": " + std::to_string(report.frames) + ",\n";
      json += "  \"seconds\": " + JsonNumber(report.seconds) + ",\n";
      json += "  \"wall_seconds\": " + JsonNumber(report.wall_seconds) + ",\n";
      json += "  \"fps\": " + JsonNumber(report.fps) + ",\n";
      json += "  \"cores_busy\": " + JsonNumber(cores_busy) + ",\n";
      json += "  \"thread_cpu_s\": " + SecondsJson(report.thread_cpu_s) + ",\n";
      json += "  \"other_threads_cpu_s\": " + JsonNumber(other_cpu_s) + ",\n";
      json += "  \"thread_wait_s\": " + SecondsJson(report.thread_wait_s) + ",\n";
      json += "  \"judge_after_frames\": " + std::to_string(judge_after) + ",\n";
      json += "  \"settings\": {";
      for (size_t i = 0; i < changed.size(); ++i) {
        json += std::string(i ? ", " : "") + JsonString(changed[i].first) + ": " +
                JsonString(changed[i].second);
      }
      json += "},\n";
      json += "  \"live\": " + std::string(live ? "true" : "false") + ",\n";
      json += "  \"frames_dropped\": " +
              std::to_string(report.live ? report.live->frames_dropped() : 0) + ",\n";
      json += "  \"rendering_timed\": " + std::string(stream ? "true" : "false") + ",\n";
      json += "  \"loop_seconds\": " + (loop_seconds ? JsonNumber(*loop_seconds) : "null") + ",\n";
      json += "  \"timing_ms\": {";
      bool first = true;
      for (const auto& [box, stats] : report.timing) {
        if (box == "update_latency") continue;
        json += std::string(first ? "\n" : ",\n") + "    " + JsonString(box) + ": " +
                StatsJson(stats);
        first = false;
      }
      json += "\n  },\n";
      json += "  \"update_latency_ms\": " + StatsJson(update) + ",\n";
      json += "  \"peak_rss_mb\": " + JsonNumber(peak_mb) + ",\n";
      json += "  \"rendered_frames_mb\": " + JsonNumber(frames_mb) + ",\n";
      json += "  \"rss_mb\": [";
      for (size_t i = 0; i < rss.size(); ++i) {
        json += std::string(i ? ", " : "") + "{\"t\": " + JsonNumber(rss[i].first) +
                ", \"mb\": " + JsonNumber(rss[i].second) + "}";
      }
      json += "],\n";
      json += "  \"rss_after_first_minute_mb\": " +
              (rss_after_minute ? JsonNumber(*rss_after_minute) : std::string("null")) + ",\n";
      json += "  \"machine\": {\"cores\": " + std::to_string(std::thread::hardware_concurrency()) +
              ", \"cpu\": " + JsonString(CpuModel()) +
              ", \"load_average\": " + JsonNumber(LoadAverage()) + "}\n}\n";
      WriteTextFile(parser.value("json").toStdString(), json);
    }
    return 0;
  } catch (const Error& error) {
    std::fprintf(stderr, "autocal bench: %s\n", error.what());
    return 1;
  }
}

}  // namespace autocal::cli
