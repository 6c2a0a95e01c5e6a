#pragma once

#include <optional>
#include <span>
#include <vector>

#include <opencv2/core.hpp>

namespace autocal {

// Confidence that no better consensus was missed: OpenCV's default.
inline constexpr double kRansacConfidence = 0.995;

// The homography from `from` to `to` with the least squared transfer error in `to`, as
// cv::findHomography(from, to, 0) finds it: a normalized linear (DLT) fit, then at most 10
// Levenberg-Marquardt steps on the transfer error. Our own because OpenCV's, which solves
// each 8x8 step by a general decomposition on cv::Mat, took 11% of the motion thread
// (docs/motion.md). Empty with fewer than 4 points or points that fix no homography
// (collinear).
std::optional<cv::Matx33d> FitHomography(std::span<const cv::Point2f> from,
                                         std::span<const cv::Point2f> to);

// A robust homography from `from` to `to`, as cv::findHomography(from, to, cv::RANSAC,
// threshold_px, mask, max_iterations, confidence) finds it: the consensus of the best
// 4-point sample (points whose transfer error is within threshold_px), the sample count
// cut as the consensus grows, then FitHomography over the consensus. Each sample's
// homography is solved as an 8x8 linear system instead of OpenCV's 9x9
// eigen-decomposition, at a fraction of the cost. The samples are drawn from a fixed seed:
// the same points give the same result. `inliers` gets the consensus (1 for its points).
// Empty when no sample fits 4 points.
std::optional<cv::Matx33d> FitHomographyRansac(std::span<const cv::Point2f> from,
                                               std::span<const cv::Point2f> to, double threshold_px,
                                               int max_iterations, double confidence,
                                               std::vector<uchar>* inliers);

}  // namespace autocal
