// Median and 95th percentile of per-frame timings, exactly from a list or, for runs of
// any length, from a histogram of fixed size.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "pipeline/calibration_pipeline.h"

namespace autocal {

// Median and 95th percentile of one box's time over the frames it ran on.
struct TimingStats {
  double median_ms = 0.0;
  double p95_ms = 0.0;
  int count = 0;
};

// The values of rank floor(q n) (0-based, ascending) for q = 0.5 and 0.95.
TimingStats TimingStatsOf(std::vector<double> ms);

// Counts timings in logarithmic bins 1% wide from 0.1 us to 1000 s, so that memory stays
// the same over a session of any length (a list of every frame's time grows by 0.9 MB an
// hour for each box at 30 frames/s). Stats() takes the same ranks as TimingStatsOf and
// answers the middle of their bin: within 0.5% of the exact value. Times outside the
// range count in the end bins.
class TimingHistogram {
 public:
  void Add(double ms);
  TimingStats Stats() const;
  int64_t count() const { return count_; }

  static constexpr double kMinMs = 1e-4;
  static constexpr double kMaxMs = 1e6;
  static constexpr double kBinRatio = 1.01;

 private:
  static constexpr int kBins = 2315;  // ceil(log(kMaxMs / kMinMs) / log(kBinRatio)).
  std::array<uint32_t, kBins> counts_{};
  int64_t count_ = 0;
};

// Each box's times over a run's frames (`autocal run`'s timing_ms, the workbench's Timing
// dock), and "frame": what boxes 1-9 and the judgement took on the frame's own threads,
// without box 2's estimate and box 10's solve, which run on workers. A box that did not
// run on a frame (0 ms) is not counted for it.
class BoxTimingLog {
 public:
  void Add(const BoxTimings& timing);
  // By name: "frame", "lines", "flow", ... (BoxTimings::Named), those that ran.
  std::map<std::string, TimingStats> Stats() const;

 private:
  std::map<std::string, TimingHistogram> boxes_;
};

}  // namespace autocal
