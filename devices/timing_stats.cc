#include "devices/timing_stats.h"

#include <algorithm>
#include <cmath>

namespace autocal {
namespace {

size_t RankAt(double q, size_t n) { return std::min(n - 1, static_cast<size_t>(q * double(n))); }

}  // namespace

TimingStats TimingStatsOf(std::vector<double> values) {
  TimingStats stats;
  stats.count = static_cast<int>(values.size());
  if (values.empty()) return stats;
  std::sort(values.begin(), values.end());
  stats.median_ms = values[RankAt(0.5, values.size())];
  stats.p95_ms = values[RankAt(0.95, values.size())];
  return stats;
}

void TimingHistogram::Add(double ms) {
  int bin = 0;
  if (ms > kMinMs) {  // NaN too lands in the first bin.
    bin = std::min(kBins - 1, static_cast<int>(std::log(ms / kMinMs) / std::log(kBinRatio)));
  }
  ++counts_[static_cast<size_t>(bin)];
  ++count_;
}

TimingStats TimingHistogram::Stats() const {
  TimingStats stats;
  stats.count = static_cast<int>(count_);
  if (count_ == 0) return stats;
  const auto value_at = [&](double q) {
    const size_t rank = RankAt(q, static_cast<size_t>(count_));
    size_t below = 0;
    for (size_t bin = 0; bin < counts_.size(); ++bin) {
      below += counts_[bin];
      if (below > rank) return kMinMs * std::pow(kBinRatio, double(bin) + 0.5);
    }
    return kMaxMs;  // Not reached: the counts add up to count_.
  };
  stats.median_ms = value_at(0.5);
  stats.p95_ms = value_at(0.95);
  return stats;
}

void BoxTimingLog::Add(const BoxTimings& timing) {
  double frame_ms = 0.0;
  for (const auto& [box, ms] : timing.Named()) {
    if (ms > 0.0) boxes_[box].Add(ms);
    if (box != "calibration" && box != "distortion") frame_ms += ms;
  }
  boxes_["frame"].Add(frame_ms);
}

std::map<std::string, TimingStats> BoxTimingLog::Stats() const {
  std::map<std::string, TimingStats> stats;
  for (const auto& [box, histogram] : boxes_) {
    if (histogram.count() > 0) stats[box] = histogram.Stats();
  }
  return stats;
}

}  // namespace autocal
