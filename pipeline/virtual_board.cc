#include "pipeline/virtual_board.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>

#include <opencv2/imgproc.hpp>

namespace autocal {

bool VirtualBoardOptions::Check(std::string* error) const {
  std::ostringstream why;
  if (squares_x < 1 || squares_y < 1) {
    why << "squares_x and squares_y must be at least 1";
  } else if (samples_per_square < 1) {
    why << "samples_per_square must be at least 1";
  } else if (min_tracks_seen < 1) {
    why << "min_tracks_seen must be at least 1";
  } else if (!(max_track_error > 0.0)) {
    why << "max_track_error must be positive";
  } else if (!(outlier_factor >= 1.0)) {
    why << "outlier_factor must be at least 1";
  }
  if (why.str().empty()) return true;
  if (error) *error = why.str();
  return false;
}

VirtualBoard AttachBoard(int plane_id, const Eigen::Isometry3d& world_from_plane,
                         const std::vector<Eigen::Vector2d>& tracked_points,
                         const VirtualBoardOptions& options) {
  std::vector<std::pair<int, Eigen::Vector2d>> numbered;
  numbered.reserve(tracked_points.size());
  for (const Eigen::Vector2d& p : tracked_points) {
    numbered.emplace_back(static_cast<int>(numbered.size()), p);
  }
  return AttachBoard(plane_id, world_from_plane, numbered, options);
}

VirtualBoard AttachBoard(int plane_id, const Eigen::Isometry3d& world_from_plane,
                         const std::vector<std::pair<int, Eigen::Vector2d>>& tracked,
                         const VirtualBoardOptions& options) {
  VirtualBoard board;
  board.plane_id = plane_id;
  board.world_from_plane = world_from_plane;
  board.squares_x = options.squares_x;
  board.squares_y = options.squares_y;
  if (tracked.empty()) return board;
  // Box 10 places a few weakly seen tracks far off their plane's patch (on the office walk
  // one at 400 times the patch's size): a board over them would reach to the plane's
  // horizon, a fan of lines where no plane was seen. Points farther from the median point
  // than outlier_factor times the median distance are left out.
  std::vector<double> us, vs;
  for (const auto& [track, uv] : tracked) {
    us.push_back(uv.x());
    vs.push_back(uv.y());
  }
  const auto median = [](std::vector<double> values) {
    const auto middle = values.begin() + values.size() / 2;
    std::nth_element(values.begin(), middle, values.end());
    return *middle;
  };
  const Eigen::Vector2d centre(median(us), median(vs));
  std::vector<double> distances;
  for (const auto& [track, uv] : tracked) distances.push_back((uv - centre).norm());
  const double reach_limit = options.outlier_factor * median(distances);
  for (const auto& entry : tracked) {
    if ((entry.second - centre).norm() <= reach_limit) board.tracked.push_back(entry);
  }

  // One corner on the first tracked point, the squares running toward the rest of them,
  // as large as fits within their extent on both axes (the outline cuts off the rest).
  board.origin = board.tracked.front().second;
  Eigen::Vector2d low = board.origin, high = board.origin, mean = Eigen::Vector2d::Zero();
  for (const auto& [track, p] : board.tracked) {
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
    mean += p / double(board.tracked.size());
  }
  const Eigen::Vector2d toward((mean - board.origin).x() >= 0 ? 1.0 : -1.0,
                               (mean - board.origin).y() >= 0 ? 1.0 : -1.0);
  const Eigen::Vector2d reach((toward.x() > 0 ? high : low).x() - board.origin.x(),
                              (toward.y() > 0 ? high : low).y() - board.origin.y());
  const Eigen::Vector2d fits(std::abs(reach.x()) / options.squares_x,
                             std::abs(reach.y()) / options.squares_y);
  board.square = fits.minCoeff() > 0.0 ? fits.minCoeff() : fits.maxCoeff();
  if (!(board.square > 0)) board.square = 1.0;
  if (toward.x() < 0) board.origin.x() -= board.square * board.squares_x;
  if (toward.y() < 0) board.origin.y() -= board.square * board.squares_y;
  std::vector<cv::Point2f> points, hull;
  for (const auto& [track, p] : board.tracked) points.emplace_back(p.x(), p.y());
  cv::convexHull(points, hull);
  for (const cv::Point2f& p : hull) board.outline.emplace_back(p.x, p.y);
  return board;
}

namespace {

// A piece of a square smaller than this (in squares) only touches the outline.
constexpr double kTouchingArea = 1e-9;

// Squared radius (ideal normalized coordinates) of the rays the image's corners see, with a
// quarter more: beyond the image's own field the lens model means nothing (a strong
// barrel's polynomial folds back, and a far point of a board lying along the view would be
// drawn near the image centre). Infinite when no corner can be unprojected.
double DrawableFieldRadius2(const CameraIntrinsics& camera) {
  double widest = 0.0;
  for (const Eigen::Vector2d& corner :
       {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(camera.width, 0.0),
        Eigen::Vector2d(0.0, camera.height), Eigen::Vector2d(camera.width, camera.height)}) {
    if (const auto ray = Unproject(camera, corner)) widest = std::max(widest, ray->squaredNorm());
  }
  return widest > 0.0 ? 1.25 * 1.25 * widest : std::numeric_limits<double>::infinity();
}

// Twice the polygon's signed area: positive when its corners run counter-clockwise.
double TwiceSignedArea(const std::vector<Eigen::Vector2d>& polygon) {
  double sum = 0.0;
  for (size_t i = 0; i < polygon.size(); ++i) {
    const Eigen::Vector2d& a = polygon[i];
    const Eigen::Vector2d& b = polygon[(i + 1) % polygon.size()];
    sum += a.x() * b.y() - a.y() * b.x();
  }
  return sum;
}

// How far `p` lies inside the edge from `from` along `edge` of a polygon whose corners run
// with `winding` (+1 counter-clockwise, -1 clockwise): negative outside.
double Inside(const Eigen::Vector2d& from, const Eigen::Vector2d& edge, double winding,
              const Eigen::Vector2d& p) {
  return winding * (edge.x() * (p - from).y() - edge.y() * (p - from).x());
}

// The part [*first, *last] of the segment from `a` (0) to `b` (1) inside the convex polygon
// `polygon` (either winding; Cyrus-Beck). False when none of it is, or the polygon has no
// area.
bool ClipToConvex(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                  const std::vector<Eigen::Vector2d>& polygon, double* first, double* last) {
  const double area2 = TwiceSignedArea(polygon);
  if (polygon.size() < 3 || area2 == 0.0) return false;
  const double winding = area2 > 0.0 ? 1.0 : -1.0;
  *first = 0.0;
  *last = 1.0;
  for (size_t i = 0; i < polygon.size(); ++i) {
    const Eigen::Vector2d edge = polygon[(i + 1) % polygon.size()] - polygon[i];
    // Inside at a + t (b - a) where at + t * slope >= 0.
    const double at = Inside(polygon[i], edge, winding, a);
    const double slope = Inside(polygon[i], edge, winding, b) - at;
    if (slope == 0.0) {
      if (at < 0.0) return false;
    } else if (slope > 0.0) {
      *first = std::max(*first, -at / slope);
    } else {
      *last = std::min(*last, -at / slope);
    }
  }
  return *first < *last;
}

}  // namespace

BoardProjection ProjectBoard(const VirtualBoard& board, const Eigen::Isometry3d& cam_from_world,
                             const CameraIntrinsics& camera, const VirtualBoardOptions& options) {
  BoardProjection projection;
  const Eigen::Isometry3d cam_from_plane = cam_from_world * board.world_from_plane;
  const double field_radius2 = DrawableFieldRadius2(camera);
  auto image_of = [&](const Eigen::Vector2d& uv, Eigen::Vector2d* pixel) {
    const Eigen::Vector3d cam = cam_from_plane * Eigen::Vector3d(uv.x(), uv.y(), 0.0);
    if (cam.z() <= 1e-6) return false;
    if ((cam.head<2>() / cam.z()).squaredNorm() > field_radius2) return false;
    *pixel = Project(camera, cam);
    return true;
  };
  const int steps = options.samples_per_square;
  // Lines of constant i, then of constant j, each within the outline (in squares along
  // it) and sampled at every step inside; a line is cut where it goes behind the camera or
  // out of the lens's field.
  for (int direction = 0; direction < 2; ++direction) {
    const int across = direction == 0 ? board.squares_x : board.squares_y;
    const int along = direction == 0 ? board.squares_y : board.squares_x;
    for (int a = 0; a <= across; ++a) {
      const Eigen::Vector2d start = direction == 0 ? board.OnPlane(a, 0) : board.OnPlane(0, a);
      const Eigen::Vector2d end =
          direction == 0 ? board.OnPlane(a, along) : board.OnPlane(along, a);
      double first = 0.0, last = 1.0;
      if (!board.outline.empty() && !ClipToConvex(start, end, board.outline, &first, &last)) {
        continue;
      }
      std::vector<double> samples{first * along};
      for (int k = static_cast<int>(std::floor(first * along * steps)) + 1;
           k < last * along * steps; ++k) {
        samples.push_back(double(k) / steps);
      }
      samples.push_back(last * along);
      std::vector<Eigen::Vector2d> line;
      for (const double t : samples) {
        Eigen::Vector2d pixel;
        if (image_of(start + (end - start) * (t / along), &pixel)) {
          line.push_back(pixel);
        } else {
          if (line.size() >= 2) projection.lines.push_back(std::move(line));
          line.clear();
        }
      }
      if (line.size() >= 2) projection.lines.push_back(std::move(line));
    }
  }
  for (int j = 0; j <= board.squares_y; ++j) {
    for (int i = 0; i <= board.squares_x; ++i) {
      Eigen::Vector2d pixel;
      if (image_of(board.OnPlane(i, j), &pixel)) projection.corners.push_back(pixel);
    }
  }
  return projection;
}

std::vector<Eigen::Vector2d> CutToOutline(const VirtualBoard& board,
                                          std::vector<Eigen::Vector2d> polygon) {
  const std::vector<Eigen::Vector2d>& outline = board.outline;
  if (outline.size() >= 3) {
    const double winding = TwiceSignedArea(outline) >= 0.0 ? 1.0 : -1.0;
    // One outline edge at a time (Sutherland-Hodgman). Not cv::intersectConvexConvex: its
    // OpenCV 4.6 version returns corners outside when an outline corner lies on one of the
    // polygon's edges, which is the rule for a board's squares (its corners sit on tracked
    // points, the outline's corners).
    for (size_t k = 0; k < outline.size() && !polygon.empty(); ++k) {
      const Eigen::Vector2d edge = outline[(k + 1) % outline.size()] - outline[k];
      std::vector<Eigen::Vector2d> kept;
      for (size_t i = 0; i < polygon.size(); ++i) {
        const Eigen::Vector2d& p = polygon[i];
        const Eigen::Vector2d& q = polygon[(i + 1) % polygon.size()];
        const double sp = Inside(outline[k], edge, winding, p);
        const double sq = Inside(outline[k], edge, winding, q);
        if (sp >= 0.0) kept.push_back(p);
        if ((sp >= 0.0) != (sq >= 0.0)) kept.push_back(p + (q - p) * (sp / (sp - sq)));
      }
      polygon = std::move(kept);
    }
  }
  // What is left of a polygon that only touches the outline has no area.
  if (std::abs(TwiceSignedArea(polygon)) <= 2.0 * kTouchingArea * board.square * board.square) {
    return {};
  }
  return polygon;
}

std::optional<double> BoardTrackError(
    const VirtualBoard& board, const Eigen::Isometry3d& cam_from_world,
    const CameraIntrinsics& camera, const std::vector<std::pair<int, Eigen::Vector2d>>& seen,
    int min_tracks) {
  const Eigen::Isometry3d cam_from_plane = cam_from_world * board.world_from_plane;
  std::vector<double> errors;
  for (const auto& [track, uv] : board.tracked) {
    const auto found = std::find_if(seen.begin(), seen.end(),
                                    [track = track](const auto& s) { return s.first == track; });
    if (found == seen.end()) continue;
    const Eigen::Vector3d cam = cam_from_plane * Eigen::Vector3d(uv.x(), uv.y(), 0.0);
    errors.push_back(cam.z() > 1e-6 ? (Project(camera, cam) - found->second).norm()
                                    : std::numeric_limits<double>::infinity());
  }
  if (errors.empty() || static_cast<int>(errors.size()) < min_tracks) return std::nullopt;
  const auto middle = errors.begin() + errors.size() / 2;
  std::nth_element(errors.begin(), middle, errors.end());
  return *middle;
}

}  // namespace autocal
