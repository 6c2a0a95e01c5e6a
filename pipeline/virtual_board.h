// Box 8: virtual calibration boards. A checkerboard is attached to each dominant plane, in
// the plane's own frame, over the area its tracks cover, and projected through the current
// camera model into any frame for the overlay: where it sticks to the real texture the
// calibration is right; where it slides, it is not. It is drawn, never measured: the
// calibration's observations are the plane's real tracks (box 9).
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "pipeline/camera_model.h"

namespace autocal {

struct VirtualBoardOptions {
  int squares_x = 8;           // Squares along the plane's first axis.
  int squares_y = 6;           // Squares along its second axis.
  int samples_per_square = 6;  // Points per square side on the drawn lines (they bend).
  // Tracked points farther from the plane's median point than this times the median
  // distance are not covered (box 10 places a few weakly seen ones far off).
  double outlier_factor = 3.0;
  // A board is drawn on a frame only where that frame confirms its pose: at least this many
  // of the plane's tracks the board was attached over are seen in it...
  int min_tracks_seen = 4;
  // ...and the board's pose puts them, at the median, this close to where they are seen
  // (a fraction of the image diagonal): a view box 10 posed wrongly draws no board.
  double max_track_error = 0.01;

  bool Check(std::string* error) const;
};

struct VirtualBoard {
  int plane_id = 0;
  Eigen::Isometry3d world_from_plane = Eigen::Isometry3d::Identity();
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  // Corner (0, 0) in plane coordinates.
  double square = 1.0;  // Side of a square, in plane units (metres once scale is known).
  int squares_x = 8;
  int squares_y = 6;
  // The plane's tracked points the board was attached over: (track id, plane coordinates).
  std::vector<std::pair<int, Eigen::Vector2d>> tracked;
  // Their convex hull in plane coordinates: the board is drawn only inside it, where the
  // plane was seen. Empty: the whole rectangle.
  std::vector<Eigen::Vector2d> outline;

  // Grid point (i, j) in plane coordinates, in squares from the origin (fractions and
  // points beyond the board allowed).
  Eigen::Vector2d OnPlane(double i, double j) const {
    return origin + square * Eigen::Vector2d(i, j);
  }
  // A point in plane coordinates, in the world.
  Eigen::Vector3d InWorld(const Eigen::Vector2d& uv) const {
    return world_from_plane * Eigen::Vector3d(uv.x(), uv.y(), 0.0);
  }
  // Corner (i, j), 0 <= i <= squares_x, 0 <= j <= squares_y, in the world.
  Eigen::Vector3d Corner(int i, int j) const { return InWorld(OnPlane(i, j)); }
};

// A board over the tracked area of a plane: its origin on the first tracked point, its
// squares as large as fit within the points' extent along both of the plane's axes, drawn
// within their outline; outlying points (VirtualBoardOptions::outlier_factor) left out.
VirtualBoard AttachBoard(int plane_id, const Eigen::Isometry3d& world_from_plane,
                         const std::vector<Eigen::Vector2d>& tracked_points,
                         const VirtualBoardOptions& options);
// The same with the tracks' ids (VirtualBoard::tracked); above, they are numbered 0, 1, ...
VirtualBoard AttachBoard(int plane_id, const Eigen::Isometry3d& world_from_plane,
                         const std::vector<std::pair<int, Eigen::Vector2d>>& tracked,
                         const VirtualBoardOptions& options);

// The board seen through `camera` from `cam_from_world`: its grid lines inside its outline,
// as polylines in pixels (bent by the lens), and every corner of its rectangle (j *
// (squares_x + 1) + i), to measure against. Parts behind the camera or beyond the lens's
// field are left out.
struct BoardProjection {
  std::vector<std::vector<Eigen::Vector2d>> lines;
  std::vector<Eigen::Vector2d> corners;
};
BoardProjection ProjectBoard(const VirtualBoard& board, const Eigen::Isometry3d& cam_from_world,
                             const CameraIntrinsics& camera, const VirtualBoardOptions& options);

// The part of the convex `polygon` (plane coordinates) inside the board's outline: all of
// it when the board has no outline, none when it lies outside or only touches it.
std::vector<Eigen::Vector2d> CutToOutline(const VirtualBoard& board,
                                          std::vector<Eigen::Vector2d> polygon);

// How far, in pixels, the board's pose puts its tracked points from where a frame sees them
// (`seen`: track id and pixel, through `camera`): the median over the tracks the frame
// shows; none when it shows fewer than `min_tracks`. A point behind the camera counts as
// infinitely far.
std::optional<double> BoardTrackError(
    const VirtualBoard& board, const Eigen::Isometry3d& cam_from_world,
    const CameraIntrinsics& camera, const std::vector<std::pair<int, Eigen::Vector2d>>& seen,
    int min_tracks);

}  // namespace autocal
