#include "pipeline/image_quality.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace autocal {
namespace {

// The share of the image's neighbour differences that a 9-pixel box blur along `axis`
// leaves in place (Crete-Roffet et al., "The blur effect", 2007).
double BlurAlong(const cv::Mat& grey, int axis) {
  cv::Mat blurred;
  cv::blur(grey, blurred, axis == 0 ? cv::Size(9, 1) : cv::Size(1, 9));
  const cv::Rect later = axis == 0 ? cv::Rect(1, 0, grey.cols - 1, grey.rows)
                                   : cv::Rect(0, 1, grey.cols, grey.rows - 1);
  const cv::Rect earlier = axis == 0 ? cv::Rect(0, 0, grey.cols - 1, grey.rows)
                                     : cv::Rect(0, 0, grey.cols, grey.rows - 1);
  const cv::Mat sharp_step = cv::abs(grey(later) - grey(earlier));
  const cv::Mat blurred_step = cv::abs(blurred(later) - blurred(earlier));
  const double total = cv::sum(sharp_step)[0];
  if (total <= 0.0) return 1.0;  // A flat image: nothing left to lose.
  const double lost = cv::sum(cv::max(sharp_step - blurred_step, 0.0))[0];
  return (total - lost) / total;
}

double Median(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

}  // namespace

ImageQuality MeasureImageQuality(const cv::Mat& image) {
  cv::Mat grey8;
  if (image.channels() == 3) {
    cv::cvtColor(image, grey8, cv::COLOR_BGR2GRAY);
  } else {
    grey8 = image;
  }
  ImageQuality quality;
  if (grey8.cols < 3 || grey8.rows < 3) return quality;
  cv::Mat grey;
  grey8.convertTo(grey, CV_32F);

  // Immerkaer, "Fast noise variance estimation", 1996.
  const cv::Mat mask = (cv::Mat_<float>(3, 3) << 1, -2, 1, -2, 4, -2, 1, -2, 1);
  cv::Mat response;
  cv::filter2D(grey, response, CV_32F, mask);
  const cv::Rect inner(1, 1, grey.cols - 2, grey.rows - 2);
  quality.noise_grey = std::sqrt(M_PI / 2.0) * cv::norm(response(inner), cv::NORM_L1) /
                       (6.0 * inner.area());

  quality.blur = std::max(BlurAlong(grey, 0), BlurAlong(grey, 1));

  int histogram[256] = {};
  for (int y = 0; y < grey8.rows; ++y) {
    const uint8_t* row = grey8.ptr<uint8_t>(y);
    for (int x = 0; x < grey8.cols; ++x) ++histogram[row[x]];
  }
  const double total = double(grey8.total());
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
  if (!(accept_as_usual_s > 0.0)) return fail("accept_as_usual_s must be > 0");
  return true;
}

ImageQualityGate::ImageQualityGate(const ImageQualityOptions& options) : options_(options) {}

std::optional<std::string> ImageQualityGate::Judge(int64_t t_ns, const ImageQuality& quality) {
  if (!options_.enabled) return std::nullopt;
  auto keep_as_good = [&] {
    degraded_since_ns_.reset();
    good_.push_back({t_ns, quality});
    // Pruned only when a good frame comes, and never below the frames needed, so that a
    // long fault keeps the baseline from before it.
    while (int(good_.size()) > options_.min_baseline_frames &&
           double(t_ns - good_.front().t_ns) > options_.baseline_s * 1e9) {
      good_.pop_front();
    }
    return std::nullopt;
  };
  if (int(good_.size()) < options_.min_baseline_frames) return keep_as_good();

  std::vector<double> noise, blur, contrast;
  for (const Sample& sample : good_) {
    noise.push_back(sample.quality.noise_grey);
    blur.push_back(sample.quality.blur);
    contrast.push_back(sample.quality.contrast_grey);
  }
  const double usual_noise = Median(noise), usual_blur = Median(blur);
  const double usual_contrast = Median(contrast);
  std::ostringstream why;
  why.precision(2);
  why << std::fixed;
  const double blur_increase = quality.blur - usual_blur;
  const double contrast_ratio = quality.contrast_grey / std::max(usual_contrast, 1.0);
  const int fog_signs = (blur_increase > options_.fog_blur_increase) +
                        (contrast_ratio < options_.fog_contrast_ratio) +
                        (quality.noise_grey < options_.fog_noise_ratio * usual_noise);
  if (fog_signs >= 2) {
    why << "fogged (blur " << quality.blur << ", usually " << usual_blur << "; contrast "
        << quality.contrast_grey << " grey levels, usually " << usual_contrast << "; noise "
        << quality.noise_grey << ", usually " << usual_noise << ")";
  } else if (blur_increase > options_.max_blur_increase) {
    why << "blurred (" << quality.blur << ", usually " << usual_blur << ")";
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
