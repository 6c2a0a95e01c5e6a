#include "pipeline/motion_stage.h"

#include <algorithm>
#include <chrono>

#include <opencv2/imgproc.hpp>

#include "pipeline/homography_ransac.h"
#include "pipeline/stopwatch.h"

namespace autocal {

bool MotionStageOptions::Check(std::string* error) const {
  std::string nested;
  if (!flow.Check(&nested)) {
    if (error) *error = "flow." + nested;
    return false;
  }
  if (!planes.Check(&nested)) {
    if (error) *error = "planes." + nested;
    return false;
  }
  if (lost_planes_kept < 0) {
    if (error) *error = "lost_planes_kept must not be negative";
    return false;
  }
  if (refind_min_matches < 4) {
    if (error) *error = "refind_min_matches must be at least 4 (a homography needs 4 points)";
    return false;
  }
  // Box 6 looks back its baselines into every track's history.
  if (flow.history_frames <= std::max(planes.baseline_frames, planes.long_baseline_frames)) {
    if (error) {
      *error = "flow.history_frames must exceed planes.baseline_frames and long_baseline_frames";
    }
    return false;
  }
  return true;
}

int MotionSnapshot::PlaneOf(int track_id) const {
  for (const DominantPlane& plane : planes) {
    if (std::binary_search(plane.track_ids.begin(), plane.track_ids.end(), track_id)) {
      return plane.id;
    }
  }
  return 0;
}

MotionStage::MotionStage(const MotionStageOptions& options)
    : options_(options), flow_(options.flow), planes_(options.planes) {}

void MotionStage::set_options(const MotionStageOptions& options) {
  options_ = options;
  flow_.set_options(options.flow);
  planes_.set_options(options.planes);
}

MotionSnapshot MotionStage::Process(int64_t t_ns, const cv::Mat& gray,
                                    const CameraIntrinsics& camera) {
  MotionSnapshot snapshot;
  snapshot.t_ns = t_ns;
  snapshot.image_size = gray.size();
  snapshot.camera = camera;
  auto start = std::chrono::steady_clock::now();
  flow_.Advance(t_ns, gray);
  snapshot.tracks_died = flow_.died();
  snapshot.flow_ms = MillisecondsSince(start);

  start = std::chrono::steady_clock::now();
  snapshot.tracks_started = flow_.Replenish();
  snapshot.features_ms = MillisecondsSince(start);

  start = std::chrono::steady_clock::now();
  planes_.Update(t_ns, flow_.tracks(), camera);
  snapshot.planes_ms = MillisecondsSince(start);

  start = std::chrono::steady_clock::now();
  snapshot.planes = Refind(gray, camera);
  snapshot.refind_ms = MillisecondsSince(start);

  snapshot.tracks = flow_.tracks();
  return snapshot;
}

std::vector<DominantPlane> MotionStage::Refind(const cv::Mat& gray,
                                               const CameraIntrinsics& camera) {
  std::vector<DominantPlane> planes = planes_.planes();
  auto known_as = [&](int id) {
    const auto it = known_as_.find(id);
    return it == known_as_.end() ? id : it->second;
  };
  // Box 4's keypoints near a plane's tracks: its outline can take in parts of other
  // planes, which a plane seen a frame later would match as well.
  auto keypoints_in = [&](const cv::Mat& image, const DominantPlane& plane,
                          const CameraIntrinsics& image_camera) {
    cv::Mat mask = cv::Mat::zeros(image.size(), CV_8U);
    const int radius = cvRound(3.0 * options_.flow.features.min_distance_px);
    for (const cv::Point2f& p : plane.points) cv::circle(mask, p, radius, 255, cv::FILLED);
    LostPlane found;
    found.id = known_as(plane.id);
    FeatureOptions features = options_.flow.features;
    features.descriptor = options_.refind_descriptor;
    found.keypoints = DetectKeypoints(image, features, mask);
    std::vector<cv::Point2f> raw;
    for (const cv::KeyPoint& k : found.keypoints.keypoints) raw.push_back(k.pt);
    found.points = UndistortPixels(raw, image_camera);
    return found;
  };
  auto held = [&](int id) {
    return std::any_of(planes.begin(), planes.end(),
                       [&](const DominantPlane& plane) { return plane.id == id; });
  };

  if (options_.lost_planes_kept > 0) {
    for (auto it = largest_.begin(); it != largest_.end();) {
      if (held(it->first)) {
        ++it;
        continue;
      }
      LostPlane lost = keypoints_in(it->second.gray, it->second.plane, it->second.camera);
      known_as_.erase(it->first);
      it = largest_.erase(it);
      if (int(lost.points.size()) < options_.refind_min_matches) continue;
      lost_.push_back(std::move(lost));
      while (int(lost_.size()) > options_.lost_planes_kept) lost_.pop_front();
    }
    // Box 6's ids only grow: a larger one than it gave before is a new plane.
    for (const DominantPlane& plane : planes) {
      if (plane.id <= newest_id_ || lost_.empty()) continue;
      const LostPlane now = keypoints_in(gray, plane, camera);
      int best = -1, best_inliers = 0;
      for (size_t k = 0; k < lost_.size(); ++k) {
        const std::vector<cv::DMatch> matches =
            MatchKeypoints(lost_[k].keypoints, now.keypoints, options_.flow.features);
        if (int(matches.size()) < options_.refind_min_matches) continue;
        std::vector<cv::Point2f> from, to;
        for (const cv::DMatch& m : matches) {
          from.push_back(lost_[k].points[m.queryIdx]);
          to.push_back(now.points[m.trainIdx]);
        }
        std::vector<uchar> inliers;
        const int count =
            FitHomographyRansac(from, to, options_.planes.shot_inlier_threshold_px,
                                options_.planes.ransac_iterations, kRansacConfidence, &inliers)
                ? cv::countNonZero(inliers)
                : 0;
        if (count >= options_.refind_min_matches && count > best_inliers) {
          best = int(k);
          best_inliers = count;
        }
      }
      if (best >= 0) {
        known_as_[plane.id] = lost_[best].id;
        lost_.erase(lost_.begin() + best);
      }
    }
    cv::Mat copy;  // The caller's pixels may change after this call.
    for (const DominantPlane& plane : planes) {
      const auto it = largest_.find(plane.id);
      if (it != largest_.end() && it->second.plane.area_fraction >= plane.area_fraction) continue;
      if (copy.empty()) copy = gray.clone();
      largest_[plane.id] = {plane, copy, camera};
    }
  }
  for (const DominantPlane& plane : planes) newest_id_ = std::max(newest_id_, plane.id);
  for (DominantPlane& plane : planes) plane.id = known_as(plane.id);
  return planes;
}

}  // namespace autocal
