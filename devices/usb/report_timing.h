// Rate and gaps of a stream of reports, from their arrival times alone: devices do not
// say when they miss a report, but a gap much longer than usual shows it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>

namespace autocal {

class ReportTiming {
 public:
  // The median is taken over the last `window` intervals; gaps are judged once
  // `min_intervals` are known.
  explicit ReportTiming(size_t window = 64, size_t min_intervals = 8);

  // Adds an arrival time (ns, non-decreasing). Returns true when the interval before it
  // is longer than 1.5 times the median interval: a late report, or dropped ones.
  bool Add(int64_t t_ns);
  // The next arrival starts a new run (after a re-plug), keeping the counts.
  void Restart();

  // Reports per second delivered over the window (gaps included); 0 until two arrivals.
  double rate_hz() const;
  double median_interval_ns() const;
  // Intervals longer than 1.5 times the median.
  uint64_t late_reports() const { return late_reports_; }
  // Reports those long intervals should have held, rounded to whole intervals.
  uint64_t missing_reports() const { return missing_reports_; }

 private:
  size_t window_;
  size_t min_intervals_;
  std::deque<int64_t> intervals_ns_;
  int64_t last_ns_ = 0;
  bool has_last_ = false;
  uint64_t late_reports_ = 0;
  uint64_t missing_reports_ = 0;
};

}  // namespace autocal
