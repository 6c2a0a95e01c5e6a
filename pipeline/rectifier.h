// Box 3, rectification: the image boxes 4-10 work on. Undistortion maps are rebuilt only
// when the calibration changes; vignetting is flattened by histogram equalization (the
// paper's Eq. 1, globally or per tile); chromatic aberration is sidestepped by taking
// geometry from the green channel, which most sensors sample twice as densely and which
// lies mid-spectrum.
#pragma once

#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "pipeline/camera_model.h"

namespace autocal {

enum class Equalization {
  kNone,    // Grey levels as they come.
  kGlobal,  // Eq. 1 over the whole image: flattens the histogram, not a spatial falloff.
  kLocal,   // Eq. 1 per tile with clipped histograms (CLAHE): also flattens vignetting.
};

struct RectifyOptions {
  bool undistort = true;      // Remove lens distortion.
  bool green_channel = true;  // Geometry from green, not a grey mix.
  Equalization equalization = Equalization::kLocal;
  double clahe_clip_limit = 4.0;  // Contrast limit of local equalization.
  int clahe_tiles = 8;            // Tiles across the image for kLocal.

  bool Check(std::string* error) const;
};

class Rectifier {
 public:
  explicit Rectifier(const RectifyOptions& options = {});

  // 8-bit single-channel image of a raw BGR (or grey) frame for features and flow: the
  // channel the options ask for, equalized, undistorted with `camera` (same K, no
  // distortion).
  cv::Mat Geometry(const cv::Mat& raw, const CameraIntrinsics& camera);
  // Undistorts any image of the camera's size (colour for display, or a channel).
  cv::Mat Undistort(const cv::Mat& image, const CameraIntrinsics& camera);
  // The channel alone: where edges are measured to sub-pixel accuracy (boxes 1-2). Not
  // equalized: a grey-level map that varies over the image moves edges.
  cv::Mat Channel(const cv::Mat& raw) const;
  // The equalization the options ask for, on a channel.
  cv::Mat Equalize(const cv::Mat& channel) const;

  void set_options(const RectifyOptions& options);
  // How often the undistortion maps were built (for tests and timing).
  int map_builds() const { return map_builds_; }

 private:
  void UpdateMaps(const CameraIntrinsics& camera);

  RectifyOptions options_;
  cv::Ptr<cv::CLAHE> clahe_;
  CameraIntrinsics mapped_camera_;
  cv::Mat map1_, map2_;
  int map_builds_ = 0;
};

}  // namespace autocal
