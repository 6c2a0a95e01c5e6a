#include "app/cli_commands.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <optional>
#include <string>

#include <QCommandLineParser>

#include "devices/inspect.h"
#include "devices/recording_writer.h"
#include "devices/sequence.h"
#include "devices/sim/simulator.h"
#include "pipeline/error.h"

namespace autocal::cli {
namespace {

// Parses `arguments` for subcommand `name`; prints help or the usage error itself.
// Returns an exit code when the command should stop here.
std::optional<int> Parse(QCommandLineParser& parser, const QString& name,
                         const QStringList& arguments) {
  parser.addHelpOption();
  if (!parser.parse(QStringList{"autocal " + name} + arguments)) {
    std::fprintf(stderr, "autocal %s: %s\n\n%s", qPrintable(name),
                 qPrintable(parser.errorText()), qPrintable(parser.helpText()));
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

// Progress on stderr: one line rewritten in place on a terminal, a line per 10% elsewhere.
class ProgressPrinter {
 public:
  explicit ProgressPrinter(const char* what)
      : what_(what), tty_(isatty(STDERR_FILENO)), start_(std::chrono::steady_clock::now()) {}

  bool operator()(size_t done, size_t total) {
    const int percent = total ? static_cast<int>(100 * done / total) : 100;
    if (!tty_ && percent / 10 == last_decile_ && done != total) return true;
    last_decile_ = percent / 10;
    const double elapsed = Elapsed();
    const double left = done ? elapsed * double(total - done) / double(done) : 0.0;
    std::fprintf(stderr, "%s%s: %zu/%zu frames (%d%%), %.1f s elapsed, ~%.0f s left%s", tty_ ? "\r" : "",
                 what_, done, total, percent, elapsed, left, tty_ ? "   " : "\n");
    if (tty_ && done == total) std::fprintf(stderr, "\n");
    return true;
  }

  double Elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  const char* what_;
  bool tty_;
  int last_decile_ = -1;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace

int Simulate(const QStringList& arguments) {
  const QString name = "simulate";
  QCommandLineParser parser;
  parser.setApplicationDescription(
      "Writes a simulated recording (frames, accelerometer, ground truth) from a scenario:\n"
      "a built-in one (see --list) or a scenario YAML file.");
  parser.addOptions({
      {"scenario", "Built-in scenario name or YAML file (default office).", "name|file", "office"},
      {"out", "Recording folder to create (must not exist or be empty).", "dir"},
      {"lens", "Lens: tessar or sonnar.", "lens"},
      {"seconds", "Duration in seconds.", "s"},
      {"resolution", "Frame size, e.g. 640x480.", "WxH"},
      {"fps", "Frame rate.", "hz"},
      {"seed", "Random seed (textures, noise).", "n"},
      {"accel-rate", "Accelerometer rate in Hz (up to 1600).", "hz"},
      {"set", "Any other scenario field, e.g. --set noise_sigma=3 (repeatable).", "key=value"},
      {"list", "List the built-in scenarios and exit."},
  });
  if (const auto code = Parse(parser, name, arguments)) return *code;

  try {
    if (parser.isSet("list")) {
      for (const std::string& scenario_name : BuiltInScenarioNames()) {
        const Scenario scenario = LoadScenario(scenario_name);
        std::printf("%-10s %s\n", scenario_name.c_str(), scenario.description.c_str());
      }
      return 0;
    }
    if (!parser.isSet("out")) return UsageError(name, "--out is required", parser);
    Scenario scenario = LoadScenario(parser.value("scenario").toStdString());
    for (const char* key : {"lens", "seconds", "resolution", "fps", "seed"}) {
      if (parser.isSet(key)) {
        ApplyScenarioOverride(&scenario, key, parser.value(key).toStdString());
      }
    }
    if (parser.isSet("accel-rate")) {
      ApplyScenarioOverride(&scenario, "accel_rate", parser.value("accel-rate").toStdString());
    }
    for (const QString& assignment : parser.values("set")) {
      const int equals = assignment.indexOf('=');
      if (equals <= 0) return UsageError(name, "--set takes key=value, got " + assignment, parser);
      ApplyScenarioOverride(&scenario, assignment.left(equals).toStdString(),
                            assignment.mid(equals + 1).toStdString());
    }
    std::string why;
    if (!scenario.Check(&why)) throw Error("scenario " + scenario.name + ": " + why);

    const std::string out = parser.value("out").toStdString();
    const std::unique_ptr<Sequence> sequence = MakeSimulatedSequence(scenario);
    ProgressPrinter progress("simulate");
    WriteSequence(*sequence, out, std::ref(progress));
    std::printf("wrote %zu frames (%dx%d) and %zu accelerometer samples to %s in %.1f s\n",
                sequence->frame_count(), sequence->session().width, sequence->session().height,
                sequence->accel().size(), out.c_str(), progress.Elapsed());
    return 0;
  } catch (const Error& error) {
    std::fprintf(stderr, "autocal %s: %s\n", qPrintable(name), error.what());
    return 1;
  }
}

int Info(const QStringList& arguments) {
  const QString name = "info";
  QCommandLineParser parser;
  parser.setApplicationDescription(
      "Validates a recording and reports frame and accelerometer counts, rates, gaps and\n"
      "their time overlap. Reads native recordings, EuRoC and TUM RGB-D folders, a video\n"
      "with an accelerometer CSV beside it, and sim:SCENARIO. Exits 1 when the recording\n"
      "has errors.");
  parser.addPositionalArgument("recording", "Recording folder, video file or sim:SPEC.");
  parser.addOptions({
      {"json", "Print the report as JSON."},
      {"truncate-at-fault", "Read up to the first fault instead of refusing the recording."},
  });
  if (const auto code = Parse(parser, name, arguments)) return *code;
  if (parser.positionalArguments().size() != 1) {
    return UsageError(name, "expected one recording", parser);
  }
  try {
    ReadOptions options;
    options.truncate_at_fault = parser.isSet("truncate-at-fault");
    const auto sequence = OpenSequence(parser.positionalArguments().front().toStdString(), options);
    const SequenceReport report = InspectSequence(*sequence);
    std::printf("%s", (parser.isSet("json") ? ReportToJson(report) : FormatReport(report)).c_str());
    return HasErrors(report) ? 1 : 0;
  } catch (const Error& error) {
    std::fprintf(stderr, "autocal %s: %s\n", qPrintable(name), error.what());
    return 1;
  }
}

}  // namespace autocal::cli
