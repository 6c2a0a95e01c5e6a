#include "pipeline/overlay_geometry.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace autocal {
namespace {

// The rectified image's camera: box 3 keeps the camera matrix and removes the distortion.
CameraIntrinsics WithoutDistortion(CameraIntrinsics camera) {
  camera.k1 = camera.k2 = camera.p1 = camera.p2 = camera.k3 = 0.0;
  return camera;
}

// Maps raw pixels into the overlay's space.
class PixelMap {
 public:
  PixelMap(const CameraIntrinsics& camera, OverlaySpace space) : camera_(camera), space_(space) {}

  std::optional<Eigen::Vector2d> operator()(const Eigen::Vector2d& raw) const {
    if (space_ == OverlaySpace::kRaw) return raw;
    return UndistortPixel(camera_, raw);
  }
  // Every point that maps; into rectified space a straight raw segment is sampled every
  // `step_px` first, since undistortion bends it.
  Polyline Map(const Polyline& raw, double step_px = 0.0) const {
    Polyline mapped;
    for (size_t i = 0; i < raw.size(); ++i) {
      const int pieces =
          (space_ == OverlaySpace::kRectified && step_px > 0.0 && i + 1 < raw.size())
              ? std::max(1, static_cast<int>(std::ceil((raw[i + 1] - raw[i]).norm() / step_px)))
              : 1;
      for (int k = 0; k < pieces; ++k) {
        const Eigen::Vector2d p =
            k == 0 ? raw[i] : raw[i] + (raw[i + 1] - raw[i]) * (double(k) / pieces);
        if (const auto q = (*this)(p)) mapped.push_back(*q);
      }
    }
    return mapped;
  }

 private:
  const CameraIntrinsics& camera_;
  OverlaySpace space_;
};

Eigen::Vector2d ToEigen(const cv::Point2f& p) { return {p.x, p.y}; }

// Gravity's arrow and the horizon through `camera` (the one of the overlay's space).
OverlayGeometry::Gravity GravityGeometry(const Eigen::Vector3d& gravity_cam, double sigma_deg,
                                         const CameraIntrinsics& working,
                                         const CameraIntrinsics& camera) {
  OverlayGeometry::Gravity out;
  out.sigma_deg = sigma_deg;
  const Eigen::Vector3d down = gravity_cam.normalized();
  // At the principal point the lens does not bend, so the projection's derivative along
  // "down" is the camera matrix's.
  out.from = {camera.cx, camera.cy};
  const Eigen::Vector2d across(camera.fx * down.x(), camera.fy * down.y());
  if (across.norm() > 1e-9) {
    out.to = out.from + across.normalized() * 0.25 * camera.height * down.head<2>().norm();
  } else {
    out.to = out.from;
  }

  // Rays perpendicular to gravity, kept inside the field of view: within the largest
  // normalized radius the image corners see (beyond it a strong barrel folds back), and on
  // the image.
  double max_radius = 0.0;
  for (const Eigen::Vector2d& corner :
       {Eigen::Vector2d(0, 0), Eigen::Vector2d(working.width - 1, 0),
        Eigen::Vector2d(0, working.height - 1),
        Eigen::Vector2d(working.width - 1, working.height - 1)}) {
    if (const auto ray = Unproject(working, corner)) max_radius = std::max(max_radius, ray->norm());
  }
  const Eigen::Vector3d first = down.unitOrthogonal();
  const Eigen::Vector3d second = down.cross(first);
  constexpr int kSamples = 720;
  Polyline piece;
  for (int k = 0; k <= kSamples; ++k) {
    const double angle = 2.0 * std::numbers::pi * k / kSamples;
    const Eigen::Vector3d ray = std::cos(angle) * first + std::sin(angle) * second;
    bool seen = ray.z() > 1e-6 && (ray.head<2>() / ray.z()).norm() <= max_radius;
    Eigen::Vector2d pixel;
    if (seen) {
      pixel = Project(camera, ray);
      seen = pixel.x() >= -0.5 && pixel.y() >= -0.5 && pixel.x() <= camera.width - 0.5 &&
             pixel.y() <= camera.height - 0.5;
    }
    if (seen) {
      piece.push_back(pixel);
    } else if (!piece.empty()) {
      if (piece.size() >= 2) out.horizon.push_back(std::move(piece));
      piece.clear();
    }
  }
  if (piece.size() >= 2) out.horizon.push_back(std::move(piece));
  // The circle of samples closes on itself: a piece running through angle 0 is one line.
  if (out.horizon.size() >= 2 && out.horizon.front().front() == out.horizon.back().back()) {
    Polyline& last = out.horizon.back();
    last.insert(last.end(), out.horizon.front().begin() + 1, out.horizon.front().end());
    out.horizon.erase(out.horizon.begin());
  }
  return out;
}

}  // namespace

std::optional<Eigen::Isometry3d> ViewPoseAt(const AttemptOutcome& attempt, int64_t t_ns) {
  const std::vector<int64_t>& times = attempt.view_times;
  const auto& poses = attempt.cam_from_world;
  const auto after = std::lower_bound(times.begin(), times.end(), t_ns);
  if (after == times.end()) return std::nullopt;
  const size_t next = static_cast<size_t>(after - times.begin());
  if (next >= poses.size()) return std::nullopt;
  if (*after == t_ns) return poses[next];
  if (next == 0 || !poses[next - 1] || !poses[next]) return std::nullopt;
  const double weight = double(t_ns - times[next - 1]) / double(times[next] - times[next - 1]);
  const Eigen::Isometry3d& before = *poses[next - 1];
  const Eigen::Isometry3d& later = *poses[next];
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::Quaterniond(before.rotation())
                      .slerp(weight, Eigen::Quaterniond(later.rotation()))
                      .toRotationMatrix();
  pose.translation() = (1.0 - weight) * before.translation() + weight * later.translation();
  return pose;
}

std::vector<PlacedBoard> PlaceBoards(const AttemptOutcome& attempt, int64_t t_ns) {
  std::vector<PlacedBoard> placed;
  if (const std::optional<Eigen::Isometry3d> pose = ViewPoseAt(attempt, t_ns)) {
    for (const VirtualBoard& board : attempt.boards) placed.push_back({board, *pose});
  }
  return placed;
}

std::vector<PlacedBoard> PlaceNewestBoards(
    const std::vector<std::shared_ptr<const AttemptOutcome>>& attempts, int64_t t_ns) {
  for (auto attempt = attempts.rbegin(); attempt != attempts.rend(); ++attempt) {
    std::vector<PlacedBoard> placed = PlaceBoards(**attempt, t_ns);
    if (!placed.empty()) return placed;
  }
  return {};
}

OverlayGeometry MakeOverlayGeometry(const FrameSnapshot& snapshot,
                                    const std::vector<PlacedBoard>& boards,
                                    const VirtualBoardOptions& board_options, OverlaySpace space) {
  const CameraIntrinsics& working = snapshot.working;
  const CameraIntrinsics camera =
      space == OverlaySpace::kRaw ? working : WithoutDistortion(working);
  const PixelMap map(working, space);
  OverlayGeometry out;
  if (snapshot.lens.distortion) {
    out.lens_verdict = LensVerdict(*snapshot.lens.distortion);
    out.lens_detail = snapshot.lens.distortion->message;
    out.lens_observable = snapshot.lens.distortion->usable;
  }

  constexpr double kLineStepPx = 8.0;
  for (const LineSegment& line : snapshot.lens.lines) {
    Polyline mapped = map.Map({line.start, line.end}, kLineStepPx);
    if (mapped.size() >= 2) out.lines.push_back(std::move(mapped));
  }

  for (const RadonSnake& snake : snapshot.lens.snakes) {
    OverlayGeometry::Snake drawn{snake.id, {}, {}};
    const std::vector<double> bends = snake.BendAngles();
    for (size_t i = 0; i < snake.vertices.size(); ++i) {
      const auto p = map(snake.vertices[i]);
      if (!p) continue;
      drawn.vertices.push_back(*p);
      const bool inner = i > 0 && i + 1 < snake.vertices.size();
      drawn.bend_deg.push_back(inner ? bends[i - 1] : 0.0);
    }
    if (drawn.vertices.size() >= 2) out.snakes.push_back(std::move(drawn));
  }

  const MotionSnapshot& motion = snapshot.motion;
  for (const Track& track : motion.tracks) {
    const auto now = map(ToEigen(track.current()));
    if (!now) continue;
    OverlayGeometry::TrackMark mark{track.id, motion.PlaneOf(track.id), *now, std::nullopt};
    if (const TrackPoint* before = track.FramesAgo(1)) mark.previous = map(ToEigen(before->pixel));
    out.tracks.push_back(mark);
  }

  for (const DominantPlane& plane : motion.planes) {
    OverlayGeometry::PlaneOutline outline{plane.id, {}, Eigen::Vector2d::Zero()};
    for (const cv::Point2f& p : plane.outline) {
      if (const auto q = map(ToEigen(p))) outline.hull.push_back(*q);
    }
    if (outline.hull.size() < 3) continue;
    int counted = 0;
    for (const cv::Point2f& p : plane.points) {
      if (const auto q = map(ToEigen(p))) {
        outline.centre += *q;
        ++counted;
      }
    }
    if (counted == 0) continue;
    outline.centre /= counted;
    out.planes.push_back(std::move(outline));
  }

  // A board only where this frame's own tracks confirm its pose (raw pixels, as tracked).
  std::vector<std::pair<int, Eigen::Vector2d>> seen;
  seen.reserve(motion.tracks.size());
  for (const Track& track : motion.tracks) seen.emplace_back(track.id, ToEigen(track.current()));
  const double max_error_px =
      board_options.max_track_error * std::hypot(working.width, working.height);
  for (const PlacedBoard& placed : boards) {
    const std::optional<double> error = BoardTrackError(
        placed.board, placed.cam_from_world, working, seen, board_options.min_tracks_seen);
    if (!error || *error > max_error_px) continue;
    BoardProjection projection =
        ProjectBoard(placed.board, placed.cam_from_world, camera, board_options);
    if (!projection.lines.empty()) {
      out.boards.push_back({placed.board.plane_id, std::move(projection.lines)});
    }
  }

  if (const auto& gravity = snapshot.inertial.gravity_cam; gravity && gravity->norm() > 0.0) {
    out.gravity = GravityGeometry(*gravity, snapshot.inertial.gravity_sigma_deg, working, camera);
  }
  return out;
}

}  // namespace autocal
