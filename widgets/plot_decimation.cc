#include "widgets/plot_decimation.h"

#include <algorithm>
#include <cmath>

namespace autocal {

SampleRange VisibleRange(const std::vector<double>& t, double t0, double t1) {
  auto begin = std::lower_bound(t.begin(), t.end(), t0);
  auto end = std::upper_bound(begin, t.end(), t1);
  if (begin != t.begin()) --begin;
  if (end != t.end()) ++end;
  return {static_cast<size_t>(begin - t.begin()), static_cast<size_t>(end - t.begin())};
}

QVector<QPointF> DecimateMinMax(const std::vector<double>& t, const std::vector<double>& v,
                                SampleRange range, int buckets) {
  QVector<QPointF> points;
  if (range.end <= range.begin) return points;
  const size_t count = range.end - range.begin;
  buckets = std::max(buckets, 1);
  if (count <= 2 * static_cast<size_t>(buckets)) {
    points.reserve(static_cast<int>(count));
    for (size_t i = range.begin; i < range.end; ++i) points.append({t[i], v[i]});
    return points;
  }
  points.reserve(2 * buckets);
  const double t0 = t[range.begin];
  const double bucket_width = (t[range.end - 1] - t0) / buckets;
  size_t lo = range.begin, hi = range.begin;  // Indices of the bucket's min and max.
  int bucket = 0;
  auto flush = [&] {
    points.append({t[std::min(lo, hi)], v[std::min(lo, hi)]});
    if (lo != hi) points.append({t[std::max(lo, hi)], v[std::max(lo, hi)]});
  };
  for (size_t i = range.begin; i < range.end; ++i) {
    const int b =
        bucket_width > 0.0
            ? std::min(buckets - 1, static_cast<int>(std::floor((t[i] - t0) / bucket_width)))
            : 0;
    if (b != bucket) {
      flush();
      bucket = b;
      lo = hi = i;
      continue;
    }
    if (v[i] < v[lo]) lo = i;
    if (v[i] > v[hi]) hi = i;
  }
  flush();
  return points;
}

}  // namespace autocal
