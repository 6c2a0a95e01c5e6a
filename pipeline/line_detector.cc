#include "pipeline/line_detector.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

namespace autocal {

bool LineDetectorOptions::Check(std::string* error) const {
  std::ostringstream why;
  if (!(canny_low > 0 && canny_high >= canny_low)) {
    why << "edge thresholds need 0 < canny_low <= canny_high";
  } else if (!(theta_resolution_deg > 0 && theta_resolution_deg <= 5)) {
    why << "theta_resolution_deg must be in (0, 5]";
  } else if (!(rho_resolution_px > 0 && rho_resolution_px <= 5)) {
    why << "rho_resolution_px must be in (0, 5]";
  } else if (!(min_length_px >= 5)) {
    why << "min_length_px must be at least 5";
  } else if (!(max_gap_px >= 0)) {
    why << "max_gap_px must not be negative";
  } else if (!(min_fill > 0 && min_fill <= 1)) {
    why << "min_fill must be in (0, 1]";
  } else if (!(inlier_distance_px > 0)) {
    why << "inlier_distance_px must be positive";
  } else if (!(max_normal_angle_deg > 0 && max_normal_angle_deg < 90)) {
    why << "max_normal_angle_deg must be in (0, 90)";
  } else if (max_lines < 1) {
    why << "max_lines must be at least 1";
  }
  if (why.str().empty()) return true;
  if (error) *error = why.str();
  return false;
}

std::pair<double, double> LineDistance(double rho_a, double theta_a, double rho_b, double theta_b) {
  double dtheta = std::abs(std::remainder(theta_a - theta_b, 2 * M_PI));
  double drho = std::abs(rho_a - rho_b);
  if (dtheta > M_PI / 2) {
    dtheta = std::abs(std::remainder(theta_a - theta_b + M_PI, 2 * M_PI));
    drho = std::abs(rho_a + rho_b);
  }
  return {dtheta, drho};
}

Eigen::Vector2d LineSegment::Normal() const { return {std::cos(theta), std::sin(theta)}; }
Eigen::Vector2d LineSegment::Direction() const { return {-std::sin(theta), std::cos(theta)}; }
double LineSegment::Distance(const Eigen::Vector2d& p) const { return Normal().dot(p) - rho; }

Gradients::Gradients(const cv::Mat& gray, double sigma) {
  CV_Assert(gray.type() == CV_8UC1);
  cv::GaussianBlur(gray, smoothed_, cv::Size(), sigma);
  // Scharr-free Sobel scaled to grey levels per pixel.
  cv::Sobel(smoothed_, gx_, CV_32F, 1, 0, 3, 1.0 / 8.0);
  cv::Sobel(smoothed_, gy_, CV_32F, 0, 1, 3, 1.0 / 8.0);
}

namespace {

float Bilinear(const cv::Mat& image, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= image.cols || y0 + 1 >= image.rows) return 0.0f;
  const float ax = static_cast<float>(x - x0), ay = static_cast<float>(y - y0);
  const float* row0 = image.ptr<float>(y0) + x0;
  const float* row1 = image.ptr<float>(y0 + 1) + x0;
  return (1 - ay) * ((1 - ax) * row0[0] + ax * row0[1]) + ay * ((1 - ax) * row1[0] + ax * row1[1]);
}

}  // namespace

Eigen::Vector2d Gradients::At(int x, int y) const {
  return {gx_.at<float>(y, x), gy_.at<float>(y, x)};
}

double Gradients::Directional(const Eigen::Vector2d& p, const Eigen::Vector2d& d) const {
  return d.x() * Bilinear(gx_, p.x(), p.y()) + d.y() * Bilinear(gy_, p.x(), p.y());
}

bool LocateEdgeAlongNormal(const Gradients& gradients, const Eigen::Vector2d& point,
                           const Eigen::Vector2d& normal, double search_px, double min_strength,
                           Eigen::Vector2d* edge, int polarity) {
  // Sample the edge strength every pixel: finer steps only interpolate the same pixels,
  // which flattens the peak and biases the parabola toward the sample grid.
  constexpr double kStep = 1.0;
  const int n = static_cast<int>(std::ceil(search_px / kStep));
  double best = 0.0;
  int best_k = 0;
  std::vector<double> strength(2 * n + 3);
  for (int k = -n - 1; k <= n + 1; ++k) {
    const double derivative = gradients.Directional(point + k * kStep * normal, normal);
    strength[k + n + 1] =
        polarity == 0 ? std::abs(derivative) : std::max(0.0, polarity * derivative);
  }
  for (int k = -n; k <= n; ++k) {
    if (strength[k + n + 1] > best) {
      best = strength[k + n + 1];
      best_k = k;
    }
  }
  if (best < min_strength) return false;
  const double left = strength[best_k + n], centre = best, right = strength[best_k + n + 2];
  const double curvature = left - 2 * centre + right;
  // A plateau (or a maximum at the search border) has no defined peak.
  if (!(curvature < 0)) return false;
  const double offset = 0.5 * (left - right) / curvature;
  *edge = point + (best_k + offset) * kStep * normal;
  return true;
}

LineFit FitLine(const std::vector<Eigen::Vector2d>& points) {
  LineFit fit;
  if (points.size() < 2) return fit;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : points) mean += p;
  mean /= double(points.size());
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  for (const auto& p : points) scatter += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver(scatter);
  Eigen::Vector2d normal = solver.eigenvectors().col(0);  // Smallest eigenvalue.
  double theta = std::atan2(normal.y(), normal.x());
  if (theta < 0) theta += M_PI;
  if (theta >= M_PI) theta -= M_PI;
  normal = {std::cos(theta), std::sin(theta)};
  fit.theta = theta;
  fit.rho = normal.dot(mean);
  fit.rms = std::sqrt(std::max(0.0, solver.eigenvalues()(0)) / double(points.size()));
  return fit;
}

namespace {

// Peaks this close to a found segment's line are that line again.
constexpr double kSameLineRadians = 2.0 * M_PI / 180.0;
constexpr double kSameLinePx = 3.0;

// An edge pixel near a line, and its position along the line.
struct EdgePixel {
  double s;
  int x, y;
};

// Edge pixels within the inlier distance of the infinite line (rho, theta) whose gradient
// runs along the line's normal, ordered along the line, between s_from and s_to. This runs
// for every Radon peak: the band is walked along the line's major axis, each pixel once,
// so nothing has to be marked as seen. Skips pixels already claimed by a segment.
std::vector<EdgePixel> CollectEdgePixels(const cv::Mat& edges, const cv::Mat& claimed,
                                         const Gradients& gradients, double rho, double theta,
                                         const LineDetectorOptions& options, double s_from = -1e9,
                                         double s_to = 1e9) {
  const Eigen::Vector2d normal(std::cos(theta), std::sin(theta));
  const Eigen::Vector2d direction(-normal.y(), normal.x());
  const double cos_limit = std::cos(options.max_normal_angle_deg * M_PI / 180.0);
  // Walk along x where the line is nearer horizontal, else along y (the band is then
  // at most 2 * inlier distance * sqrt(2) pixels across the walk).
  const bool along_x = std::abs(normal.y()) >= std::abs(normal.x());
  const int major_size = along_x ? edges.cols : edges.rows;
  const int minor_size = along_x ? edges.rows : edges.cols;
  const double major_cos = along_x ? normal.x() : normal.y();
  const double minor_cos = along_x ? normal.y() : normal.x();
  const double half_band = options.inlier_distance_px / std::abs(minor_cos);
  // The stretch [s_from, s_to] of the line spans these columns (rows), widened by the band.
  int major_begin = 1, major_end = major_size - 1;
  const double major_foot = rho * major_cos, major_step = along_x ? direction.x() : direction.y();
  if (s_from > -1e8 && s_to < 1e8) {
    const double a = major_foot + s_from * major_step, b = major_foot + s_to * major_step;
    const double margin = options.inlier_distance_px + 1.0;
    major_begin = std::max(major_begin, int(std::floor(std::min(a, b) - margin)));
    major_end = std::min(major_end, int(std::ceil(std::max(a, b) + margin)) + 1);
  }
  std::vector<EdgePixel> pixels;
  for (int major = major_begin; major < major_end; ++major) {
    // Where the line crosses this column (row), and the band around it.
    const double centre = (rho - major * major_cos) / minor_cos;
    const int low = std::max(1, int(std::ceil(centre - half_band)));
    const int high = std::min(minor_size - 2, int(std::floor(centre + half_band)));
    for (int minor = low; minor <= high; ++minor) {
      const int x = along_x ? major : minor, y = along_x ? minor : major;
      if (!edges.at<uint8_t>(y, x) || claimed.at<uint8_t>(y, x)) continue;
      const Eigen::Vector2d pixel(x, y);
      if (std::abs(normal.dot(pixel) - rho) > options.inlier_distance_px) continue;
      const double s = direction.dot(pixel);
      if (s < s_from || s > s_to) continue;
      // The edge must run along the line: its gradient close to the line's normal.
      const Eigen::Vector2d gradient = gradients.At(x, y);
      const double magnitude = gradient.norm();
      if (magnitude <= 0 || std::abs(gradient.dot(normal)) < cos_limit * magnitude) continue;
      pixels.push_back({s, x, y});
    }
  }
  std::sort(pixels.begin(), pixels.end(),
            [](const EdgePixel& a, const EdgePixel& b) { return a.s < b.s; });
  return pixels;
}

// A line (rho, theta) of the Radon transform and how many edge pixels voted for it.
struct RadonPeak {
  double rho, theta;
  int votes;
};

// The linear Radon transform of the sparse edge map, binned as cv::HoughLines bins it, and
// its local maxima above `min_votes`, strongest first. Each edge pixel votes only for the
// lines its gradient could be normal to (within max_normal_angle_deg, as CollectEdgePixels
// asks of a line's pixels): a quarter of the votes of every orientation at the defaults,
// and no peaks raised by edges that cross the line.
std::vector<RadonPeak> FindRadonPeaks(const cv::Mat& edges, const Gradients& gradients,
                                      const LineDetectorOptions& options, int min_votes) {
  const double theta_step = options.theta_resolution_deg * M_PI / 180.0;
  const int thetas = static_cast<int>(std::lround(M_PI / theta_step));
  const double max_rho = edges.cols + edges.rows;
  const int rhos = static_cast<int>(std::lround((2 * max_rho + 1) / options.rho_resolution_px));
  const double rho_offset = (rhos - 1) / 2;
  std::vector<double> cos_table(thetas), sin_table(thetas);
  for (int n = 0; n < thetas; ++n) {
    cos_table[n] = std::cos(n * theta_step) / options.rho_resolution_px;
    sin_table[n] = std::sin(n * theta_step) / options.rho_resolution_px;
  }
  const double reach = options.max_normal_angle_deg * M_PI / 180.0;
  // An angle bin counted past either end, brought into [0, thetas).
  const auto wrapped = [thetas](int n) {
    while (n < 0) n += thetas;
    while (n >= thetas) n -= thetas;
    return n;
  };
  // Each edge pixel votes for the run of angles its gradient could be normal to: `count`
  // of them from `first` on.
  struct Voter {
    int x, y, first, count;
  };
  std::vector<Voter> found;
  int most_angles = 0;
  for (int y = 0; y < edges.rows; ++y) {
    const uint8_t* row = edges.ptr<uint8_t>(y);
    for (int x = 0; x < edges.cols; ++x) {
      // Edge pixels are a few in a hundred: eight pixels at a time until one is.
      if (x % 8 == 0 && x + 8 <= edges.cols) {
        uint64_t eight;
        std::memcpy(&eight, row + x, sizeof eight);
        if (!eight) {
          x += 7;
          continue;
        }
      }
      if (!row[x]) continue;
      const Eigen::Vector2d g = gradients.At(x, y);
      if (g.x() == 0 && g.y() == 0) continue;
      const double angle = std::atan2(g.y(), g.x());
      const int first = static_cast<int>(std::ceil((angle - reach) / theta_step));
      const int last = static_cast<int>(std::floor((angle + reach) / theta_step));
      if (last < first) continue;
      // Normals a half turn apart are one line (theta in [0, pi), rho of either sign).
      found.push_back({x, y, wrapped(first), last - first + 1});
      most_angles = std::max(most_angles, last - first + 1);
    }
  }
  // Grouped by first angle, and within a group by count, largest first (a counting sort):
  // the pixels voting for angle n from `ahead` angles before it are then one run of
  // x and y.
  const int keys_per_angle = most_angles + 1;
  const auto key = [&](int first, int count) {
    return first * keys_per_angle + (most_angles - count);
  };
  std::vector<int> key_begin(size_t(thetas) * keys_per_angle + 1, 0);
  for (const Voter& voter : found) ++key_begin[key(voter.first, voter.count) + 1];
  for (size_t k = 1; k < key_begin.size(); ++k) key_begin[k] += key_begin[k - 1];
  std::vector<int> xs(found.size()), ys(found.size());
  {
    std::vector<int> next(key_begin.begin(), key_begin.end() - 1);
    for (const Voter& voter : found) {
      const int at = next[key(voter.first, voter.count)]++;
      xs[at] = voter.x;
      ys[at] = voter.y;
    }
  }
  // Stored by angle, then distance, and filled an angle at a time: the votes of one angle
  // land in one row that stays in the cache (cast a pixel at a time, each vote landed in a
  // cache line of its own). Each run's distances are computed first and counted after: in
  // one loop a vote took three times as long. A border of empty bins all round keeps the
  // neighbour comparisons inside; 16 bits hold more votes than an image has pixels on a line.
  const int stride = rhos + 2;
  std::vector<uint16_t> accumulator(size_t(thetas + 2) * stride, 0);
  auto bin = [&](int n, int r) -> uint16_t& { return accumulator[size_t(n + 1) * stride + r + 1]; };
  std::vector<int> distances(found.size());
  for (int n = 0; n < thetas; ++n) {
    uint16_t* row = &bin(n, 0);
    const double cos_n = cos_table[n], sin_n = sin_table[n];
    for (int ahead = 0; ahead < most_angles; ++ahead) {
      const int first = wrapped(n - ahead);
      // Those of the group with more than `ahead` angles.
      const int begin = key_begin[key(first, most_angles)];
      const int end = key_begin[key(first, ahead + 1) + 1];
      for (int i = begin; i < end; ++i) {
        // Rounded to the nearest bin (the sum is positive: truncation floors).
        distances[i - begin] = static_cast<int>(xs[i] * cos_n + ys[i] * sin_n + rho_offset + 0.5);
      }
      for (int i = 0; i < end - begin; ++i) ++row[distances[i]];
    }
  }
  // Scanned in memory order. Most bins hold fewer votes than a line needs: a block of them
  // is passed over on its largest count.
  constexpr int kBlock = 16;
  std::vector<RadonPeak> peaks;
  for (int n = 0; n < thetas; ++n) {
    const uint16_t* before = &bin(n - 1, 0);
    const uint16_t* row = &bin(n, 0);
    const uint16_t* after = &bin(n + 1, 0);
    for (int block = 0; block < rhos; block += kBlock) {
      const int block_end = std::min(rhos, block + kBlock);
      uint16_t most = 0;
      for (int r = block; r < block_end; ++r) most = std::max(most, row[r]);
      if (most <= min_votes) continue;
      for (int r = block; r < block_end; ++r) {
        const int votes = row[r];
        if (votes > min_votes && votes > row[r - 1] && votes >= row[r + 1] && votes > before[r] &&
            votes >= after[r]) {
          peaks.push_back({(r - rho_offset) * options.rho_resolution_px, n * theta_step, votes});
        }
      }
    }
  }
  // Strongest first; among equals by angle, then distance (the order peaks are tried in
  // decides which of two lines claims a shared pixel).
  std::sort(peaks.begin(), peaks.end(), [](const RadonPeak& a, const RadonPeak& b) {
    if (a.votes != b.votes) return a.votes > b.votes;
    if (a.theta != b.theta) return a.theta < b.theta;
    return a.rho < b.rho;
  });
  return peaks;
}

}  // namespace

std::vector<LineSegment> DetectLines(const cv::Mat& gray, const LineDetectorOptions& options) {
  return DetectLines(Gradients(gray, 1.0), options);
}

std::vector<LineSegment> DetectLines(const Gradients& gradients,
                                     const LineDetectorOptions& options) {
  cv::Mat edges;
  cv::Canny(gradients.smoothed(), edges, options.canny_low, options.canny_high, 3, true);

  const int min_votes = static_cast<int>(options.min_length_px * options.min_fill);
  std::vector<RadonPeak> peaks = FindRadonPeaks(edges, gradients, options, min_votes);
  // Weak peaks past a few per wanted line are clutter (texture, noise): not worth a look.
  peaks.resize(std::min<size_t>(peaks.size(), 2 * options.max_lines));

  std::vector<LineSegment> segments;
  cv::Mat claimed = cv::Mat::zeros(edges.size(), CV_8U);
  for (const RadonPeak& peak : peaks) {
    if (int(segments.size()) >= options.max_lines) break;
    double rho = peak.rho, theta = peak.theta;
    // Neighbouring bins of a line already taken hold its own votes again.
    const bool taken = std::any_of(segments.begin(), segments.end(), [&](const LineSegment& s) {
      const auto [dtheta, drho] = LineDistance(s.rho, s.theta, rho, theta);
      return dtheta < kSameLineRadians && drho < kSameLinePx;
    });
    if (taken) continue;
    std::vector<EdgePixel> pixels =
        CollectEdgePixels(edges, claimed, gradients, rho, theta, options);
    if (int(pixels.size()) < min_votes) continue;
    // The Radon bins quantize the peak: refit on its pixels and look again.
    std::vector<Eigen::Vector2d> xy;
    for (const EdgePixel& p : pixels) xy.emplace_back(p.x, p.y);
    const LineFit coarse = FitLine(xy);
    // The refitted line turns a little: its positions along the line shift by under a
    // pixel per hundred, so the same stretch widened by the longest gap holds the pixels.
    const Eigen::Vector2d first(pixels.front().x, pixels.front().y);
    const Eigen::Vector2d last(pixels.back().x, pixels.back().y);
    rho = coarse.rho;
    theta = coarse.theta;
    const Eigen::Vector2d along(-std::sin(theta), std::cos(theta));
    const double margin = options.max_gap_px + 2.0;
    const double s_first = along.dot(first), s_last = along.dot(last);
    pixels =
        CollectEdgePixels(edges, claimed, gradients, rho, theta, options,
                          std::min(s_first, s_last) - margin, std::max(s_first, s_last) + margin);
    if (int(pixels.size()) < min_votes) continue;
    const Eigen::Vector2d normal(std::cos(theta), std::sin(theta));

    // Cut the line at gaps; each run long and full enough becomes a segment, fitted on
    // the sub-pixel positions of its edge points.
    size_t begin = 0;
    for (size_t i = 1; i <= pixels.size(); ++i) {
      if (i < pixels.size() && pixels[i].s - pixels[i - 1].s <= options.max_gap_px + 1.0) continue;
      const double length = pixels[i - 1].s - pixels[begin].s;
      const size_t run_begin = begin;
      begin = i;
      if (length < options.min_length_px || i - run_begin < options.min_fill * length) continue;
      std::vector<Eigen::Vector2d> points;
      for (size_t j = run_begin; j < i; ++j) {
        Eigen::Vector2d edge;
        if (LocateEdgeAlongNormal(gradients, Eigen::Vector2d(pixels[j].x, pixels[j].y), normal, 1.0,
                                  1.0, &edge) &&
            std::abs(normal.dot(edge) - rho) <= options.inlier_distance_px) {
          points.push_back(edge);
        }
      }
      if (points.size() < options.min_fill * length) continue;
      const LineFit fit = FitLine(points);
      LineSegment segment;
      segment.rho = fit.rho;
      segment.theta = fit.theta;
      segment.rms_distance = fit.rms;
      segment.support = static_cast<int>(points.size());
      // End points: the extreme edge points projected onto the fitted line.
      const Eigen::Vector2d n = segment.Normal();
      segment.start = points.front() - segment.Distance(points.front()) * n;
      segment.end = points.back() - segment.Distance(points.back()) * n;
      for (size_t j = run_begin; j < i; ++j) claimed.at<uint8_t>(pixels[j].y, pixels[j].x) = 1;
      segments.push_back(segment);
      if (int(segments.size()) >= options.max_lines) break;
    }
  }
  return segments;
}

}  // namespace autocal
