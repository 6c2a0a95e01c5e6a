// Renders a scene through the exact lens model: every pixel's ray is the undistorted
// (Newton-inverted) normalized coordinate of its distorted one, intersected with the
// scene's planes; plane boundaries are supersampled and textures filtered by footprint.
// Light is averaged over the exposure's instants (motion blur); sensor effects (fog,
// lateral colour, vignetting, noise) follow.
#pragma once

#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "devices/sim/lens.h"
#include "devices/sim/scene.h"
#include "pipeline/camera_model.h"

namespace autocal {

// When an image is taken, which places the scene's moving planes: seconds after the first
// frame at its middle row, and from one row to the next (a rolling shutter; 0: a global one).
struct ShotTime {
  double middle_s = 0.0;
  double row_period_s = 0.0;
};

// One instant of an exposure: the camera's pose and, for a rolling shutter, each row's, at
// `time_s` (the middle row's).
struct ExposureInstant {
  Eigen::Isometry3d world_from_cam = Eigen::Isometry3d::Identity();
  std::vector<Eigen::Isometry3d> world_from_cam_by_row;
  double time_s = 0.0;
};

struct RenderOptions {
  int supersampling = 3;    // Sub-rays per side where a neighbour sees another plane; 1: none.
  // Rolling shutter: the camera's pose for each row (as many as the image has rows);
  // empty: the pose passed to Render for every row (a global shutter).
  std::vector<Eigen::Isometry3d> world_from_cam_by_row;
  ShotTime time;  // Of the pose passed to Render (and its rows).
  // Motion blur: the exposure's other instants, whose light is averaged with that at the
  // pose passed to Render (which alone gives the labels). Empty: an instantaneous exposure.
  std::vector<ExposureInstant> blur_instants;
  FrameEffects effects;     // Fog, colour fringes, vignetting and noise of this frame.
  uint64_t noise_seed = 1;  // Seeds this frame's sensor noise.
};

struct RenderedFrame {
  cv::Mat image;   // CV_8UC3, BGR.
  cv::Mat labels;  // CV_16U: id of the plane each pixel centre sees; 0 for none.
};

// Per-pixel rays of one set of intrinsics (defined in renderer.cc).
struct RayTable;

class Renderer {
 public:
  explicit Renderer(std::shared_ptr<const Scene> scene);
  ~Renderer();

  // Thread-safe; the result depends only on the arguments.
  RenderedFrame Render(const CameraIntrinsics& intrinsics, const Eigen::Isometry3d& world_from_cam,
                       const RenderOptions& options) const;
  // The label image alone (no shading, no effects): cheaper. `world_from_cam_by_row` and
  // `time` as in RenderOptions.
  cv::Mat RenderLabels(const CameraIntrinsics& intrinsics, const Eigen::Isometry3d& world_from_cam,
                       const std::vector<Eigen::Isometry3d>& world_from_cam_by_row = {},
                       const ShotTime& time = {}) const;

 private:
  // The ray table of `intrinsics`, from the cache or built (rays depend only on the
  // intrinsics, so a cached table is identical to a rebuilt one).
  std::shared_ptr<const RayTable> Rays(const CameraIntrinsics& intrinsics) const;

  std::shared_ptr<const Scene> scene_;
  mutable std::mutex mutex_;
  mutable std::list<std::shared_ptr<const RayTable>> cache_;  // Most recent first.
};

}  // namespace autocal
