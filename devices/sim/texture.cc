#include "devices/sim/texture.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace autocal {
namespace {

// At most this many trilinear taps along the long axis of a stretched footprint.
constexpr int kMaxAnisotropy = 4;

inline int Wrap(int i, int n) {
  const int m = i % n;
  return m < 0 ? m + n : m;
}

inline int Floor(double x) {
  const int i = static_cast<int>(x);
  return i > x ? i - 1 : i;
}

// log2 of a positive float, piecewise linear between powers of two (exact at them, error
// below 0.09): a mip level needs no more, and this is several times cheaper than log2.
inline float FastLog2(float x) {
  int exponent = 0;
  const float mantissa = std::frexp(x, &exponent);  // x = mantissa 2^exponent, mantissa in [0.5, 1).
  return static_cast<float>(exponent - 1) + 2.0f * mantissa - 1.0f;
}

}  // namespace

Texture::Texture(const cv::Mat& bgr, double texel_m, bool repeat)
    : texel_m_(texel_m), repeat_(repeat) {
  CV_Assert(bgr.type() == CV_8UC3 && !bgr.empty() && texel_m > 0.0);
  levels_.push_back({bgr.clone(), 1.0 / texel_m, 1.0 / texel_m});
  // Each level halves the previous one by area averaging, so level texels stay aligned
  // with the ones below (cv::pyrDown would shift them by half a texel).
  while (levels_.back().image.cols > 1 || levels_.back().image.rows > 1) {
    const cv::Mat& previous = levels_.back().image;
    const cv::Size size(std::max(1, (previous.cols + 1) / 2), std::max(1, (previous.rows + 1) / 2));
    cv::Mat next;
    cv::resize(previous, next, size, 0, 0, cv::INTER_AREA);
    levels_.push_back({next, size.width / (bgr.cols * texel_m), size.height / (bgr.rows * texel_m)});
  }
}

cv::Vec3f Texture::Bilinear(const Level& level, double a, double b) const {
  const cv::Mat& image = level.image;
  const double x = a * level.scale_x - 0.5;
  const double y = b * level.scale_y - 0.5;
  int x0 = Floor(x), y0 = Floor(y);
  const float wx = static_cast<float>(x - x0), wy = static_cast<float>(y - y0);
  int x1 = x0 + 1, y1 = y0 + 1;
  if (repeat_) {
    x0 = Wrap(x0, image.cols);
    x1 = Wrap(x1, image.cols);
    y0 = Wrap(y0, image.rows);
    y1 = Wrap(y1, image.rows);
  } else {
    x0 = std::clamp(x0, 0, image.cols - 1);
    x1 = std::clamp(x1, 0, image.cols - 1);
    y0 = std::clamp(y0, 0, image.rows - 1);
    y1 = std::clamp(y1, 0, image.rows - 1);
  }
  const uchar* row0 = image.ptr<uchar>(y0);
  const uchar* row1 = image.ptr<uchar>(y1);
  cv::Vec3f out;
  for (int c = 0; c < 3; ++c) {
    const float top = row0[3 * x0 + c] + wx * (row0[3 * x1 + c] - row0[3 * x0 + c]);
    const float bottom = row1[3 * x0 + c] + wx * (row1[3 * x1 + c] - row1[3 * x0 + c]);
    out[c] = top + wy * (bottom - top);
  }
  return out;
}

cv::Vec3f Texture::Trilinear(double lod, double a, double b) const {
  if (lod <= 0.0) return Bilinear(levels_.front(), a, b);
  const int last = static_cast<int>(levels_.size()) - 1;
  if (lod >= last) return Bilinear(levels_.back(), a, b);
  const int level = static_cast<int>(lod);
  const float w = static_cast<float>(lod - level);
  const cv::Vec3f fine = Bilinear(levels_[level], a, b);
  const cv::Vec3f coarse = Bilinear(levels_[level + 1], a, b);
  return fine + w * (coarse - fine);
}

cv::Vec3f Texture::Sample(const Footprint& f) const {
  // The pixel covers the parallelogram spanned by the two per-pixel steps; filter along
  // its longer side with several taps and pick the mip level from what each tap covers.
  const double len_u = std::sqrt(f.da_du * f.da_du + f.db_du * f.db_du);
  const double len_v = std::sqrt(f.da_dv * f.da_dv + f.db_dv * f.db_dv);
  const bool u_major = len_u >= len_v;
  const double major = u_major ? len_u : len_v;
  const double area = std::abs(f.da_du * f.db_dv - f.db_du * f.da_dv);
  const double minor = major > 0.0 ? area / major : 0.0;
  const int taps =
      minor > 0.0 ? std::clamp(static_cast<int>(std::ceil(major / minor - 0.01)), 1, kMaxAnisotropy)
                  : kMaxAnisotropy;
  const double filter_width = std::max(major / taps, minor);
  const double lod = FastLog2(static_cast<float>(std::max(filter_width / texel_m_, 1e-6)));
  if (taps == 1) return Trilinear(lod, f.a, f.b);
  const double step_a = u_major ? f.da_du : f.da_dv;
  const double step_b = u_major ? f.db_du : f.db_dv;
  cv::Vec3f sum(0.f, 0.f, 0.f);
  for (int i = 0; i < taps; ++i) {
    const double s = (i + 0.5) / taps - 0.5;
    sum += Trilinear(lod, f.a + s * step_a, f.b + s * step_b);
  }
  return sum * (1.0f / taps);
}

}  // namespace autocal
