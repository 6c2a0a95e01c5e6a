// The subcommands of the `autocal` command-line tool. Each takes its arguments (without
// the program and subcommand names) and returns the process exit code:
// 0 success, 1 failure (the reason printed on stderr), 2 bad usage.
#pragma once

#include <QStringList>

namespace autocal::cli {

int Simulate(const QStringList& arguments);
int Info(const QStringList& arguments);
int Distortion(const QStringList& arguments);
// run_command.cc
int Run(const QStringList& arguments);
// export_command.cc
int Export(const QStringList& arguments);
// record_command.cc
int Record(const QStringList& arguments);
int Devices(const QStringList& arguments);
// bench_command.cc
int Bench(const QStringList& arguments);
// check_command.cc
int Check(const QStringList& arguments);
// readout_command.cc
int Readout(const QStringList& arguments);

}  // namespace autocal::cli
