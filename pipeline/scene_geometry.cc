#include "pipeline/scene_geometry.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace autocal {
namespace {

// The part of `quad` (plane coordinates) within the board's outline, in the world.
ScenePolygon WithinOutline(const VirtualBoard& board, const std::array<Eigen::Vector2d, 4>& quad) {
  ScenePolygon polygon;
  for (const Eigen::Vector2d& p : CutToOutline(board, {quad.begin(), quad.end()})) {
    polygon.push_back(board.InWorld(p));
  }
  return polygon;
}

}  // namespace

std::optional<SceneGeometry> MakeSceneGeometry(const AttemptOutcome& attempt,
                                               const CameraIntrinsics& camera,
                                               const std::optional<Eigen::Vector3d>& gravity_cam) {
  SceneGeometry scene;
  std::optional<Eigen::Isometry3d> newest;
  for (const std::optional<Eigen::Isometry3d>& cam_from_world : attempt.cam_from_world) {
    if (!cam_from_world) continue;
    newest = cam_from_world->inverse();
    scene.trajectory.push_back(newest->translation());
  }
  if (!newest) return std::nullopt;
  scene.world_from_camera = *newest;
  const Eigen::Vector3d centre = newest->translation();

  double nearest = std::numeric_limits<double>::infinity();
  for (const VirtualBoard& board : attempt.boards) {
    SceneBoard drawn;
    drawn.plane_id = board.plane_id;
    const auto corner = [&](int i, int j) { return board.OnPlane(i, j); };
    const std::array<Eigen::Vector2d, 4> grown = {corner(-1, -1), corner(board.squares_x + 1, -1),
                                                  corner(board.squares_x + 1, board.squares_y + 1),
                                                  corner(-1, board.squares_y + 1)};
    const std::array<Eigen::Vector2d, 4> inner = {corner(0, 0), corner(board.squares_x, 0),
                                                  corner(board.squares_x, board.squares_y),
                                                  corner(0, board.squares_y)};
    for (size_t k = 0; k < 4; ++k) {
      drawn.plane[k] = board.InWorld(grown[k]);
      ScenePolygon piece =
          WithinOutline(board, {grown[k], grown[(k + 1) % 4], inner[(k + 1) % 4], inner[k]});
      if (!piece.empty()) drawn.border.push_back(std::move(piece));
    }
    for (int j = 0; j < board.squares_y; ++j) {
      for (int i = 0; i < board.squares_x; ++i) {
        ScenePolygon square = WithinOutline(
            board, {corner(i, j), corner(i + 1, j), corner(i + 1, j + 1), corner(i, j + 1)});
        if (!square.empty()) ((i + j) % 2 == 0 ? drawn.dark : drawn.light).push_back(square);
      }
    }
    const Eigen::Vector3d board_centre =
        (board.Corner(0, 0) + board.Corner(board.squares_x, board.squares_y)) / 2.0;
    nearest = std::min(nearest, (board_centre - centre).norm());
    scene.boards.push_back(std::move(drawn));
  }
  scene.frustum_depth = std::isfinite(nearest) ? 0.5 * nearest : 0.5;

  const double w = camera.width - 1, h = camera.height - 1;
  const std::array<Eigen::Vector2d, 4> corners = {Eigen::Vector2d(0, 0), Eigen::Vector2d(w, 0),
                                                  Eigen::Vector2d(w, h), Eigen::Vector2d(0, h)};
  scene.frustum[0] = centre;
  for (size_t k = 0; k < corners.size(); ++k) {
    // Beyond the fold of a strong barrel the corner has no ray: the pinhole's then.
    const Eigen::Vector2d ray =
        Unproject(camera, corners[k])
            .value_or(Eigen::Vector2d((corners[k].x() - camera.cx) / camera.fx,
                                      (corners[k].y() - camera.cy) / camera.fy));
    scene.frustum[k + 1] = *newest * (scene.frustum_depth * ray.homogeneous());
  }
  if (gravity_cam && gravity_cam->norm() > 0) {
    scene.gravity = newest->linear() * gravity_cam->normalized();
    scene.gravity_length = scene.frustum_depth;
    for (const VirtualBoard& board : attempt.boards) {
      const Eigen::Vector3d normal = board.world_from_plane.linear().col(2);
      const double towards = normal.dot(*scene.gravity);
      if (std::abs(towards) < 1e-9) continue;  // Parallel: never met.
      const double distance = normal.dot(board.world_from_plane.translation() - centre) / towards;
      if (distance > 0) scene.gravity_length = std::min(scene.gravity_length, 0.8 * distance);
    }
  }
  return scene;
}

}  // namespace autocal
