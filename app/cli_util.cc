#include "app/cli_util.h"

#include <unistd.h>

#include <csignal>
#include <cstdio>

#include "pipeline/error.h"
#include "pipeline/option_fields.h"
#include "pipeline/self_calibration.h"

namespace autocal::cli {

namespace {

StopRequest g_stop;

void RequestStop(int signal) {
  g_stop.signal = signal;
  g_stop.requested = true;
  std::signal(signal, SIG_DFL);
}

}  // namespace

const StopRequest& CatchStopSignals() {
  static_assert(std::atomic<bool>::is_always_lock_free && std::atomic<int>::is_always_lock_free,
                "set from a signal handler");
  std::signal(SIGINT, RequestStop);
  std::signal(SIGTERM, RequestStop);
  return g_stop;
}

const char* StopSignalName(int signal) { return signal == SIGTERM ? "SIGTERM" : "SIGINT"; }

std::optional<int> Parse(QCommandLineParser& parser, const QString& name,
                         const QStringList& arguments) {
  parser.addHelpOption();
  if (!parser.parse(QStringList{"autocal " + name} + arguments)) {
    std::fprintf(stderr, "autocal %s: %s\n\n%s", qPrintable(name), qPrintable(parser.errorText()),
                 qPrintable(parser.helpText()));
    return 2;
  }
  if (parser.isSet("help")) {
    std::printf("%s", qPrintable(parser.helpText()));
    return 0;
  }
  return std::nullopt;
}

int UsageError(const QString& name, const QString& message, const QCommandLineParser& parser) {
  std::fprintf(stderr, "autocal %s: %s\n\n%s", qPrintable(name), qPrintable(message),
               qPrintable(parser.helpText()));
  return 2;
}

void AddPipelineSettingsOptions(QCommandLineParser& parser) {
  parser.addOptions({
      {"settings", "Pipeline settings file (name = value lines; see autocal run --print-settings).",
       "file"},
      {"set",
       "One pipeline option, e.g. --set material.window_s=3 (repeatable; after --settings).",
       "name=value"},
  });
}

std::optional<QString> MalformedSetting(const QCommandLineParser& parser) {
  for (const QString& assignment : parser.values("set")) {
    if (assignment.indexOf('=') <= 0) return "--set takes name=value, got " + assignment;
  }
  return std::nullopt;
}

PipelineOptions PipelineOptionsFrom(const QCommandLineParser& parser, const PipelineOptions& base) {
  PipelineOptions options = base;
  if (parser.isSet("settings")) {
    options = ReadPipelineSettings(parser.value("settings").toStdString(), base);
  }
  for (const QString& assignment : parser.values("set")) {
    const qsizetype equals = assignment.indexOf('=');
    SetPipelineOption(&options, assignment.left(equals).toStdString(),
                      assignment.mid(equals + 1).toStdString());
  }
  std::string why;
  if (!options.Check(&why)) throw Error("pipeline options: " + why);
  return options;
}

std::optional<double> ReadoutMsOption(const QCommandLineParser& parser, QString* error) {
  if (!parser.isSet("readout-ms")) return std::nullopt;
  bool ok = false;
  const double ms = parser.value("readout-ms").toDouble(&ok);
  if (ok && IsReadoutMs(ms)) return ms;
  *error = QStringLiteral("--readout-ms takes milliseconds in [0, %1]").arg(kMaxReadoutMs);
  return std::nullopt;
}

void ReportRollingShutter(const char* name, const SessionInfo& session,
                          const PipelineOptions& options) {
  const double stated = session.readout_ms, used = options.calibration.readout_ms;
  if (stated > 0 && used == stated) {
    std::fprintf(stderr,
                 "autocal %s: the recording's camera has a rolling shutter (rows read over %g "
                 "ms): undone (calibration.readout_ms=%g)\n",
                 name, stated, stated);
  } else if (stated > 0) {
    std::fprintf(stderr,
                 "autocal %s: warning: the recording's camera has a rolling shutter (rows read "
                 "over %g ms), but calibration.readout_ms is set to %g\n",
                 name, stated, used);
  }
}

ProgressPrinter::ProgressPrinter(const char* what, const char* unit)
    : what_(what),
      unit_(unit),
      tty_(isatty(STDERR_FILENO)),
      start_(std::chrono::steady_clock::now()) {}

bool ProgressPrinter::operator()(size_t done, size_t total, const QString& detail) {
  const int percent = total ? static_cast<int>(100 * done / total) : 100;
  if (!tty_ && percent / 10 == last_decile_ && done != total) return true;
  last_decile_ = percent / 10;
  const double elapsed = Elapsed();
  const double left = done ? elapsed * double(total - done) / double(done) : 0.0;
  std::fprintf(stderr, "%s%s: %zu/%zu %s (%d%%), %.1f s elapsed, ~%.0f s left%s%s%s",
               tty_ ? "\r" : "", what_, done, total, unit_, percent, elapsed, left,
               detail.isEmpty() ? "" : "; ", qPrintable(detail), tty_ ? "   " : "\n");
  if (tty_ && done == total) std::fprintf(stderr, "\n");
  return true;
}

double ProgressPrinter::Elapsed() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

}  // namespace autocal::cli
