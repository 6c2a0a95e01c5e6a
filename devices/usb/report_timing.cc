#include "devices/usb/report_timing.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace autocal {

ReportTiming::ReportTiming(size_t window, size_t min_intervals)
    : window_(std::max<size_t>(window, 1)), min_intervals_(std::max<size_t>(min_intervals, 1)) {}

bool ReportTiming::Add(int64_t t_ns) {
  const bool first = !has_last_;
  const int64_t interval = t_ns - last_ns_;
  last_ns_ = t_ns;
  has_last_ = true;
  if (first) return false;

  // Judged against the median before this interval joins it, so one long gap does not
  // excuse itself.
  bool late = false;
  const double median = median_interval_ns();
  if (intervals_ns_.size() >= min_intervals_ && median > 0.0 && interval > 1.5 * median) {
    late = true;
    ++late_reports_;
    missing_reports_ += static_cast<uint64_t>(
        std::max<int64_t>(std::llround(static_cast<double>(interval) / median) - 1, 0));
  }
  intervals_ns_.push_back(interval);
  if (intervals_ns_.size() > window_) intervals_ns_.pop_front();
  return late;
}

void ReportTiming::Restart() { has_last_ = false; }

double ReportTiming::median_interval_ns() const {
  if (intervals_ns_.empty()) return 0.0;
  std::vector<int64_t> sorted(intervals_ns_.begin(), intervals_ns_.end());
  const size_t mid = sorted.size() / 2;
  std::nth_element(sorted.begin(), sorted.begin() + mid, sorted.end());
  if (sorted.size() % 2 == 1) return static_cast<double>(sorted[mid]);
  const int64_t upper = sorted[mid];
  const int64_t lower = *std::max_element(sorted.begin(), sorted.begin() + mid);
  return 0.5 * static_cast<double>(lower + upper);
}

double ReportTiming::rate_hz() const {
  int64_t total_ns = 0;
  for (int64_t interval : intervals_ns_) total_ns += interval;
  return total_ns > 0 ? 1e9 * static_cast<double>(intervals_ns_.size()) / total_ns : 0.0;
}

}  // namespace autocal
