// The readout of a rolling shutter measured from a recording (devices/readout_sweep.h):
// the choice among trials worked by hand, and whole sweeps on simulated walks whose true
// readout is known.
#include "devices/readout_sweep.h"

#include <gtest/gtest.h>

#include "devices/in_memory_sequence.h"
#include "devices/sim/simulator.h"
#include "test_util.h"

namespace autocal {
namespace {

// Trials whose median RMS is 0.05 + 1e-4 (x - centre)^2 px: a parabola with its vertex at
// `centre`, which the three trials around it give back exactly.
std::vector<ReadoutTrial> Parabola(double centre, const std::vector<double>& readouts) {
  std::vector<ReadoutTrial> trials;
  for (const double x : readouts) {
    trials.push_back({x, 10, 10, 10, 0.05 + 1e-4 * (x - centre) * (x - centre)});
  }
  return trials;
}

TEST(BestReadout, VertexOfTheParabolaThroughTheBestAndItsNeighbours) {
  const ReadoutEstimate estimate = BestReadout(Parabola(23.0, {0, 5, 10, 15, 20, 25, 30, 35}));
  ASSERT_TRUE(estimate.readout_ms) << estimate.why;
  EXPECT_NEAR(*estimate.readout_ms, 23.0, 1e-9);
  EXPECT_EQ(estimate.trials.size(), 8u);
  // Within 5% of the best (25 ms, 0.0504 px): (x - 23)^2 <= 29.2, so 20 to 25 ms.
  EXPECT_EQ(estimate.nearly_as_well_from_ms, 20.0);
  EXPECT_EQ(estimate.nearly_as_well_to_ms, 25.0);
  // Unevenly spaced and out of order: the same vertex.
  const ReadoutEstimate shuffled = BestReadout(Parabola(23.0, {40, 0, 21, 12, 30}));
  ASSERT_TRUE(shuffled.readout_ms) << shuffled.why;
  EXPECT_NEAR(*shuffled.readout_ms, 23.0, 1e-9);
  EXPECT_EQ(shuffled.trials.front().readout_ms, 40.0) << "the trials as tried";
}

TEST(BestReadout, AtTheEndsOfTheRangeTried) {
  const ReadoutEstimate global = BestReadout(Parabola(-3.0, {0, 10, 20}));
  ASSERT_TRUE(global.readout_ms) << global.why;
  EXPECT_EQ(*global.readout_ms, 0.0);
  EXPECT_PRED_FORMAT2(::testing::IsSubstring, "global shutter, or one under 10 ms", global.why);

  const ReadoutEstimate beyond = BestReadout(Parabola(50.0, {0, 10, 20, 30, 40}));
  EXPECT_FALSE(beyond.readout_ms);
  EXPECT_PRED_FORMAT2(::testing::IsSubstring, "largest readout tried", beyond.why);
  const ReadoutEstimate below = BestReadout(Parabola(0.0, {10, 20, 30}));
  EXPECT_FALSE(below.readout_ms);
  EXPECT_PRED_FORMAT2(::testing::IsSubstring, "smallest readout tried", below.why);
}

TEST(BestReadout, TrialsWithoutASolvedAttemptDoNotCount) {
  std::vector<ReadoutTrial> trials = Parabola(23.0, {0, 10, 20, 30, 40});
  trials[2].solved = 0;  // 20 ms: its RMS is not a measurement.
  trials[2].median_rms_px = 0.0;
  const ReadoutEstimate estimate = BestReadout(trials);
  ASSERT_TRUE(estimate.readout_ms) << estimate.why;
  EXPECT_NEAR(*estimate.readout_ms, 23.0, 1e-9) << "from 10, 30 and 40 ms";
  for (ReadoutTrial& t : trials) t.solved = t.readout_ms < 20 ? 1 : 0;
  const ReadoutEstimate none = BestReadout(trials);
  EXPECT_FALSE(none.readout_ms);
  EXPECT_PRED_FORMAT2(::testing::IsSubstring, "fewer than three", none.why);
}

// The office walk through the wide lens, 8 s at 320x240: rows read over 30 ms, and a
// global shutter.
TEST(MeasureReadout, FindsTheSimulatedReadout) {
  const std::string spec = "office,lens=sonnar,resolution=320x240,seconds=8";
  // Rendered once for all the trials.
  const InMemorySequence rolling(MakeSimulatedSequence(ParseScenarioSpec(spec + ",readout_ms=30")));
  const ReadoutEstimate estimate = MeasureReadout(rolling, {}, {0, 15, 30, 45});
  for (const ReadoutTrial& t : estimate.trials) {
    std::printf("%g ms: %d attempts, %d solved, %d accepted, median RMS %.4f px\n", t.readout_ms,
                t.attempts, t.solved, t.accepted, t.median_rms_px);
  }
  ASSERT_TRUE(estimate.readout_ms) << estimate.why;
  EXPECT_NEAR(*estimate.readout_ms, 30.0, 5.0) << estimate.why;

  const InMemorySequence global(MakeSimulatedSequence(ParseScenarioSpec(spec)));
  const ReadoutEstimate none = MeasureReadout(global, {}, {0, 15, 30});
  ASSERT_TRUE(none.readout_ms) << none.why;
  EXPECT_EQ(*none.readout_ms, 0.0) << none.why;
}

}  // namespace
}  // namespace autocal
