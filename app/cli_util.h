// What every subcommand of `autocal` shares: option parsing with its help and usage
// errors, and progress on stderr.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <optional>

#include <QCommandLineParser>
#include <QString>
#include <QStringList>

#include "devices/offline_runner.h"
#include "devices/sequence.h"
#include "pipeline/calibration_pipeline.h"

namespace autocal::cli {

// Parses `arguments` for subcommand `name`; prints help or the usage error itself.
// Returns an exit code when the command should stop here.
std::optional<int> Parse(QCommandLineParser& parser, const QString& name,
                         const QStringList& arguments);

// Prints `message` and the help; returns the bad-usage exit code, 2.
int UsageError(const QString& name, const QString& message, const QCommandLineParser& parser);

// The options --settings (a pipeline settings file) and --set (one option, repeatable).
void AddPipelineSettingsOptions(QCommandLineParser& parser);

// A --set that is not name=value, as a usage error's message.
std::optional<QString> MalformedSetting(const QCommandLineParser& parser);

// Pipeline options from `base`, then --settings, then each --set in order (all name=value:
// MalformedSetting), checked. Throws Error naming the file and line, or the option, at
// fault.
PipelineOptions PipelineOptionsFrom(const QCommandLineParser& parser,
                                    const PipelineOptions& base = {});

// --readout-ms (milliseconds in [0, kMaxReadoutMs]), for the subcommands that take it: none
// when not given; when it is not such a number, none and a usage error's message in `error`.
std::optional<double> ReadoutMsOption(const QCommandLineParser& parser, QString* error);

// On stderr, for subcommand `name`: the recording's rolling shutter undone, or a warning
// when `options` (the user's settings) measure it with another readout.
void ReportRollingShutter(const char* name, const SessionInfo& session,
                          const PipelineOptions& options);

// SIGINT or SIGTERM from now on sets `requested` (and `signal`) instead of ending the program,
// so that a long command stops cleanly with its files complete; a second one ends it as
// usual.
struct StopRequest {
  std::atomic<bool> requested{false};
  std::atomic<int> signal{0};
};
const StopRequest& CatchStopSignals();
// "SIGINT" or "SIGTERM".
const char* StopSignalName(int signal);

// Progress on stderr: one line rewritten in place on a terminal, a line per 10% elsewhere.
class ProgressPrinter {
 public:
  ProgressPrinter(const char* what, const char* unit);

  // `detail`, when not empty, is appended to the line.
  bool operator()(size_t done, size_t total, const QString& detail = {});
  double Elapsed() const;

 private:
  const char* what_;
  const char* unit_;
  bool tty_;
  int last_decile_ = -1;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace autocal::cli
