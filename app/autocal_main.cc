// autocal: the headless command-line tool. Parses the subcommand and hands over.
#include <cstdio>
#include <exception>
#include <functional>
#include <map>

#include <QCoreApplication>
#include <QStringList>

#include "app/cli_commands.h"
#include "pipeline/self_calibration.h"
#include "pipeline/version.h"

namespace {

struct Subcommand {
  std::function<int(const QStringList&)> run;
  const char* summary;
};

const std::map<QString, Subcommand>& Subcommands() {
  static const std::map<QString, Subcommand> kSubcommands = {
      {"simulate", {autocal::cli::Simulate, "write a simulated recording from a scenario"}},
      {"info", {autocal::cli::Info, "validate a recording and report its contents"}},
      {"run",
       {autocal::cli::Run, "calibrate from a recording: boxes 1-10, history, summary, export"}},
      {"export",
       {autocal::cli::Export, "export a calibration history, or the calibration it ends with"}},
      {"distortion",
       {autocal::cli::Distortion, "estimate lens distortion from straight lines in still images"}},
      {"record",
       {autocal::cli::Record, "record a live camera + accelerometer (or any source) to a folder"}},
      {"devices", {autocal::cli::Devices, "list cameras and look for a USB accelerometer"}},
      {"readout",
       {autocal::cli::Readout, "measure a recording's rolling-shutter readout (a run per guess)"}},
      {"bench",
       {autocal::cli::Bench, "time the whole pipeline on a simulated recording (fps, latency)"}},
      {"check",
       {autocal::cli::Check,
        "the vest check: walk, then pass / fail against the pre-mission "
        "calibration"}},
  };
  return kSubcommands;
}

void PrintUsage(std::FILE* out) {
  std::fprintf(out,
               "usage: autocal <command> [options]\n"
               "       autocal <command> --help\n"
               "       autocal --version\n\n"
               "Keeps a camera + accelerometer rig calibrated without a target.\n\n"
               "commands:\n");
  for (const auto& [name, command] : Subcommands()) {
    std::fprintf(out, "  %-10s %s\n", qPrintable(name), command.summary);
  }
}

}  // namespace

int main(int argc, char** argv) {
  autocal::QuietSolverWarnings();
  QCoreApplication app(argc, argv);
  QCoreApplication::setApplicationName("autocal");
  QCoreApplication::setApplicationVersion(autocal::kVersion);
  const QStringList arguments = QCoreApplication::arguments();
  if (arguments.size() < 2) {
    PrintUsage(stderr);
    return 2;
  }
  const QString& first = arguments.at(1);
  if (first == "--version" || first == "-v") {
    std::printf("autocal %s\n", autocal::kVersion);
    return 0;
  }
  if (first == "--help" || first == "-h" || first == "help") {
    PrintUsage(stdout);
    return 0;
  }
  const auto command = Subcommands().find(first);
  if (command == Subcommands().end()) {
    std::fprintf(stderr, "autocal: unknown command '%s'\n\n", qPrintable(first));
    PrintUsage(stderr);
    return 2;
  }
  try {
    return command->second.run(arguments.mid(2));
  } catch (const std::exception& error) {
    // Commands report expected failures themselves; this is a bug or a library's surprise.
    std::fprintf(stderr, "autocal %s: unexpected error: %s\n", qPrintable(first), error.what());
    return 1;
  }
}
