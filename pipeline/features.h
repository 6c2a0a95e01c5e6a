// Box 4, features: FAST corners to start tracks at, spread over the image by a grid of
// cells, and scale-invariant keypoints with descriptors (SIFT or ORB) to match still shots
// (and, in time, to find a lost plane again).
#pragma once

#include <climits>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace autocal {

enum class DescriptorType {
  kOrb,   // Binary, fast; matched by Hamming distance.
  kSift,  // Float, slower, more distinctive; matched by L2 distance.
};

struct FeatureOptions {
  int grid_columns = 8;          // Cells across the image that corners are spread over.
  int grid_rows = 6;             // Cells down the image.
  int max_per_cell = 8;          // Tracked points per cell, existing ones counted.
  int fast_threshold = 12;       // FAST: grey-level contrast of the ring around a corner.
  int min_fast_threshold = 6;    // Cells with no corner at all are searched again at this.
  double min_distance_px = 8.0;  // New corners keep this far from tracked points and each other.
  int border_px = 12;            // No corners this close to the border (half an LK window).
  // Keypoints for still shots: SIFT finds and places more of them on fine, low-contrast
  // texture (carpet, plaster) across a change of view.
  DescriptorType descriptor = DescriptorType::kSift;
  int max_keypoints = 1500;  // Strongest scale-invariant keypoints kept per image.
  double match_ratio = 0.8;  // Lowe's test: best match closer than this times the second.

  bool Check(std::string* error) const;
};

// The grid cell (row-major index) of a point in an image of `size`.
int GridCell(const cv::Point2f& point, cv::Size size, const FeatureOptions& options);

// Corners to start new tracks at in an 8-bit grey image. Each cell takes its strongest
// FAST corners until it holds `max_per_cell` points, counting the `existing` ones already
// tracked there (an empty cell without corners at fast_threshold looks again down to
// min_fast_threshold); no corner comes within `min_distance_px` of an existing point or
// of another new corner. When more than `max_new` qualify, cells take turns, the emptiest
// first, so the new corners go where tracks are missing.
std::vector<cv::Point2f> DetectCorners(const cv::Mat& gray, const FeatureOptions& options,
                                       const std::vector<cv::Point2f>& existing = {},
                                       int max_new = INT_MAX);

// Scale-invariant keypoints of one image and their descriptors (one row each).
struct KeypointSet {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;  // CV_8U rows for ORB, CV_32F rows for SIFT.
};

// Keypoints of an 8-bit grey image (inside `mask` if given), the strongest
// `max_keypoints`, with descriptors of the type the options ask for.
KeypointSet DetectKeypoints(const cv::Mat& gray, const FeatureOptions& options,
                            const cv::Mat& mask = {});

// Matches from `a` to `b` that pass Lowe's ratio test and are mutual best matches
// (queryIdx in a, trainIdx in b).
std::vector<cv::DMatch> MatchKeypoints(const KeypointSet& a, const KeypointSet& b,
                                       const FeatureOptions& options);

}  // namespace autocal
