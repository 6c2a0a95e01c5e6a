// Box 8: virtual calibration boards. A checkerboard is attached to each dominant plane, in
// the plane's own frame, over the area its tracks cover, and projected through the current
// camera model into any frame for the overlay: where it sticks to the real texture the
// calibration is right; where it slides, it is not. It is drawn, never measured: the
// calibration's observations are the plane's real tracks (box 9).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "pipeline/camera_model.h"

namespace autocal {

struct VirtualBoardOptions {
  int squares_x = 8;           // Squares along the plane's first axis.
  int squares_y = 6;           // Squares along its second axis.
  int samples_per_square = 6;  // Points per square side on the drawn lines (they bend).

  bool Check(std::string* error) const;
};

struct VirtualBoard {
  int plane_id = 0;
  Eigen::Isometry3d world_from_plane = Eigen::Isometry3d::Identity();
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  // Corner (0, 0) in plane coordinates.
  double square = 1.0;  // Side of a square, in plane units (metres once scale is known).
  int squares_x = 8;
  int squares_y = 6;

  // Corner (i, j), 0 <= i <= squares_x, 0 <= j <= squares_y, in the world.
  Eigen::Vector3d Corner(int i, int j) const;
};

// A board over the tracked area of a plane: its origin on the first tracked point, its
// squares sized so the board covers the points' extent along the plane's axes.
VirtualBoard AttachBoard(int plane_id, const Eigen::Isometry3d& world_from_plane,
                         const std::vector<Eigen::Vector2d>& tracked_points,
                         const VirtualBoardOptions& options);

// The board seen through `camera` from `cam_from_world`: its grid lines as polylines
// (bent by the lens), and its corners, in pixels. Parts behind the camera are left out.
struct BoardProjection {
  std::vector<std::vector<Eigen::Vector2d>> lines;
  std::vector<Eigen::Vector2d> corners;
};
BoardProjection ProjectBoard(const VirtualBoard& board, const Eigen::Isometry3d& cam_from_world,
                             const CameraIntrinsics& camera, const VirtualBoardOptions& options);

}  // namespace autocal
