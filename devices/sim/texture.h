// Mip-mapped textures for the simulator's planes, sampled with a trilinear, anisotropic
// filter sized by each pixel's footprint on the plane, so that textures do not alias.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace autocal {

// Where a pixel (or sub-pixel) lands on a plane: plane coordinates and how they change per
// pixel step, all in metres.
struct Footprint {
  double a = 0.0, b = 0.0;          // Plane coordinates of the ray's hit.
  double da_du = 0.0, db_du = 0.0;  // Change per step along the image x axis.
  double da_dv = 0.0, db_dv = 0.0;  // Change per step along the image y axis.
};

class Texture {
 public:
  // `bgr` (CV_8UC3) covers [0, cols * texel_m) x [0, rows * texel_m) of plane
  // coordinates; texel (i, j) covers [i, i + 1) x [j, j + 1) texels, its centre at
  // (i + 0.5, j + 0.5). With `repeat` the texture tiles the plane, otherwise its border
  // texels extend. The mip pyramid is built here, once.
  Texture(const cv::Mat& bgr, double texel_m, bool repeat);

  // Filtered BGR colour (0-255) of the pixel whose footprint is given.
  cv::Vec3f Sample(const Footprint& footprint) const;

 private:
  struct Level {
    cv::Mat image;   // CV_8UC4 (BGR and a pad byte: one texel is one 32-bit load).
    double scale_x;  // Texels of this level per metre along a.
    double scale_y;  // Texels of this level per metre along b.
  };

  // Bilinear and trilinear lookups write B, G, R (and the pad) to out[0..3].
  void Bilinear(const Level& level, double a, double b, float* out) const;
  void Trilinear(double lod, double a, double b, float* out) const;

  std::vector<Level> levels_;
  double inv_texel2_;  // 1 / texel_m^2 of level 0.
  bool repeat_;
};

}  // namespace autocal
