#include "pipeline/homography_ransac.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

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

// Scales and shifts points to their centroid at a mean distance of sqrt(2), the same in x
// and y so that squared distances keep their proportions (Hartley's normalization).
Eigen::Matrix3d Normalizer(std::span<const cv::Point2f> points) {
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (const cv::Point2f& p : points) centroid += Eigen::Vector2d(p.x, p.y);
  centroid /= double(points.size());
  double distance = 0.0;
  for (const cv::Point2f& p : points) distance += (Eigen::Vector2d(p.x, p.y) - centroid).norm();
  distance /= double(points.size());
  const double scale = distance > 0.0 ? std::sqrt(2.0) / distance : 1.0;
  Eigen::Matrix3d t = Eigen::Matrix3d::Identity();
  t(0, 0) = t(1, 1) = scale;
  t.topRightCorner<2, 1>() = -scale * centroid;
  return t;
}

}  // namespace

std::optional<cv::Matx33d> FitHomography(std::span<const cv::Point2f> from,
                                         std::span<const cv::Point2f> to) {
  CV_Assert(from.size() == to.size());
  const int count = int(from.size());
  if (count < 4) return std::nullopt;
  const Eigen::Matrix3d t_from = Normalizer(from), t_to = Normalizer(to);
  std::vector<Eigen::Vector2d> p(count), q(count);
  for (int i = 0; i < count; ++i) {
    p[i] = (t_from * Eigen::Vector3d(from[i].x, from[i].y, 1.0)).head<2>();
    q[i] = (t_to * Eigen::Vector3d(to[i].x, to[i].y, 1.0)).head<2>();
  }

  // The linear fit: the unit h minimizing |A h|, the eigenvector of A^T A with the smallest
  // eigenvalue.
  Eigen::Matrix<double, 9, 9> ata = Eigen::Matrix<double, 9, 9>::Zero();
  for (int i = 0; i < count; ++i) {
    Eigen::Matrix<double, 9, 1> u, v;
    u << p[i].x(), p[i].y(), 1.0, 0.0, 0.0, 0.0, -q[i].x() * p[i].x(), -q[i].x() * p[i].y(),
        -q[i].x();
    v << 0.0, 0.0, 0.0, p[i].x(), p[i].y(), 1.0, -q[i].y() * p[i].x(), -q[i].y() * p[i].y(),
        -q[i].y();
    ata.selfadjointView<Eigen::Lower>().rankUpdate(u);
    ata.selfadjointView<Eigen::Lower>().rankUpdate(v);
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eigen(
      ata.selfadjointView<Eigen::Lower>());
  if (eigen.info() != Eigen::Success) return std::nullopt;
  // Points that fix no homography leave more than one direction of (nearly) no residual.
  if (!(eigen.eigenvalues()(1) > 1e-9 * eigen.eigenvalues()(8))) return std::nullopt;
  const Eigen::Matrix<double, 9, 1> smallest = eigen.eigenvectors().col(0);
  if (std::abs(smallest(8)) < 1e-12) return std::nullopt;
  Eigen::Matrix<double, 8, 1> h = smallest.head<8>() / smallest(8);

  // Levenberg-Marquardt on the transfer error, in the normalized frames: the same
  // minimum, since the normalization scales every error in `to` alike, and a better
  // conditioned problem. `squared_error` gives the error at x, with J^T J (its lower
  // triangle) and J^T r.
  const auto squared_error = [&](const Eigen::Matrix<double, 8, 1>& x,
                                 Eigen::Matrix<double, 8, 8>* jtj,
                                 Eigen::Matrix<double, 8, 1>* jtr) {
    double sum = 0.0;
    jtj->setZero();
    jtr->setZero();
    for (int i = 0; i < count; ++i) {
      const double a = p[i].x(), b = p[i].y();
      const double w = 1.0 / (x(6) * a + x(7) * b + 1.0);
      const double u = (x(0) * a + x(1) * b + x(2)) * w, v = (x(3) * a + x(4) * b + x(5)) * w;
      const double du = u - q[i].x(), dv = v - q[i].y();
      sum += du * du + dv * dv;
      Eigen::Matrix<double, 8, 1> ju, jv;
      ju << a * w, b * w, w, 0.0, 0.0, 0.0, -u * a * w, -u * b * w;
      jv << 0.0, 0.0, 0.0, a * w, b * w, w, -v * a * w, -v * b * w;
      jtj->selfadjointView<Eigen::Lower>().rankUpdate(ju);
      jtj->selfadjointView<Eigen::Lower>().rankUpdate(jv);
      *jtr += ju * du + jv * dv;
    }
    return sum;
  };
  Eigen::Matrix<double, 8, 8> jtj;
  Eigen::Matrix<double, 8, 1> jtr;
  double error = squared_error(h, &jtj, &jtr);
  double damping = 1e-3;
  // As many steps as OpenCV's refinement takes at most.
  for (int iteration = 0; iteration < 10 && std::isfinite(error); ++iteration) {
    Eigen::Matrix<double, 8, 8> damped = jtj.selfadjointView<Eigen::Lower>();
    damped.diagonal() *= 1.0 + damping;
    const Eigen::Matrix<double, 8, 1> step = damped.ldlt().solve(-jtr);
    if (!(step.norm() > 1e-12 * h.norm())) break;
    const Eigen::Matrix<double, 8, 1> next = h + step;
    Eigen::Matrix<double, 8, 8> next_jtj;
    Eigen::Matrix<double, 8, 1> next_jtr;
    const double next_error = squared_error(next, &next_jtj, &next_jtr);
    if (next_error < error) {
      const bool converged = error - next_error <= 1e-12 * error;
      h = next;
      error = next_error;
      jtj = next_jtj;
      jtr = next_jtr;
      damping = std::max(damping / 10.0, 1e-9);
      if (converged) break;
    } else {
      damping *= 10.0;
    }
  }

  Eigen::Matrix3d normalized;
  normalized << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), 1.0;
  const Eigen::Matrix3d fitted = t_to.inverse() * normalized * t_from;
  if (!fitted.allFinite() || fitted(2, 2) == 0.0) return std::nullopt;
  cv::Matx33d result;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) result(r, c) = fitted(r, c) / fitted(2, 2);
  }
  return result;
}

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
  return FitHomography(in_from, in_to);
}

}  // namespace autocal
