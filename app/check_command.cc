// `autocal check`: the vest check headless (docs/vest_check.md). What to do next goes to
// stderr as it changes; the verdict, the table and the reasons to stdout. The PDF report
// comes from the workbench's dialog (it needs Qt's GUI module, which this tool does not load).
#include <cstdio>
#include <optional>
#include <string>

#include <QCommandLineParser>

#include "app/cli_commands.h"
#include "app/cli_util.h"
#include "devices/vest_check_run.h"
#include "pipeline/calibration_io.h"
#include "pipeline/error.h"

namespace autocal::cli {
namespace {

// Exit codes beyond the shared ones (0 pass, 1 failure to run, 2 bad usage).
constexpr int kExitFail = 3;
constexpr int kExitInconclusive = 4;

void PrintResult(const VestCheckResult& result) {
  std::printf("%s\n", VestVerdictName(result.verdict).c_str());
  std::printf(
      "%.1f s walked, %d frames; calibration updates: %d attempted, %d accepted in the "
      "current regime\n",
      result.seconds, result.frames, result.attempts, result.accepted_in_regime);
  if (result.readout_ms > 0) {
    std::printf("measured with a rolling shutter, rows read over %.1f ms\n", result.readout_ms);
  } else {
    std::printf("measured with a global shutter (readout 0 ms)\n");
  }
  if (!result.criteria.empty()) {
    std::printf("%-11s %12s %12s %11s %10s  %s\n", "parameter", "pre-mission", "measured",
                "difference", "tolerance", "verdict");
    for (const VestCriterion& c : result.criteria) {
      if (c.parameter == "distortion") {
        std::printf("%-11s %12s %12s %8.2f %-2s %7.2f %-2s  %s\n", c.parameter.c_str(), "", "",
                    c.difference, c.unit.c_str(), c.tolerance, c.unit.c_str(),
                    c.pass ? "pass" : "FAIL");
      } else {
        std::printf("%-11s %12.2f %12.2f %+8.2f %-2s %7.2f %-2s  %s\n", c.parameter.c_str(),
                    c.premission, c.measured, c.difference, c.unit.c_str(), c.tolerance,
                    c.unit.c_str(), c.pass ? "pass" : "FAIL");
      }
    }
  }
  for (const std::string& reason : result.reasons) std::printf("  %s\n", reason.c_str());
  for (const VestNeedStatus& s : result.coverage) {
    std::printf("%-7s %s: %s%s\n", s.done ? "done" : "missing", s.name.c_str(), s.measured.c_str(),
                s.required ? "" : " (helps, not needed)");
  }
  for (const std::string& alarm : result.alarms) std::printf("alarm at %s\n", alarm.c_str());
}

}  // namespace

int Check(const QStringList& arguments) {
  const QString name = "check";
  const VestCheckOptions defaults;
  QCommandLineParser parser;
  parser.setApplicationDescription(
      "The vest check: walk with the vest for a minute while the pipeline calibrates the\n"
      "camera, then compare with the pre-mission calibration. Prints what to do next while\n"
      "the walk lasts, then PASS, FAIL or INCONCLUSIVE with the reasons. Ctrl-C ends the\n"
      "walk early: the verdict is then on what was seen, and the exit code is 130.\n"
      "Exit codes: 0 pass, 3 fail, 4 inconclusive, 1 the check could not run, 2 bad usage.");
  parser.addOptions({
      {"input", "camera:N for the vest's camera, sim:SCENARIO, or a recording.", "source"},
      {"accel", "usb for the vest's USB accelerometer; default: the source's own.", "spec"},
      {"prior", "The pre-mission calibration (any format `autocal` writes); default: the source's.",
       "file"},
      {"seconds", "How long to walk.", "s", QString::number(defaults.duration_s)},
      {"readout-ms",
       "The camera's rolling-shutter readout (ms; 0: a global shutter; `autocal readout` "
       "measures it). Default: what the source states (a live camera states none).",
       "ms"},
      {"focal-tolerance", "Largest difference of fx, fy that passes, percent.", "percent",
       QString::number(defaults.tolerance.focal_percent)},
      {"principal-tolerance", "Largest difference of cx, cy that passes, pixels.", "px",
       QString::number(defaults.tolerance.principal_px)},
      {"distortion-tolerance",
       "Largest displacement between the two lenses' distortion (to 90% of the half-diagonal).",
       "px", QString::number(defaults.tolerance.distortion_px)},
  });
  if (const auto code = Parse(parser, name, arguments)) return *code;
  if (!parser.isSet("input")) return UsageError(name, "--input is required", parser);
  VestCheckOptions options;
  const auto number = [&](const char* option, double* value) {
    bool ok = false;
    *value = parser.value(option).toDouble(&ok);
    return ok;
  };
  if (!number("seconds", &options.duration_s) ||
      !number("focal-tolerance", &options.tolerance.focal_percent) ||
      !number("principal-tolerance", &options.tolerance.principal_px) ||
      !number("distortion-tolerance", &options.tolerance.distortion_px)) {
    return UsageError(name, "--seconds and the tolerances take numbers", parser);
  }
  std::string why;
  if (!options.Check(&why)) return UsageError(name, QString::fromStdString(why), parser);
  QString bad_readout;
  const std::optional<double> readout_ms = ReadoutMsOption(parser, &bad_readout);
  if (!bad_readout.isEmpty()) return UsageError(name, bad_readout, parser);

  try {
    std::optional<CameraIntrinsics> premission;
    if (parser.isSet("prior")) premission = ReadCalibration(parser.value("prior").toStdString());
    VestCheckHooks hooks;
    hooks.connected = [](const std::string& description, const std::string& devices) {
      std::fprintf(stderr, "checking %s (%s)\n", description.c_str(), devices.c_str());
    };
    std::string shown;
    hooks.checked = [&](const VestCheck& check) {
      const std::string guidance = check.Guidance();
      if (guidance == shown) return;
      shown = guidance;
      std::fprintf(stderr, "%5.1f s  %3.0f%%  %s\n", check.elapsed_s(), 100 * check.Progress(),
                   guidance.c_str());
    };
    const StopRequest& stop = CatchStopSignals();
    const VestCheckResult result =
        RunVestCheck(parser.value("input").toStdString(), parser.value("accel").toStdString(),
                     premission, readout_ms, options, stop.requested, hooks);
    PrintResult(result);
    if (stop.requested) {
      // A script must not take a walk cut short for the one the procedure asks.
      std::fprintf(stderr,
                   "autocal check: stopped by %s after %.1f s of the %.0f s walk; the verdict "
                   "is on what was seen\n",
                   StopSignalName(stop.signal), result.seconds, options.duration_s);
      return 128 + stop.signal;
    }
    return result.verdict == VestVerdict::kPass   ? 0
           : result.verdict == VestVerdict::kFail ? kExitFail
                                                  : kExitInconclusive;
  } catch (const Error& error) {
    std::fprintf(stderr, "autocal check: %s\n", error.what());
    return 1;
  }
}

}  // namespace autocal::cli
