#include "pipeline/rectifier.h"

#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

namespace autocal {

bool RectifyOptions::Check(std::string* error) const {
  std::ostringstream why;
  if (!(clahe_clip_limit > 0)) {
    why << "clahe_clip_limit must be positive";
  } else if (clahe_tiles < 1 || clahe_tiles > 64) {
    why << "clahe_tiles must be in [1, 64]";
  }
  if (why.str().empty()) return true;
  if (error) *error = why.str();
  return false;
}

Rectifier::Rectifier(const RectifyOptions& options) { set_options(options); }

void Rectifier::set_options(const RectifyOptions& options) {
  options_ = options;
  clahe_ =
      cv::createCLAHE(options.clahe_clip_limit, cv::Size(options.clahe_tiles, options.clahe_tiles));
}

cv::Mat Rectifier::Channel(const cv::Mat& raw) const {
  CV_Assert(raw.depth() == CV_8U && (raw.channels() == 1 || raw.channels() == 3));
  cv::Mat gray;
  if (raw.channels() == 1) {
    gray = raw;
  } else if (options_.green_channel) {
    cv::extractChannel(raw, gray, 1);
  } else {
    cv::cvtColor(raw, gray, cv::COLOR_BGR2GRAY);
  }
  return gray;
}

cv::Mat Rectifier::Equalize(const cv::Mat& channel) const {
  cv::Mat equalized;
  switch (options_.equalization) {
    case Equalization::kNone:
      return channel;
    case Equalization::kGlobal:
      cv::equalizeHist(channel, equalized);
      return equalized;
    case Equalization::kLocal:
      clahe_->apply(channel, equalized);
      return equalized;
  }
  return channel;
}

void Rectifier::UpdateMaps(const CameraIntrinsics& camera) {
  if (!map1_.empty() && camera == mapped_camera_) return;
  cv::Mat k, d;
  cv::eigen2cv(camera.CameraMatrix(), k);
  const auto dist = camera.Distortion();
  d = cv::Mat(dist, true).reshape(1, 1);
  cv::initUndistortRectifyMap(k, d, cv::noArray(), k, cv::Size(camera.width, camera.height),
                              CV_16SC2, map1_, map2_);
  mapped_camera_ = camera;
  ++map_builds_;
}

cv::Mat Rectifier::Undistort(const cv::Mat& image, const CameraIntrinsics& camera) {
  if (!options_.undistort) return image;
  UpdateMaps(camera);
  cv::Mat undistorted;
  cv::remap(image, undistorted, map1_, map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  return undistorted;
}

cv::Mat Rectifier::Geometry(const cv::Mat& raw, const CameraIntrinsics& camera) {
  return Undistort(Equalize(Channel(raw)), camera);
}

}  // namespace autocal
