#include "devices/sim/renderer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "devices/sim/random.h"
#include "pipeline/error.h"

namespace autocal {
namespace {

// Newton is run until the distorted point is reproduced to this (normalized units, about
// 1e-9 px), the tolerance of UndistortNormalized.
constexpr double kRayTolerance = 1e-12;
constexpr int kMaxNewtonIterations = 30;
// Pixels are grouped in runs of this many along a row; each run gets the list of planes
// that can be hit by its rays.
constexpr int kTileWidth = 32;
// Rows of the blocks pass 1 shades together.
constexpr int kBandHeight = 16;
// Hits closer than this to the camera's principal plane are not rendered (the camera is
// never that close to a surface); it bounds the projected extent of planes that reach
// behind the camera.
constexpr double kNearM = 1e-3;
// Ray tables kept for reuse (threads rendering different frames of a drifting lens each
// need their own).
constexpr size_t kCachedRayTables = 4;
// Grey level fog pulls the image toward.
constexpr float kFogGrey = 190.0f;

// Distortion at (x, y) and its Jacobian.
inline void Distort(const double* k, double x, double y, double* xd, double* yd, double* j00,
                    double* j01, double* j10, double* j11) {
  const double k1 = k[0], k2 = k[1], p1 = k[2], p2 = k[3], k3 = k[4];
  const double x2 = x * x, y2 = y * y, xy = x * y, r2 = x2 + y2;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double dradial = k1 + r2 * (2.0 * k2 + 3.0 * r2 * k3);
  *xd = x * radial + 2.0 * p1 * xy + p2 * (r2 + 2.0 * x2);
  *yd = y * radial + p1 * (r2 + 2.0 * y2) + 2.0 * p2 * xy;
  *j00 = radial + 2.0 * x2 * dradial + 2.0 * p1 * y + 6.0 * p2 * x;
  *j01 = 2.0 * xy * dradial + 2.0 * p1 * x + 2.0 * p2 * y;
  *j10 = *j01;
  *j11 = radial + 2.0 * y2 * dradial + 6.0 * p1 * y + 2.0 * p2 * x;
}

// Inverts the distortion by Newton's method from (*x, *y), the same iteration as
// UndistortNormalized. On success (*x, *y) is the ideal point and inv the inverse
// Jacobian there (row-major). The result depends only on the start and the target, and
// every start used here is itself a pure function of the intrinsics: rendering stays
// deterministic whatever was rendered before.
bool SolveRay(const double* k, double xd, double yd, double* x, double* y, double inv[4]) {
  for (int i = 0; i < kMaxNewtonIterations; ++i) {
    double px, py, j00, j01, j10, j11;
    Distort(k, *x, *y, &px, &py, &j00, &j01, &j10, &j11);
    const double det = j00 * j11 - j01 * j10;
    // Past the fold of a strong barrel no ray maps to this point.
    if (!(det > 1e-12)) return false;
    inv[0] = j11 / det;
    inv[1] = -j01 / det;
    inv[2] = -j10 / det;
    inv[3] = j00 / det;
    const double rx = px - xd, ry = py - yd;
    if (rx * rx + ry * ry <= kRayTolerance * kRayTolerance) return true;
    double sx = inv[0] * rx + inv[1] * ry, sy = inv[2] * rx + inv[3] * ry;
    const double step = std::sqrt(sx * sx + sy * sy);
    const double max_step = 0.5 * (1.0 + std::sqrt(*x * *x + *y * *y));
    if (step > max_step) {
      sx *= max_step / step;
      sy *= max_step / step;
    }
    *x -= sx;
    *y -= sy;
    if (!std::isfinite(*x) || !std::isfinite(*y)) return false;
  }
  return false;
}

// Inverse of the radial part r -> r (1 + k1 r^2 + k2 r^4 + k3 r^6), tabulated on distorted
// radii with its slope and interpolated by cubic Hermite: for a radial lens the start is
// already within Newton's tolerance, so most pixels need one evaluation.
class RadialInverse {
 public:
  RadialInverse(const double* k, double max_distorted) {
    auto f = [k](double r) {
      const double r2 = r * r;
      return r * (1.0 + r2 * (k[0] + r2 * (k[1] + r2 * k[4])));
    };
    auto df = [k](double r) {
      const double r2 = r * r;
      return 1.0 + r2 * (3.0 * k[0] + r2 * (5.0 * k[1] + 7.0 * r2 * k[4]));
    };
    // The monotonic part ends at the fold (f' = 0) or where it is no longer needed.
    double fold = 0.0;
    constexpr double kScan = 1e-3;
    while (fold < 50.0 && df(fold + kScan) > 0.0 && f(fold) < max_distorted) fold += kScan;
    step_ = std::max(max_distorted, 1e-9) / kEntries;
    radius_.resize(kEntries + 2);
    slope_.resize(kEntries + 2);
    const double limit = fold + kScan;
    double r = 0.0;
    for (int i = 0; i < kEntries + 2; ++i) {
      const double target = i * step_;
      if (f(limit) <= target) {
        radius_[i] = limit;
        slope_[i] = 0.0;
        continue;
      }
      // Newton from the previous entry: f is increasing and smooth here.
      for (int it = 0; it < 20; ++it) {
        const double next = std::clamp(r - (f(r) - target) / df(r), 0.0, limit);
        if (std::abs(next - r) < 1e-15) break;
        r = next;
      }
      radius_[i] = r;
      slope_[i] = step_ / df(r);  // dr per table step.
    }
  }

  void Guess(double xd, double yd, double* x, double* y) const {
    const double rd = std::sqrt(xd * xd + yd * yd);
    if (rd <= 0.0) {
      *x = xd;
      *y = yd;
      return;
    }
    const double pos = std::min(rd / step_, static_cast<double>(kEntries));
    const int i = static_cast<int>(pos);
    const double w = pos - i, w2 = w * w, w3 = w2 * w;
    const double r = (2 * w3 - 3 * w2 + 1) * radius_[i] + (w3 - 2 * w2 + w) * slope_[i] +
                     (-2 * w3 + 3 * w2) * radius_[i + 1] + (w3 - w2) * slope_[i + 1];
    *x = xd * r / rd;
    *y = yd * r / rd;
  }

 private:
  static constexpr int kEntries = 4096;
  double step_ = 1.0;
  std::vector<double> radius_;
  std::vector<double> slope_;
};

// A scene plane in the camera frame, ready for ray casting: for the ray r = (x, y, 1),
// depth = d / (C.r), a = (A.r) / (C.r), b = (B.r) / (C.r).
struct CamPlane {
  double A[3], B[3], C[3];
  double d;
  double width, height;
  double xmin, xmax, ymin, ymax;  // Bounds of the rays that can hit it.
  int index;                      // Into Scene::planes.
};

struct Hit {
  double depth = std::numeric_limits<double>::infinity();
  double a = 0.0, b = 0.0, inv_den = 0.0;
  int plane = -1;  // Into the CamPlane vector.
};

// The scene's planes at `time_s` seen from `world_from_cam`.
std::vector<CamPlane> CameraPlanes(const Scene& scene, const Eigen::Isometry3d& world_from_cam,
                                   double time_s) {
  const Eigen::Matrix3d cam_from_world = world_from_cam.rotation().transpose();
  const Eigen::Vector3d t = world_from_cam.translation();
  std::vector<CamPlane> planes;
  for (size_t i = 0; i < scene.planes.size(); ++i) {
    const Plane& plane = scene.planes[i];
    if (!plane.PresentAt(time_s)) continue;
    const Eigen::Vector3d o = cam_from_world * (plane.OriginAt(time_s) - t);
    const Eigen::Vector3d u = cam_from_world * plane.axis_u;
    const Eigen::Vector3d v = cam_from_world * plane.axis_v;
    const Eigen::Vector3d n = v.cross(u);
    const double d = n.dot(o);
    // Planes are seen from the side their normal points to: the camera must be there.
    if (!(d < 0.0)) continue;
    // Clip the rectangle to z >= kNearM and bound its projection.
    const Eigen::Vector3d corners[4] = {o, o + plane.width_m * u,
                                        o + plane.width_m * u + plane.height_m * v,
                                        o + plane.height_m * v};
    CamPlane cp;
    cp.xmin = cp.ymin = std::numeric_limits<double>::infinity();
    cp.xmax = cp.ymax = -std::numeric_limits<double>::infinity();
    auto include = [&cp](const Eigen::Vector3d& p) {
      cp.xmin = std::min(cp.xmin, p.x() / p.z());
      cp.xmax = std::max(cp.xmax, p.x() / p.z());
      cp.ymin = std::min(cp.ymin, p.y() / p.z());
      cp.ymax = std::max(cp.ymax, p.y() / p.z());
    };
    bool any = false;
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d& p = corners[k];
      const Eigen::Vector3d& q = corners[(k + 1) % 4];
      if (p.z() >= kNearM) {
        include(p);
        any = true;
      }
      if ((p.z() >= kNearM) != (q.z() >= kNearM)) {
        include(p + (kNearM - p.z()) / (q.z() - p.z()) * (q - p));
        any = true;
      }
    }
    if (!any) continue;
    const Eigen::Vector3d A = d * u - u.dot(o) * n;
    const Eigen::Vector3d B = d * v - v.dot(o) * n;
    for (int k = 0; k < 3; ++k) {
      cp.A[k] = A[k];
      cp.B[k] = B[k];
      cp.C[k] = n[k];
    }
    cp.d = d;
    cp.width = plane.width_m;
    cp.height = plane.height_m;
    cp.index = static_cast<int>(i);
    planes.push_back(cp);
  }
  return planes;
}

// The scene's planes in the camera of each row: one set for a global shutter, a set per row
// for a rolling one.
class RowPlanes {
 public:
  RowPlanes(const Scene& scene, const Eigen::Isometry3d& world_from_cam,
            const std::vector<Eigen::Isometry3d>& world_from_cam_by_row, int height,
            const ShotTime& time) {
    if (world_from_cam_by_row.empty()) {
      all_rows_ = CameraPlanes(scene, world_from_cam, time.middle_s);
      most_ = all_rows_.size();
      return;
    }
    if (static_cast<int>(world_from_cam_by_row.size()) != height) {
      throw Error("simulator: " + std::to_string(world_from_cam_by_row.size()) +
                  " row poses for an image of " + std::to_string(height) + " rows");
    }
    by_row_.resize(height);
    cv::parallel_for_(cv::Range(0, height), [&](const cv::Range& rows) {
      for (int v = rows.start; v < rows.end; ++v) {
        const double row_s = time.middle_s + (v - 0.5 * (height - 1)) * time.row_period_s;
        by_row_[v] = CameraPlanes(scene, world_from_cam_by_row[v], row_s);
      }
    });
    for (const auto& planes : by_row_) most_ = std::max(most_, planes.size());
  }

  const std::vector<CamPlane>& operator[](int row) const {
    return by_row_.empty() ? all_rows_ : by_row_[row];
  }
  // The most planes any row has (sizes the candidate lists).
  size_t most() const { return most_; }

 private:
  std::vector<CamPlane> all_rows_;
  std::vector<std::vector<CamPlane>> by_row_;
  size_t most_ = 0;
};

// Nearest hit of the ray (x, y, 1) among the candidate planes.
inline Hit Intersect(const std::vector<CamPlane>& planes, const int* candidates, int count,
                     double x, double y) {
  Hit hit;
  for (int c = 0; c < count; ++c) {
    const CamPlane& p = planes[candidates[c]];
    const double den = p.C[0] * x + p.C[1] * y + p.C[2];
    if (!(den < 0.0)) continue;
    const double inv = 1.0 / den;
    const double depth = p.d * inv;
    if (depth >= hit.depth || depth < kNearM) continue;
    const double a = (p.A[0] * x + p.A[1] * y + p.A[2]) * inv;
    if (a < 0.0 || a >= p.width) continue;
    const double b = (p.B[0] * x + p.B[1] * y + p.B[2]) * inv;
    if (b < 0.0 || b >= p.height) continue;
    hit.depth = depth;
    hit.a = a;
    hit.b = b;
    hit.inv_den = inv;
    hit.plane = candidates[c];
  }
  return hit;
}

}  // namespace

struct RayTable {
  CameraIntrinsics intrinsics;
  int width = 0, height = 0;
  std::array<double, 5> dist{};
  std::vector<double> x, y;  // Ideal normalized coordinates of each pixel centre's ray.
  // Change of the ray per pixel step along u and v.
  std::vector<float> dx_du, dy_du, dx_dv, dy_dv;
  std::vector<uint8_t> valid;  // 0 where no ray maps to the pixel.
  std::vector<float> cos4;     // cos^4 of the angle between the ray and the optical axis.
  // Bounds of the rays (sub-pixel rays included) of each tile of kTileWidth pixels.
  int tiles_per_row = 0;
  std::vector<double> tile_xmin, tile_xmax, tile_ymin, tile_ymax;

  explicit RayTable(const CameraIntrinsics& c)
      : intrinsics(c), width(c.width), height(c.height), dist(c.Distortion()) {
    const size_t n = static_cast<size_t>(width) * height;
    x.resize(n);
    y.resize(n);
    dx_du.resize(n);
    dy_du.resize(n);
    dx_dv.resize(n);
    dy_dv.resize(n);
    valid.resize(n);
    cos4.resize(n);
    tiles_per_row = (width + kTileWidth - 1) / kTileWidth;
    tile_xmin.assign(static_cast<size_t>(tiles_per_row) * height, 0.0);
    tile_xmax = tile_ymin = tile_ymax = tile_xmin;
    double max_rd = 0.0;
    for (double u : {-0.5, width - 0.5}) {
      for (double v : {-0.5, height - 0.5}) {
        max_rd = std::max(max_rd, std::hypot((u - c.cx) / c.fx, (v - c.cy) / c.fy));
      }
    }
    const RadialInverse radial(dist.data(), 1.01 * max_rd);
    cv::parallel_for_(cv::Range(0, height), [this, &radial](const cv::Range& rows) {
      for (int v = rows.start; v < rows.end; ++v) BuildRow(v, radial);
    });
  }

  void BuildRow(int v, const RadialInverse& radial) {
    const CameraIntrinsics& c = intrinsics;
    for (int u = 0; u < width; ++u) {
      const size_t i = static_cast<size_t>(v) * width + u;
      const double xd = (u - c.cx) / c.fx, yd = (v - c.cy) / c.fy;
      double rx, ry, inv[4];
      radial.Guess(xd, yd, &rx, &ry);
      valid[i] = SolveRay(dist.data(), xd, yd, &rx, &ry, inv) ? 1 : 0;
      if (!valid[i]) continue;
      x[i] = rx;
      y[i] = ry;
      dx_du[i] = static_cast<float>(inv[0] / c.fx);
      dy_du[i] = static_cast<float>(inv[2] / c.fx);
      dx_dv[i] = static_cast<float>(inv[1] / c.fy);
      dy_dv[i] = static_cast<float>(inv[3] / c.fy);
      const double q = 1.0 + rx * rx + ry * ry;
      cos4[i] = static_cast<float>(1.0 / (q * q));
    }
    for (int t = 0; t < tiles_per_row; ++t) {
      double xmin = std::numeric_limits<double>::infinity(), ymin = xmin;
      double xmax = -xmin, ymax = -xmin;
      for (int u = t * kTileWidth; u < std::min(width, (t + 1) * kTileWidth); ++u) {
        const size_t i = static_cast<size_t>(v) * width + u;
        if (!valid[i]) continue;
        // Sub-pixel rays reach half a pixel each way; the factor covers the curvature.
        const double ex = 0.75 * (std::abs(dx_du[i]) + std::abs(dx_dv[i]));
        const double ey = 0.75 * (std::abs(dy_du[i]) + std::abs(dy_dv[i]));
        xmin = std::min(xmin, x[i] - ex);
        xmax = std::max(xmax, x[i] + ex);
        ymin = std::min(ymin, y[i] - ey);
        ymax = std::max(ymax, y[i] + ey);
      }
      const size_t ti = static_cast<size_t>(v) * tiles_per_row + t;
      tile_xmin[ti] = xmin;
      tile_xmax[ti] = xmax;
      tile_ymin[ti] = ymin;
      tile_ymax[ti] = ymax;
    }
  }

  // Planes whose projection overlaps the tile; returns their count.
  int Candidates(const std::vector<CamPlane>& planes, int v, int tile, int* out) const {
    const size_t ti = static_cast<size_t>(v) * tiles_per_row + tile;
    int count = 0;
    for (size_t p = 0; p < planes.size(); ++p) {
      const CamPlane& cp = planes[p];
      if (cp.xmax < tile_xmin[ti] || cp.xmin > tile_xmax[ti] || cp.ymax < tile_ymin[ti] ||
          cp.ymin > tile_ymax[ti]) {
        continue;
      }
      out[count++] = static_cast<int>(p);
    }
    return count;
  }
};

namespace {

// Colour of a hit, the texture filtered over the footprint of a (sub-)pixel whose ray
// changes by (dx_du, dy_du) and (dx_dv, dy_dv) per step.
inline cv::Vec3f Shade(const Scene& scene, const std::vector<CamPlane>& planes, const Hit& hit,
                       float dx_du, float dy_du, float dx_dv, float dy_dv) {
  const CamPlane& p = planes[hit.plane];
  const Plane& plane = scene.planes[p.index];
  // a = A.r / C.r, so da = (A.dr - a C.dr) / C.r; likewise b.
  const double cu = p.C[0] * dx_du + p.C[1] * dy_du;
  const double cv = p.C[0] * dx_dv + p.C[1] * dy_dv;
  Footprint f;
  f.a = hit.a;
  f.b = hit.b;
  f.da_du = (p.A[0] * dx_du + p.A[1] * dy_du - hit.a * cu) * hit.inv_den;
  f.db_du = (p.B[0] * dx_du + p.B[1] * dy_du - hit.b * cu) * hit.inv_den;
  f.da_dv = (p.A[0] * dx_dv + p.A[1] * dy_dv - hit.a * cv) * hit.inv_den;
  f.db_dv = (p.B[0] * dx_dv + p.B[1] * dy_dv - hit.b * cv) * hit.inv_den;
  return scene.textures[plane.texture].Sample(f) * plane.shade;
}

}  // namespace

Renderer::Renderer(std::shared_ptr<const Scene> scene) : scene_(std::move(scene)) {}

Renderer::~Renderer() = default;

std::shared_ptr<const RayTable> Renderer::Rays(const CameraIntrinsics& intrinsics) const {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = cache_.begin(); it != cache_.end(); ++it) {
      if ((*it)->intrinsics == intrinsics) {
        auto table = *it;
        cache_.splice(cache_.begin(), cache_, it);
        return table;
      }
    }
  }
  std::string why;
  if (!intrinsics.Check(&why)) throw Error("simulator: bad intrinsics: " + why);
  auto table = std::make_shared<const RayTable>(intrinsics);
  std::lock_guard<std::mutex> lock(mutex_);
  cache_.push_front(table);
  if (cache_.size() > kCachedRayTables) cache_.pop_back();
  return table;
}

cv::Mat Renderer::RenderLabels(const CameraIntrinsics& intrinsics,
                               const Eigen::Isometry3d& world_from_cam,
                               const std::vector<Eigen::Isometry3d>& world_from_cam_by_row,
                               const ShotTime& time) const {
  const auto rays = Rays(intrinsics);
  const RowPlanes row_planes(*scene_, world_from_cam, world_from_cam_by_row, rays->height, time);
  cv::Mat labels(rays->height, rays->width, CV_16U);
  cv::parallel_for_(cv::Range(0, rays->height), [&](const cv::Range& rows) {
    std::vector<int> candidates(row_planes.most() + 1);
    for (int v = rows.start; v < rows.end; ++v) {
      const std::vector<CamPlane>& planes = row_planes[v];
      uint16_t* out = labels.ptr<uint16_t>(v);
      for (int t = 0; t < rays->tiles_per_row; ++t) {
        const int count = rays->Candidates(planes, v, t, candidates.data());
        for (int u = t * kTileWidth; u < std::min(rays->width, (t + 1) * kTileWidth); ++u) {
          const size_t i = static_cast<size_t>(v) * rays->width + u;
          out[u] = 0;
          if (!rays->valid[i]) continue;
          const Hit hit = Intersect(planes, candidates.data(), count, rays->x[i], rays->y[i]);
          if (hit.plane >= 0)
            out[u] = static_cast<uint16_t>(scene_->planes[planes[hit.plane].index].id);
        }
      }
    }
  });
  return labels;
}

namespace {

// The light reaching each pixel at one instant (CV_32FC3, linear BGR) and the plane each
// pixel centre sees.
cv::Mat Radiance(const Scene& scene, const RayTable& table, const CameraIntrinsics& intrinsics,
                 const RowPlanes& row_planes, int supersampling, cv::Mat* labels) {
  const int width = table.width, height = table.height;
  cv::Mat colour(height, width, CV_32FC3);
  labels->create(height, width, CV_16U);

  // Pass 1: one ray per pixel centre gives the label and the colour. Pixels are visited
  // in blocks of kTileWidth x kBandHeight, whose texels stay in cache.
  const int bands = (height + kBandHeight - 1) / kBandHeight;
  cv::parallel_for_(cv::Range(0, bands), [&](const cv::Range& band_range) {
    std::vector<int> candidates(row_planes.most() + 1);
    for (int band = band_range.start; band < band_range.end; ++band) {
      for (int t = 0; t < table.tiles_per_row; ++t) {
        for (int v = band * kBandHeight; v < std::min(height, (band + 1) * kBandHeight); ++v) {
          const std::vector<CamPlane>& planes = row_planes[v];
          uint16_t* label = labels->ptr<uint16_t>(v);
          cv::Vec3f* out = colour.ptr<cv::Vec3f>(v);
          const int count = table.Candidates(planes, v, t, candidates.data());
          for (int u = t * kTileWidth; u < std::min(width, (t + 1) * kTileWidth); ++u) {
            const size_t i = static_cast<size_t>(v) * width + u;
            label[u] = 0;
            out[u] = cv::Vec3f(0.f, 0.f, 0.f);
            if (!table.valid[i]) continue;
            const Hit hit = Intersect(planes, candidates.data(), count, table.x[i], table.y[i]);
            if (hit.plane < 0) {
              out[u] = scene.background;
              continue;
            }
            label[u] = static_cast<uint16_t>(scene.planes[planes[hit.plane].index].id);
            out[u] = Shade(scene, planes, hit, table.dx_du[i], table.dy_du[i], table.dx_dv[i],
                           table.dy_dv[i]);
          }
        }
      }
    }
  });

  // Pass 2: where a neighbour sees another plane, average S x S sub-pixel rays, so that
  // silhouettes are antialiased like a real sensor's area integration.
  const int s = std::max(1, supersampling);
  if (s > 1) {
    const double* k = table.dist.data();
    cv::parallel_for_(cv::Range(0, height), [&](const cv::Range& rows) {
      std::vector<int> candidates(row_planes.most() + 1);
      for (int v = rows.start; v < rows.end; ++v) {
        const std::vector<CamPlane>& planes = row_planes[v];
        const uint16_t* above = labels->ptr<uint16_t>(std::max(0, v - 1));
        const uint16_t* here = labels->ptr<uint16_t>(v);
        const uint16_t* below = labels->ptr<uint16_t>(std::min(height - 1, v + 1));
        cv::Vec3f* out = colour.ptr<cv::Vec3f>(v);
        for (int t = 0; t < table.tiles_per_row; ++t) {
          int count = -1;
          for (int u = t * kTileWidth; u < std::min(width, (t + 1) * kTileWidth); ++u) {
            const size_t i = static_cast<size_t>(v) * width + u;
            const uint16_t l = here[u];
            const bool edge = above[u] != l || below[u] != l || (u > 0 && here[u - 1] != l) ||
                              (u + 1 < width && here[u + 1] != l);
            if (!edge || !table.valid[i]) continue;
            if (count < 0) count = table.Candidates(planes, v, t, candidates.data());
            const float sub = 1.0f / s;
            cv::Vec3f sum(0.f, 0.f, 0.f);
            for (int sj = 0; sj < s; ++sj) {
              for (int si = 0; si < s; ++si) {
                const double du = (si + 0.5) / s - 0.5, dv = (sj + 0.5) / s - 0.5;
                const double xd = (u + du - intrinsics.cx) / intrinsics.fx;
                const double yd = (v + dv - intrinsics.cy) / intrinsics.fy;
                // Start from the centre ray moved to first order: one Newton step away.
                double x = table.x[i] + table.dx_du[i] * du + table.dx_dv[i] * dv;
                double y = table.y[i] + table.dy_du[i] * du + table.dy_dv[i] * dv;
                double inv[4];
                if (!SolveRay(k, xd, yd, &x, &y, inv)) continue;
                const Hit hit = Intersect(planes, candidates.data(), count, x, y);
                if (hit.plane < 0) {
                  sum += scene.background;
                  continue;
                }
                sum += Shade(scene, planes, hit, sub * table.dx_du[i], sub * table.dy_du[i],
                             sub * table.dx_dv[i], sub * table.dy_dv[i]);
              }
            }
            out[u] = sum * (1.0f / (s * s));
          }
        }
      }
    });
  }

  return colour;
}

}  // namespace

RenderedFrame Renderer::Render(const CameraIntrinsics& intrinsics,
                               const Eigen::Isometry3d& world_from_cam,
                               const RenderOptions& options) const {
  const auto rays = Rays(intrinsics);
  const RayTable& table = *rays;
  const int width = table.width, height = table.height;
  RenderedFrame frame;
  cv::Mat colour = Radiance(
      *scene_, table, intrinsics,
      RowPlanes(*scene_, world_from_cam, options.world_from_cam_by_row, height, options.time),
      options.supersampling, &frame.labels);
  if (!options.blur_instants.empty()) {
    cv::Mat instant_labels;
    for (const ExposureInstant& instant : options.blur_instants) {
      colour += Radiance(*scene_, table, intrinsics,
                         RowPlanes(*scene_, instant.world_from_cam, instant.world_from_cam_by_row,
                                   height, {instant.time_s, options.time.row_period_s}),
                         options.supersampling, &instant_labels);
    }
    colour *= 1.0 / (1.0 + static_cast<double>(options.blur_instants.size()));
  }

  // Sensor effects: fog (blur, lost contrast), lateral colour, vignetting, noise.
  const FrameEffects& effects = options.effects;
  if (effects.fog_blur_sigma_px > 0.0) {
    cv::GaussianBlur(colour, colour, cv::Size(), effects.fog_blur_sigma_px,
                     effects.fog_blur_sigma_px, cv::BORDER_REFLECT);
  }
  // Lateral colour: red magnified and blue shrunk about the principal point, by
  // chromatic_px at the farthest corner.
  std::vector<cv::Mat> planes_bgr;
  cv::split(colour, planes_bgr);
  if (effects.chromatic_px != 0.0) {
    double corner = 0.0;
    for (double u : {0.0, width - 1.0}) {
      for (double v : {0.0, height - 1.0}) {
        corner = std::max(corner, std::hypot(u - intrinsics.cx, v - intrinsics.cy));
      }
    }
    for (const auto& [channel, sign] : {std::pair{2, 1.0}, std::pair{0, -1.0}}) {
      // Output pixel p reads the channel at c + (p - c) / scale.
      const double inverse = 1.0 / (1.0 + sign * effects.chromatic_px / corner);
      const cv::Matx23d output_to_input(inverse, 0.0, intrinsics.cx * (1.0 - inverse), 0.0, inverse,
                                        intrinsics.cy * (1.0 - inverse));
      cv::Mat moved;
      cv::warpAffine(planes_bgr[channel], moved, output_to_input, colour.size(),
                     cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REPLICATE);
      planes_bgr[channel] = moved;
    }
  }
  // Fog contrast, vignetting, noise, quantization.
  const float contrast = static_cast<float>(effects.fog_contrast);
  const float fog_offset = (1.0f - contrast) * kFogGrey;
  const float vignetting = static_cast<float>(effects.vignetting);
  frame.image.create(height, width, CV_8UC3);
  cv::parallel_for_(cv::Range(0, height), [&](const cv::Range& rows) {
    cv::Mat noise(1, 3 * width, CV_32F, cv::Scalar(0));
    for (int v = rows.start; v < rows.end; ++v) {
      if (effects.noise_sigma > 0.0) {
        // One generator per row: the noise does not depend on how rows meet threads.
        cv::RNG rng(MixSeed(options.noise_seed, kFrameNoiseStream, static_cast<uint64_t>(v)));
        rng.fill(noise, cv::RNG::NORMAL, 0.0, effects.noise_sigma);
      }
      const float* n = noise.ptr<float>(0);
      const float* blue = planes_bgr[0].ptr<float>(v);
      const float* green = planes_bgr[1].ptr<float>(v);
      const float* red = planes_bgr[2].ptr<float>(v);
      const float* cos4 = table.cos4.data() + static_cast<size_t>(v) * width;
      uchar* out = frame.image.ptr<uchar>(v);
      for (int u = 0; u < width; ++u) {
        const float falloff = 1.0f - vignetting * (1.0f - cos4[u]);
        const float gain = contrast * falloff, offset = fog_offset * falloff;
        out[3 * u] = cv::saturate_cast<uchar>(blue[u] * gain + offset + n[3 * u]);
        out[3 * u + 1] = cv::saturate_cast<uchar>(green[u] * gain + offset + n[3 * u + 1]);
        out[3 * u + 2] = cv::saturate_cast<uchar>(red[u] * gain + offset + n[3 * u + 2]);
      }
    }
  });
  return frame;
}

}  // namespace autocal
