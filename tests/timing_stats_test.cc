// The summary's timing figures: the histogram a run of any length keeps against the exact
// ranks of every value, and against values worked by hand.
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "devices/timing_stats.h"

namespace autocal {
namespace {

// Half a bin either way: the middle of a 1% bin is within 0.5% of anything in it.
constexpr double kRelativeTolerance = 0.005;

TimingHistogram HistogramOf(const std::vector<double>& values) {
  TimingHistogram histogram;
  for (double ms : values) histogram.Add(ms);
  return histogram;
}

TEST(TimingStats, RanksWorkedByHand) {
  // Sorted 1 2 3 4: the median is rank floor(0.5 * 4) = 2, the 95th percentile rank
  // floor(0.95 * 4) = 3.
  const std::vector<double> values = {4.0, 1.0, 3.0, 2.0};
  const TimingStats exact = TimingStatsOf(values);
  EXPECT_EQ(exact.median_ms, 3.0);
  EXPECT_EQ(exact.p95_ms, 4.0);
  EXPECT_EQ(exact.count, 4);

  const TimingStats binned = HistogramOf(values).Stats();
  EXPECT_NEAR(binned.median_ms, 3.0, 3.0 * kRelativeTolerance);
  EXPECT_NEAR(binned.p95_ms, 4.0, 4.0 * kRelativeTolerance);
  EXPECT_EQ(binned.count, 4);
}

TEST(TimingStats, HistogramAgreesWithTheExactRanksOverManyFrames) {
  // A box's times over an hour at 30 frames/s, spread over four decades.
  std::mt19937 random(7);
  std::lognormal_distribution<double> ms(std::log(2.0), 1.2);
  std::vector<double> values(108000);
  for (double& value : values) value = ms(random);
  const TimingStats exact = TimingStatsOf(values);
  const TimingStats binned = HistogramOf(values).Stats();
  EXPECT_EQ(binned.count, exact.count);
  EXPECT_NEAR(binned.median_ms, exact.median_ms, exact.median_ms * kRelativeTolerance);
  EXPECT_NEAR(binned.p95_ms, exact.p95_ms, exact.p95_ms * kRelativeTolerance);
  // A 5% shift of every value shows: the bins resolve well below it.
  std::vector<double> slower = values;
  for (double& value : slower) value *= 1.05;
  EXPECT_GT(HistogramOf(slower).Stats().median_ms, binned.median_ms * 1.04);
}

TEST(TimingStats, OutOfRangeTimesCountInTheEndBins) {
  const std::vector<double> values = {0.0, std::numeric_limits<double>::quiet_NaN(), 1e-9, 5.0,
                                      1e9};
  const TimingStats binned = HistogramOf(values).Stats();
  EXPECT_EQ(binned.count, 5);
  // Ranks 2 and 4 of five: the third value below range, and the one above.
  EXPECT_LE(binned.median_ms, TimingHistogram::kMinMs * TimingHistogram::kBinRatio);
  EXPECT_GE(binned.p95_ms, TimingHistogram::kMaxMs / TimingHistogram::kBinRatio);
}

TEST(TimingStats, EmptyHasNoFigures) {
  const TimingStats binned = TimingHistogram().Stats();
  EXPECT_EQ(binned.count, 0);
  EXPECT_EQ(binned.median_ms, 0.0);
  EXPECT_EQ(binned.p95_ms, 0.0);
}

TEST(TimingStats, BoxLogCountsTheBoxesThatRanAndTheFrameWithoutTheWorkers) {
  BoxTimingLog log;
  BoxTimings first;
  first.lines_ms = 2.0;
  first.rectify_ms = 1.0;
  first.flow_ms = 3.0;
  first.planes_ms = 1.5;
  first.refind_ms = 20.0;       // On the frame's thread, as box 6's.
  first.distortion_ms = 10.0;   // On box 2's worker.
  first.calibration_ms = 50.0;  // On box 10's.
  log.Add(first);
  BoxTimings second;
  second.lines_ms = 4.0;
  second.flow_ms = 1.0;
  log.Add(second);

  const std::map<std::string, TimingStats> stats = log.Stats();
  EXPECT_EQ(stats.count("features"), 0u) << "never ran";
  EXPECT_EQ(stats.at("lines").count, 2);
  EXPECT_EQ(stats.at("planes").count, 1);
  EXPECT_EQ(stats.at("calibration").count, 1);
  EXPECT_NEAR(stats.at("calibration").median_ms, 50.0, 50.0 * kRelativeTolerance);
  // Frames of 2 + 1 + 3 + 1.5 + 20 = 27.5 and 4 + 1 = 5 ms: rank 1 of two is 27.5, for both.
  EXPECT_EQ(stats.at("frame").count, 2);
  EXPECT_NEAR(stats.at("frame").median_ms, 27.5, 27.5 * kRelativeTolerance);
  EXPECT_NEAR(stats.at("frame").p95_ms, 27.5, 27.5 * kRelativeTolerance);
}

}  // namespace
}  // namespace autocal
