#include "pipeline/self_calibration.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string_view>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <glog/logging.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "pipeline/intrinsics_stand_still.h"
#include "pipeline/plane_point_cost.h"
#include "pipeline/plumb_line_problem.h"

namespace autocal {

bool SelfCalibrationOptions::Check(std::string* error) const {
  std::ostringstream why;
  if (!(loss_px > 0)) {
    why << "loss_px must be positive";
  } else if (!(prior_focal_fraction > 0) || !(prior_principal_px > 0) || !(prior_distortion > 0)) {
    why << "prior sigmas (prior_focal_fraction, prior_principal_px, prior_distortion) must be "
           "positive";
  } else if (!(prior_track_noise_px > 0)) {
    why << "prior_track_noise_px must be positive";
  } else if (min_frames < 3) {
    why << "min_frames must be at least 3";
  } else if (min_points_per_plane < 6) {
    why << "min_points_per_plane must be at least 6";
  } else if (!(min_rotation_deg >= 0)) {
    why << "min_rotation_deg must not be negative";
  } else if (!(barely_moved_px >= 0)) {
    why << "barely_moved_px must not be negative";
  } else if (!(max_focal_sigma > 0)) {
    why << "max_focal_sigma must be positive";
  } else if (max_iterations < 1) {
    why << "max_iterations must be at least 1";
  } else if (warm_first_pass_iterations < 1) {
    why << "warm_first_pass_iterations must be at least 1";
  } else if (!(function_tolerance > 0 && function_tolerance < 1)) {
    why << "function_tolerance must be between 0 and 1";
  } else if (!(still_intrinsics_px >= 0)) {
    why << "still_intrinsics_px must not be negative";
  } else if (!(warm_start_max_median_px > 0)) {
    why << "warm_start_max_median_px must be positive";
  } else if (!(max_point_rms_ratio == 0 || max_point_rms_ratio >= 1)) {
    why << "max_point_rms_ratio must be 0 (none left out) or at least 1";
  } else if (!IsReadoutMs(readout_ms)) {
    why << "readout_ms must be in [0, " << kMaxReadoutMs << "]";
  }
  if (why.str().empty()) return true;
  if (error) *error = why.str();
  return false;
}

namespace {

// A rolling-shutter correction may move a point up to this many times as far as the
// fastest of its view's points was seen to move over the row's delay, plus a pixel.
constexpr double kMaxShiftOverSeen = 3.0;
// A solve whose reprojection RMS exceeds this many times its median observation's error
// has come apart: Gaussian noise gives 0.85, the simulated walks' solves 1.35 at most.
constexpr double kMaxRmsOverMedian = 10.0;

// The accelerometer's "down" in a frame at rest, against the world's down turned into it.
struct GravityCost {
  GravityCost(const Eigen::Vector3d& down_cam, double weight) : down_(down_cam), weight_(weight) {}

  template <typename T>
  bool operator()(const T* cam_from_world, const T* down_world, T* residual) const {
    T turned[3];
    ceres::AngleAxisRotatePoint(cam_from_world, down_world, turned);
    for (int i = 0; i < 3; ++i) residual[i] = T(weight_) * (turned[i] - T(down_[i]));
    return true;
  }

  Eigen::Vector3d down_;
  double weight_;
};

// The weak prior: each free intrinsic near the last accepted value.
struct PriorCost {
  PriorCost(const std::array<double, kNumIntrinsics>& prior,
            const std::array<double, kNumIntrinsics>& weight)
      : prior_(prior), weight_(weight) {}

  template <typename T>
  bool operator()(const T* intrinsics, T* residual) const {
    for (int i = 0; i < kNumIntrinsics; ++i) {
      residual[i] = T(weight_[i]) * (intrinsics[i] - T(prior_[i]));
    }
    return true;
  }

  std::array<double, kNumIntrinsics> prior_, weight_;
};

using Pose = std::array<double, 6>;  // Angle-axis, then translation.

Eigen::Isometry3d ToIsometry(const Pose& pose);

// A view's motion at its time, in its camera frame: cam_from_world turns as
// R(t + s) = Exp(s turn_rate) R(t), and the camera's centre moves at `velocity`.
struct ViewMotion {
  Eigen::Vector3d turn_rate = Eigen::Vector3d::Zero();  // rad/s.
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();   // The window's units a second.
};

// From the nearest posed views before and after each posed view (one side at the ends).
std::vector<ViewMotion> ViewMotions(const std::vector<Pose>& poses, const std::vector<int>& posed,
                                    const std::vector<int64_t>& t_ns) {
  std::vector<ViewMotion> motion(poses.size());
  for (size_t i = 0; i < posed.size() && posed.size() > 1; ++i) {
    const int before = posed[i > 0 ? i - 1 : i];
    const int after = posed[i + 1 < posed.size() ? i + 1 : i];
    const double span_s = 1e-9 * double(t_ns[after] - t_ns[before]);
    if (!(span_s > 0)) continue;
    const Eigen::Isometry3d a = ToIsometry(poses[before]), b = ToIsometry(poses[after]);
    const Eigen::AngleAxisd turn(b.rotation() * a.rotation().transpose());
    const Eigen::Isometry3d here = ToIsometry(poses[posed[i]]);
    // Camera centres: -R^T t.
    const Eigen::Vector3d travel = b.inverse().translation() - a.inverse().translation();
    motion[posed[i]].turn_rate = turn.angle() / span_s * turn.axis();
    motion[posed[i]].velocity = here.rotation() * travel / span_s;
  }
  return motion;
}

Eigen::Isometry3d ToIsometry(const Pose& pose) {
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d axis(pose[0], pose[1], pose[2]);
  const double angle = axis.norm();
  if (angle > 0) iso.linear() = Eigen::AngleAxisd(angle, axis / angle).toRotationMatrix();
  iso.translation() = Eigen::Vector3d(pose[3], pose[4], pose[5]);
  return iso;
}

Pose FromIsometry(const Eigen::Isometry3d& iso) {
  const Eigen::AngleAxisd axis(iso.rotation());
  const Eigen::Vector3d v = axis.angle() * axis.axis();
  return {v.x(), v.y(), v.z(), iso.translation().x(), iso.translation().y(), iso.translation().z()};
}

double AngleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a * b.transpose()).angle() * 180.0 / M_PI;
}

// Observations of one plane: point id -> frame -> ideal normalized coordinates.
using Tracks = std::map<int, std::map<int, Eigen::Vector2d>>;

struct Structure {
  std::vector<std::optional<Eigen::Isometry3d>> cam_from_world;
  std::vector<std::map<int, Eigen::Vector3d>> points;  // Per plane: point id -> world.
  bool from_start = false;  // Built on an earlier attempt's solution, not the homographies.
};

// Poses of the frames that share enough anchor-plane points with the reference frame,
// from the homographies between them (the plane is n . X = 1 in the reference camera).
void PoseFromAnchor(const Tracks& anchor, int reference, int frame_count, Structure* s) {
  struct Candidate {
    int frame;
    Eigen::Matrix3d rotation;
    Eigen::Vector3d translation, normal;
  };
  std::vector<Candidate> candidates;
  for (int frame = 0; frame < frame_count; ++frame) {
    if (frame == reference) continue;
    std::vector<cv::Point2f> from, to;
    for (const auto& [id, seen] : anchor) {
      const auto a = seen.find(reference), b = seen.find(frame);
      if (a == seen.end() || b == seen.end()) continue;
      from.emplace_back(float(a->second.x()), float(a->second.y()));
      to.emplace_back(float(b->second.x()), float(b->second.y()));
    }
    if (from.size() < 8) continue;
    const cv::Mat h = cv::findHomography(from, to, cv::RANSAC, 0.005);
    if (h.empty()) continue;
    std::vector<cv::Mat> rotations, translations, normals;
    cv::decomposeHomographyMat(h, cv::Mat::eye(3, 3, CV_64F), rotations, translations, normals);
    std::vector<int> visible;
    cv::filterHomographyDecompByVisibleRefpoints(rotations, normals, from, to, visible);
    for (int k : visible) {
      Candidate c;
      c.frame = frame;
      cv::cv2eigen(rotations[k], c.rotation);
      cv::cv2eigen(translations[k], c.translation);
      cv::cv2eigen(normals[k], c.normal);
      candidates.push_back(c);
    }
  }
  if (candidates.empty()) return;
  // The true normal is the same from every frame; the twin solutions wander.
  Eigen::Vector3d normal = candidates.front().normal;
  int best_votes = -1;
  for (const Candidate& c : candidates) {
    int votes = 0;
    for (const Candidate& other : candidates) {
      votes += other.frame != c.frame && c.normal.dot(other.normal) > std::cos(10 * M_PI / 180);
    }
    if (votes > best_votes) {
      best_votes = votes;
      normal = c.normal;
    }
  }
  for (const Candidate& c : candidates) {
    if (c.normal.dot(normal) < std::cos(15 * M_PI / 180)) continue;
    auto& pose = s->cam_from_world[c.frame];
    if (pose) continue;
    Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
    iso.linear() = c.rotation;
    iso.translation() = c.translation;
    pose = iso;
  }
  // Reference-frame points of the anchor on its plane.
  for (const auto& [id, seen] : anchor) {
    const auto a = seen.find(reference);
    if (a == seen.end()) continue;
    const Eigen::Vector3d ray(a->second.x(), a->second.y(), 1.0);
    if (normal.dot(ray) > 1e-6) s->points[0][id] = ray / normal.dot(ray);
  }
}

// Points seen from two posed frames with enough parallax, triangulated.
void Triangulate(const std::vector<Tracks>& planes, Structure* s) {
  for (size_t p = 0; p < planes.size(); ++p) {
    for (const auto& [id, seen] : planes[p]) {
      if (s->points[p].count(id)) continue;
      double best_angle = 1.0 * M_PI / 180;
      std::optional<std::pair<int, int>> pair;
      for (auto a = seen.begin(); a != seen.end(); ++a) {
        if (!s->cam_from_world[a->first]) continue;
        const Eigen::Vector3d ray_a = s->cam_from_world[a->first]->rotation().transpose() *
                                      Eigen::Vector3d(a->second.x(), a->second.y(), 1).normalized();
        for (auto b = std::next(a); b != seen.end(); ++b) {
          if (!s->cam_from_world[b->first]) continue;
          const Eigen::Vector3d ray_b =
              s->cam_from_world[b->first]->rotation().transpose() *
              Eigen::Vector3d(b->second.x(), b->second.y(), 1).normalized();
          const double angle = std::acos(std::clamp(ray_a.dot(ray_b), -1.0, 1.0));
          if (angle > best_angle) {
            best_angle = angle;
            pair = {a->first, b->first};
          }
        }
      }
      if (!pair) continue;
      cv::Mat pa, pb;
      cv::eigen2cv(Eigen::Matrix<double, 3, 4>(s->cam_from_world[pair->first]->matrix().topRows(3)),
                   pa);
      cv::eigen2cv(
          Eigen::Matrix<double, 3, 4>(s->cam_from_world[pair->second]->matrix().topRows(3)), pb);
      const Eigen::Vector2d& xa = seen.at(pair->first);
      const Eigen::Vector2d& xb = seen.at(pair->second);
      cv::Mat homogeneous;
      cv::triangulatePoints(pa, pb, cv::Mat(cv::Point2d(xa.x(), xa.y())),
                            cv::Mat(cv::Point2d(xb.x(), xb.y())), homogeneous);
      const Eigen::Vector3d x(homogeneous.at<double>(0) / homogeneous.at<double>(3),
                              homogeneous.at<double>(1) / homogeneous.at<double>(3),
                              homogeneous.at<double>(2) / homogeneous.at<double>(3));
      if ((*s->cam_from_world[pair->first] * x).z() > 0 &&
          (*s->cam_from_world[pair->second] * x).z() > 0) {
        s->points[p][id] = x;
      }
    }
  }
}

// Frames without a pose placed by PnP on the points known so far.
// From an earlier solution those points are as good as the tracks: a view is placed only
// if at least half of them agree on its pose (within 0.005 in normalized coordinates, a
// pixel at 320x240), as one placed by a few had any pose, and solves started from it
// came apart or crawled. Samples of 4 (AP3P) make that cheap: 100 draws find one clean of
// a half that disagree 99.8% of the time (OpenCV's default, EPnP on 5 over 200 draws,
// spent a quarter of box 10's time on such views). The pose is then solved again on the
// consensus (SOLVEPNP_ITERATIVE); refined from AP3P's, solves came apart.
// From the homographies the points are rough (5-35 px), the agreeing few are all there
// is, and OpenCV's default places the view on them for the solve to put right (AP3P's
// poses on so few put a view 100 px off).
void PlaceByPnp(const std::vector<Tracks>& planes, Structure* s) {
  const bool known_well = s->from_start;
  const int draws = known_well ? 100 : 200;
  const int kernel = known_well ? cv::SOLVEPNP_AP3P : cv::SOLVEPNP_ITERATIVE;
  constexpr double kThreshold = 0.005, kConfidence = 0.99;
  const cv::Mat normalized = cv::Mat::eye(3, 3, CV_64F);
  for (size_t frame = 0; frame < s->cam_from_world.size(); ++frame) {
    if (s->cam_from_world[frame]) continue;
    std::vector<cv::Point3d> object;
    std::vector<cv::Point2d> image;
    for (size_t p = 0; p < planes.size(); ++p) {
      for (const auto& [id, seen] : planes[p]) {
        const auto known = s->points[p].find(id);
        const auto here = seen.find(int(frame));
        if (known == s->points[p].end() || here == seen.end()) continue;
        object.emplace_back(known->second.x(), known->second.y(), known->second.z());
        image.emplace_back(here->second.x(), here->second.y());
      }
    }
    if (object.size() < 8) continue;
    cv::Mat rvec, tvec;
    std::vector<int> consensus;
    if (!cv::solvePnPRansac(object, image, normalized, cv::noArray(), rvec, tvec, false, draws,
                            kThreshold, kConfidence, consensus, kernel) ||
        (known_well && (consensus.size() < 8 || 2 * consensus.size() < object.size()))) {
      continue;
    }
    if (known_well) {
      std::vector<cv::Point3d> agreeing_object;
      std::vector<cv::Point2d> agreeing_image;
      for (const int i : consensus) {
        agreeing_object.push_back(object[i]);
        agreeing_image.push_back(image[i]);
      }
      cv::solvePnP(agreeing_object, agreeing_image, normalized, cv::noArray(), rvec, tvec, false,
                   cv::SOLVEPNP_ITERATIVE);
    }
    Pose pose = {rvec.at<double>(0), rvec.at<double>(1), rvec.at<double>(2),
                 tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)};
    // Points on one plane project the same through a pose turned half round about the
    // plane's normal and put behind the camera; PnP may return that one. Such a view could
    // not be evaluated and would stand in the result turned over.
    const Eigen::Isometry3d cam_from_world = ToIsometry(pose);
    const auto in_front = std::count_if(object.begin(), object.end(), [&](const cv::Point3d& x) {
      return (cam_from_world * Eigen::Vector3d(x.x, x.y, x.z)).z() > 0;
    });
    if (2 * in_front < long(object.size())) continue;
    s->cam_from_world[frame] = cam_from_world;
  }
}

// The earlier solution carried into this window's world (the reference camera's): poses
// of the views it placed, and the points of its planes that are tracked here. False when it
// did not place the reference view.
bool StructureFromStart(const CalibrationStart& start, const std::vector<const PlaneTrack*>& used,
                        const std::vector<Tracks>& planes, int reference, Structure* s) {
  if (int(start.cam_from_world.size()) != int(s->cam_from_world.size()) ||
      !start.cam_from_world[reference]) {
    return false;
  }
  const Eigen::Isometry3d world_from_old = *start.cam_from_world[reference];
  const Eigen::Isometry3d old_from_world = world_from_old.inverse();
  for (size_t frame = 0; frame < start.cam_from_world.size(); ++frame) {
    if (start.cam_from_world[frame])
      s->cam_from_world[frame] = *start.cam_from_world[frame] * old_from_world;
  }
  s->cam_from_world[reference] = Eigen::Isometry3d::Identity();
  for (size_t p = 0; p < planes.size(); ++p) {
    const auto old = std::find_if(start.planes.begin(), start.planes.end(),
                                  [&](const PlaneEstimate& e) { return e.id == used[p]->id; });
    if (old == start.planes.end() || old->points.size() < 3) continue;
    const Eigen::Isometry3d world_from_plane = world_from_old * old->world_from_plane;
    for (const auto& [id, uv] : old->points) {
      if (planes[p].count(id)) {
        s->points[p][id] = world_from_plane * Eigen::Vector3d(uv.x(), uv.y(), 0);
      }
    }
    // Its tracks new to this window: where the ray of the first placed view that sees
    // them meets the plane (as the anchor's are placed without a start).
    const Eigen::Vector3d normal = world_from_plane.rotation().col(2);
    const Eigen::Vector3d origin = world_from_plane.translation();
    for (const auto& [id, seen] : planes[p]) {
      if (s->points[p].count(id)) continue;
      for (const auto& [frame, x] : seen) {
        if (!s->cam_from_world[frame]) continue;
        const Eigen::Isometry3d world_from_cam = s->cam_from_world[frame]->inverse();
        const Eigen::Vector3d ray = world_from_cam.rotation() * Eigen::Vector3d(x.x(), x.y(), 1);
        const double depth = normal.dot(origin - world_from_cam.translation()) / normal.dot(ray);
        if (std::isfinite(depth) && depth > 0) {
          s->points[p][id] = world_from_cam.translation() + depth * ray;
        }
        break;
      }
    }
  }
  return true;
}

// A plane's frame for its estimate (its virtual board is laid in it, and the next window
// starts from its points there), on the plane through `points` with normal `normal`: its
// origin at the point nearest the points' centroid, its first axis toward the point
// farthest from that.
Eigen::Isometry3d PlaneFrame(const std::map<int, Eigen::Vector3d>& points,
                             const Eigen::Vector3d& normal) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& [id, x] : points) centroid += x;
  centroid /= double(points.size());
  const auto farthest_from = [&](const Eigen::Vector3d& from, double sign) {
    const Eigen::Vector3d* best = &points.begin()->second;
    double best_distance = -std::numeric_limits<double>::infinity();
    for (const auto& [id, x] : points) {
      const double distance = sign * (x - from).squaredNorm();
      if (distance > best_distance) {
        best = &x;
        best_distance = distance;
      }
    }
    return *best;
  };
  const Eigen::Vector3d origin = farthest_from(centroid, -1.0);
  Eigen::Vector3d axis_u = farthest_from(origin, 1.0) - origin;
  axis_u = (axis_u - normal.dot(axis_u) * normal).normalized();
  Eigen::Isometry3d world_from_plane = Eigen::Isometry3d::Identity();
  world_from_plane.linear() << axis_u, normal.cross(axis_u), normal;
  world_from_plane.translation() = origin;
  return world_from_plane;
}

// Box 10 with the whole scene one rigid world: every plane still, the camera moving.
SelfCalibrationResult SolveInOneWorld(const CalibrationMaterial& material,
                                      const CameraIntrinsics& prior,
                                      const SelfCalibrationOptions& options) {
  SelfCalibrationResult result;
  result.estimate = prior;
  // Which intrinsics are free.
  std::vector<int> fixed;
  if (!options.estimate_principal_point) fixed.insert(fixed.end(), {kCx, kCy});
  if (!options.estimate_distortion) fixed.insert(fixed.end(), {kK1, kK2});
  if (!options.estimate_tangential) fixed.insert(fixed.end(), {kP1, kP2});
  if (!options.estimate_k3) fixed.push_back(kK3);
  const bool warm = options.warm_start && material.start.has_value();
  // Where the free intrinsics start; the prior stays the prior, and holds the fixed ones.
  CameraIntrinsics start = prior;
  if (warm) {
    std::array<double, kNumIntrinsics> packed = prior.Packed();
    const std::array<double, kNumIntrinsics> solved = material.start->intrinsics.Packed();
    for (int i = 0; i < kNumIntrinsics; ++i) {
      if (std::find(fixed.begin(), fixed.end(), i) == fixed.end()) packed[i] = solved[i];
    }
    start = CameraIntrinsics::FromPacked(packed, prior.width, prior.height);
  }
  auto no_update = [&](const std::string& why) {
    result.reason = "no update: " + why;
    return result;
  };
  if (!material.degraded.empty()) return no_update(material.degraded);

  // Observations in ideal normalized coordinates of the prior, per usable plane; the
  // largest plane anchors the world.
  std::vector<const PlaneTrack*> used;
  std::vector<Tracks> tracks;
  size_t largest = 0;  // Tracked points of the largest plane.
  for (const PlaneTrack& plane : material.planes) {
    Tracks t;
    for (const PlaneObservation& o : plane.observations) {
      if (o.frame < 0 || o.frame >= material.frame_count) continue;
      if (const auto ray = Unproject(start, o.pixel)) t[o.point][o.frame] = *ray;
    }
    largest = std::max(largest, t.size());
    if (int(t.size()) < options.min_points_per_plane) continue;
    used.push_back(&plane);
    tracks.push_back(std::move(t));
  }
  if (tracks.empty()) {
    return no_update("no plane with enough tracked points (" +
                     (material.planes.empty() ? std::string("none found")
                                              : "the largest has " + std::to_string(largest)) +
                     ", " + std::to_string(options.min_points_per_plane) + " needed)");
  }
  const auto by_size = [&](size_t a, size_t b) { return tracks[a].size() > tracks[b].size(); };
  std::vector<size_t> order(tracks.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), by_size);
  std::vector<Tracks> sorted_tracks;
  std::vector<const PlaneTrack*> sorted_used;
  for (size_t i : order) {
    sorted_tracks.push_back(std::move(tracks[i]));
    sorted_used.push_back(used[i]);
  }
  tracks = std::move(sorted_tracks);
  used = std::move(sorted_used);

  // The anchor's reference, the view that holds the world still: the one that sees most of
  // the anchor; on a warm start, the one of those the start placed, as the start's structure
  // carries over only through a view it placed (from a view new to the window, the solve
  // began cold: 40 iterations instead of 6 on the office walk).
  std::map<int, int> seen_in;
  for (const auto& [id, seen] : tracks[0]) {
    for (const auto& [frame, x] : seen) ++seen_in[frame];
  }
  const auto sees_most = [&](const auto& eligible) {
    int best = -1, best_count = 0;
    for (const auto& [frame, count] : seen_in) {
      if (eligible(frame) && count > best_count) {
        best = frame;
        best_count = count;
      }
    }
    return best;
  };
  const int cold_reference = sees_most([](int) { return true; });
  // A start made for views other than this window's (their count differs) is none.
  const bool start_fits =
      warm && material.start->cam_from_world.size() == size_t(material.frame_count);
  const int warm_reference = !start_fits ? -1 : sees_most([&](int frame) {
    return material.start->cam_from_world[frame].has_value();
  });

  // The initial structure: the earlier solution where there is one (fewer iterations, as
  // windows overlap), else the anchor's homographies; then views placed by PnP and points
  // triangulated, as far as they reach.
  auto build = [&](bool from_start, int reference) {
    Structure built;
    built.cam_from_world.resize(material.frame_count);
    built.cam_from_world[reference] = Eigen::Isometry3d::Identity();
    built.points.resize(tracks.size());
    built.from_start =
        from_start && StructureFromStart(*material.start, used, tracks, reference, &built);
    if (!built.from_start) PoseFromAnchor(tracks[0], reference, material.frame_count, &built);
    for (int round = 0; round < 3; ++round) {
      Triangulate(tracks, &built);
      PlaceByPnp(tracks, &built);
    }
    Triangulate(tracks, &built);
    return built;
  };
  int reference = warm_reference >= 0 ? warm_reference : cold_reference;
  Structure structure = build(warm_reference >= 0, reference);
  if (warm_reference >= 0 &&
      std::count_if(structure.cam_from_world.begin(), structure.cam_from_world.end(),
                    [](const auto& pose) { return pose.has_value(); }) < options.min_frames) {
    reference = cold_reference;
    structure = build(false, reference);
  }

  std::vector<int> posed;
  for (int f = 0; f < material.frame_count; ++f) {
    if (structure.cam_from_world[f]) posed.push_back(f);
  }
  if (int(posed.size()) < options.min_frames) {
    return no_update("too few frames could be placed (" + std::to_string(posed.size()) + ", " +
                     std::to_string(options.min_frames) + " needed)");
  }
  for (int a : posed) {
    for (int b : posed) {
      result.rotation_spread_deg =
          std::max(result.rotation_spread_deg, AngleDeg(structure.cam_from_world[a]->rotation(),
                                                        structure.cam_from_world[b]->rotation()));
    }
  }
  if (result.rotation_spread_deg < options.min_rotation_deg) {
    result.too_little_view_change = true;
    std::ostringstream why;
    why.precision(2);
    why << std::fixed << "insufficient rotation (" << result.rotation_spread_deg
        << " deg between views, " << options.min_rotation_deg << " needed)";
    return no_update(why.str());
  }

  // Each plane m . X = 1 in the camera of its own reference view, the one that sees most of
  // its points (the window's reference where it sees as many), and each point on its ray
  // (a, b, 1) there (PlanePointCost).
  // One loss for every residual, outliving the problem: not one allocated for each.
  ceres::CauchyLoss loss(options.loss_px);
  ceres::Problem problem(UnownedLosses());
  auto* ordering = new ceres::ParameterBlockOrdering;
  std::array<double, kNumIntrinsics> intrinsics = start.Packed();
  std::vector<Pose> frame_poses(material.frame_count);
  for (int f : posed) frame_poses[f] = FromIsometry(*structure.cam_from_world[f]);
  std::vector<int> plane_reference(tracks.size(), -1);
  std::vector<std::array<double, 3>> plane_params(tracks.size());
  std::vector<std::map<int, std::array<double, 2>>> rays(tracks.size());
  struct Residual {
    int frame, plane, point;
    Eigen::Vector2d pixel;    // As a global shutter would have seen it at the frame's time.
    Eigen::Vector2d tracked;  // As box 9 measured it.
    PlanePointCost* plane_cost = nullptr;  // Whichever of the two measures it.
    ReferenceRayCost* ray_cost = nullptr;
  };
  std::vector<Residual> residuals;
  for (size_t p = 0; p < tracks.size(); ++p) {
    const auto& points = structure.points[p];
    if (int(points.size()) < options.min_points_per_plane) continue;
    std::map<int, int> seen_by;  // Frame -> the plane's points it sees.
    for (const PlaneObservation& o : used[p]->observations) {
      if (points.count(o.point) && structure.cam_from_world[o.frame]) ++seen_by[o.frame];
    }
    if (seen_by.empty()) continue;
    int k = seen_by.begin()->first;
    for (const auto& [frame, count] : seen_by) {
      if (count > seen_by[k] || (count == seen_by[k] && frame == reference)) k = frame;
    }
    plane_reference[p] = k;
    const Eigen::Isometry3d& reference_from_world = *structure.cam_from_world[k];
    // m from the points' inverse depths in view k, 1 / z = m . (a, b, 1), by least squares.
    // Points triangulated over little parallax scatter along their rays, and a plane fitted
    // to their positions turns toward the rays, nearly edge-on to the views; in inverse depth
    // the scatter averages out instead. From the wrong start, 33 of 40 synthetic
    // rooms converged with a fitted plane, 40 of 40 so (docs/calibration.md, session 25).
    Eigen::Matrix3d normal_matrix = Eigen::Matrix3d::Zero();
    Eigen::Vector3d normal_rhs = Eigen::Vector3d::Zero();
    for (const auto& [id, x] : points) {
      const Eigen::Vector3d in_reference = reference_from_world * x;
      if (in_reference.z() == 0.0) continue;
      const Eigen::Vector3d ray = in_reference / in_reference.z();
      normal_matrix += ray * ray.transpose();
      normal_rhs += ray / in_reference.z();
    }
    const Eigen::Vector3d m = normal_matrix.ldlt().solve(normal_rhs);
    plane_params[p] = {m.x(), m.y(), m.z()};
    // A ray reaches points behind view k too (any but those level with its camera), but a
    // point that view k sees there was triangulated wrong: left out, as behind any other
    // camera that sees it (below).
    std::set<int> seen_by_reference;
    for (const PlaneObservation& o : used[p]->observations) {
      if (o.frame == k) seen_by_reference.insert(o.point);
    }
    for (const auto& [id, x] : points) {
      const Eigen::Vector3d in_reference = reference_from_world * x;
      if (in_reference.z() != 0.0 && (in_reference.z() > 0.0 || !seen_by_reference.count(id))) {
        rays[p][id] = {in_reference.x() / in_reference.z(), in_reference.y() / in_reference.z()};
      }
    }
    for (const auto& [id, seen] : tracks[p]) {
      if (!rays[p].count(id)) continue;
      for (const PlaneObservation& o : used[p]->observations) {
        if (o.point == id && structure.cam_from_world[o.frame]) {
          residuals.push_back({o.frame, int(p), id, o.pixel, o.pixel});
        }
      }
    }
  }
  // A residual's reprojection error (px) at the values in the arrays (not the solver's
  // blocks: copy_out below brings those back); nullopt where the point cannot be evaluated.
  const auto error_px = [&](const Residual& r) -> std::optional<Eigen::Vector2d> {
    Eigen::Vector2d e;
    const int k = plane_reference[r.plane];
    const double* ray = rays[r.plane].at(r.point).data();
    if (r.frame == k) {
      const double* const at[] = {intrinsics.data(), ray};
      ReferenceRayCost(r.pixel).Evaluate(at, e.data(), nullptr);
      return e;
    }
    if (!PlanePointCost(r.pixel).Residual(intrinsics.data(), frame_poses[r.frame].data(),
                                          frame_poses[k].data(), plane_params[r.plane].data(), ray,
                                          e.data())) {
      return std::nullopt;
    }
    return e;
  };
  // A point that the initial structure places behind a camera that sees it (a track that
  // jumped to another surface, a triangulation gone wrong) cannot be evaluated at all:
  // left out, or the solver could not start.
  std::erase_if(residuals, [&](const Residual& r) { return !error_px(r); });
  // A rolling shutter saw each point from its row's pose: the tracked pixel is moved to
  // where the frame's own pose would have seen it, by the point's image's motion over the
  // row's delay, as the structure so far places it and the neighbouring views move.
  const double line_s = 1e-3 * options.readout_ms / prior.height;
  const bool rolling = line_s > 0 && material.frame_t_ns.size() == size_t(material.frame_count);
  // The fastest each view saw a point's image move (px/s, between the point's neighbouring
  // observations), which bounds how far a row's delay can have moved a point in that view.
  std::vector<double> seen_speed(material.frame_count, 0.0);
  if (rolling) {
    std::map<std::pair<int, int>, std::map<int, Eigen::Vector2d>> seen;  // Point -> frame.
    for (const Residual& r : residuals) seen[{r.plane, r.point}][r.frame] = r.tracked;
    for (const auto& [point, frames] : seen) {
      for (auto a = frames.begin(), b = std::next(a); b != frames.end(); ++a, ++b) {
        const double span_s =
            1e-9 * double(material.frame_t_ns[b->first] - material.frame_t_ns[a->first]);
        if (!(span_s > 0)) continue;
        const double speed = (b->second - a->second).norm() / span_s;
        seen_speed[a->first] = std::max(seen_speed[a->first], speed);
        seen_speed[b->first] = std::max(seen_speed[b->first], speed);
      }
    }
  }
  const auto undo_rolling_shutter = [&] {
    const std::vector<ViewMotion> motion = ViewMotions(frame_poses, posed, material.frame_t_ns);
    std::vector<Eigen::Isometry3d> cam_from_world(frame_poses.size());
    for (int f : posed) cam_from_world[f] = ToIsometry(frame_poses[f]);
    const auto project = [&](const Eigen::Vector3d& x) {
      Eigen::Vector2d pixel;
      ProjectNormalized(intrinsics.data(), x.x() / x.z(), x.y() / x.z(), pixel.data(), nullptr,
                        nullptr);
      return pixel;
    };
    for (Residual& r : residuals) {
      const int k = plane_reference[r.plane];
      const std::optional<Eigen::Vector3d> in_reference =
          PointOnRay(plane_params[r.plane].data(), rays[r.plane].at(r.point).data());
      if (!in_reference) continue;
      const Eigen::Vector3d at_frame_time =
          cam_from_world[r.frame] * (cam_from_world[k].inverse() * *in_reference);
      const double delay_s = (r.tracked.y() - 0.5 * (prior.height - 1)) * line_s;
      const Eigen::Vector3d turn = motion[r.frame].turn_rate * delay_s;
      const Eigen::Vector3d at_row_time =
          (turn.norm() > 0 ? Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix()
                           : Eigen::Matrix3d::Identity()) *
              at_frame_time -
          delay_s * motion[r.frame].velocity;
      if (!(at_frame_time.z() > 0) || !(at_row_time.z() > 0)) continue;
      const Eigen::Vector2d shift = project(at_row_time) - project(at_frame_time);
      // Further than any of the view's points was seen to move over the delay: the view's
      // motion is wrong, not the point (a neighbouring view posed far off on a few points
      // in a fast turn moved points by up to 13700 px, and the solve came apart, its RMS
      // 1e10 px). The point keeps the correction it had.
      if (shift.norm() > kMaxShiftOverSeen * seen_speed[r.frame] * std::abs(delay_s) + 1.0) {
        continue;
      }
      r.pixel = r.tracked - shift;
      if (r.plane_cost) r.plane_cost->set_pixel(r.pixel);
      if (r.ray_cost) r.ray_cost->set_pixel(r.pixel);
    }
  };
  if (rolling) undo_rolling_shutter();
  for (size_t p = 0; p < tracks.size(); ++p) {
    std::set<int> kept;
    for (const Residual& r : residuals) {
      if (r.plane == int(p)) kept.insert(r.point);
    }
    std::erase_if(rays[p], [&](const auto& ray) { return !kept.count(ray.first); });
    if (!rays[p].empty()) ++result.planes_used;
    result.points_used += int(rays[p].size());
  }
  // The reference view holds the world still; a start that leaves it without a point it
  // sees (its anchor plane new to this window) is of no use, nor one that does not fit
  // the window's tracks.
  const auto median_error_px = [&] {
    std::vector<double> errors;
    for (const Residual& r : residuals) {
      const Eigen::Vector2d e = *error_px(r);
      errors.push_back(std::hypot(e.x(), e.y()));
    }
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
    return errors[errors.size() / 2];
  };
  const bool reference_sees = std::any_of(residuals.begin(), residuals.end(),
                                          [&](const Residual& r) { return r.frame == reference; });
  if (warm && (!reference_sees || median_error_px() > options.warm_start_max_median_px)) {
    SelfCalibrationOptions cold = options;
    cold.warm_start = false;
    return SelfCalibrate(material, prior, cold);
  }
  result.observations_used = int(residuals.size());
  if (residuals.empty()) return no_update("no plane point seen from two placed frames");
  // Its pose is what holds the world still; with none of its points left in front of it
  // (its anchor plane too poorly triangulated to keep), nothing would.
  if (!reference_sees) return no_update("no plane point placed in front of the reference view");

  // The parameter blocks, in one arena: the points' rays (eliminated first), then the
  // intrinsics, frame poses and planes; the lines and the gravity direction after.
  std::vector<const LineObservation*> lines;
  for (const LineObservation& line : material.lines) {
    if (line.points.size() >= 5) lines.push_back(&line);
  }
  size_t capacity =
      kNumIntrinsics + 6 * posed.size() + 3 * tracks.size() + 3 + PlumbLineParameterCount(lines);
  for (const auto& plane_rays : rays) capacity += 2 * plane_rays.size();
  ParameterArena arena(capacity);
  std::vector<std::map<int, double*>> ray_blocks(tracks.size());
  for (size_t p = 0; p < tracks.size(); ++p) {
    for (const auto& [id, ray] : rays[p]) ray_blocks[p][id] = arena.Add(ray);
  }
  double* const intrinsics_block = arena.Add(intrinsics);
  std::vector<double*> frame_blocks(material.frame_count, nullptr);
  for (int f : posed) frame_blocks[f] = arena.Add(frame_poses[f]);
  std::vector<double*> plane_blocks(tracks.size(), nullptr);
  for (size_t p = 0; p < tracks.size(); ++p) {
    if (!rays[p].empty()) plane_blocks[p] = arena.Add(plane_params[p]);
  }

  for (Residual& r : residuals) {
    const int k = plane_reference[r.plane];
    double* const ray = ray_blocks[r.plane].at(r.point);
    if (r.frame == k) {
      r.ray_cost = new ReferenceRayCost(r.pixel);
      problem.AddResidualBlock(r.ray_cost, &loss, intrinsics_block, ray);
    } else {
      r.plane_cost = new PlanePointCost(r.pixel);
      problem.AddResidualBlock(r.plane_cost, &loss, intrinsics_block, frame_blocks[r.frame],
                               frame_blocks[k], plane_blocks[r.plane], ray);
    }
  }
  for (size_t p = 0; p < tracks.size(); ++p) {
    for (const auto& [id, block] : ray_blocks[p]) ordering->AddElementToGroup(block, 0);
    if (plane_blocks[p] && problem.HasParameterBlock(plane_blocks[p])) {
      ordering->AddElementToGroup(plane_blocks[p], 1);
    }
  }
  // Gauge: the reference camera is the world, and the anchor's distance from its reference
  // view stays where it is (the scale).
  problem.SetParameterBlockConstant(frame_blocks[reference]);
  if (plane_blocks[0] && problem.HasParameterBlock(plane_blocks[0])) {
    problem.SetManifold(plane_blocks[0], new ceres::SphereManifold<3>());
  }
  for (int f : posed) {
    if (problem.HasParameterBlock(frame_blocks[f])) {
      ordering->AddElementToGroup(frame_blocks[f], 1);
    }
  }

  // Straight lines (box 2) and gravity at rest (box 7).
  const std::vector<double*> line_blocks =
      AddPlumbLineResiduals(lines, start, &loss, intrinsics_block, &problem, ordering, &arena);
  result.lines_used = int(lines.size());
  double* down_world = nullptr;
  for (const GravityObservation& g : material.gravity) {
    if (g.frame < 0 || g.frame >= material.frame_count || !structure.cam_from_world[g.frame]) {
      continue;
    }
    if (!down_world) {
      const Eigen::Vector3d d =
          structure.cam_from_world[g.frame]->rotation().transpose() * g.down_cam.normalized();
      down_world = arena.Add(std::array{d.x(), d.y(), d.z()});
    }
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<GravityCost, 3, 6, 3>(new GravityCost(
                                 g.down_cam.normalized(), 180.0 / M_PI / g.sigma_deg)),
                             nullptr, frame_blocks[g.frame], down_world);
  }
  if (down_world) {
    problem.SetManifold(down_world, new ceres::SphereManifold<3>());
    ordering->AddElementToGroup(down_world, 1);
  }

  // The weak prior on the free intrinsics.
  std::array<double, kNumIntrinsics> weight{};
  const double noise_px = options.prior_track_noise_px;
  weight[kFx] = noise_px / (options.prior_focal_fraction * prior.fx);
  weight[kFy] = noise_px / (options.prior_focal_fraction * prior.fy);
  weight[kCx] = weight[kCy] = noise_px / options.prior_principal_px;
  weight[kK1] = weight[kK2] = weight[kP1] = weight[kP2] = weight[kK3] =
      noise_px / options.prior_distortion;
  for (int i : fixed) weight[i] = 0.0;
  problem.AddResidualBlock(
      new ceres::AutoDiffCostFunction<PriorCost, kNumIntrinsics, kNumIntrinsics>(
          new PriorCost(prior.Packed(), weight)),
      nullptr, intrinsics_block);
  if (!fixed.empty()) {
    problem.SetManifold(intrinsics_block, new ceres::SubsetManifold(kNumIntrinsics, fixed));
  }
  ordering->AddElementToGroup(intrinsics_block, 1);

  ceres::Solver::Options solver_options;
  // Strictly descending steps. Non-monotonic ones took a third less time on the simulated
  // walks but wandered off on real shots (OpenCV's left*.jpg: fx +6.7% after 100
  // iterations instead of -0.02% after 8; tests/self_calibration_real_test.cc).
  // The points are eliminated; what is left (the intrinsics, 6 per view and per plane:
  // about 150 columns on a 2 s window, most views sharing tracks) is nearly full, so a
  // dense factor beats a sparse one's bookkeeping: 8-19% off a solve (kernels_bench), the
  // same result to 1e-10.
  solver_options.linear_solver_type = ceres::DENSE_SCHUR;
  solver_options.linear_solver_ordering.reset(ordering);
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  // One thread: with two, the gradient and the Schur complement are summed in an order
  // that depends on thread timing, and results would differ in the last digits.
  solver_options.num_threads = 1;
  // Trial steps that put a point behind a camera are refused, as they should be; Ceres
  // would log each one.
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  // Points that fit far worse than the rest are left out (below), and the solve goes on
  // without them. From an earlier attempt's solution the first pass need only tell them
  // apart, which it does once an iteration lowers the cost by less than 1%: the walks came
  // out as close to the truth as after a full first pass, and both passes together take
  // what one full pass did. Or after a few iterations: first passes of 4-9 iterations were
  // a fifth of the outdoor walk's, in two of its three longest solves. From the homographies
  // it must converge: stopped early, its residuals are still uneven and good points would
  // be left out.
  const bool leave_out = options.max_point_rms_ratio > 0;
  if (leave_out && structure.from_start) {
    solver_options.function_tolerance = 1e-2;
    solver_options.max_num_iterations =
        std::min(options.warm_first_pass_iterations, options.max_iterations);
  }
  // The last pass also stops once the calibration stands still.
  IntrinsicsStandStill stand_still(intrinsics_block, prior, options.still_intrinsics_px);
  const auto last_pass = [&] {
    if (options.still_intrinsics_px <= 0) return;
    solver_options.update_state_every_iteration = true;
    solver_options.callbacks.push_back(&stand_still);
  };
  if (!leave_out) last_pass();
  ceres::Solve(solver_options, &problem, &summary);
  if (!summary.IsSolutionUsable()) return no_update("the solver failed: " + summary.BriefReport());
  result.iterations = int(summary.iterations.size()) - 1;
  const auto copy_out = [&] {
    std::copy_n(intrinsics_block, kNumIntrinsics, intrinsics.begin());
    for (int f : posed) std::copy_n(frame_blocks[f], 6, frame_poses[f].begin());
    for (size_t p = 0; p < tracks.size(); ++p) {
      if (plane_blocks[p]) std::copy_n(plane_blocks[p], 3, plane_params[p].begin());
      for (auto& [id, ray] : rays[p]) std::copy_n(ray_blocks[p].at(id), 2, ray.begin());
    }
  };
  copy_out();

  // The Cauchy loss hardly discounts those points: they are off by a few tenths of a pixel
  // in a consistent way (a track on the wrong plane), not by pixels.
  if (leave_out) {
    std::map<std::pair<int, int>, std::pair<double, int>> by_point;  // Squared sum, count.
    for (const Residual& r : residuals) {
      auto& [sum_sq, count] = by_point[{r.plane, r.point}];
      sum_sq += error_px(r)->squaredNorm();
      ++count;
    }
    std::vector<double> mean_sq;
    for (const auto& [point, sum] : by_point) mean_sq.push_back(sum.first / sum.second);
    std::nth_element(mean_sq.begin(), mean_sq.begin() + mean_sq.size() / 2, mean_sq.end());
    const double limit_sq = std::pow(options.max_point_rms_ratio, 2) * mean_sq[mean_sq.size() / 2];
    std::set<std::pair<int, int>> left_out;
    std::map<int, int> staying;  // Per plane, its points in the problem that stay.
    for (const auto& [point, sum] : by_point) {
      if (sum.first / sum.second > limit_sq) {
        left_out.insert(point);
      } else {
        ++staying[point.first];
      }
    }
    // A plane left with fewer points than a plane needs to be used at all goes whole, all
    // but the anchor, whose pose holds the scale: its pose would hang on the few that stay
    // (on two, free to turn about the line through them), and the solve wandered (the
    // office tessar walk at 640x480: planes left with 2 or 3 points, 86-100 iterations).
    std::set<int> dropped;
    for (size_t p = 1; p < rays.size(); ++p) {
      if (!plane_blocks[p] || !problem.HasParameterBlock(plane_blocks[p]) ||
          staying[int(p)] >= options.min_points_per_plane) {
        continue;
      }
      dropped.insert(int(p));
      for (const auto& [id, ray] : rays[p]) left_out.insert({int(p), id});
    }
    // The anchor, if nearly all its points fit badly, keeps them all: fewer than three would
    // not hold its plane, and its plane holds the scale.
    if (staying[0] < 3) std::erase_if(left_out, [](const auto& point) { return point.first == 0; });
    for (const auto& [plane, id] : left_out) {
      double* const block = ray_blocks[plane].at(id);
      ordering->Remove(block);
      problem.RemoveParameterBlock(block);
      rays[plane].erase(id);
    }
    for (const int plane : dropped) {
      ordering->Remove(plane_blocks[plane]);
      problem.RemoveParameterBlock(plane_blocks[plane]);
      --result.planes_used;
    }
    std::erase_if(residuals, [&](const Residual& r) {
      return left_out.count({r.plane, r.point}) > 0;
    });
    result.points_used -= int(left_out.size());
    result.observations_used = int(residuals.size());
    // Lines likewise: a world line that is not quite straight (the horizon over a corner of
    // the ground, 0.2-0.3 px from straight where the rest are within 0.06) bent the
    // distortion and the focal length with it (outdoor walk: fx -1%, a false jump alarm).
    const std::vector<bool> straight =
        StraightLines(lines, CameraIntrinsics::FromPacked(intrinsics, prior.width, prior.height),
                      options.max_point_rms_ratio);
    for (size_t i = 0; i < lines.size(); ++i) {
      if (straight[i]) continue;
      ordering->Remove(line_blocks[i]);
      problem.RemoveParameterBlock(line_blocks[i]);
      --result.lines_used;
    }
    if (rolling) undo_rolling_shutter();  // From the first pass's poses and points.
    // On from where the first pass stopped, with the step size it ended with.
    solver_options.function_tolerance = options.function_tolerance;
    solver_options.max_num_iterations = options.max_iterations;
    solver_options.initial_trust_region_radius = summary.iterations.back().trust_region_radius;
    last_pass();
    ceres::Solve(solver_options, &problem, &summary);
    if (!summary.IsSolutionUsable()) {
      return no_update("the solver failed: " + summary.BriefReport());
    }
    result.iterations += int(summary.iterations.size()) - 1;
    copy_out();
  }
  // The points were measured from the poses the pass before started from; once more from
  // those this one found (after a start from the homographies, the first were rough: a
  // synthetic walk's cy came out 2.8 px off without this pass, 0.2 px with it).
  if (rolling) {
    undo_rolling_shutter();
    solver_options.initial_trust_region_radius = summary.iterations.back().trust_region_radius;
    ceres::Solve(solver_options, &problem, &summary);
    if (!summary.IsSolutionUsable()) {
      return no_update("the solver failed: " + summary.BriefReport());
    }
    result.iterations += int(summary.iterations.size()) - 1;
    copy_out();
  }
  // The last pass still descending when its iterations ran out has been crawling along a
  // valley the material leaves nearly flat (outdoors, the ground alone with facade tracks
  // among its points, before box 9 left those out: docs/calibration.md, "Outdoors"). Where
  // it stopped is arbitrary; taken on, such solves raised false jump alarms on a steady lens.
  if (summary.termination_type == ceres::NO_CONVERGENCE) {
    const std::vector<ceres::IterationSummary>& steps = summary.iterations;
    const size_t span = std::min<size_t>(steps.size() - 1, 10);  // Its last ten iterations.
    const double before = steps[steps.size() - 1 - span].cost;
    const double fall_per_step =
        (before - steps.back().cost) / before / double(std::max<size_t>(span, 1));
    std::ostringstream why;
    why.precision(3);
    why << "the solve did not converge (" << options.max_iterations
        << " iterations, the cost still falling " << 100 * fall_per_step << "% an iteration)";
    return no_update(why.str());
  }

  const CameraIntrinsics estimate =
      CameraIntrinsics::FromPacked(intrinsics, prior.width, prior.height);
  double sum_sq = 0.0;
  std::vector<double> errors;
  std::map<int, std::pair<double, int>> by_view;  // Squared sum, count.
  for (const Residual& r : residuals) {
    const double squared = error_px(r)->squaredNorm();
    sum_sq += squared;
    errors.push_back(std::sqrt(squared));
    by_view[r.frame].first += squared;
    ++by_view[r.frame].second;
  }
  result.rms_px = std::sqrt(sum_sq / (2.0 * residuals.size()));
  // A solve that fits most observations and misses a few by far has come apart: a view or
  // a plane torn from the rest, in a minimum where the robust loss gave up on it (a wrong
  // readout told, in a fast turn: RMS 4-19 px, half the observations within 0.1-0.25 px).
  // Its covariance, scaled by that RMS, would blame the focal length.
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  const double median_px = errors.empty() ? 0.0 : errors[errors.size() / 2];
  if (!errors.empty() && result.rms_px > kMaxRmsOverMedian * median_px) {
    const auto worst =
        std::max_element(by_view.begin(), by_view.end(), [](const auto& a, const auto& b) {
          return a.second.first / a.second.second < b.second.first / b.second.second;
        });
    result.came_apart = true;
    std::ostringstream why;
    why.precision(3);
    why << "the solve came apart: RMS " << result.rms_px << " px where half the observations"
        << " fit within " << median_px << " px (the worst view "
        << std::sqrt(worst->second.first / (2.0 * worst->second.second)) << " px RMS, "
        << material.frame_count - 1 - worst->first << " frames before the window's last)";
    return no_update(why.str());
  }
  // Only views the points left in still place: one that saw only a plane left out kept
  // whatever pose the first pass had wandered to (thousands of units off, a garbage view
  // in the workbench's 3D scene and in the next attempt's start).
  std::set<int> placed;
  for (const Residual& r : residuals) {
    placed.insert(r.frame);
    placed.insert(plane_reference[r.plane]);
  }
  result.frames_used = int(placed.size());
  result.cam_from_world.resize(material.frame_count);
  for (int f : placed) result.cam_from_world[f] = ToIsometry(frame_poses[f]);
  for (size_t p = 0; p < tracks.size(); ++p) {
    if (!plane_blocks[p] || !problem.HasParameterBlock(plane_blocks[p])) continue;
    const Eigen::Isometry3d world_from_reference =
        ToIsometry(frame_poses[plane_reference[p]]).inverse();
    std::map<int, Eigen::Vector3d> world;
    for (const auto& [id, ray] : rays[p]) {
      if (const auto x = PointOnRay(plane_params[p].data(), ray.data())) {
        world[id] = world_from_reference * *x;
      }
    }
    if (world.empty()) continue;
    PlaneEstimate plane;
    plane.id = used[p]->id;
    const Eigen::Vector3d m(plane_params[p][0], plane_params[p][1], plane_params[p][2]);
    plane.world_from_plane = PlaneFrame(world, world_from_reference.linear() * m.normalized());
    const Eigen::Isometry3d plane_from_world = plane.world_from_plane.inverse();
    for (const auto& [id, x] : world) {
      plane.points.emplace_back(id, (plane_from_world * x).head<2>());
    }
    result.planes.push_back(std::move(plane));
  }

  // The covariance says whether the material pins the intrinsics down (it does not under
  // pure translation, rotation about the optical axis, a single fronto-parallel view...).
  for (int i = 0; i < kNumIntrinsics; ++i) {
    if (std::find(fixed.begin(), fixed.end(), i) == fixed.end())
      result.free_parameters.push_back(i);
  }
  Eigen::MatrixXd clustered;
  const std::optional<Eigen::MatrixXd> unit_covariance = MarginalCovariance(
      &problem, *solver_options.linear_solver_ordering, intrinsics_block, &clustered);
  if (!unit_covariance) {
    return no_update("the material does not constrain the intrinsics (singular covariance)");
  }
  // A track's views taken for independent made the sigmas half what the attempts scatter
  // by (docs/calibration.md, "How far an attempt's sigmas can be trusted"): each point's
  // views count as one cluster. The unit covariance at 0.01 px keeps noiseless material
  // from claiming certainty.
  result.covariance = clustered + 1e-4 * *unit_covariance;
  const double focal_sigma = std::sqrt(result.covariance(0, 0)) / estimate.fx;  // fx is free.
  result.estimate = estimate;
  if (focal_sigma > options.max_focal_sigma) {
    std::ostringstream why;
    why.precision(2);
    why << std::fixed << "focal length not observable (sigma " << 100 * focal_sigma << "%, "
        << 100 * options.max_focal_sigma << "% allowed)";
    result.estimate = prior;
    return no_update(why.str());
  }
  result.usable = true;
  std::ostringstream report;
  report.precision(4);
  report << "fx " << estimate.fx << " fy " << estimate.fy << " cx " << estimate.cx << " cy "
         << estimate.cy << " k1 " << estimate.k1 << " k2 " << estimate.k2 << "; rms "
         << result.rms_px << " px over " << result.observations_used << " observations of "
         << result.points_used << " points on " << result.planes_used << " planes in "
         << result.frames_used << " frames, " << result.lines_used << " lines, rotation spread "
         << result.rotation_spread_deg << " deg; " << result.iterations << " iterations";
  result.reason = report.str();
  return result;
}

// How far a plane's image moved between two of its views.
double PlaneImageMotionPx(const PlaneTrack& plane) {
  std::map<int, std::map<int, Eigen::Vector2d>> by_frame;  // Frame -> point -> pixel.
  for (const PlaneObservation& o : plane.observations) by_frame[o.frame][o.point] = o.pixel;
  std::vector<std::map<int, Eigen::Vector2d>> views;
  for (auto& [frame, points] : by_frame) views.push_back(std::move(points));
  return LargestMedianDisplacementPx(views);
}

// SolveInOneWorld, and when its views differ too little, each plane in a world of its own.
SelfCalibrationResult SolveInSceneOrPlaneWorlds(const CalibrationMaterial& material,
                                                const CameraIntrinsics& prior,
                                                const SelfCalibrationOptions& options) {
  SelfCalibrationResult joint = SolveInOneWorld(material, prior, options);
  if (joint.usable || !(joint.too_little_view_change || joint.came_apart)) return joint;
  // The views differ too little for the scene as a whole, or the scene came apart as one
  // world, but the planes need not hold still together: a board moved about before a fixed
  // camera is seen from many orientations relative to itself, as Zhang's method has it
  // (the board the anchor, the room behind it tears from it). Each plane is then its own
  // world, solved alone; gravity and the earlier solution, which are of the scene's world,
  // are left out.
  std::optional<SelfCalibrationResult> best;
  double best_focal_sigma = std::numeric_limits<double>::infinity();
  double widest_deg = 0.0;
  int widest_plane = 0;
  for (const PlaneTrack& plane : material.planes) {
    std::set<int> points;
    for (const PlaneObservation& o : plane.observations) points.insert(o.point);
    // A plane in its own world is one that moved before the camera; one whose image held
    // still (the room behind the board) has no view change of its own to give, and its
    // noise alone, decomposed into poses, would give a wrong one.
    if (int(points.size()) < options.min_points_per_plane ||
        !(PlaneImageMotionPx(plane) >= options.barely_moved_px)) {
      continue;
    }
    CalibrationMaterial alone;
    alone.frame_count = material.frame_count;
    alone.frame_t_ns = material.frame_t_ns;
    alone.planes = {plane};
    alone.lines = material.lines;
    SelfCalibrationResult own = SolveInOneWorld(alone, prior, options);
    if (own.rotation_spread_deg > widest_deg) {
      widest_deg = own.rotation_spread_deg;
      widest_plane = plane.id;
    }
    if (!own.usable) continue;
    const double focal_sigma = std::sqrt(own.covariance(0, 0)) / own.estimate.fx;
    if (focal_sigma < best_focal_sigma) {
      best_focal_sigma = focal_sigma;
      own.own_world_plane = plane.id;
      best = std::move(own);
    }
  }
  std::ostringstream why;
  why.precision(2);
  why << std::fixed;
  if (best) {
    why << "; plane " << best->own_world_plane << " alone, in its own world: relative to it the"
        << " views differ by " << best->rotation_spread_deg << " deg";
    if (joint.came_apart) {
      why << ", and the scene as one world came apart (the plane moved, or the rest of the "
             "scene did)";
    } else {
      why << ", relative to the scene by " << joint.rotation_spread_deg
          << " deg (the plane moved, or the rest of the scene did)";
    }
    best->reason += why.str();
    return *best;
  }
  if (widest_plane != 0 && widest_deg > joint.rotation_spread_deg) {
    why << " (relative to any one plane at most " << widest_deg << " deg, plane " << widest_plane
        << ")";
    joint.reason += why.str();
  }
  return joint;
}

}  // namespace

SelfCalibrationResult SelfCalibrate(const CalibrationMaterial& material,
                                    const CameraIntrinsics& prior,
                                    const SelfCalibrationOptions& options) {
  SelfCalibrationResult result = SolveInSceneOrPlaneWorlds(material, prior, options);
  // Whatever else failed, a camera that barely moved is the cause to name first: it is the
  // one the user can do something about, and the rest follows from it.
  if (result.usable || !material.degraded.empty() || !material.motion ||
      !(material.motion->image_px < options.barely_moved_px)) {
    return result;
  }
  const WindowMotion& motion = *material.motion;
  std::ostringstream why;
  why.precision(1);
  why << std::fixed << "no update: " << kBarelyMovedCause << " (its image moved at most "
      << motion.image_px << " px over " << motion.span_s << " s";
  if (motion.tilt_deg) why << ", it tilted " << *motion.tilt_deg << " deg";
  why << "; " << options.barely_moved_px << " px needed): ";
  constexpr std::string_view kNoUpdate = "no update: ";
  const std::string_view rest(result.reason);
  why << (rest.starts_with(kNoUpdate) ? rest.substr(kNoUpdate.size()) : rest);
  result.reason = why.str();
  return result;
}

double LargestMedianDisplacementPx(const std::vector<std::map<int, Eigen::Vector2d>>& views) {
  constexpr size_t kMinShared = 8;  // Fewer say nothing of the image as a whole.
  double largest = 0.0;
  std::vector<double> moved;
  for (size_t a = 0; a < views.size(); ++a) {
    for (size_t b = a + 1; b < views.size(); ++b) {
      moved.clear();
      for (auto i = views[a].begin(), j = views[b].begin();
           i != views[a].end() && j != views[b].end();) {
        if (i->first < j->first) {
          ++i;
        } else if (j->first < i->first) {
          ++j;
        } else {
          moved.push_back((j++->second - i++->second).norm());
        }
      }
      if (moved.size() < kMinShared) continue;
      std::nth_element(moved.begin(), moved.begin() + moved.size() / 2, moved.end());
      largest = std::max(largest, moved[moved.size() / 2]);
    }
  }
  return largest;
}

std::string NoUpdateCause(const std::string& reason) {
  constexpr std::string_view kNoUpdate = "no update: ";
  std::string_view cause(reason);
  if (!cause.starts_with(kNoUpdate)) return {};
  cause.remove_prefix(kNoUpdate.size());
  return std::string(cause.substr(0, std::min(cause.find(" ("), cause.find(':'))));
}

CalibrationStart StartFrom(const SelfCalibrationResult& solved,
                           const std::vector<int64_t>& solved_views,
                           const std::vector<int64_t>& views) {
  CalibrationStart start;
  start.intrinsics = solved.estimate;
  start.planes = solved.planes;
  start.cam_from_world.resize(views.size());
  for (size_t frame = 0; frame < views.size(); ++frame) {
    const auto same = std::lower_bound(solved_views.begin(), solved_views.end(), views[frame]);
    if (same == solved_views.end() || *same != views[frame]) continue;
    const size_t solved_frame = size_t(same - solved_views.begin());
    if (solved_frame < solved.cam_from_world.size()) {
      start.cam_from_world[frame] = solved.cam_from_world[solved_frame];
    }
  }
  return start;
}

void QuietSolverWarnings() { FLAGS_minloglevel = google::GLOG_ERROR; }

}  // namespace autocal
