// Keeps long time series fast to draw: at most two points per pixel column.
#pragma once

#include <cstddef>
#include <vector>

#include <QPointF>
#include <QVector>

namespace autocal {

// Half-open index range [begin, end) into a sorted time vector.
struct SampleRange {
  size_t begin = 0;
  size_t end = 0;
};

// The samples needed to draw [t0, t1]: those inside, plus one on either side so that the
// line runs to the plot's edges.
SampleRange VisibleRange(const std::vector<double>& t, double t0, double t1);

// Min-max decimation: splits the range's time span into `buckets` equal parts and keeps
// each part's smallest and largest value, in time order. Peaks survive any zoom level,
// unlike taking every n-th sample. Returns every sample when there are at most
// 2 * buckets of them.
QVector<QPointF> DecimateMinMax(const std::vector<double>& t, const std::vector<double>& v,
                                SampleRange range, int buckets);

}  // namespace autocal
