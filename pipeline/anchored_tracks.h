// Box 9: plane tracks measured without Lucas-Kanade's drift. Box 5 follows a patch from
// frame to frame with a translation-only window, so as the walk scales and shears the
// patch, the point it follows slides: 0.5 px after 5-9 views of a window, 1.4-3.5 px after
// 15-20 (docs/calibration.md), and box 10's focal length leans with it. Here each plane
// track is measured against the patch where it was first measured on its plane (its
// anchor), warped by the plane's homography from then to now: every view of the track
// then points at the same spot of the scene, and the tracker's position serves only as
// the search's start.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "pipeline/camera_model.h"
#include "pipeline/planes.h"

namespace autocal {

struct AnchorOptions {
  bool enabled = true;
  int window_px = 15;  // Side of the patch aligned (odd).
  // The aligned position may be this far from the tracker's; farther, the track is not
  // measured in this view (a patch that does not match its anchor any more).
  double max_shift_px = 3.0;
  // Zero-mean normalized correlation of the aligned patch with its warped anchor, at least.
  double min_correlation = 0.8;
  // Nor is a point measured that lies off its plane: farther from where the plane's
  // homography carries its anchor than off_plane_ratio times the plane's median point in
  // this view, and than off_plane_fraction of the image's diagonal (1 px at 640x480; 0: no
  // such test). Outdoors the ground's plane holds facade tracks by their feet, where
  // parallax over box 6's baselines cannot yet tell them from the ground; far and slow,
  // they live longest, and made 10-12% of box 10's ground observations, 2 px RMS off the
  // ground at 640x480. Parallax scales with the image, hence the diagonal; a plane's own
  // homography may be off by more (box 6 follows it on drifting tracks), hence the median.
  double off_plane_fraction = 0.00125;
  double off_plane_ratio = 3.0;
  int max_iterations = 15;   // Gauss-Newton steps per alignment...
  double epsilon_px = 0.01;  // ...or until a step is shorter than this.

  bool Check(std::string* error) const;
};

class AnchoredTracks {
 public:
  explicit AnchoredTracks(const AnchorOptions& options = {});

  // The raw pixels of `plane`'s member tracks in `image` (the image box 5 tracked, with
  // the plane's homography in undistorted pixels of `camera`), in the order of
  // plane.track_ids; nothing for a track whose alignment failed or that lies off the
  // plane (AnchorOptions::off_plane_fraction). A track new to the plane, or whose plane
  // has moved its reference frame since, is anchored here at the tracker's position.
  std::vector<std::optional<cv::Point2f>> Measure(const DominantPlane& plane, const cv::Mat& image,
                                                  const CameraIntrinsics& camera);
  // Drops the anchors of tracks no plane holds any more; call after each view's Measure.
  void Keep(const std::vector<DominantPlane>& planes);

  // A new window size drops the anchors (their patches are cut for the old one); they are
  // taken again at the next view.
  void set_options(const AnchorOptions& options);

 private:
  struct Anchor {
    int plane = 0;
    int64_t reference_t_ns = 0;
    cv::Matx33d reference_to_anchor;  // The plane's homography when the anchor was taken.
    CameraIntrinsics camera;          // The calibration it was taken with.
    cv::Point2f raw;                  // Pixel the patch is centred on,
    cv::Point2d ideal;                // undistorted,
    cv::Matx22d ideal_from_raw;       // and the undistortion's Jacobian there.
    cv::Mat patch;                    // CV_32F around it, wide enough to warp from.
  };
  std::optional<Anchor> Take(const DominantPlane& plane, const cv::Mat& image,
                             const CameraIntrinsics& camera, cv::Point2f pixel) const;
  // The anchor aligned with `image` near `start`, and how far (px) that lies from where the
  // plane's homography carries the anchor.
  struct Aligned {
    cv::Point2f at;
    double off_plane_px = 0.0;
  };
  std::optional<Aligned> Align(const Anchor& anchor, const DominantPlane& plane,
                               const cv::Mat& image, const CameraIntrinsics& camera,
                               cv::Point2f start);

  AnchorOptions options_;
  std::map<int, Anchor> anchors_;                             // By track id.
  cv::Mat wide_, gx_, gy_, template_, sampled_, current_;     // Scratch of Align.
};

}  // namespace autocal
