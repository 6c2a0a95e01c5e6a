#include "pipeline/image_quality.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace autocal {
namespace {

// Good frames whose image moved within this factor of a moving frame's speed show the blur
// its exposure makes.
constexpr double kPeerSpeedRatio = 2.0;

double Median(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

// Sums for Crete-Roffet's blur measure along one axis ("The blur effect", 2007): the
// image's neighbour differences, and the part of them a 9-pixel box blur (OpenCV's
// reflect-101 border) takes away. Kept nine times over, so that all is integer: the
// blurred difference of neighbours is the difference of the two samples the box gains
// and loses, over 9.
struct BlurSums {
  int64_t total9 = 0;
  int64_t lost9 = 0;

  // Steps from[i] -> to[i], while the box gains gained[i] and loses lost[i]. Summed in
  // 32 bits over one row (at most 9 * 255 per step), which the compiler vectorizes.
  void Add(const uint8_t* from, const uint8_t* to, const uint8_t* gained, const uint8_t* lost,
           int n) {
    int32_t total = 0, removed = 0;
    for (int i = 0; i < n; ++i) {
      const int32_t sharp9 = 9 * std::abs(int32_t(to[i]) - int32_t(from[i]));
      total += sharp9;
      removed += std::max(sharp9 - std::abs(int32_t(gained[i]) - int32_t(lost[i])), 0);
    }
    total9 += total;
    lost9 += removed;
  }
  double Kept() const {
    if (total9 == 0) return 1.0;  // A flat image: nothing left to lose.
    return double(total9 - lost9) / double(total9);
  }
};

}  // namespace

// One pass over the rows, in integers, instead of OpenCV's filters on a float copy: the
// same measures (the noise exactly, the blur to rounding) in about a tenth of the time,
// since this runs on every frame.
ImageQuality MeasureImageQuality(const cv::Mat& image) {
  cv::Mat grey;
  if (image.channels() == 3) {
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  } else {
    grey = image;
  }
  CV_Assert(grey.type() == CV_8UC1);
  ImageQuality quality;
  const int width = grey.cols, height = grey.rows;
  if (width < 3 || height < 3) return quality;

  // The 9-pixel box around x + 1 gains the sample at x + 5 and loses the one at x - 4.
  constexpr int kBoxRadius = 4;
  auto reflect = [](int i, int size) {
    return cv::borderInterpolate(i, size, cv::BORDER_REFLECT_101);
  };
  // Columns whose box reaches over the border take their samples through these tables.
  const int inner_begin = std::min(kBoxRadius, width - 1);
  const int inner_end = std::max(inner_begin, width - kBoxRadius - 1);
  std::vector<int> border_columns;
  for (int x = 0; x + 1 < width; ++x) {
    if (x < inner_begin || x >= inner_end) border_columns.push_back(x);
  }
  std::vector<uint8_t> border_samples[4];

  // Immerkaer's mask (1 -2 1; -2 4 -2; 1 -2 1) is the horizontal second difference taken
  // again vertically: three rows of horizontal second differences roll down the image.
  std::vector<int16_t> second[3];
  for (auto& row : second) row.assign(width, 0);
  int64_t noise_sum = 0;
  BlurSums along_rows, along_columns;
  int histogram[256] = {};
  for (int y = 0; y < height; ++y) {
    const uint8_t* row = grey.ptr<uint8_t>(y);
    for (int x = 0; x < width; ++x) ++histogram[row[x]];
    along_rows.Add(row + inner_begin, row + inner_begin + 1, row + inner_begin + kBoxRadius + 1,
                   row + inner_begin - kBoxRadius, inner_end - inner_begin);
    for (auto& samples : border_samples) samples.clear();
    for (const int x : border_columns) {
      border_samples[0].push_back(row[x]);
      border_samples[1].push_back(row[x + 1]);
      border_samples[2].push_back(row[reflect(x + kBoxRadius + 1, width)]);
      border_samples[3].push_back(row[reflect(x - kBoxRadius, width)]);
    }
    along_rows.Add(border_samples[0].data(), border_samples[1].data(), border_samples[2].data(),
                   border_samples[3].data(), int(border_columns.size()));
    if (y + 1 < height) {
      along_columns.Add(row, grey.ptr<uint8_t>(y + 1),
                        grey.ptr<uint8_t>(reflect(y + kBoxRadius + 1, height)),
                        grey.ptr<uint8_t>(reflect(y - kBoxRadius, height)), width);
    }
    int16_t* newest = second[y % 3].data();
    for (int x = 1; x + 1 < width; ++x) {
      newest[x] = int16_t(row[x - 1] - 2 * row[x] + row[x + 1]);
    }
    if (y >= 2) {
      const int16_t* above = second[(y - 2) % 3].data();
      const int16_t* middle = second[(y - 1) % 3].data();
      int32_t row_sum = 0;  // At most 16 * 255 per pixel.
      for (int x = 1; x + 1 < width; ++x) row_sum += std::abs(above[x] - 2 * middle[x] + newest[x]);
      noise_sum += row_sum;
    }
  }
  // Immerkaer, "Fast noise variance estimation", 1996.
  const double inner_area = double(width - 2) * double(height - 2);
  quality.noise_grey = std::sqrt(M_PI / 2.0) * double(noise_sum) / (6.0 * inner_area);
  quality.blur = std::max(along_rows.Kept(), along_columns.Kept());

  const double total = double(grey.total());
  double seen = 0.0;
  int low = -1, high = 255;
  for (int level = 0; level < 256; ++level) {
    seen += histogram[level];
    if (low < 0 && seen >= 0.05 * total) low = level;
    if (seen >= 0.95 * total) {
      high = level;
      break;
    }
  }
  quality.contrast_grey = double(high - std::max(low, 0));
  return quality;
}

std::optional<double> ImageSpeedPx(const std::vector<Track>& tracks) {
  std::vector<double> flow;
  for (const Track& track : tracks) {
    if (const TrackPoint* before = track.FramesAgo(1)) {
      flow.push_back(cv::norm(track.current() - before->pixel));
    }
  }
  if (flow.empty()) return std::nullopt;
  return Median(std::move(flow));
}

bool ImageQualityOptions::Check(std::string* error) const {
  auto fail = [&](const std::string& what) {
    if (error) *error = what;
    return false;
  };
  if (!(baseline_s > 0.0)) return fail("baseline_s must be > 0");
  if (min_baseline_frames < 1) return fail("min_baseline_frames must be >= 1");
  if (!(max_blur_increase > 0.0)) return fail("max_blur_increase must be > 0");
  if (!(fog_blur_increase > 0.0)) return fail("fog_blur_increase must be > 0");
  if (!(fog_contrast_ratio > 0.0 && fog_contrast_ratio <= 1.0)) {
    return fail("fog_contrast_ratio must be in (0, 1]");
  }
  if (!(fog_noise_ratio > 0.0 && fog_noise_ratio <= 1.0)) {
    return fail("fog_noise_ratio must be in (0, 1]");
  }
  if (!(max_noise_ratio >= 1.0)) return fail("max_noise_ratio must be >= 1");
  if (!(min_noise_increase_grey >= 0.0)) return fail("min_noise_increase_grey must be >= 0");
  if (!(min_contrast_ratio > 0.0 && min_contrast_ratio <= 1.0)) {
    return fail("min_contrast_ratio must be in (0, 1]");
  }
  if (!(motion_blur_speed_px > 0.0)) return fail("motion_blur_speed_px must be > 0");
  if (!(accept_as_usual_s > 0.0)) return fail("accept_as_usual_s must be > 0");
  return true;
}

ImageQualityGate::ImageQualityGate(const ImageQualityOptions& options) : options_(options) {}

std::optional<std::string> ImageQualityGate::Judge(int64_t t_ns, const ImageQuality& quality,
                                                   std::optional<double> image_speed_px) {
  if (!options_.enabled) return std::nullopt;
  const double speed = image_speed_px.value_or(0.0);
  const bool moving = speed >= options_.motion_blur_speed_px;
  auto keep_as_good = [&] {
    degraded_since_ns_.reset();
    good_.push_back({t_ns, quality, speed});
    // Pruned only when a good frame comes, and never below the frames needed, so that a
    // long fault keeps the baseline from before it.
    while (int(good_.size()) > options_.min_baseline_frames &&
           double(t_ns - good_.front().t_ns) > options_.baseline_s * 1e9) {
      good_.pop_front();
    }
    return std::nullopt;
  };
  if (int(good_.size()) < options_.min_baseline_frames) return keep_as_good();

  // Blur and the noise measured (which the scene's smoothed texture lowers) are compared
  // with good frames whose image moved about as fast; contrast with all of them.
  std::vector<double> noise, blur, contrast, peer_noise, peer_blur;
  for (const Sample& sample : good_) {
    noise.push_back(sample.quality.noise_grey);
    blur.push_back(sample.quality.blur);
    contrast.push_back(sample.quality.contrast_grey);
    const bool peer = moving ? sample.speed_px >= speed / kPeerSpeedRatio &&
                                   sample.speed_px <= speed * kPeerSpeedRatio
                             : sample.speed_px < options_.motion_blur_speed_px;
    if (peer) {
      peer_noise.push_back(sample.quality.noise_grey);
      peer_blur.push_back(sample.quality.blur);
    }
  }
  // Too few such frames, and the frame moving: its blur may be the exposure's alone.
  const bool peers_known = 2 * int(peer_blur.size()) >= options_.min_baseline_frames;
  const bool lenient = moving && !peers_known;
  const double usual_noise = Median(peers_known ? peer_noise : noise);
  const double usual_blur = Median(peers_known ? peer_blur : blur);
  const double usual_contrast = Median(contrast);
  std::ostringstream why;
  why.precision(2);
  why << std::fixed;
  const double blur_increase = quality.blur - usual_blur;
  const double contrast_ratio = quality.contrast_grey / std::max(usual_contrast, 1.0);
  const bool blurred_sign = blur_increase > options_.fog_blur_increase;
  const bool faded_sign = contrast_ratio < options_.fog_contrast_ratio;
  const bool smoothed_sign = quality.noise_grey < options_.fog_noise_ratio * usual_noise;
  const bool fogged = lenient ? faded_sign && (blurred_sign || smoothed_sign)
                              : blurred_sign + faded_sign + smoothed_sign >= 2;
  if (fogged) {
    why << "fogged (blur " << quality.blur << ", usually " << usual_blur << "; contrast "
        << quality.contrast_grey << " grey levels, usually " << usual_contrast << "; noise "
        << quality.noise_grey << ", usually " << usual_noise;
    if (moving) why << "; the image moving " << speed << " px a frame";
    why << ")";
  } else if (!lenient && blur_increase > options_.max_blur_increase) {
    why << "blurred (" << quality.blur << ", usually " << usual_blur;
    if (moving) why << ", the image moving " << speed << " px a frame";
    why << ")";
  } else if (contrast_ratio < options_.min_contrast_ratio) {
    why << "low contrast (" << quality.contrast_grey << " grey levels, usually "
        << usual_contrast << ")";
  }
  if (quality.noise_grey > options_.max_noise_ratio * usual_noise &&
      quality.noise_grey > usual_noise + options_.min_noise_increase_grey) {
    why << (why.tellp() > 0 ? ", " : "") << "noisy (" << quality.noise_grey
        << " grey levels, usually " << usual_noise << ")";
  }
  if (why.tellp() == 0) return keep_as_good();
  if (!degraded_since_ns_) degraded_since_ns_ = t_ns;
  if (double(t_ns - *degraded_since_ns_) > options_.accept_as_usual_s * 1e9) {
    good_.clear();
    return keep_as_good();
  }
  return "image degraded: " + why.str();
}

}  // namespace autocal
