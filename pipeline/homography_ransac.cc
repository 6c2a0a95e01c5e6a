#include "pipeline/homography_ransac.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <Eigen/LU>
#include <opencv2/calib3d.hpp>

namespace autocal {
namespace {

// Twice the signed area of the triangle (a, b, c).
double Orientation(const cv::Point2f& a, const cv::Point2f& b, const cv::Point2f& c) {
  return (double(b.x) - a.x) * (double(c.y) - a.y) - (double(b.y) - a.y) * (double(c.x) - a.x);
}

// Four points no three of which are (nearly) collinear on either side, and whose
// triangles keep their orientation from one side to the other: a homography of a plane
// seen from the front cannot mirror them.
bool UsableSample(const std::array<cv::Point2f, 4>& from, const std::array<cv::Point2f, 4>& to) {
  static constexpr int kTriangles[4][3] = {{0, 1, 2}, {1, 2, 3}, {0, 2, 3}, {0, 1, 3}};
  int flipped = 0;
  for (const auto& t : kTriangles) {
    const double a = Orientation(from[t[0]], from[t[1]], from[t[2]]);
    const double b = Orientation(to[t[0]], to[t[1]], to[t[2]]);
    // Collinear within single precision, relative to the triangle's sides.
    auto degenerate = [&](const std::array<cv::Point2f, 4>& p, double area) {
      const double sides = cv::norm(p[t[1]] - p[t[0]]) * cv::norm(p[t[2]] - p[t[0]]);
      return std::abs(area) <= std::numeric_limits<float>::epsilon() * sides;
    };
    if (degenerate(from, a) || degenerate(to, b)) return false;
    flipped += (a * b < 0);
  }
  return flipped == 0 || flipped == 4;
}

// The homography (h33 = 1) through four correspondences in general position.
std::optional<Eigen::Matrix3d> FourPointHomography(const std::array<cv::Point2f, 4>& from,
                                                   const std::array<cv::Point2f, 4>& to) {
  // Centred on each side's first point and scaled to unit size: the 8x8 system is then
  // well conditioned at any image size.
  auto normalizer = [](const std::array<cv::Point2f, 4>& p) {
    double size = 0.0;
    for (const cv::Point2f& q : p) size = std::max(size, cv::norm(q - p[0]));
    Eigen::Matrix3d t = Eigen::Matrix3d::Identity();
    t(0, 0) = t(1, 1) = 1.0 / size;
    t(0, 2) = -p[0].x / size;
    t(1, 2) = -p[0].y / size;
    return t;
  };
  const Eigen::Matrix3d t_from = normalizer(from), t_to = normalizer(to);
  Eigen::Matrix<double, 8, 8> a;
  Eigen::Matrix<double, 8, 1> b;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d p = t_from * Eigen::Vector3d(from[i].x, from[i].y, 1.0);
    const Eigen::Vector3d q = t_to * Eigen::Vector3d(to[i].x, to[i].y, 1.0);
    a.row(2 * i) << p.x(), p.y(), 1.0, 0.0, 0.0, 0.0, -p.x() * q.x(), -p.y() * q.x();
    a.row(2 * i + 1) << 0.0, 0.0, 0.0, p.x(), p.y(), 1.0, -p.x() * q.y(), -p.y() * q.y();
    b(2 * i) = q.x();
    b(2 * i + 1) = q.y();
  }
  const Eigen::FullPivLU<Eigen::Matrix<double, 8, 8>> lu(a);
  if (!lu.isInvertible()) return std::nullopt;
  const Eigen::Matrix<double, 8, 1> x = lu.solve(b);
  Eigen::Matrix3d normalized;
  normalized << x(0), x(1), x(2), x(3), x(4), x(5), x(6), x(7), 1.0;
  Eigen::Matrix3d h = t_to.inverse() * normalized * t_from;
  if (!h.allFinite() || h(2, 2) == 0.0) return std::nullopt;
  return h / h(2, 2);
}

// Samples needed to draw one free of outliers with the given confidence (the standard
// RANSAC bound), at most `limit`.
int SamplesNeeded(double confidence, double outlier_ratio, int limit) {
  const double miss = std::log(std::max(1.0 - confidence, std::numeric_limits<double>::min()));
  const double clean = std::pow(1.0 - outlier_ratio, 4);
  if (clean >= 1.0) return 0;
  const double per_sample = std::log(1.0 - clean);
  if (per_sample >= 0.0 || -miss >= limit * -per_sample) return limit;
  return int(std::lround(miss / per_sample));
}

}  // namespace

std::optional<cv::Matx33d> FitHomographyRansac(std::span<const cv::Point2f> from,
                                               std::span<const cv::Point2f> to, double threshold_px,
                                               int max_iterations, double confidence,
                                               std::vector<uchar>* inliers) {
  const int count = int(from.size());
  CV_Assert(from.size() == to.size());
  inliers->assign(count, 0);
  if (count < 4) return std::nullopt;
  cv::RNG rng(~uint64_t{0});
  const double threshold_sq = threshold_px * threshold_px;
  std::vector<uchar> consensus(count);
  int best = 3;  // A consensus needs more points than the sample's three degrees of freedom.
  int needed = max_iterations;
  // Draws that give no usable sample are bounded, as OpenCV bounds them.
  constexpr int kMaxDraws = 1000;
  for (int iteration = 0; iteration < needed; ++iteration) {
    std::array<int, 4> pick{};
    std::array<cv::Point2f, 4> sample_from, sample_to;
    bool usable = false;
    for (int draw = 0; draw < kMaxDraws && !usable; ++draw) {
      for (int i = 0; i < 4; ++i) {
        do {
          pick[i] = rng.uniform(0, count);
        } while (std::find(pick.begin(), pick.begin() + i, pick[i]) != pick.begin() + i);
        sample_from[i] = from[pick[i]];
        sample_to[i] = to[pick[i]];
      }
      usable = UsableSample(sample_from, sample_to);
    }
    if (!usable) break;
    const std::optional<Eigen::Matrix3d> h = FourPointHomography(sample_from, sample_to);
    if (!h) continue;
    int support = 0;
    for (int k = 0; k < count; ++k) {
      const double x = from[k].x, y = from[k].y;
      const double w = 1.0 / ((*h)(2, 0) * x + (*h)(2, 1) * y + (*h)(2, 2));
      const double dx = ((*h)(0, 0) * x + (*h)(0, 1) * y + (*h)(0, 2)) * w - to[k].x;
      const double dy = ((*h)(1, 0) * x + (*h)(1, 1) * y + (*h)(1, 2)) * w - to[k].y;
      consensus[k] = dx * dx + dy * dy <= threshold_sq;
      support += consensus[k];
    }
    if (support > best) {
      best = support;
      inliers->swap(consensus);
      needed = SamplesNeeded(confidence, double(count - support) / count, needed);
    }
  }
  if (best < 4) {
    inliers->assign(count, 0);
    return std::nullopt;
  }
  std::vector<cv::Point2f> in_from, in_to;
  for (int k = 0; k < count; ++k) {
    if ((*inliers)[k]) {
      in_from.push_back(from[k]);
      in_to.push_back(to[k]);
    }
  }
  const cv::Mat h = cv::findHomography(in_from, in_to, 0);
  if (h.empty()) return std::nullopt;
  return cv::Matx33d(h);
}

}  // namespace autocal
