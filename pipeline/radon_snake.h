// Radon snakes (box 1): a straight line found by the Radon transform is cut into short
// edges joined by hinges. Each frame the hinges slide along their normals onto the real
// edge, the snake grows at its ends while the edge goes on, and so it stays locked on a
// world line that the lens bends as it moves toward the border. The bend angle at every
// inner hinge is zero exactly when the image of the line is straight.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "pipeline/line_detector.h"

namespace autocal {

struct SnakeOptions {
  double spacing_px = 12.0;        // Length of one edge between hinges.
  double search_px = 8.0;          // How far a snake may move along its normals per frame.
  double min_edge_strength = 3.0;  // Weakest edge a hinge locks on, grey levels per px.
  // A hinge bending this much more or less than the snake's median bend has jumped to
  // another edge or turned a corner (lens bends change slowly along a line).
  double max_bend_change_deg = 2.5;
  // Whether a noisy edge (real texture, JPEG) raises that limit to three times its own
  // scatter of bends, up to four times the option. Still images take it: each snake there
  // is tracked on one image, and a fixed limit cut real edges into pieces too short to
  // keep. Video does not: from frame to frame a looser snake drifts onto neighbouring edges.
  bool adaptive_bend = false;
  double min_length_px = 60.0;    // Snakes shorter than this are seeded neither kept.
  int max_grow_per_frame = 4;     // Hinges added at each end per frame, at most.
  double border_margin_px = 2.0;  // Hinges stay this far inside the image.
  // Only lines passing this close to the principal point seed snakes (fraction of the
  // half-diagonal): there the lens bends them least, so the Radon transform sees them.
  double seed_max_distance = 0.5;
  int max_snakes = 24;  // Snakes tracked at once, at most.

  bool Check(std::string* error) const;
};

struct RadonSnake {
  int id = 0;
  // Hinges in pixels, ordered along the edge. The two end hinges are where the snake
  // probes for more of its edge (they may sit on a junction); the inner ones are
  // confirmed, and only they are measurements.
  std::vector<Eigen::Vector2d> vertices;
  // Sign of the edge across the left normal at each hinge: +1 where the image brightens
  // to the left. It may alternate along a snake (a checkerboard's grid lines).
  std::vector<int> polarities;
  int age = 0;  // Frames tracked.

  // Bend at each inner vertex, degrees (vertices.size() - 2 values; signed).
  std::vector<double> BendAngles() const;
  double Length() const;
  // The confirmed hinges: all but the two ends.
  std::vector<Eigen::Vector2d> InnerVertices() const;
};

// Tracks snakes from frame to frame. Not thread-safe; one per video stream.
class SnakeTracker {
 public:
  explicit SnakeTracker(const SnakeOptions& options = {}) : options_(options) {}

  // Moves every snake onto the edges of this frame, drops the ones that lost their edge,
  // and seeds new ones from `lines` near `principal_point`.
  void Update(const Gradients& gradients, const std::vector<LineSegment>& lines,
              const Eigen::Vector2d& principal_point, cv::Size image_size);

  // Adds snakes along polylines of raw pixels where an edge is expected (a line found
  // straight in an image undistorted by a tentative lens, carried back through it): each
  // is resampled, its hinges moved onto the edge within `search_px`, and the longest run
  // of them that locked is kept (when next tracked it grows along its edge to a snake's
  // length, or is dropped). Polylines a snake follows already are skipped.
  void Seed(const Gradients& gradients, const std::vector<std::vector<Eigen::Vector2d>>& polylines,
            double search_px, cv::Size image_size);

  const std::vector<RadonSnake>& snakes() const { return snakes_; }
  void set_options(const SnakeOptions& options) { options_ = options; }
  void Reset() { snakes_.clear(); }

 private:
  SnakeOptions options_;
  std::vector<RadonSnake> snakes_;
  int next_id_ = 1;
};

}  // namespace autocal
