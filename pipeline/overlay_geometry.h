// What the workbench's overlay layers draw on one frame, as pixel geometry: Radon lines and
// snakes (box 1), tracks and their flow (box 5), dominant planes (box 6), virtual boards
// (box 8) and gravity with its horizon (box 7), taken from a frame's snapshot and laid out
// in the pixels of the image they are drawn on, the raw frame or box 3's rectified one.
// Everything here is projection and undistortion, so that the widgets only draw.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "pipeline/calibration_pipeline.h"
#include "pipeline/camera_model.h"
#include "pipeline/virtual_board.h"

namespace autocal {

using Polyline = std::vector<Eigen::Vector2d>;

// The image an overlay is drawn on.
enum class OverlaySpace {
  kRaw,        // The frame as recorded.
  kRectified,  // Box 3's undistortion of it: the same camera matrix, no distortion.
};

struct OverlayGeometry {
  struct Snake {
    int id = 0;
    Polyline vertices;
    std::vector<double> bend_deg;  // Per vertex, signed; 0 at the two end hinges.
  };
  struct TrackMark {
    int id = 0;
    int plane_id = 0;  // 0: on no plane.
    Eigen::Vector2d now = Eigen::Vector2d::Zero();
    std::optional<Eigen::Vector2d> previous;  // In the frame before: the flow vector's tail.
  };
  struct PlaneOutline {
    int id = 0;
    Polyline hull;                                     // Closed: the last point joins the first.
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // Of its tracked points.
  };
  struct Board {
    int plane_id = 0;
    std::vector<Polyline> lines;  // The grid lines, bent by the lens in the raw image.
  };
  struct Gravity {
    // From the principal point toward where "down" points, as long as a quarter of the
    // image height times the part of gravity across the optical axis (short when the
    // camera looks straight down or up).
    Eigen::Vector2d from = Eigen::Vector2d::Zero();
    Eigen::Vector2d to = Eigen::Vector2d::Zero();
    double sigma_deg = 0.0;
    // The image of the plane through the camera centre perpendicular to gravity, in pieces
    // where it leaves the field of view.
    std::vector<Polyline> horizon;
  };

  std::vector<Polyline> lines;  // Box 1's straight lines (curved in rectified space).
  std::vector<Snake> snakes;
  std::vector<TrackMark> tracks;
  std::vector<PlaneOutline> planes;
  std::vector<Board> boards;
  std::optional<Gravity> gravity;
  // Box 2's newest estimate in a few words (LensVerdict) and in full (its message), and
  // whether it determined the lens; empty before the first.
  std::string lens_verdict;
  std::string lens_detail;
  bool lens_observable = false;
};

// A virtual board and where the camera was, in the board's world, when the frame was taken.
struct PlacedBoard {
  VirtualBoard board;
  Eigen::Isometry3d cam_from_world = Eigen::Isometry3d::Identity();
};

// The camera's pose in an attempt's world at time `t_ns`: box 10's pose of the view taken
// then, or interpolated between the two views around it (rotation by slerp). Nothing
// outside the span of the views or next to a view box 10 left out.
std::optional<Eigen::Isometry3d> ViewPoseAt(const AttemptOutcome& attempt, int64_t t_ns);

// The boards of `attempt` placed at the camera's pose at `t_ns`; none when its views do
// not reach that time.
std::vector<PlacedBoard> PlaceBoards(const AttemptOutcome& attempt, int64_t t_ns);
// The boards of the newest of `attempts` (in judging order) that places some at `t_ns`.
std::vector<PlacedBoard> PlaceNewestBoards(
    const std::vector<std::shared_ptr<const AttemptOutcome>>& attempts, int64_t t_ns);

// The overlay of a frame in `space`, with `boards` projected through the frame's working
// calibration (the one its boxes 1-6 used). A board is drawn only when the frame's tracks
// confirm its pose (BoardTrackError within board_options' limits): a view box 10 posed
// wrongly would otherwise put a board where no plane is. Points that cannot be undistorted
// (beyond the fold of a strong barrel) are left out.
OverlayGeometry MakeOverlayGeometry(const FrameSnapshot& snapshot,
                                    const std::vector<PlacedBoard>& boards,
                                    const VirtualBoardOptions& board_options, OverlaySpace space);

}  // namespace autocal
