#include "devices/sim/texture.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

namespace autocal {
namespace {

// At most this many trilinear taps along the long axis of a stretched footprint.
constexpr int kMaxAnisotropy = 4;
// Trilinear filtering blends two mip levels only where the level of detail is more than
// this from both ("brilinear"): close to a level, that level alone is as good and half the
// work; the blend weight is stretched over the rest, so it stays continuous.
constexpr double kPureLevelBand = 0.15;

inline int Wrap(int i, int n) {
  const int m = i % n;
  return m < 0 ? m + n : m;
}

inline int Floor(double x) {
  const int i = static_cast<int>(x);
  return i > x ? i - 1 : i;
}

// log2 of a positive float, piecewise linear between powers of two (exact at them, error
// below 0.09): a mip level needs no more, and reading the float's bits is several times
// cheaper than log2.
inline float FastLog2(float x) {
  uint32_t bits = 0;
  std::memcpy(&bits, &x, sizeof(bits));
  const int exponent = static_cast<int>((bits >> 23) & 0xff) - 127;
  const float mantissa = static_cast<float>(bits & 0x7fffff) * (1.0f / 8388608.0f);
  return static_cast<float>(exponent) + mantissa;
}

}  // namespace

Texture::Texture(const cv::Mat& bgr, double texel_m, bool repeat)
    : inv_texel2_(1.0 / (texel_m * texel_m)), repeat_(repeat) {
  CV_Assert(bgr.type() == CV_8UC3 && !bgr.empty() && texel_m > 0.0);
  cv::Mat bgra;
  cv::cvtColor(bgr, bgra, cv::COLOR_BGR2BGRA);
  levels_.push_back({bgra, 1.0 / texel_m, 1.0 / texel_m});
  // Each level halves the previous one by area averaging, so level texels stay aligned
  // with the ones below (cv::pyrDown would shift them by half a texel).
  while (levels_.back().image.cols > 1 || levels_.back().image.rows > 1) {
    const cv::Mat& previous = levels_.back().image;
    const cv::Size size(std::max(1, (previous.cols + 1) / 2), std::max(1, (previous.rows + 1) / 2));
    cv::Mat next;
    cv::resize(previous, next, size, 0, 0, cv::INTER_AREA);
    levels_.push_back(
        {next, size.width / (bgr.cols * texel_m), size.height / (bgr.rows * texel_m)});
  }
}

void Texture::Bilinear(const Level& level, double a, double b, float* out) const {
  const cv::Mat& image = level.image;
  const double x = a * level.scale_x - 0.5;
  const double y = b * level.scale_y - 0.5;
  const int x0 = Floor(x), y0 = Floor(y);
  const float wx = static_cast<float>(x - x0), wy = static_cast<float>(y - y0);
  const uchar* p00;
  const uchar* p01;
  const uchar* p10;
  const uchar* p11;
  if (x0 >= 0 && y0 >= 0 && x0 + 1 < image.cols && y0 + 1 < image.rows) {
    p00 = image.data + y0 * image.step[0] + 4 * x0;
    p01 = p00 + 4;
    p10 = p00 + image.step[0];
    p11 = p10 + 4;
  } else {
    // At the border: wrap round a repeating texture, else extend the border texels.
    auto col = [&](int i) {
      return repeat_ ? Wrap(i, image.cols) : std::clamp(i, 0, image.cols - 1);
    };
    auto row = [&](int j) {
      return repeat_ ? Wrap(j, image.rows) : std::clamp(j, 0, image.rows - 1);
    };
    const uchar* row0 = image.ptr<uchar>(row(y0));
    const uchar* row1 = image.ptr<uchar>(row(y0 + 1));
    p00 = row0 + 4 * col(x0);
    p01 = row0 + 4 * col(x0 + 1);
    p10 = row1 + 4 * col(x0);
    p11 = row1 + 4 * col(x0 + 1);
  }
  auto texel = [](const uchar* p) {
    return cv::v_cvt_f32(cv::v_reinterpret_as_s32(cv::v_load_expand_q(p)));
  };
  const cv::v_float32x4 c00 = texel(p00), c01 = texel(p01), c10 = texel(p10), c11 = texel(p11);
  const cv::v_float32x4 vx = cv::v_setall_f32(wx), vy = cv::v_setall_f32(wy);
  const cv::v_float32x4 top = cv::v_muladd(c01 - c00, vx, c00);
  const cv::v_float32x4 bottom = cv::v_muladd(c11 - c10, vx, c10);
  cv::v_store(out, cv::v_muladd(bottom - top, vy, top));
}

void Texture::Trilinear(double lod, double a, double b, float* out) const {
  if (lod <= 0.0) return Bilinear(levels_.front(), a, b, out);
  const int last = static_cast<int>(levels_.size()) - 1;
  if (lod >= last) return Bilinear(levels_.back(), a, b, out);
  const int level = static_cast<int>(lod);
  const double blend = (lod - level - kPureLevelBand) / (1.0 - 2.0 * kPureLevelBand);
  if (blend <= 0.0) return Bilinear(levels_[level], a, b, out);
  if (blend >= 1.0) return Bilinear(levels_[level + 1], a, b, out);
  float fine[4], coarse[4];
  Bilinear(levels_[level], a, b, fine);
  Bilinear(levels_[level + 1], a, b, coarse);
  const cv::v_float32x4 f = cv::v_load(fine);
  cv::v_store(out,
              cv::v_muladd(cv::v_load(coarse) - f, cv::v_setall_f32(static_cast<float>(blend)), f));
}

cv::Vec3f Texture::Sample(const Footprint& f) const {
  // The pixel covers the parallelogram spanned by its two steps; filter along the longer
  // side with several taps and pick the mip level from what each tap covers. Worked in
  // squared lengths: no square roots per pixel.
  const double len2_u = f.da_du * f.da_du + f.db_du * f.db_du;
  const double len2_v = f.da_dv * f.da_dv + f.db_dv * f.db_dv;
  const bool u_major = len2_u >= len2_v;
  const double major2 = std::max(u_major ? len2_u : len2_v, 1e-30);
  const double area = std::abs(f.da_du * f.db_dv - f.db_du * f.da_dv);
  // major / minor = major^2 / area; a stretch under 1.5 is filtered by a single tap.
  const double stretch = major2 / std::max(area, 1e-30);
  const int taps = std::clamp(static_cast<int>(stretch + 0.5), 1, kMaxAnisotropy);
  const double width2 = std::max(major2 / (taps * taps), area * area / major2);
  const double lod = 0.5 * FastLog2(static_cast<float>(width2 * inv_texel2_));
  float out[4];
  if (taps == 1) {
    Trilinear(lod, f.a, f.b, out);
    return {out[0], out[1], out[2]};
  }
  const double step_a = u_major ? f.da_du : f.da_dv;
  const double step_b = u_major ? f.db_du : f.db_dv;
  cv::v_float32x4 sum = cv::v_setzero_f32();
  for (int i = 0; i < taps; ++i) {
    const double s = (i + 0.5) / taps - 0.5;
    Trilinear(lod, f.a + s * step_a, f.b + s * step_b, out);
    sum += cv::v_load(out);
  }
  cv::v_store(out, sum * cv::v_setall_f32(1.0f / taps));
  return {out[0], out[1], out[2]};
}

}  // namespace autocal
