#include "pipeline/virtual_board.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace autocal {

bool VirtualBoardOptions::Check(std::string* error) const {
  std::ostringstream why;
  if (squares_x < 1 || squares_y < 1) {
    why << "squares_x and squares_y must be at least 1";
  } else if (samples_per_square < 1) {
    why << "samples_per_square must be at least 1";
  }
  if (why.str().empty()) return true;
  if (error) *error = why.str();
  return false;
}

Eigen::Vector3d VirtualBoard::Corner(int i, int j) const {
  const Eigen::Vector2d uv = origin + square * Eigen::Vector2d(i, j);
  return world_from_plane * Eigen::Vector3d(uv.x(), uv.y(), 0.0);
}

VirtualBoard AttachBoard(int plane_id, const Eigen::Isometry3d& world_from_plane,
                         const std::vector<Eigen::Vector2d>& tracked_points,
                         const VirtualBoardOptions& options) {
  VirtualBoard board;
  board.plane_id = plane_id;
  board.world_from_plane = world_from_plane;
  board.squares_x = options.squares_x;
  board.squares_y = options.squares_y;
  if (tracked_points.empty()) return board;
  // One corner on the first tracked point, the squares running toward the rest of them
  // and covering their extent.
  board.origin = tracked_points.front();
  Eigen::Vector2d low = board.origin, high = board.origin, mean = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& p : tracked_points) {
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
    mean += p / double(tracked_points.size());
  }
  const Eigen::Vector2d toward((mean - board.origin).x() >= 0 ? 1.0 : -1.0,
                               (mean - board.origin).y() >= 0 ? 1.0 : -1.0);
  const Eigen::Vector2d reach((toward.x() > 0 ? high : low).x() - board.origin.x(),
                              (toward.y() > 0 ? high : low).y() - board.origin.y());
  board.square =
      std::max(std::abs(reach.x()) / options.squares_x, std::abs(reach.y()) / options.squares_y);
  if (!(board.square > 0)) board.square = 1.0;
  if (toward.x() < 0) board.origin.x() -= board.square * board.squares_x;
  if (toward.y() < 0) board.origin.y() -= board.square * board.squares_y;
  return board;
}

namespace {

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

}  // namespace

BoardProjection ProjectBoard(const VirtualBoard& board, const Eigen::Isometry3d& cam_from_world,
                             const CameraIntrinsics& camera, const VirtualBoardOptions& options) {
  BoardProjection projection;
  const Eigen::Isometry3d cam_from_plane = cam_from_world * board.world_from_plane;
  const double field_radius2 = DrawableFieldRadius2(camera);
  auto image_of = [&](double i, double j, Eigen::Vector2d* pixel) {
    const Eigen::Vector2d uv = board.origin + board.square * Eigen::Vector2d(i, j);
    const Eigen::Vector3d cam = cam_from_plane * Eigen::Vector3d(uv.x(), uv.y(), 0.0);
    if (cam.z() <= 1e-6) return false;
    if ((cam.head<2>() / cam.z()).squaredNorm() > field_radius2) return false;
    *pixel = Project(camera, cam);
    return true;
  };
  const int steps = options.samples_per_square;
  // Lines of constant i, then of constant j; a line is cut where it goes behind the camera
  // or out of the lens's field.
  for (int direction = 0; direction < 2; ++direction) {
    const int across = direction == 0 ? board.squares_x : board.squares_y;
    const int along = direction == 0 ? board.squares_y : board.squares_x;
    for (int a = 0; a <= across; ++a) {
      std::vector<Eigen::Vector2d> line;
      for (int k = 0; k <= along * steps; ++k) {
        const double t = double(k) / steps;
        Eigen::Vector2d pixel;
        const bool seen = direction == 0 ? image_of(a, t, &pixel) : image_of(t, a, &pixel);
        if (seen) {
          line.push_back(pixel);
        } else if (!line.empty()) {
          projection.lines.push_back(std::move(line));
          line.clear();
        }
      }
      if (line.size() >= 2) projection.lines.push_back(std::move(line));
    }
  }
  for (int j = 0; j <= board.squares_y; ++j) {
    for (int i = 0; i <= board.squares_x; ++i) {
      Eigen::Vector2d pixel;
      if (image_of(i, j, &pixel)) projection.corners.push_back(pixel);
    }
  }
  return projection;
}

}  // namespace autocal
