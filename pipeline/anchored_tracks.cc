#include "pipeline/anchored_tracks.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <sstream>

#include <Eigen/Core>
#include <opencv2/imgproc.hpp>

namespace autocal {

bool AnchorOptions::Check(std::string* error) const {
  std::ostringstream why;
  if (window_px < 5 || window_px % 2 == 0) {
    why << "window_px must be odd and at least 5";
  } else if (!(max_shift_px > 0)) {
    why << "max_shift_px must be positive";
  } else if (!(off_plane_fraction >= 0)) {
    why << "off_plane_fraction must not be negative";
  } else if (!(off_plane_ratio >= 1)) {
    why << "off_plane_ratio must be at least 1";
  } else if (!(min_correlation > -1 && min_correlation < 1)) {
    why << "min_correlation must be between -1 and 1";
  } else if (max_iterations < 1) {
    why << "max_iterations must be at least 1";
  } else if (!(epsilon_px > 0)) {
    why << "epsilon_px must be positive";
  }
  if (why.str().empty()) return true;
  if (error) *error = why.str();
  return false;
}

AnchoredTracks::AnchoredTracks(const AnchorOptions& options) : options_(options) {}

void AnchoredTracks::set_options(const AnchorOptions& options) {
  if (options.window_px != options_.window_px) anchors_.clear();
  options_ = options;
}

namespace {

// The anchor's patch reaches this far around its pixel: room for the plane to shrink to
// half its size in the image before the warped window runs off it. Tracks nearer the
// border than that are not anchored (nor measured): anchoring them with what of the patch
// the image holds, down to 9 px from the border, made the sixteen 10 s walks worse at
// 320x240 (mean final |fx error| 0.10 -> 0.14%, distortion 0.12 -> 0.15 px), the lens
// bending the patch too much there for one linearization.
int PatchRadius(const AnchorOptions& options) { return options.window_px + 2; }

bool Inside(const cv::Mat& image, cv::Point2f p, double margin) {
  return p.x >= margin && p.y >= margin && p.x <= image.cols - 1 - margin &&
         p.y <= image.rows - 1 - margin;
}

// A float patch (an ROI too) as an Eigen array: its sums run in SIMD.
using PatchArray = Eigen::Array<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
Eigen::Map<const PatchArray, 0, Eigen::OuterStride<>> AsArray(const cv::Mat& patch) {
  return {patch.ptr<float>(), patch.rows, patch.cols, Eigen::OuterStride<>(patch.step1())};
}
Eigen::Map<PatchArray, 0, Eigen::OuterStride<>> AsArray(cv::Mat& patch) {
  return {patch.ptr<float>(), patch.rows, patch.cols, Eigen::OuterStride<>(patch.step1())};
}

// Scales a float patch to zero mean and unit spread into `standardized`; returns the
// spread, or nothing if it is not above `min_spread`. Not OpenCV's meanStdDev, subtract
// and divide: on a 15x15 patch they cost more in dispatch than in arithmetic (Align took a
// tenth of the motion thread, half of it in cv::subtract).
std::optional<float> Standardize(const cv::Mat& patch, float min_spread, cv::Mat* standardized) {
  const auto values = AsArray(patch);
  const float mean = values.mean();
  const float spread = std::sqrt((values - mean).square().mean());
  if (!(spread > min_spread)) return std::nullopt;
  standardized->create(patch.size(), CV_32F);
  AsArray(*standardized) = (values - mean) / spread;
  return spread;
}

// Below this (px of the anchor's patch) the lens and the homography's perspective bend the
// resampling of the anchor's patch nowhere on its edge off the linearization at its
// centre, and the affine warp stands. A translation-only alignment takes the bend for a shift: outward at the edge of
// a wide lens (110 deg at 320x240: 0.26 px on average past 60% of the half-diagonal), which
// box 10 took for a weaker barrel there (docs/calibration.md, "Lenses it was not tuned on").
constexpr double kLinearEnoughPx = 0.01;

// `patch` (CV_32F) resampled bilinearly on a (2 half + 1)^2 grid whose corners, edge
// midpoints and centre land at `at` (row-major, in the patch's pixels), the points between
// placed by the biquadratic through those nine. Every sample must lie inside the patch.
void ResampleBiquadratic(const cv::Mat& patch, const std::array<cv::Point2d, 9>& at, int half,
                         cv::Mat* out) {
  const int side = 2 * half + 1;
  out->create(side, side, CV_32F);
  // The weights of the three nodes on an axis at grid index k.
  const auto lagrange = [half](int k) {
    const double t = double(k - half) / half;
    return std::array<double, 3>{0.5 * t * (t - 1.0), 1.0 - t * t, 0.5 * t * (t + 1.0)};
  };
  for (int row = 0; row < side; ++row) {
    const std::array<double, 3> wy = lagrange(row);
    std::array<cv::Point2d, 3> column;  // Each column of nodes interpolated to this row.
    for (int j = 0; j < 3; ++j) column[j] = wy[0] * at[j] + wy[1] * at[3 + j] + wy[2] * at[6 + j];
    float* target = out->ptr<float>(row);
    for (int col = 0; col < side; ++col) {
      const std::array<double, 3> wx = lagrange(col);
      const cv::Point2d p = wx[0] * column[0] + wx[1] * column[1] + wx[2] * column[2];
      const int x0 = std::clamp(int(std::floor(p.x)), 0, patch.cols - 2);
      const int y0 = std::clamp(int(std::floor(p.y)), 0, patch.rows - 2);
      const float ax = float(p.x - x0), ay = float(p.y - y0);
      const float* above = patch.ptr<float>(y0) + x0;
      const float* below = patch.ptr<float>(y0 + 1) + x0;
      target[col] = (1.0f - ay) * ((1.0f - ax) * above[0] + ax * above[1]) +
                    ay * ((1.0f - ax) * below[0] + ax * below[1]);
    }
  }
}

// The raw pixel of an undistorted one (the camera matrix alone), and the Jacobian of the
// raw pixel with respect to the undistorted one there.
struct RawOfIdeal {
  cv::Point2d pixel;
  cv::Matx22d jacobian;
};
RawOfIdeal RawFromIdeal(const CameraIntrinsics& camera, cv::Point2d ideal) {
  const auto packed = camera.Packed();
  double pixel[2], by_normalized[4];
  ProjectNormalized(packed.data(), (ideal.x - camera.cx) / camera.fx,
                    (ideal.y - camera.cy) / camera.fy, pixel, nullptr, by_normalized);
  return {{pixel[0], pixel[1]},
          {by_normalized[0] / camera.fx, by_normalized[1] / camera.fy,
           by_normalized[2] / camera.fx, by_normalized[3] / camera.fy}};
}

}  // namespace

std::optional<AnchoredTracks::Anchor> AnchoredTracks::Take(const DominantPlane& plane,
                                                           const cv::Mat& image,
                                                           const CameraIntrinsics& camera,
                                                           cv::Point2f pixel) const {
  const int radius = PatchRadius(options_);
  if (!Inside(image, pixel, radius + 1)) return std::nullopt;
  const auto ideal = UndistortPixel(camera, Eigen::Vector2d(pixel.x, pixel.y));
  if (!ideal) return std::nullopt;
  Anchor anchor;
  anchor.plane = plane.id;
  anchor.reference_t_ns = plane.reference_t_ns;
  anchor.reference_to_anchor = plane.homography;
  anchor.camera = camera;
  anchor.raw = pixel;
  anchor.ideal = {ideal->x(), ideal->y()};
  anchor.ideal_from_raw = RawFromIdeal(camera, anchor.ideal).jacobian.inv();
  cv::getRectSubPix(image, cv::Size(2 * radius + 1, 2 * radius + 1), pixel, anchor.patch, CV_32F);
  return anchor;
}

std::optional<AnchoredTracks::Aligned> AnchoredTracks::Align(const Anchor& anchor,
                                                             const DominantPlane& plane,
                                                             const cv::Mat& image,
                                                             const CameraIntrinsics& camera,
                                                             cv::Point2f start) {
  const int r = options_.window_px / 2;
  if (!Inside(image, start, r + options_.max_shift_px + 2)) return std::nullopt;

  // The anchor's neighbourhood carried to this view, linearized at the anchor's pixel:
  // undistorted, through the plane's homography from the anchor's frame to now, and
  // distorted again.
  const cv::Matx33d h = plane.homography * anchor.reference_to_anchor.inv();
  const cv::Vec3d carried = h * cv::Vec3d(anchor.ideal.x, anchor.ideal.y, 1.0);
  if (!(carried[2] > 0)) return std::nullopt;
  const double x = carried[0] / carried[2], y = carried[1] / carried[2];
  const cv::Matx22d homography_jacobian(
      (h(0, 0) - x * h(2, 0)) / carried[2], (h(0, 1) - x * h(2, 1)) / carried[2],
      (h(1, 0) - y * h(2, 0)) / carried[2], (h(1, 1) - y * h(2, 1)) / carried[2]);
  const RawOfIdeal on_plane = RawFromIdeal(camera, {x, y});  // Where the plane puts it.
  const cv::Matx22d now_from_anchor =
      on_plane.jacobian * homography_jacobian * anchor.ideal_from_raw;
  const double det = cv::determinant(now_from_anchor);
  if (!(det > 0.25 && det < 4.0)) return std::nullopt;
  const cv::Matx22d anchor_from_now = now_from_anchor.inv();

  // The anchor patch resampled on this view's pixel grid around the point, one pixel
  // wider than the window for the gradients. Every sample must come from the patch.
  const int radius = PatchRadius(options_);
  const int side = 2 * r + 3;
  for (const cv::Vec2d& corner :
       {cv::Vec2d(-1, -1), cv::Vec2d(1, -1), cv::Vec2d(-1, 1), cv::Vec2d(1, 1)}) {
    const cv::Vec2d reach = anchor_from_now * ((r + 1) * corner);
    if (std::abs(reach[0]) > radius - 1 || std::abs(reach[1]) > radius - 1) return std::nullopt;
  }
  // Where this view's pixels at the corners and edge midpoints of the resampled patch lie
  // in the anchor's patch, exactly: undistorted by this view's calibration, back through
  // the homography, distorted by the anchor's (the centre is the anchor's pixel).
  const cv::Matx33d back = h.inv();
  std::array<cv::Point2d, 9> exact;  // Row-major over offsets (-(r + 1), 0, r + 1) squared.
  double bend = 0.0;                 // The most they lie off the linearization.
  for (int i = 0; i < 9; ++i) {
    const cv::Vec2d offset((r + 1) * (i % 3 - 1), (r + 1) * (i / 3 - 1));
    exact[i] = {double(radius), double(radius)};
    if (i == 4) continue;
    const auto ideal_now =
        UndistortPixel(camera, {on_plane.pixel.x + offset[0], on_plane.pixel.y + offset[1]});
    if (!ideal_now) return std::nullopt;
    const cv::Vec3d then = back * cv::Vec3d(ideal_now->x(), ideal_now->y(), 1.0);
    if (!(then[2] > 0)) return std::nullopt;
    const cv::Point2d raw =
        RawFromIdeal(anchor.camera, {then[0] / then[2], then[1] / then[2]}).pixel;
    exact[i] += cv::Point2d(raw.x - anchor.raw.x, raw.y - anchor.raw.y);
    const cv::Vec2d linear = anchor_from_now * offset;
    bend = std::max(bend, std::hypot(exact[i].x - radius - linear[0],
                                     exact[i].y - radius - linear[1]));
  }
  if (bend < kLinearEnoughPx) {
    const cv::Matx23d sample_at(anchor_from_now(0, 0), anchor_from_now(0, 1),
                                radius - (anchor_from_now(0, 0) + anchor_from_now(0, 1)) * (r + 1),
                                anchor_from_now(1, 0), anchor_from_now(1, 1),
                                radius - (anchor_from_now(1, 0) + anchor_from_now(1, 1)) * (r + 1));
    cv::warpAffine(anchor.patch, wide_, sample_at, cv::Size(side, side),
                   cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REPLICATE);
  } else {
    for (const cv::Point2d& p : exact) {
      if (std::abs(p.x - radius) > radius - 1 || std::abs(p.y - radius) > radius - 1) {
        return std::nullopt;
      }
    }
    ResampleBiquadratic(anchor.patch, exact, r + 1, &wide_);
  }
  const cv::Rect inner(1, 1, 2 * r + 1, 2 * r + 1);
  // Zero mean and unit spread on both sides: the local equalization of each frame
  // shifts and scales the grey levels of a patch as the view around it changes.
  const std::optional<float> spread = Standardize(wide_(inner), 1.0f, &template_);
  if (!spread) return std::nullopt;  // Too flat to place.
  // Central differences (cv::Sobel costs more in setting up than in filtering a patch).
  gx_.create(inner.size(), CV_32F);
  gy_.create(inner.size(), CV_32F);
  const float half_over_spread = float(0.5 / *spread);
  for (int row = 0; row < inner.height; ++row) {
    const float* above = wide_.ptr<float>(row);
    const float* middle = wide_.ptr<float>(row + 1);
    const float* below = wide_.ptr<float>(row + 2);
    float* dx = gx_.ptr<float>(row);
    float* dy = gy_.ptr<float>(row);
    for (int col = 0; col < inner.width; ++col) {
      dx[col] = half_over_spread * (middle[col + 2] - middle[col]);
      dy[col] = half_over_spread * (below[col + 1] - above[col + 1]);
    }
  }
  const auto gx = AsArray(gx_), gy = AsArray(gy_), model = AsArray(template_);
  const double gxx = (gx * gx).sum(), gxy = (gx * gy).sum(), gyy = (gy * gy).sum();
  const double hessian_det = gxx * gyy - gxy * gxy;
  if (!(hessian_det > 1e-6 * (gxx + gyy) * (gxx + gyy))) return std::nullopt;

  // Inverse compositional Gauss-Newton on the translation.
  cv::Point2f at = start;
  const auto sample = [&] {
    cv::getRectSubPix(image, cv::Size(2 * r + 1, 2 * r + 1), at, sampled_, CV_32F);
    return Standardize(sampled_, 1e-3f, &current_).has_value();
  };
  for (int iteration = 0; iteration < options_.max_iterations; ++iteration) {
    if (!sample()) return std::nullopt;
    const auto seen = AsArray(current_);
    const double ex = (gx * (seen - model)).sum(), ey = (gy * (seen - model)).sum();
    const cv::Point2f step(float((gyy * ex - gxy * ey) / hessian_det),
                           float((gxx * ey - gxy * ex) / hessian_det));
    at -= step;
    if (cv::norm(at - start) > options_.max_shift_px) return std::nullopt;
    if (std::hypot(step.x, step.y) < options_.epsilon_px) break;
  }
  if (!sample()) return std::nullopt;
  if ((AsArray(current_) * model).mean() < options_.min_correlation) {
    return std::nullopt;
  }
  return Aligned{at, std::hypot(at.x - on_plane.pixel.x, at.y - on_plane.pixel.y)};
}

std::vector<std::optional<cv::Point2f>> AnchoredTracks::Measure(const DominantPlane& plane,
                                                                const cv::Mat& image,
                                                                const CameraIntrinsics& camera) {
  std::vector<std::optional<cv::Point2f>> measured(plane.track_ids.size());
  std::vector<std::pair<size_t, double>> off_plane;  // Aligned tracks: (index, px off).
  for (size_t i = 0; i < plane.track_ids.size(); ++i) {
    const cv::Point2f tracked = plane.points[i];
    if (!options_.enabled) {
      measured[i] = tracked;
      continue;
    }
    const auto found = anchors_.find(plane.track_ids[i]);
    if (found != anchors_.end() && found->second.plane == plane.id) {
      Anchor& anchor = found->second;
      if (anchor.reference_t_ns == plane.previous_reference_t_ns) {
        // The plane's homographies start from a later frame now.
        anchor.reference_to_anchor = anchor.reference_to_anchor * plane.previous_to_reference.inv();
        anchor.reference_t_ns = plane.reference_t_ns;
      }
      if (anchor.reference_t_ns == plane.reference_t_ns) {
        if (const auto aligned = Align(anchor, plane, image, camera, tracked)) {
          measured[i] = aligned->at;
          off_plane.emplace_back(i, aligned->off_plane_px);
        }
        continue;
      }
    }
    // New to the plane, or its homographies start from a frame unknown to the anchor:
    // anchored afresh where the tracker has it.
    if (auto taken = Take(plane, image, camera, tracked)) {
      anchors_.insert_or_assign(plane.track_ids[i], std::move(*taken));
      measured[i] = tracked;
    } else {
      anchors_.erase(plane.track_ids[i]);
    }
  }
  if (options_.off_plane_fraction > 0 && !off_plane.empty()) {
    std::vector<double> distances;
    for (const auto& [i, px] : off_plane) distances.push_back(px);
    std::nth_element(distances.begin(), distances.begin() + distances.size() / 2, distances.end());
    const double limit = std::max(options_.off_plane_fraction * std::hypot(image.cols, image.rows),
                                  options_.off_plane_ratio * distances[distances.size() / 2]);
    for (const auto& [i, px] : off_plane) {
      if (px > limit) measured[i].reset();
    }
  }
  return measured;
}

void AnchoredTracks::Keep(const std::vector<DominantPlane>& planes) {
  std::set<int> held;
  for (const DominantPlane& plane : planes)
    held.insert(plane.track_ids.begin(), plane.track_ids.end());
  std::erase_if(anchors_, [&](const auto& entry) { return !held.count(entry.first); });
}

}  // namespace autocal
