// Whether a frame is fit to measure from: fog (blur, lost contrast) and noise bursts make
// tracks wander and planes blur, and a calibration solved on them drifts off the trend.
// Each frame is measured on the raw image and compared with what this camera showed on
// its recent good frames, so that a scene's own texture does not count as a fault. The
// blur a moving exposure makes is no fault either: a worn camera turns in every window.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "pipeline/flow.h"

namespace autocal {

struct ImageQuality {
  // Standard deviation of the sensor noise, grey levels, by Immerkaer's estimator (a
  // Laplacian difference that cancels smooth image content).
  double noise_grey = 0.0;
  // How much a further blur changes the image (Crete-Roffet's measure): 0 for a sharp
  // image, 1 when re-blurring changes nothing.
  double blur = 0.0;
  // Spread of the grey levels between their 5th and 95th percentiles.
  double contrast_grey = 0.0;
};

// Measures an 8-bit BGR or grey image.
ImageQuality MeasureImageQuality(const cv::Mat& image);

// How far the image moved into the tracks' latest frame: the median length of their flow
// vectors, pixels; nothing when no track has one.
std::optional<double> ImageSpeedPx(const std::vector<Track>& tracks);

struct ImageQualityOptions {
  bool enabled = true;
  double baseline_s = 3.0;          // Good frames this far back make the usual quality.
  int min_baseline_frames = 10;     // Fewer: nothing is judged yet.
  double max_blur_increase = 0.12;  // Blur above the usual by more than this: defocus.
  // Fog blurs, fades, and its blur smooths the sensor noise away: two of these three
  // signs at once (blur up by this much, contrast or noise below these fractions of the
  // usual) make a frame fogged. One alone is a scene's own change (a plain wall, a quick
  // turn, another exposure).
  double fog_blur_increase = 0.06;
  double fog_contrast_ratio = 0.8;
  double fog_noise_ratio = 0.75;
  double min_contrast_ratio = 0.5;       // Contrast below this fraction alone: glare, fog.
  double max_noise_ratio = 2.0;          // Noise above this many times the usual...
  double min_noise_increase_grey = 3.0;  // ...and by at least this many grey levels.
  // Image moving at least this fast (pixels a frame, the tracks' median flow) is blurred
  // by the exposure: its blur and noise are compared with good frames moving half to twice
  // as fast, or, with too few of those, it is fogged only if its contrast falls too, and
  // never blurred alone. Slower frames are compared with the slower good ones.
  double motion_blur_speed_px = 2.0;
  // A degradation that lasts longer becomes the usual (a darker place, a dirty window):
  // calibrating on it is then better than never calibrating again.
  double accept_as_usual_s = 10.0;

  bool Check(std::string* error) const;
};

// Judges each frame against the median of the recent good ones.
class ImageQualityGate {
 public:
  explicit ImageQualityGate(const ImageQualityOptions& options = {});

  // Frames in time order, with how far the image moved since the previous frame (pixels;
  // nothing when unknown, judged as at rest). Returns why the frame is degraded, or nothing
  // when it is fit.
  std::optional<std::string> Judge(int64_t t_ns, const ImageQuality& quality,
                                   std::optional<double> image_speed_px = std::nullopt);

  void set_options(const ImageQualityOptions& options) { options_ = options; }

 private:
  struct Sample {
    int64_t t_ns;
    ImageQuality quality;
    double speed_px;  // The image's speed, 0 when unknown.
  };

  ImageQualityOptions options_;
  std::deque<Sample> good_;
  std::optional<int64_t> degraded_since_ns_;
};

}  // namespace autocal
