#include "pipeline/features.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numeric>
#include <sstream>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "pipeline/error.h"

namespace autocal {

bool FeatureOptions::Check(std::string* error) const {
  std::ostringstream why;
  if (grid_columns < 1 || grid_columns > 64) {
    why << "grid_columns must be in [1, 64]";
  } else if (grid_rows < 1 || grid_rows > 64) {
    why << "grid_rows must be in [1, 64]";
  } else if (max_per_cell < 1) {
    why << "max_per_cell must be at least 1";
  } else if (fast_threshold < 1 || fast_threshold > 255) {
    why << "fast_threshold must be in [1, 255]";
  } else if (min_fast_threshold < 1 || min_fast_threshold > fast_threshold) {
    why << "min_fast_threshold must be in [1, fast_threshold]";
  } else if (!(min_distance_px >= 0)) {
    why << "min_distance_px must not be negative";
  } else if (border_px < 0) {
    why << "border_px must not be negative";
  } else if (max_keypoints < 1) {
    why << "max_keypoints must be at least 1";
  } else if (!(match_ratio > 0 && match_ratio <= 1)) {
    why << "match_ratio must be in (0, 1]";
  }
  if (why.str().empty()) return true;
  if (error) *error = why.str();
  return false;
}

int GridCell(const cv::Point2f& point, cv::Size size, const FeatureOptions& options) {
  const int column =
      std::clamp(int(point.x * options.grid_columns / size.width), 0, options.grid_columns - 1);
  const int row =
      std::clamp(int(point.y * options.grid_rows / size.height), 0, options.grid_rows - 1);
  return row * options.grid_columns + column;
}

namespace {

// FAST looks 3 pixels round a point and non-maximum suppression one more: a cell is
// searched with this margin so that its corners are those of the whole image.
constexpr int kFastMargin = 4;

// Adds the strongest free FAST corners (at `threshold`) of one cell to `taken` until it
// holds `room`, keeping them min_distance_px apart (marked off in `free`).
void TakeCorners(const cv::Mat& gray, int cell, int threshold, int room,
                 const FeatureOptions& options, cv::Mat* free, std::vector<cv::Point2f>* taken) {
  const int column = cell % options.grid_columns, row = cell / options.grid_columns;
  const cv::Rect area(
      cv::Point(column * gray.cols / options.grid_columns, row * gray.rows / options.grid_rows),
      cv::Point((column + 1) * gray.cols / options.grid_columns,
                (row + 1) * gray.rows / options.grid_rows));
  const cv::Rect search =
      (area - cv::Point(kFastMargin, kFastMargin) + cv::Size(2 * kFastMargin, 2 * kFastMargin)) &
      cv::Rect(cv::Point(0, 0), gray.size());
  std::vector<cv::KeyPoint> corners;
  cv::FAST(gray(search), corners, threshold, true);
  std::sort(corners.begin(), corners.end(),
            [](const cv::KeyPoint& a, const cv::KeyPoint& b) { return a.response > b.response; });
  const int spacing = static_cast<int>(std::ceil(options.min_distance_px));
  for (const cv::KeyPoint& corner : corners) {
    if (int(taken->size()) >= room) break;
    const cv::Point2f point = corner.pt + cv::Point2f(search.tl());
    const cv::Point pixel(cvRound(point.x), cvRound(point.y));
    if (GridCell(point, gray.size(), options) != cell || !free->at<uint8_t>(pixel)) continue;
    taken->push_back(point);
    if (spacing > 0) cv::circle(*free, pixel, spacing, cv::Scalar(0), cv::FILLED);
  }
}

}  // namespace

std::vector<cv::Point2f> DetectCorners(const cv::Mat& gray, const FeatureOptions& options,
                                       const std::vector<cv::Point2f>& existing, int max_new) {
  CV_Assert(gray.type() == CV_8UC1);
  const int cells = options.grid_columns * options.grid_rows;
  const int spacing = static_cast<int>(std::ceil(options.min_distance_px));
  // Free pixels: inside the border and away from every point taken.
  cv::Mat free(gray.size(), CV_8U, cv::Scalar(0));
  const cv::Rect inner(options.border_px, options.border_px, gray.cols - 2 * options.border_px,
                       gray.rows - 2 * options.border_px);
  if (inner.width <= 0 || inner.height <= 0 || max_new <= 0) return {};
  free(inner).setTo(255);
  std::vector<int> held(cells, 0);
  for (const cv::Point2f& p : existing) {
    ++held[GridCell(p, gray.size(), options)];
    if (spacing > 0) cv::circle(free, p, spacing, cv::Scalar(0), cv::FILLED);
  }

  // The emptiest cells are searched first, and only as many as it takes: FAST over the
  // whole image each frame would cost more than the tracking itself.
  std::vector<int> order(cells);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return held[a] < held[b]; });
  std::vector<std::vector<cv::Point2f>> taken(cells);
  int total = 0;
  int last_held = -1;
  for (int cell : order) {
    const int room = options.max_per_cell - held[cell];
    // Enough found, and every cell as empty as the last one searched had its turn.
    if (room <= 0 || (total >= max_new && held[cell] > last_held)) break;
    TakeCorners(gray, cell, options.fast_threshold, room, options, &free, &taken[cell]);
    // A cell with nothing at all looks again at a lower threshold: a weak corner there is
    // worth more than a strong one where tracks are plenty.
    if (taken[cell].empty() && held[cell] == 0 &&
        options.min_fast_threshold < options.fast_threshold) {
      TakeCorners(gray, cell, options.min_fast_threshold, room, options, &free, &taken[cell]);
    }
    total += static_cast<int>(taken[cell].size());
    last_held = held[cell];
  }

  // Cells take turns, the emptiest first, until max_new are chosen.
  std::vector<cv::Point2f> chosen;
  chosen.reserve(std::min(total, max_new));
  for (int rank = 0; rank < options.max_per_cell && int(chosen.size()) < max_new; ++rank) {
    for (int cell : order) {
      if (rank < int(taken[cell].size())) chosen.push_back(taken[cell][rank]);
      if (int(chosen.size()) == max_new) break;
    }
  }
  return chosen;
}

KeypointSet DetectKeypoints(const cv::Mat& gray, const FeatureOptions& options,
                            const cv::Mat& mask) {
  CV_Assert(gray.type() == CV_8UC1);
  cv::Ptr<cv::Feature2D> detector;
  switch (options.descriptor) {
    case DescriptorType::kOrb:
      detector = cv::ORB::create(options.max_keypoints);
      break;
    case DescriptorType::kSift:
      detector = cv::SIFT::create(options.max_keypoints);
      break;
  }
  KeypointSet set;
  detector->detectAndCompute(gray, mask, set.keypoints, set.descriptors);
  return set;
}

namespace {

// The CPU's popcount instruction where it has one: without it a 64-bit popcount is a
// library call, and a distance as slow as OpenCV's per-pair one.
#if defined(__x86_64__)
#define AUTOCAL_POPCOUNT_CLONES [[gnu::target_clones("popcnt", "default")]]
#else
#define AUTOCAL_POPCOUNT_CLONES
#endif

// Hamming distances between the rows of two binary descriptor matrices.
AUTOCAL_POPCOUNT_CLONES void HammingDistances(const cv::Mat& a, const cv::Mat& b,
                                              cv::Mat* distances) {
  const int words = a.cols / 8;
  const int tail = a.cols % 8;
  const auto load = [](const uchar* at, int bytes) {
    uint64_t word = 0;
    std::memcpy(&word, at, size_t(bytes));
    return word;
  };
  for (int i = 0; i < a.rows; ++i) {
    const uchar* x = a.ptr<uchar>(i);
    float* out = distances->ptr<float>(i);
    for (int j = 0; j < b.rows; ++j) {
      const uchar* y = b.ptr<uchar>(j);
      int count = 0;
      for (int w = 0; w < words; ++w)
        count += std::popcount(load(x + 8 * w, 8) ^ load(y + 8 * w, 8));
      if (tail > 0) count += std::popcount(load(x + 8 * words, tail) ^ load(y + 8 * words, tail));
      out[j] = float(count);
    }
  }
}
#undef AUTOCAL_POPCOUNT_CLONES

#if defined(__x86_64__)
constexpr int kOrbBytes = 32;

#define AUTOCAL_WIDE_POPCOUNT gnu::target("avx512f,avx512vl,avx512dq,avx512vpopcntdq")

// The four 64-bit counts of one pair of 32-byte descriptors.
[[AUTOCAL_WIDE_POPCOUNT]] __m256i PairCounts(__m256i x, const uchar* y) {
  return _mm256_popcnt_epi64(
      _mm256_xor_si256(x, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(y))));
}

// ORB's 32-byte descriptors, four of b's rows against one of a's at a time with AVX-512's
// popcount: a quarter of the time the loop above takes (the same integer counts).
[[AUTOCAL_WIDE_POPCOUNT]] void OrbHammingDistancesWide(const cv::Mat& a, const cv::Mat& b,
                                                       cv::Mat* distances) {
  const int four_rows = b.rows / 4 * 4;
  for (int i = 0; i < a.rows; ++i) {
    const __m256i x = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(a.ptr<uchar>(i)));
    float* out = distances->ptr<float>(i);
    for (int j = 0; j < four_rows; j += 4) {
      const __m256i c0 = PairCounts(x, b.ptr<uchar>(j)), c1 = PairCounts(x, b.ptr<uchar>(j + 1));
      const __m256i c2 = PairCounts(x, b.ptr<uchar>(j + 2)),
                    c3 = PairCounts(x, b.ptr<uchar>(j + 3));
      // Added up pair by pair: (c0, c1) and (c2, c3) lane-wise, then across the halves.
      const __m256i s01 =
          _mm256_add_epi64(_mm256_unpacklo_epi64(c0, c1), _mm256_unpackhi_epi64(c0, c1));
      const __m256i s23 =
          _mm256_add_epi64(_mm256_unpacklo_epi64(c2, c3), _mm256_unpackhi_epi64(c2, c3));
      const __m256i sums = _mm256_add_epi64(_mm256_permute2x128_si256(s01, s23, 0x20),
                                            _mm256_permute2x128_si256(s01, s23, 0x31));
      _mm_storeu_ps(out + j, _mm256_cvtepi64_ps(sums));
    }
    for (int j = four_rows; j < b.rows; ++j) {
      alignas(32) uint64_t lanes[4];
      _mm256_store_si256(reinterpret_cast<__m256i*>(lanes), PairCounts(x, b.ptr<uchar>(j)));
      out[j] = float(lanes[0] + lanes[1] + lanes[2] + lanes[3]);
    }
  }
}
#undef AUTOCAL_WIDE_POPCOUNT
#endif

// OrbHammingDistancesWide where the descriptors are ORB's and the CPU can; false elsewhere.
bool OrbHammingDistancesIfWide([[maybe_unused]] const cv::Mat& a, [[maybe_unused]] const cv::Mat& b,
                               [[maybe_unused]] cv::Mat* distances) {
#if defined(__x86_64__)
  static const bool cpu_can =
      __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
      __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vpopcntdq");
  if (!cpu_can || a.cols != kOrbBytes) return false;
  OrbHammingDistancesWide(a, b, distances);
  return true;
#else
  return false;
#endif
}

}  // namespace

std::vector<cv::DMatch> MatchKeypoints(const KeypointSet& a, const KeypointSet& b,
                                       const FeatureOptions& options) {
  if (a.descriptors.empty() || b.descriptors.empty()) return {};
  if (a.descriptors.type() != b.descriptors.type() || a.descriptors.cols != b.descriptors.cols) {
    throw Error("MatchKeypoints: the two sets hold different kinds of descriptor");
  }
  // Every distance once, for both directions (cv::BFMatcher's knnMatch and match computed
  // each twice, at 9 ms for 1446 x 633 ORB descriptors where this takes 1-2). Scanned in
  // index order with strict comparisons, ties go to the lowest index, as BFMatcher's do.
  cv::Mat distances(a.descriptors.rows, b.descriptors.rows, CV_32F);
  if (a.descriptors.depth() == CV_8U) {
    if (!OrbHammingDistancesIfWide(a.descriptors, b.descriptors, &distances)) {
      HammingDistances(a.descriptors, b.descriptors, &distances);
    }
  } else {
    cv::batchDistance(a.descriptors, b.descriptors, distances, CV_32F, cv::noArray(), cv::NORM_L2);
  }
  std::vector<int> nearest_in_a(distances.cols, -1);
  std::vector<float> nearest_in_a_distance(distances.cols, std::numeric_limits<float>::infinity());
  for (int i = 0; i < distances.rows; ++i) {
    const float* row = distances.ptr<float>(i);
    for (int j = 0; j < distances.cols; ++j) {
      if (row[j] < nearest_in_a_distance[j]) {
        nearest_in_a_distance[j] = row[j];
        nearest_in_a[j] = i;
      }
    }
  }
  std::vector<cv::DMatch> matches;
  for (int i = 0; i < distances.rows; ++i) {
    const float* row = distances.ptr<float>(i);
    int best = 0;
    float second_distance = std::numeric_limits<float>::infinity();
    for (int j = 1; j < distances.cols; ++j) {
      if (row[j] < row[best]) {
        second_distance = row[best];
        best = j;
      } else if (row[j] < second_distance) {
        second_distance = row[j];
      }
    }
    // Lowe's ratio test, where a second candidate exists; then the cross-check.
    if (row[best] >= options.match_ratio * second_distance) continue;
    if (nearest_in_a[best] != i) continue;
    matches.emplace_back(i, best, row[best]);
  }
  return matches;
}

}  // namespace autocal
