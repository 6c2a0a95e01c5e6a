#pragma once

#include <optional>
#include <span>
#include <vector>

#include <opencv2/core.hpp>

namespace autocal {

// Confidence that no better consensus was missed: OpenCV's default.
inline constexpr double kRansacConfidence = 0.995;

// A robust homography from `from` to `to`, as cv::findHomography(from, to, cv::RANSAC,
// threshold_px, mask, max_iterations, confidence) finds it: the consensus of the best
// 4-point sample (points whose transfer error is within threshold_px), the sample count
// cut as the consensus grows, then a least-squares and Levenberg-Marquardt fit over the
// consensus (cv::findHomography method 0). Each sample's homography is solved as an 8x8
// linear system instead of OpenCV's 9x9 eigen-decomposition, at a fraction of the cost.
// The samples are drawn from a fixed seed: the same points give the same result.
// `inliers` gets the consensus (1 for its points). Empty when no sample fits 4 points.
std::optional<cv::Matx33d> FitHomographyRansac(std::span<const cv::Point2f> from,
                                               std::span<const cv::Point2f> to, double threshold_px,
                                               int max_iterations, double confidence,
                                               std::vector<uchar>* inliers);

}  // namespace autocal
