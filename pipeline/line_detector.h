// Box 1, lines: straight lines as peaks of the linear Radon transform of the edge map,
// refined to sub-pixel accuracy and cut into segments with end points.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace autocal {

struct LineDetectorOptions {
  double canny_low = 30.0;             // Lower hysteresis threshold of the edge detector.
  double canny_high = 90.0;            // Upper hysteresis threshold of the edge detector.
  double theta_resolution_deg = 1.0;   // Angular bin of the Radon transform (refined after).
  double rho_resolution_px = 1.0;      // Distance bin of the Radon transform.
  double min_length_px = 40.0;         // Shortest segment reported.
  double max_gap_px = 3.0;             // Longest run without edge pixels inside a segment.
  double min_fill = 0.7;               // Fraction of a segment's length backed by edge pixels.
  double inlier_distance_px = 1.5;     // Edge pixels this close to a line belong to it.
  double max_normal_angle_deg = 20.0;  // Edge gradient must be this close to the line normal.
  int max_lines = 30;                  // At most this many segments per image.

  bool Check(std::string* error) const;
};

// A straight segment: the line x cos(theta) + y sin(theta) = rho (pixels, theta in
// [0, pi)) between two end points.
struct LineSegment {
  double rho = 0.0;
  double theta = 0.0;
  Eigen::Vector2d start = Eigen::Vector2d::Zero();
  Eigen::Vector2d end = Eigen::Vector2d::Zero();
  int support = 0;            // Edge pixels behind it.
  double rms_distance = 0.0;  // RMS distance of its sub-pixel edge points to the line, px.

  double Length() const { return (end - start).norm(); }
  Eigen::Vector2d Normal() const;
  Eigen::Vector2d Direction() const;
  // Signed distance of a point to the infinite line.
  double Distance(const Eigen::Vector2d& p) const;
};

class Gradients;

// Angle (radians) and offset (px) between two lines x cos(theta) + y sin(theta) = rho,
// allowing for the wrap (rho, theta) == (-rho, theta + pi).
std::pair<double, double> LineDistance(double rho_a, double theta_a, double rho_b, double theta_b);

// Finds straight segments in an 8-bit single-channel image.
std::vector<LineSegment> DetectLines(const cv::Mat& gray, const LineDetectorOptions& options);
// The same, on gradients already computed (with sigma 1) for other boxes.
std::vector<LineSegment> DetectLines(const Gradients& gradients,
                                     const LineDetectorOptions& options);

// Image gradients (CV_32F) of a smoothed image, sampled with bilinear interpolation.
class Gradients {
 public:
  // Gaussian smoothing with `sigma` before the Sobel derivatives.
  Gradients(const cv::Mat& gray, double sigma);
  // The gradient at a pixel (inside the image).
  Eigen::Vector2d At(int x, int y) const;
  // Derivative along the unit vector `direction` at a sub-pixel point (0 outside).
  double Directional(const Eigen::Vector2d& point, const Eigen::Vector2d& direction) const;
  const cv::Mat& smoothed() const { return smoothed_; }

 private:
  cv::Mat smoothed_, gx_, gy_;
};

// Sub-pixel position of the strongest edge within `search_px` of `point` along `normal`:
// the peak of a parabola through the largest directional derivative and its neighbours.
// `polarity` +1 wants the image to brighten along `normal`, -1 to darken, 0 either.
// Returns false when no edge rises above `min_strength` (grey levels per pixel).
bool LocateEdgeAlongNormal(const Gradients& gradients, const Eigen::Vector2d& point,
                           const Eigen::Vector2d& normal, double search_px, double min_strength,
                           Eigen::Vector2d* edge, int polarity = 0);

// Total-least-squares line through points: returns (rho, theta) with theta in [0, pi),
// and the RMS distance.
struct LineFit {
  double rho = 0.0;
  double theta = 0.0;
  double rms = 0.0;
};
LineFit FitLine(const std::vector<Eigen::Vector2d>& points);

}  // namespace autocal
