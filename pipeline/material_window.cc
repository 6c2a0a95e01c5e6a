#include "pipeline/material_window.h"

#include <algorithm>
#include <cmath>
#include <set>

namespace autocal {

bool MaterialOptions::Check(std::string* error) const {
  std::string why;
  if (!(window_s > 0)) {
    why = "window_s must be positive";
  } else if (view_every_frames < 1) {
    why = "view_every_frames must be at least 1";
  } else if (!(attempt_every_s > 0)) {
    why = "attempt_every_s must be positive";
  } else if (max_points_per_plane < 6) {
    why = "max_points_per_plane must be at least 6";
  } else if (min_views_per_point < 2) {
    why = "min_views_per_point must be at least 2";
  } else if (max_lines < 0) {
    why = "max_lines must not be negative";
  } else if (!quality.Check(&why)) {
    why = "quality." + why;
  } else if (!anchor.Check(&why)) {
    why = "anchor." + why;
  }
  if (why.empty()) return true;
  if (error) *error = why;
  return false;
}

MaterialWindow::MaterialWindow(const MaterialOptions& options)
    : options_(options), anchors_(options.anchor) {}

bool MaterialWindow::Add(const MotionSnapshot& motion, const InertialSnapshot& inertial,
                         const cv::Mat& image, const CameraIntrinsics& camera) {
  if (frames_seen_++ % options_.view_every_frames != 0) return false;
  View view;
  view.t_ns = motion.t_ns;
  for (const DominantPlane& plane : motion.planes) {
    const std::vector<std::optional<cv::Point2f>> measured = anchors_.Measure(plane, image, camera);
    auto& points = view.planes[plane.id];
    points.reserve(plane.track_ids.size());
    for (size_t i = 0; i < plane.track_ids.size(); ++i) {
      if (measured[i]) {
        points.emplace_back(plane.track_ids[i], Eigen::Vector2d(measured[i]->x, measured[i]->y));
      }
    }
  }
  anchors_.Keep(motion.planes);
  for (const Track& track : motion.tracks) {
    view.tracked[track.id] = Eigen::Vector2d(track.current().x, track.current().y);
  }
  if (inertial.gravity_source == GravitySource::kMeasured && inertial.gravity_cam) {
    GravityObservation gravity;
    gravity.down_cam = inertial.gravity_cam->normalized();
    gravity.sigma_deg = inertial.gravity_sigma_deg;
    view.gravity = gravity;
  }
  views_.push_back(std::move(view));
  const int64_t window_ns = static_cast<int64_t>(options_.window_s * 1e9);
  while (views_.back().t_ns - views_.front().t_ns > window_ns) views_.pop_front();
  return true;
}

CalibrationMaterial MaterialWindow::Assemble(const std::vector<LineObservation>& lines) const {
  CalibrationMaterial material;
  material.frame_count = static_cast<int>(views_.size());
  for (const View& view : views_) material.frame_t_ns.push_back(view.t_ns);

  std::set<int> plane_ids;
  for (const View& view : views_) {
    for (const auto& [id, points] : view.planes) plane_ids.insert(id);
  }
  for (const int id : plane_ids) {
    std::map<int, int> views_of_track;
    for (const View& view : views_) {
      const auto plane = view.planes.find(id);
      if (plane == view.planes.end()) continue;
      for (const auto& [track, pixel] : plane->second) ++views_of_track[track];
    }
    std::vector<std::pair<int, int>> ranked;  // (views, track id)
    for (const auto& [track, count] : views_of_track) {
      if (count >= options_.min_views_per_point) ranked.emplace_back(count, track);
    }
    std::sort(ranked.begin(), ranked.end(), std::greater<>());
    if (static_cast<int>(ranked.size()) > options_.max_points_per_plane) {
      ranked.resize(options_.max_points_per_plane);
    }
    std::set<int> chosen;
    for (const auto& [count, track] : ranked) chosen.insert(track);

    PlaneTrack plane_track;
    plane_track.id = id;
    for (int frame = 0; frame < material.frame_count; ++frame) {
      const auto plane = views_[frame].planes.find(id);
      if (plane == views_[frame].planes.end()) continue;
      for (const auto& [track, pixel] : plane->second) {
        if (chosen.count(track)) plane_track.observations.push_back({frame, track, pixel});
      }
    }
    if (!plane_track.observations.empty()) material.planes.push_back(std::move(plane_track));
  }

  for (int frame = 0; frame < material.frame_count; ++frame) {
    if (!views_[frame].gravity) continue;
    GravityObservation gravity = *views_[frame].gravity;
    gravity.frame = frame;
    material.gravity.push_back(gravity);
  }

  material.motion = Motion();

  // Every n-th shape, so the thinned set keeps the pool's spread over the image.
  const size_t keep = static_cast<size_t>(options_.max_lines);
  if (lines.size() <= keep) {
    material.lines = lines;
  } else if (keep > 0) {
    for (size_t i = 0; i < keep; ++i) material.lines.push_back(lines[i * lines.size() / keep]);
  }
  return material;
}

WindowMotion MaterialWindow::Motion() const {
  WindowMotion motion;
  motion.span_s = span_s();
  std::vector<std::map<int, Eigen::Vector2d>> tracked;
  for (const View& view : views_) tracked.push_back(view.tracked);
  motion.image_px = LargestMedianDisplacementPx(tracked);
  for (size_t a = 0; a < views_.size(); ++a) {
    if (!views_[a].gravity) continue;
    for (size_t b = a + 1; b < views_.size(); ++b) {
      if (!views_[b].gravity) continue;
      const double cosine =
          std::clamp(views_[a].gravity->down_cam.dot(views_[b].gravity->down_cam), -1.0, 1.0);
      motion.tilt_deg = std::max(motion.tilt_deg.value_or(0.0), std::acos(cosine) * 180.0 / M_PI);
    }
  }
  return motion;
}

std::vector<int64_t> MaterialWindow::view_times() const {
  std::vector<int64_t> times;
  for (const View& view : views_) times.push_back(view.t_ns);
  return times;
}

double MaterialWindow::span_s() const {
  return views_.empty() ? 0.0 : 1e-9 * double(views_.back().t_ns - views_.front().t_ns);
}

}  // namespace autocal
