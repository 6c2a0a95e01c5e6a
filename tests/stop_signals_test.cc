// A long command's Ctrl-C: the first SIGINT or SIGTERM asks it to stop cleanly, a second
// ends it as usual (for a user whose clean stop hangs). Each case runs in a child process,
// where the signal's disposition can change and the program can die.
#include <csignal>
#include <cstdlib>

#include <gtest/gtest.h>
#include <unistd.h>

#include "app/cli_util.h"

namespace autocal::cli {
namespace {

// The child's exit code: 0 when the first signal only asked to stop.
void RaiseOnce(int signal) {
  const StopRequest& stop = CatchStopSignals();
  std::raise(signal);
  _exit(stop.requested && stop.signal == signal ? 0 : 3);
}

void RaiseTwice(int signal) {
  CatchStopSignals();
  std::raise(signal);
  std::raise(signal);
  _exit(0);
}

TEST(StopSignals, TheFirstAsksToStop) {
  EXPECT_EXIT(RaiseOnce(SIGINT), testing::ExitedWithCode(0), "");
  EXPECT_EXIT(RaiseOnce(SIGTERM), testing::ExitedWithCode(0), "");
}

TEST(StopSignals, TheSecondEndsTheProgram) {
  EXPECT_EXIT(RaiseTwice(SIGINT), testing::KilledBySignal(SIGINT), "");
  EXPECT_EXIT(RaiseTwice(SIGTERM), testing::KilledBySignal(SIGTERM), "");
}

}  // namespace
}  // namespace autocal::cli
