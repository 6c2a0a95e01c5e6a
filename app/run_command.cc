// `autocal run`: a recording or a live source through boxes 1-10, headless.
#include <unistd.h>

#include <cstdio>
#include <memory>
#include <string>

#include <QCommandLineParser>

#include "app/cli_commands.h"
#include "app/cli_util.h"
#include "devices/offline_runner.h"
#include "devices/sequence.h"
#include "devices/source.h"
#include "devices/still_shot_run.h"
#include "pipeline/calibration_io.h"
#include "pipeline/error.h"
#include "pipeline/option_fields.h"

namespace autocal::cli {
namespace {

void PrintCalibration(const char* label, const CameraIntrinsics& c) {
  std::printf("%-8s fx %.2f fy %.2f cx %.2f cy %.2f k1 %.5f k2 %.5f p1 %.6f p2 %.6f k3 %.5f\n",
              label, c.fx, c.fy, c.cx, c.cy, c.k1, c.k2, c.p1, c.p2, c.k3);
}

void PrintError(const char* label, const CalibrationError& e) {
  std::printf("%-26s fx %+.3f%% fy %+.3f%% cx %+.2f px cy %+.2f px distortion %.3f px\n", label,
              e.fx_percent, e.fy_percent, e.cx_px, e.cy_px, e.distortion_px);
}

// `stills`: the report is of `run --stills`, whose frames are all read before any work.
void PrintReport(const RunReport& report, bool stills) {
  const auto count = [&](Verdict v) {
    const auto found = report.verdicts.find(v);
    return found == report.verdicts.end() ? 0 : found->second;
  };
  std::printf("%zu frames (%.1f s of recording) in %.1f s: %.1f frames/s\n", report.frames,
              report.seconds, report.wall_seconds, report.fps);
  if (report.stopped && stills) {
    std::printf("stopped after %d attempts, before the rest were made\n", report.attempts);
  } else if (report.stopped) {
    std::printf("stopped after %zu of the input's %zu frames\n", report.frames,
                report.frames_in_input);
  }
  PrintCalibration("prior", report.prior);
  PrintCalibration("final", report.final.calibration);
  std::printf("attempts %d: accepted %d, rejected %d, no update %d, alarm %d, new regime %d\n",
              report.attempts, count(Verdict::kAccepted), count(Verdict::kRejected),
              count(Verdict::kNoUpdate), count(Verdict::kAlarm), count(Verdict::kNewRegime));
  for (const RunReport::CauseCount& cause : report.no_update_causes) {
    std::printf("  %d x %s\n", cause.count, cause.latest.c_str());
  }
  for (const Alarm& alarm : report.alarms) {
    std::printf("alarm at %.2f s: %s\n", 1e-9 * double(alarm.t_ns), alarm.description.c_str());
  }
  if (report.live) {
    const LiveRunReport& live = *report.live;
    std::printf(
        "live: %llu frames received, %llu dropped (%llu by the pipeline, %llu by the source), "
        "%llu accelerometer samples dropped; ended by %s\n",
        static_cast<unsigned long long>(live.frames_received),
        static_cast<unsigned long long>(live.frames_dropped()),
        static_cast<unsigned long long>(live.pipeline_dropped),
        static_cast<unsigned long long>(live.source_dropped),
        static_cast<unsigned long long>(live.accel_dropped), live.ended_by.c_str());
    for (const TimeGap& gap : live.camera_gaps) {
      std::printf("camera gap: %.3f s without frames\n", gap.seconds());
    }
    if (live.camera_disconnections > 0 || live.accel_disconnections > 0) {
      std::printf("disconnections: camera %d, accelerometer %d\n", live.camera_disconnections,
                  live.accel_disconnections);
    }
  }
  if (report.truth) {
    PrintError("error against the truth:", report.truth->final);
    if (report.truth->converged_at_s) {
      std::printf("within tolerance from %.2f s\n", *report.truth->converged_at_s);
      PrintError("worst after that:", *report.truth->worst_after_convergence);
    } else {
      std::printf("never within tolerance\n");
    }
  }
}

// One line a second while a live source runs (rewritten in place on a terminal).
void PrintLiveProgress(const RunProgress& p, bool tty) {
  std::fprintf(stderr, "%srun: %.1f s, %zu frames done of %zu received, %llu dropped",
               tty ? "\r\033[K" : "", p.wall_seconds, p.frame, p.frames,
               static_cast<unsigned long long>(p.frames_dropped));
  if (p.source) {
    std::fprintf(stderr, " (camera %.1f Hz, accelerometer %.0f Hz)", p.source->camera_rate_hz,
                 p.source->accel_rate_hz);
  }
  if (p.snapshot) {
    const CameraIntrinsics& c = p.snapshot->calibration.calibration;
    std::fprintf(stderr, "; fx %.1f cx %.1f cy %.1f, regime %d", c.fx, c.cx, c.cy,
                 p.snapshot->calibration.regime);
  }
  std::fprintf(stderr, tty ? "" : "\n");
}

// Starts the live source and runs it until it ends, --seconds pass or SIGINT/SIGTERM.
RunReport RunLive(FrameSource& source, const RunSettings& settings, double seconds) {
  const bool tty = isatty(STDERR_FILENO);
  LiveRunControl control;
  control.seconds = seconds;
  control.stop = &CatchStopSignals().requested;
  control.progress = [tty](const RunProgress& p) { PrintLiveProgress(p, tty); };
  control.on_event = [tty](const SourceEvent& event) {
    std::fprintf(stderr, "%srun: %s\n", tty ? "\r\033[K" : "", FormatSourceEvent(event).c_str());
  };
  RunReport report = RunSource(source, settings, control);
  if (tty) std::fprintf(stderr, "\n");
  return report;
}

}  // namespace

int Run(const QStringList& arguments) {
  const QString name = "run";
  QCommandLineParser parser;
  parser.setApplicationDescription(
      "Runs a recording through the whole pipeline (lines, distortion, tracks, planes,\n"
      "accelerometer, self-calibration, history) headless, as fast as the machine allows,\n"
      "or a live source (camera:N with --accel usb, or a recording played with --live) as it\n"
      "comes, dropping the frames the pipeline cannot take, until it ends, --seconds pass or\n"
      "Ctrl-C. Every calibration attempt and its verdict goes to the history; the output is\n"
      "the filtered calibration. Ctrl-C on a recording stops the run early: the history,\n"
      "summary and export are written for the frames done, and the exit code is 130.");
  parser.addOptions({
      {"input",
       "Native recording, EuRoC or TUM folder, video with accelerometer CSV, image folder, "
       "sim:SCENARIO, or a live camera: camera:N, camera:/dev/videoN (with ,size=WxH ,fps=F "
       ",format=MJPG).",
       "source"},
      {"accel",
       "Accelerometer: usb, usb:VID:PID, usb:mapping=FILE (with a camera), a CSV file, or none "
       "(default: the input's own).",
       "spec"},
      {"live",
       "Play a recorded input in real time as a live source: frames the pipeline cannot take "
       "are dropped and counted."},
      {"speed", "With --live: recording seconds played per second (default 1).", "x", "1"},
      {"seconds", "Live: stop after this many wall-clock seconds (default: at the end or Ctrl-C).",
       "s"},
      {"prior",
       "Calibration to start from (any format `autocal` writes); default: the recording's "
       "pre-mission calibration.",
       "file"},
      {"history", "SQLite history file to append every attempt to.", "file.sqlite"},
      {"summary", "Write the run's summary as JSON here.", "file.json"},
      {"export", "Write the final calibration here (with --format).", "file"},
      {"format",
       "Format of --export: " + QString::fromStdString([] {
         std::string names;
         for (const std::string& n : CalibrationFormatNames())
           names += (names.empty() ? "" : ", ") + n;
         return names;
       }()) +
           ".",
       "name"},
      {"accel-offset", "Seconds added to accelerometer timestamps (default 0).", "s", "0"},
      {"print-settings",
       "Print every pipeline option with its value and meaning, and exit (with --input: as a "
       "run on it would take them)."},
      {"truncate-at-fault", "Keep a recording up to its first fault instead of refusing it."},
      {"stills",
       "The input's frames are still shots of one scene from different viewpoints (an image "
       "folder of photographs, at least 3): calibrated together from the planes their "
       "keypoints share, not as a video. Without --prior, from a 75 degree field of view."},
  });
  AddPipelineSettingsOptions(parser);
  if (const auto code = Parse(parser, name, arguments)) return *code;
  if (const auto malformed = MalformedSetting(parser)) return UsageError(name, *malformed, parser);
  if (!parser.isSet("input") && !parser.isSet("print-settings")) {
    return UsageError(name, "--input is required", parser);
  }
  if (parser.isSet("export") != parser.isSet("format")) {
    return UsageError(name, "--export and --format go together", parser);
  }
  double seconds = 0.0;
  if (parser.isSet("seconds")) {
    bool ok = false;
    seconds = parser.value("seconds").toDouble(&ok);
    if (!ok || !(seconds > 0)) return UsageError(name, "--seconds takes a positive number", parser);
  }
  const std::string input = parser.value("input").toStdString();
  // Through the source interface: live inputs, and recordings with another accelerometer.
  const bool as_source =
      parser.isSet("live") || parser.isSet("accel") || input.starts_with("camera:");
  const bool stills = parser.isSet("stills");
  if (stills && (as_source || parser.isSet("seconds"))) {
    return UsageError(name, "--stills goes with a recording or an image folder (not a camera, --live, --accel)",
                      parser);
  }
  if (as_source && parser.isSet("truncate-at-fault")) {
    return UsageError(name, "--truncate-at-fault goes with a recording alone (no --live, --accel)",
                      parser);
  }
  bool offset_ok = false;
  RunSettings settings;
  settings.accel_time_offset_s = parser.value("accel-offset").toDouble(&offset_ok);
  if (!offset_ok) {
    return UsageError(name, "--accel-offset takes seconds, got " + parser.value("accel-offset"),
                      parser);
  }

  try {
    settings.pipeline = PipelineOptionsFrom(parser);
    if (parser.isSet("print-settings") && !parser.isSet("input")) {
      std::printf("%s", PipelineSettingsText(settings.pipeline).c_str());
      return 0;
    }
    std::optional<CalibrationFormat> export_format;
    if (parser.isSet("format")) {
      export_format = CalibrationFormatFromName(parser.value("format").toStdString());
    }
    if (parser.isSet("prior"))
      settings.prior = ReadCalibration(parser.value("prior").toStdString());
    settings.history_path = parser.value("history").toStdString();
    std::unique_ptr<FrameSource> source;
    std::unique_ptr<Sequence> opened;
    const Sequence* sequence = nullptr;
    if (stills) {
      // Through the source interface, which reads a plain image folder too.
      source = OpenSource(input, "", SourceOptions());
      sequence = source->sequence();
      const SessionInfo& session = sequence->session();
      if (!settings.prior && !session.premission_calibration) {
        settings.prior = CameraIntrinsics::FromFieldOfView(session.width, session.height, 75.0);
        std::fprintf(stderr, "autocal run: no --prior: starting from a 75 degree field of view\n");
      }
    } else if (as_source) {
      SourceOptions source_options;
      source_options.real_time = parser.isSet("live");
      bool speed_ok = false;
      source_options.real_time_speed = parser.value("speed").toDouble(&speed_ok);
      if (!speed_ok || (parser.isSet("speed") && !parser.isSet("live"))) {
        return UsageError(name, "--speed takes a number and goes with --live", parser);
      }
      source = OpenSource(input, parser.value("accel").toStdString(), source_options);
      sequence = source->live() ? nullptr : source->sequence();
    } else {
      ReadOptions read_options;
      read_options.truncate_at_fault = parser.isSet("truncate-at-fault");
      opened = OpenSequence(input, read_options);
      sequence = opened.get();
    }
    if (sequence && parser.isSet("seconds")) {
      return UsageError(name, "--seconds goes with a live source (camera:N, or --live)", parser);
    }
    // A recording, played or not, states its camera: the settings start from that.
    if (const Sequence* recording = sequence ? sequence : source->sequence()) {
      settings.pipeline = PipelineOptionsFrom(parser, RecordingDefaults(recording->session()));
      ReportRollingShutter("run", recording->session(), settings.pipeline);
    }
    if (parser.isSet("print-settings")) {
      std::printf("%s", PipelineSettingsText(settings.pipeline).c_str());
      return 0;
    }
    if (sequence) {
      for (const std::string& warning : sequence->warnings()) {
        std::fprintf(stderr, "autocal run: warning: %s\n", warning.c_str());
      }
    } else if (!parser.isSet("seconds") && !source->sequence()) {
      std::fprintf(stderr, "autocal run: running until Ctrl-C (--seconds N stops earlier)\n");
    }

    RunReport report;
    const StopRequest* stop = nullptr;  // Offline runs stop early on SIGINT or SIGTERM.
    if (stills) {
      stop = &CatchStopSignals();
      report = RunStillShots(
          *sequence, settings,
          [](const std::string& step) { std::fprintf(stderr, "run: %s\n", step.c_str()); },
          &stop->requested);
    } else if (sequence) {
      ProgressPrinter printer("run", "frames");
      const auto show = [&](const RunProgress& progress) {
        const CameraIntrinsics& c = progress.snapshot->calibration.calibration;
        printer(progress.frame, progress.frames,
                QString("fx %1 cx %2 cy %3, regime %4")
                    .arg(c.fx, 0, 'f', 1)
                    .arg(c.cx, 0, 'f', 1)
                    .arg(c.cy, 0, 'f', 1)
                    .arg(progress.snapshot->calibration.regime));
      };
      stop = &CatchStopSignals();
      report = RunSequence(*sequence, settings, show, &stop->requested);
    } else {
      report = RunLive(*source, settings, seconds);
    }
    PrintReport(report, stills);
    if (parser.isSet("summary")) WriteSummary(parser.value("summary").toStdString(), report);
    if (export_format) {
      WriteCalibration(parser.value("export").toStdString(), report.final.calibration,
                       *export_format);
    }
    if (report.stopped) {
      // The files are whole, but of part of the input: a script must not take them for all.
      const std::string done =
          stills ? std::to_string(report.attempts) + " attempts"
                 : std::to_string(report.frames) + " of " +
                       std::to_string(report.frames_in_input) + " frames";
      std::fprintf(stderr,
                   "autocal run: stopped by %s after %s; the history, summary and export hold "
                   "those\n",
                   StopSignalName(stop->signal), done.c_str());
      return 128 + stop->signal;
    }
    return 0;
  } catch (const Error& error) {
    std::fprintf(stderr, "autocal run: %s\n", error.what());
    return 1;
  }
}

}  // namespace autocal::cli
