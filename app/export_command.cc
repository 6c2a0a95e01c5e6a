// `autocal export`: a stored calibration history, whole or as the calibration it ends with.
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include <QCommandLineParser>

#include "app/cli_commands.h"
#include "app/cli_util.h"
#include "pipeline/calibration_export.h"
#include "pipeline/calibration_io.h"
#include "pipeline/error.h"
#include "pipeline/history_replay.h"
#include "pipeline/history_store.h"

namespace autocal::cli {
namespace {

std::string Joined(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& name : names) text += (text.empty() ? "" : ", ") + name;
  return text;
}

}  // namespace

int Export(const QStringList& arguments) {
  const QString name = "export";
  QCommandLineParser parser;
  parser.setApplicationDescription(
      "Exports a calibration history (the SQLite file `autocal run --history` writes):\n"
      "every attempt with its verdict and reason (--format " +
      QString::fromStdString(Joined(HistoryFormatNames())) +
      "), or, with --calibration, the filtered calibration at the end of the history or at\n"
      "--at seconds, the one the run started from while it holds no attempt (--format " +
      QString::fromStdString(Joined(CalibrationFormatNames())) + ").");
  parser.addOptions({
      {"history", "History file to read.", "file.sqlite"},
      {"out", "File to write (replaced).", "file"},
      {"format", "Output format (see above).", "name"},
      {"calibration", "Export the filtered calibration instead of the attempts."},
      {"at", "With --calibration: the time, seconds on the recording's clock.", "s"},
  });
  if (const auto code = Parse(parser, name, arguments)) return *code;
  for (const char* required : {"history", "out", "format"}) {
    if (!parser.isSet(required)) {
      return UsageError(name, QString("--%1 is required").arg(required), parser);
    }
  }
  if (parser.isSet("at") && !parser.isSet("calibration")) {
    return UsageError(name, "--at goes with --calibration", parser);
  }
  // A format only of the other kind (json is both) is most likely a forgotten or stray
  // --calibration: say which, rather than only that the name is unknown.
  const std::string format = parser.value("format").toStdString();
  const bool calibration = parser.isSet("calibration");
  const auto listed = [&format](const std::vector<std::string>& names) {
    return std::find(names.begin(), names.end(), format) != names.end();
  };
  if (!listed(calibration ? CalibrationFormatNames() : HistoryFormatNames()) &&
      listed(calibration ? HistoryFormatNames() : CalibrationFormatNames())) {
    return UsageError(name,
                      QString("%1 is a %2 format: it goes %3 --calibration")
                          .arg(parser.value("format"), calibration ? "history" : "calibration",
                               calibration ? "without" : "with"),
                      parser);
  }
  double at_s = 0.0;
  if (parser.isSet("at")) {
    bool ok = false;
    at_s = parser.value("at").toDouble(&ok);
    if (!ok) return UsageError(name, "--at takes seconds, got " + parser.value("at"), parser);
  }

  try {
    const std::string out = parser.value("out").toStdString();
    const StoredHistory stored =
        HistoryStore(parser.value("history").toStdString(), HistoryStore::Mode::kOpenExisting)
            .Load();
    if (!calibration) {
      const HistoryFormat history_format = HistoryFormatFromName(format);
      std::vector<HistoryEntry> entries;
      for (const AttemptRecord& record : stored.attempts) entries.push_back(ToHistoryEntry(record));
      WriteHistory(out, entries, history_format);
      std::printf("wrote %zu attempts to %s\n", entries.size(), out.c_str());
      return 0;
    }
    const CalibrationFormat calibration_format = CalibrationFormatFromName(format);
    if (stored.premission.width == 0) {
      throw Error(parser.value("history").toStdString(), 0,
                  "holds no start (its run stopped before writing the calibration it started "
                  "from): there is no calibration to export");
    }
    const int64_t t_ns = parser.isSet("at")        ? static_cast<int64_t>(at_s * 1e9)
                         : stored.attempts.empty() ? 0
                                                   : stored.attempts.back().t_ns;
    const FilteredCalibration filtered = ReplayHistory(stored).Current(t_ns);
    WriteCalibration(out, filtered.calibration, calibration_format);
    if (stored.attempts.empty()) {
      // Before the first attempt the calibration in effect is the one the run started
      // from: what `autocal run --export` writes for a run stopped that early.
      std::printf(
          "wrote the calibration the run started from (the history holds no attempt) "
          "to %s\n",
          out.c_str());
    } else {
      std::printf("wrote the calibration at %.3f s (regime %d, trend over %d attempts) to %s\n",
                  1e-9 * double(t_ns), filtered.regime, filtered.points, out.c_str());
    }
    return 0;
  } catch (const Error& error) {
    std::fprintf(stderr, "autocal %s: %s\n", qPrintable(name), error.what());
    return 1;
  }
}

}  // namespace autocal::cli
