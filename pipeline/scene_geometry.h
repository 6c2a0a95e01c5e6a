// What the workbench's 3-D view draws, worked out from a judged attempt: the camera's
// trajectory over the attempt's window (box 10's per-view poses), the camera's frustum at
// the newest view through the current intrinsics, each plane's virtual board (box 8) with
// its squares, and gravity. Everything is in the attempt's world: the window's reference
// camera, with the first plane's first point at depth 1 (SelfCalibrationResult). Attempts
// are solved each in a world of their own, so the scene is that of one attempt.
#pragma once

#include <array>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "pipeline/calibration_pipeline.h"

namespace autocal {

// A convex polygon, its corners in order.
using ScenePolygon = std::vector<Eigen::Vector3d>;

// Everything of a board is cut to its outline (VirtualBoard::outline, the hull of the
// tracked points), as the video overlay draws it: the plane is shown only where it was seen.
struct SceneBoard {
  int plane_id = 0;
  // The plane around the board: the board grown by one square on every side.
  std::array<Eigen::Vector3d, 4> plane;
  // Squares, each within the outline; dark are those with (i + j) even. A square wholly
  // outside is left out.
  std::vector<ScenePolygon> dark, light;
  // The plane outside the board, as up to four pieces: with the light squares, the plane's
  // area without the dark squares (nothing drawn twice in one place).
  std::vector<ScenePolygon> border;
};

struct SceneGeometry {
  std::vector<Eigen::Vector3d> trajectory;  // Camera centres of the posed views, in time.
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();  // The newest view.
  // The frustum at the newest view: the camera centre, then the rays through the image's
  // corners (0, 0), (w-1, 0), (w-1, h-1), (0, h-1), cut at `frustum_depth`.
  std::array<Eigen::Vector3d, 5> frustum;
  double frustum_depth = 0.0;
  std::vector<SceneBoard> boards;
  std::optional<Eigen::Vector3d> gravity;  // Unit "down" in the world, when known.
  // How long to draw gravity from the camera: the frustum's depth, or less, so as to stop
  // short of the first board's plane it would meet (the floor under the camera).
  double gravity_length = 0.0;
};

// The scene of `attempt` seen through `camera` (the calibration in effect). `gravity_cam`:
// gravity in the camera frame at the attempt's newest view, if known. Nothing when the
// attempt posed no view. The frustum is cut at half the distance from the newest camera
// to the nearest board centre (0.5, the first point's depth, without boards).
std::optional<SceneGeometry> MakeSceneGeometry(const AttemptOutcome& attempt,
                                               const CameraIntrinsics& camera,
                                               const std::optional<Eigen::Vector3d>& gravity_cam);

}  // namespace autocal
