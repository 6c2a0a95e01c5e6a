#include "pipeline/planes.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>
#include <unordered_map>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

#include "pipeline/homography_ransac.h"

namespace autocal {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
// Thresholds over the long baseline: drift grows about as the square root of time.
const double kLongScale = std::sqrt(2.0);
// Attempts at a new plane per frame whose inliers are too few or too crowded.
constexpr int kDetectAttempts = 4;
// The fewest matches a still-shot plane's guided matching starts from: a homography fitted
// to fewer is as likely chance.
constexpr int kMinGuidedSeed = 8;

cv::Point2f Transfer(const cv::Matx33d& h, const cv::Point2f& p) {
  const cv::Vec3d q = h * cv::Vec3d(p.x, p.y, 1.0);
  return {static_cast<float>(q[0] / q[2]), static_cast<float>(q[1] / q[2])};
}

double Distance(const cv::Point2f& a, const cv::Point2f& b) { return cv::norm(a - b); }

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

double RotationAngleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const double c = std::clamp(((a.transpose() * b).trace() - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c) * 180.0 / M_PI;
}

std::vector<cv::Point2f> Hull(const std::vector<cv::Point2f>& points) {
  std::vector<cv::Point2f> hull;
  if (points.size() >= 3) cv::convexHull(points, hull);
  return hull;
}

double AreaFraction(const std::vector<cv::Point2f>& hull, cv::Size size) {
  return hull.size() < 3 ? 0.0 : cv::contourArea(hull) / (double(size.width) * size.height);
}

// Standard deviation of points across their narrowest direction, over the image diagonal.
double NarrowSpread(const std::vector<cv::Point2f>& points, cv::Size size) {
  if (points.size() < 3) return 0.0;
  cv::Mat samples(int(points.size()), 2, CV_32F, const_cast<cv::Point2f*>(points.data()));
  cv::Mat covariance, mean;
  cv::calcCovarMatrix(samples, covariance, mean,
                      cv::COVAR_NORMAL | cv::COVAR_ROWS | cv::COVAR_SCALE);
  cv::Mat eigenvalues;
  cv::eigen(covariance, eigenvalues);
  return std::sqrt(std::max(0.0, eigenvalues.at<double>(1))) / std::hypot(size.width, size.height);
}

bool Distorted(const CameraIntrinsics& camera) {
  const auto d = camera.Distortion();
  return std::any_of(d.begin(), d.end(), [](double k) { return k != 0.0; });
}

cv::Matx33d CameraMatrix(const CameraIntrinsics& camera) {
  return {camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0};
}

// The flow (pixels) that the translation alone causes at the centre of the plane's
// reference view, the smallest among the decompositions: under pure rotation every
// decomposition has none.
double Parallax(const std::vector<PlaneMotion>& motions, const CameraIntrinsics& camera) {
  double parallax = kInfinity;
  for (const PlaneMotion& m : motions) {
    parallax = std::min(parallax, m.translation_over_distance.norm());
  }
  return motions.empty() ? 0.0 : parallax * std::sqrt(camera.fx * camera.fy);
}

// Repetitive texture (a chessboard, floor tiles, a facade's windows) fails Lowe's test, its
// keypoints alike, and a plane of it is found from its few distinct keypoints (a border,
// a corner) if at all. Its homography then tells the alike ones apart: a keypoint of `a`
// that it brings within `radius_px` of one of `b` whose descriptor is no farther than the
// plane's own matches' is matched to the nearest such (guided matching), one to one and
// keypoints of other planes' matches left alone. Appends the matches to `matches` and
// their indices to `inliers`; returns how many.
int GuidedMatches(const KeypointSet& a, const KeypointSet& b,
                  const std::vector<cv::Point2f>& ideal_a, const std::vector<cv::Point2f>& ideal_b,
                  const cv::Matx33d& homography, double radius_px, std::vector<bool>* taken_a,
                  std::vector<bool>* taken_b, std::vector<cv::DMatch>* matches,
                  std::vector<int>* inliers) {
  float max_distance = 0.0f;
  for (int k : *inliers) max_distance = std::max(max_distance, (*matches)[k].distance);
  const int norm = a.descriptors.depth() == CV_8U ? cv::NORM_HAMMING : cv::NORM_L2;
  // b's keypoints in cells of the radius: a prediction's candidates are in the 3 x 3 around.
  const auto cell_of = [&](const cv::Point2f& p) {
    return std::pair{int(std::floor(p.x / radius_px)), int(std::floor(p.y / radius_px))};
  };
  std::map<std::pair<int, int>, std::vector<int>> cells;
  for (int j = 0; j < int(ideal_b.size()); ++j) {
    if (!(*taken_b)[j]) cells[cell_of(ideal_b[j])].push_back(j);
  }
  struct Candidate {
    double offset_px;
    int i, j;
    float distance;
  };
  std::vector<Candidate> candidates;
  for (int i = 0; i < int(ideal_a.size()); ++i) {
    if ((*taken_a)[i]) continue;
    const cv::Point2f predicted = Transfer(homography, ideal_a[i]);
    const auto [cx, cy] = cell_of(predicted);
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        const auto cell = cells.find({cx + dx, cy + dy});
        if (cell == cells.end()) continue;
        for (int j : cell->second) {
          const double offset = Distance(predicted, ideal_b[j]);
          if (offset > radius_px) continue;
          const float distance = float(cv::norm(a.descriptors.row(i), b.descriptors.row(j), norm));
          if (distance <= max_distance) candidates.push_back({offset, i, j, distance});
        }
      }
    }
  }
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& x, const Candidate& y) { return x.offset_px < y.offset_px; });
  int added = 0;
  for (const Candidate& c : candidates) {
    if ((*taken_a)[c.i] || (*taken_b)[c.j]) continue;
    (*taken_a)[c.i] = (*taken_b)[c.j] = true;
    inliers->push_back(int(matches->size()));
    matches->emplace_back(c.i, c.j, c.distance);
    ++added;
  }
  return added;
}

}  // namespace

bool PlaneOptions::Check(std::string* error) const {
  std::ostringstream why;
  if (baseline_frames < 1) {
    why << "baseline_frames must be at least 1";
  } else if (long_baseline_frames != 0 && long_baseline_frames <= baseline_frames) {
    why << "long_baseline_frames must be 0 or exceed baseline_frames";
  } else if (young_frames < 0 || young_frames >= baseline_frames) {
    why << "young_frames must be in [0, baseline_frames)";
  } else if (!(inlier_threshold_px > 0)) {
    why << "inlier_threshold_px must be positive";
  } else if (!(eject_threshold_px >= inlier_threshold_px)) {
    why << "eject_threshold_px must be at least inlier_threshold_px";
  } else if (!(join_radius > 0)) {
    why << "join_radius must be positive";
  } else if (ransac_iterations < 10) {
    why << "ransac_iterations must be at least 10";
  } else if (min_inliers < 4) {
    why << "min_inliers must be at least 4 (a homography needs 4 points)";
  } else if (!(min_area_fraction >= 0 && min_area_fraction < 1)) {
    why << "min_area_fraction must be in [0, 1)";
  } else if (min_tracks_to_keep < 4 || min_tracks_to_keep > min_inliers) {
    why << "min_tracks_to_keep must be in [4, min_inliers]";
  } else if (!(min_parallax_px >= 0)) {
    why << "min_parallax_px must not be negative";
  } else if (!(noise_scale >= 0)) {
    why << "noise_scale must not be negative";
  } else if (!(max_noise_scale >= 1)) {
    why << "max_noise_scale must be at least 1";
  } else if (!(min_spread >= 0)) {
    why << "min_spread must not be negative";
  } else if (max_planes < 1) {
    why << "max_planes must be at least 1";
  } else if (max_reference_frames <= baseline_frames) {
    why << "max_reference_frames must exceed baseline_frames";
  } else if (!(merge_fraction > 0 && merge_fraction <= 1)) {
    why << "merge_fraction must be in (0, 1]";
  } else if (normal_votes < 1) {
    why << "normal_votes must be at least 1";
  } else if (!(normal_agreement_deg > 0 && normal_agreement_deg < 90)) {
    why << "normal_agreement_deg must be in (0, 90)";
  } else if (!(shot_inlier_threshold_px > 0)) {
    why << "shot_inlier_threshold_px must be positive";
  }
  if (why.str().empty()) return true;
  if (error) *error = why.str();
  return false;
}

std::vector<cv::Point2f> UndistortPixels(const std::vector<cv::Point2f>& points,
                                         const CameraIntrinsics& camera) {
  if (points.empty() || !Distorted(camera)) return points;
  std::vector<cv::Point2f> undistorted;
  undistorted.reserve(points.size());
  for (const cv::Point2f& point : points) {
    // Newton's method, a few steps, where cv::undistortPoints iterates a fixed point: on a
    // strong barrel's corners that takes up to 100 steps (it was 4% of the motion thread).
    if (const auto ideal = UndistortPixel(camera, {point.x, point.y})) {
      undistorted.emplace_back(float(ideal->x()), float(ideal->y()));
      continue;
    }
    // Beyond the fold no ray sees the point; OpenCV's fixed point still gives one nearby.
    const auto d = camera.Distortion();
    const cv::Matx33d k = CameraMatrix(camera);
    std::vector<cv::Point2f> fixed_point;
    cv::undistortPoints(
        std::vector<cv::Point2f>{point}, fixed_point, k, std::vector<double>(d.begin(), d.end()),
        cv::noArray(), k,
        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-6));
    undistorted.push_back(fixed_point.front());
  }
  return undistorted;
}

std::vector<PlaneMotion> DecomposePlaneHomography(const cv::Matx33d& homography,
                                                  const CameraIntrinsics& camera,
                                                  const std::vector<cv::Point2f>& reference,
                                                  const std::vector<cv::Point2f>& current) {
  std::vector<cv::Mat> rotations, translations, normals;
  cv::decomposeHomographyMat(homography, CameraMatrix(camera), rotations, translations, normals);
  // The visibility test works on rays, i.e. normalized coordinates.
  auto normalized = [&](const std::vector<cv::Point2f>& pixels) {
    std::vector<cv::Point2f> rays;
    rays.reserve(pixels.size());
    for (const cv::Point2f& p : pixels) {
      rays.emplace_back(float((p.x - camera.cx) / camera.fx), float((p.y - camera.cy) / camera.fy));
    }
    return rays;
  };
  std::vector<int> valid;
  cv::filterHomographyDecompByVisibleRefpoints(rotations, normals, normalized(reference),
                                               normalized(current), valid);
  std::vector<PlaneMotion> motions;
  for (int i : valid) {
    PlaneMotion m;
    cv::cv2eigen(rotations[i], m.rotation);
    cv::cv2eigen(translations[i], m.translation_over_distance);
    Eigen::Vector3d n;
    cv::cv2eigen(normals[i], n);
    // OpenCV's normal points from the camera to the plane (n.X = d > 0 on it).
    m.normal_reference = -n.normalized();
    motions.push_back(m);
  }
  return motions;
}

// What one Update works on.
struct PlaneTracker::Frame {
  int64_t t_ns = 0;
  int64_t base_t_ns = 0;  // The frame baseline_frames ago.
  const std::vector<Track>* tracks = nullptr;
  const CameraIntrinsics* camera = nullptr;
  std::unordered_map<int, int> index;  // Track id -> index in *tracks.
  std::vector<cv::Point2f> now;        // Per track: undistorted position now,
  std::vector<cv::Point2f> base;       // in the baseline frame,
  std::vector<bool> has_base;          // if it was tracked then,
  std::vector<cv::Point2f> start;      // where it started, for young tracks,
  std::vector<int64_t> start_t_ns;     // and when (-1: not judged young),
  std::vector<cv::Point2f> far;        // in the frame long_baseline_frames ago,
  std::vector<bool> has_far;           // if it was tracked then, and how many undistorted
  std::vector<float> magnification;    // pixels a pixel of the image tracked spans now.
  int64_t far_t_ns = -1;               // The long baseline's frame, if there is one.

  cv::Size size() const { return {camera->width, camera->height}; }
  // Indices of the tracks of `members` that are tracked since the baseline frame.
  std::vector<int> Based(const std::map<int, cv::Point2f>& members) const {
    std::vector<int> based;
    for (const auto& [id, point] : members) {
      const auto it = index.find(id);
      if (it != index.end() && has_base[it->second]) based.push_back(it->second);
    }
    return based;
  }
  // Errors are judged in pixels of the image tracked, where Lucas-Kanade made them.
  // Transfer errors in pixels of the image tracked, over the baseline...
  double RecentError(const cv::Matx33d& recent, int track) const {
    return Distance(Transfer(recent, base[track]), now[track]) / magnification[track];
  }
  // ...and over the long baseline, when both the plane and the track reach back that far.
  double LongError(const std::optional<cv::Matx33d>& longer, int track) const {
    return longer && has_far[track]
               ? Distance(Transfer(*longer, far[track]), now[track]) / magnification[track]
               : 0.0;
  }
};

PlaneTracker::PlaneTracker(const PlaneOptions& options) : options_(options) {}

const cv::Matx33d* PlaneTracker::State::ChainAt(int64_t t_ns) const {
  const auto it = std::lower_bound(chain.begin(), chain.end(), t_ns,
                                   [](const auto& entry, int64_t t) { return entry.first < t; });
  return it != chain.end() && it->first == t_ns ? &it->second : nullptr;
}

bool PlaneTracker::FollowRecent(State* state, const Frame& frame) const {
  std::erase_if(state->members, [&](const auto& member) {
    const auto it = frame.index.find(member.first);
    return it == frame.index.end() ||
           (!frame.has_base[it->second] && frame.start_t_ns[it->second] < 0);
  });
  if (int(state->members.size()) < options_.min_tracks_to_keep) return false;
  const std::vector<int> based = frame.Based(state->members);
  std::vector<cv::Point2f> base, now;
  for (int i : based) {
    base.push_back(frame.base[i]);
    now.push_back(frame.now[i]);
  }
  std::vector<uchar> mask;
  const std::optional<cv::Matx33d> recent =
      FitHomographyRansac(base, now, state->scale * options_.eject_threshold_px,
                          options_.ransac_iterations, kRansacConfidence, &mask);
  if (!recent) return false;
  state->recent = *recent;
  std::vector<double> errors;
  for (size_t k = 0; k < based.size(); ++k) {
    if (mask[k]) errors.push_back(frame.RecentError(state->recent, based[k]));
  }
  state->scale = Scale(errors);
  state->longer.reset();
  std::vector<cv::Point2f> far, far_now;
  for (int i : frame.Based(state->members)) {
    if (!frame.has_far[i]) continue;
    far.push_back(frame.far[i]);
    far_now.push_back(frame.now[i]);
  }
  if (int(far.size()) >= options_.min_tracks_to_keep) {
    const std::optional<cv::Matx33d> longer =
        FitHomographyRansac(far, far_now, kLongScale * state->scale * options_.eject_threshold_px,
                            options_.ransac_iterations, kRansacConfidence, &mask);
    if (longer) state->longer = *longer;
  }
  return true;
}

double PlaneTracker::Error(const State& state, const Frame& frame, int track) const {
  if (frame.has_base[track]) return frame.RecentError(state.recent, track);
  if (frame.start_t_ns[track] < 0) return kInfinity;
  const cv::Matx33d* to_base = state.ChainAt(frame.base_t_ns);
  const cv::Matx33d* to_start = state.ChainAt(frame.start_t_ns[track]);
  if (!to_base || !to_start) return kInfinity;
  const cv::Matx33d start_to_now = state.recent * *to_base * to_start->inv();
  return Distance(Transfer(start_to_now, frame.start[track]), frame.now[track]) /
         frame.magnification[track];
}

double PlaneTracker::Scale(std::vector<double> errors) const {
  if (errors.empty()) return 1.0;
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  return std::clamp(
      options_.noise_scale * errors[errors.size() / 2] / options_.inlier_threshold_px, 1.0,
      options_.max_noise_scale);
}

bool PlaneTracker::Near(const State& state, const Frame& frame, int track) const {
  const double radius =
      options_.join_radius * std::hypot(frame.camera->width, frame.camera->height);
  const cv::Point2f& p = frame.now[track];
  return std::any_of(state.members.begin(), state.members.end(), [&](const auto& member) {
    return Distance(frame.now[frame.index.at(member.first)], p) <= radius;
  });
}

std::vector<std::vector<int>> PlaneTracker::Assign(const Frame& frame) {
  std::vector<int> owner(frame.tracks->size(), -1);
  for (size_t s = 0; s < states_.size(); ++s) {
    for (const auto& [id, point] : states_[s].members) owner[frame.index.at(id)] = int(s);
  }
  struct Fit {
    bool judged = false;
    double best = kInfinity, second = kInfinity, own = kInfinity;
    int chosen = -1;
    bool other_fits = false;  // A member that another plane fits as well as its own.
  };
  std::vector<Fit> fits(frame.tracks->size());
  std::vector<int> members(states_.size(), 0), ambiguous(states_.size(), 0);
  for (size_t i = 0; i < frame.tracks->size(); ++i) {
    if (!frame.has_base[i] && frame.start_t_ns[i] < 0) continue;
    Fit& fit = fits[i];
    fit.judged = true;
    for (size_t s = 0; s < states_.size(); ++s) {
      const double error = Error(states_[s], frame, int(i)) / states_[s].scale;
      if (int(s) == owner[i]) fit.own = error;
      if (error < fit.best) {
        fit.second = fit.best;
        fit.best = error;
        fit.chosen = int(s);
      } else {
        fit.second = std::min(fit.second, error);
      }
    }
    if (owner[i] >= 0) {
      fit.other_fits = fit.chosen != owner[i] ? fit.best <= options_.inlier_threshold_px
                                              : fit.second <= options_.inlier_threshold_px;
      ++members[owner[i]];
      ambiguous[owner[i]] += fit.other_fits;
    }
  }
  std::vector<std::vector<int>> joiners(states_.size());
  for (size_t i = 0; i < frame.tracks->size(); ++i) {
    const Fit& fit = fits[i];
    if (!fit.judged) continue;
    if (owner[i] >= 0) {
      // Points near where two planes meet, or where parallax is too small to tell planes
      // apart, fit more than one: they leave. But when another plane fits most of the
      // members as well, the frame tells nothing (the camera only turned, and the
      // rotation's homography fits every plane): memberships stay as they were.
      const bool told_apart = 2 * ambiguous[owner[i]] <= members[owner[i]];
      if (fit.own > options_.eject_threshold_px || (fit.other_fits && told_apart) ||
          frame.LongError(states_[owner[i]].longer, int(i)) / states_[owner[i]].scale >
              kLongScale * options_.eject_threshold_px) {
        states_[owner[i]].members.erase((*frame.tracks)[i].id);
      }
    } else if (fit.chosen >= 0 && fit.best <= options_.inlier_threshold_px &&
               fit.second > options_.eject_threshold_px &&
               Near(states_[fit.chosen], frame, int(i)) &&
               frame.LongError(states_[fit.chosen].longer, int(i)) / states_[fit.chosen].scale <=
                   kLongScale * options_.inlier_threshold_px) {
      joiners[fit.chosen].push_back(int(i));
    }
  }
  return joiners;
}

bool PlaneTracker::FollowReference(State* state, const Frame& frame,
                                   const std::vector<int>& joiners) const {
  std::vector<int> ids;
  std::vector<cv::Point2f> reference, now;
  for (const auto& [id, point] : state->members) {
    ids.push_back(id);
    reference.push_back(point);
    now.push_back(frame.now[frame.index.at(id)]);
  }
  std::vector<uchar> mask;
  const std::optional<cv::Matx33d> fit =
      FitHomographyRansac(reference, now, state->scale * options_.eject_threshold_px,
                          options_.ransac_iterations, kRansacConfidence, &mask);
  if (!fit) return false;
  const cv::Matx33d h = *fit;
  // Members that drifted from their reference point (tracks drift as the view of their
  // patch changes) still follow the plane over the baseline: they stay, outside the fit,
  // until the reference moves up and measures them afresh.
  const cv::Matx33d inverse = h.inv();
  for (int i : joiners) {
    state->members.emplace((*frame.tracks)[i].id, Transfer(inverse, frame.now[i]));
  }
  state->homography = h;
  state->chain.emplace_back(frame.t_ns, h);
  ++state->age;
  return true;
}

void PlaneTracker::Merge(const Frame& frame) {
  auto fitting = [&](const State& model, const std::vector<int>& tracks) {
    return std::count_if(tracks.begin(), tracks.end(), [&](int i) {
      return frame.RecentError(model.recent, i) <= model.scale * options_.eject_threshold_px;
    });
  };
  for (size_t a = 0; a < states_.size(); ++a) {
    for (size_t b = a + 1; b < states_.size();) {
      const std::vector<int> in_a = frame.Based(states_[a].members);
      const std::vector<int> in_b = frame.Based(states_[b].members);
      // Each homography must fit the other plane's tracks: a plane dwindled to a strip along
      // a corner fits the next wall's homography (the strip lies on both), and merged into
      // it, gave its id to the next wall (the office walk: box 10 then took the tracks of
      // both walls for one plane).
      bool merge = fitting(states_[a], in_b) >= options_.merge_fraction * in_b.size() &&
                   fitting(states_[b], in_a) >= options_.merge_fraction * in_a.size();
      if (merge) {
        // One homography for both, or two planes after all.
        std::vector<cv::Point2f> base, now;
        for (const std::vector<int>* set : {&in_a, &in_b}) {
          for (int i : *set) {
            base.push_back(frame.base[i]);
            now.push_back(frame.now[i]);
          }
        }
        std::vector<uchar> mask;
        const std::optional<cv::Matx33d> both = FitHomographyRansac(
            base, now, std::max(states_[a].scale, states_[b].scale) * options_.eject_threshold_px,
            options_.ransac_iterations, kRansacConfidence, &mask);
        // Without parallax one homography fits any two planes (the rotation's): only a
        // translation can show them to be one.
        merge = both &&
                std::count(mask.begin(), mask.end(), 1) >= options_.merge_fraction * mask.size() &&
                Parallax(DecomposePlaneHomography(*both, *frame.camera, base, now),
                         *frame.camera) >= options_.min_parallax_px;
      }
      if (!merge) {
        ++b;
        continue;
      }
      // The older plane keeps its id and takes the other's tracks.
      const cv::Matx33d inverse = states_[a].homography.inv();
      for (const auto& [id, point] : states_[b].members) {
        states_[a].members.emplace(id, Transfer(inverse, frame.now[frame.index.at(id)]));
      }
      states_.erase(states_.begin() + b);
    }
  }
}

void PlaneTracker::Detect(const Frame& frame) {
  std::vector<bool> owned(frame.tracks->size(), false);
  for (const State& state : states_) {
    for (const auto& [id, point] : state.members) owned[frame.index.at(id)] = true;
  }
  // Tracks that no plane holds, and that fit none: those that fit one were left out
  // because they fit another as well.
  std::vector<int> pool;
  for (size_t i = 0; i < frame.tracks->size(); ++i) {
    if (owned[i] || !frame.has_base[i]) continue;
    if (std::none_of(states_.begin(), states_.end(), [&](const State& state) {
          return frame.RecentError(state.recent, int(i)) <=
                 state.scale * options_.eject_threshold_px;
        })) {
      pool.push_back(int(i));
    }
  }
  for (int attempt = 0; attempt < kDetectAttempts && int(states_.size()) < options_.max_planes;
       ++attempt) {
    if (int(pool.size()) < options_.min_inliers) return;
    std::vector<cv::Point2f> base, now;
    for (int i : pool) {
      base.push_back(frame.base[i]);
      now.push_back(frame.now[i]);
    }
    // The consensus at the looser eject threshold (tracks drift); the plane's tracks are
    // those within the inlier threshold of its refined homography.
    std::vector<uchar> mask;
    const std::optional<cv::Matx33d> consensus =
        FitHomographyRansac(base, now, options_.eject_threshold_px, options_.ransac_iterations,
                            kRansacConfidence, &mask);
    if (!consensus) return;
    cv::Matx33d h = *consensus;
    std::vector<int> rest;
    for (size_t k = 0; k < pool.size(); ++k) {
      if (!mask[k]) rest.push_back(pool[k]);
    }
    std::vector<double> errors;
    for (size_t k = 0; k < pool.size(); ++k) {
      if (mask[k]) errors.push_back(frame.RecentError(h, pool[k]));
    }
    const double scale = Scale(errors);
    auto core = [&] {
      std::vector<size_t> in;
      for (size_t k = 0; k < pool.size(); ++k) {
        if (mask[k] && frame.RecentError(h, pool[k]) <= scale * options_.inlier_threshold_px) {
          in.push_back(k);
        }
      }
      return in;
    };
    std::vector<size_t> in = core();
    if (in.size() >= 4) {
      std::vector<cv::Point2f> from, to;
      for (size_t k : in) {
        from.push_back(base[k]);
        to.push_back(now[k]);
      }
      if (const auto refined = FitHomography(from, to)) {
        h = *refined;
        in = core();
      }
    }
    // Over the long baseline a mixture of planes too close in depth to part over the
    // short one comes apart: the core keeps the long fit's tracks.
    std::vector<cv::Point2f> far_from, far_to;
    for (size_t k : in) {
      if (!frame.has_far[pool[k]]) continue;
      far_from.push_back(frame.far[pool[k]]);
      far_to.push_back(now[k]);
    }
    if (int(far_from.size()) >= options_.min_tracks_to_keep) {
      std::vector<uchar> far_mask;
      const std::optional<cv::Matx33d> longer =
          FitHomographyRansac(far_from, far_to, kLongScale * scale * options_.eject_threshold_px,
                              options_.ransac_iterations, kRansacConfidence, &far_mask);
      if (longer) {
        std::erase_if(in, [&](size_t k) {
          return frame.LongError(*longer, pool[k]) >
                 kLongScale * scale * options_.inlier_threshold_px;
        });
      }
    }
    std::vector<int> inliers;
    std::vector<cv::Point2f> inlier_base, inlier_now, inlier_pixels;
    for (size_t k : in) {
      inliers.push_back(pool[k]);
      inlier_base.push_back(base[k]);
      inlier_now.push_back(now[k]);
      inlier_pixels.push_back((*frame.tracks)[pool[k]].current());
    }
    if (int(inliers.size()) < options_.min_inliers) return;
    // Without parallax every plane fits the homography of the rotation: nothing to find.
    if (Parallax(DecomposePlaneHomography(h, *frame.camera, inlier_base, inlier_now),
                 *frame.camera) < options_.min_parallax_px) {
      return;
    }
    pool = std::move(rest);
    if (AreaFraction(Hull(inlier_pixels), frame.size()) < options_.min_area_fraction) continue;

    State state;
    state.id = next_id_++;
    state.reference_t_ns = frame.base_t_ns;
    state.homography = state.recent = h;
    state.scale = scale;
    for (size_t k = 0; k < inliers.size(); ++k) {
      state.members.emplace((*frame.tracks)[inliers[k]].id, inlier_base[k]);
    }
    // The chain over the baseline: every inlier is seen in every frame since the base.
    for (auto t = frame_times_.end() - 1 - options_.baseline_frames; t + 1 != frame_times_.end();
         ++t) {
      std::vector<cv::Point2f> at;
      for (int i : inliers) {
        const Track& track = (*frame.tracks)[i];
        at.push_back(ideal_.at(track.id)[track.At(*t) - track.history.data()]);
      }
      state.chain.emplace_back(*t, FitHomography(inlier_base, at).value_or(cv::Matx33d::eye()));
    }
    state.chain.emplace_back(frame.t_ns, h);
    states_.push_back(std::move(state));
  }
}

void PlaneTracker::Reanchor(State* state, const Frame& frame) const {
  // The new reference is the baseline frame, where every member was measured.
  const cv::Matx33d* to_base = state->ChainAt(frame.base_t_ns);
  if (!to_base) return;
  const cv::Matx33d old_to_new = *to_base;
  const cv::Matx33d new_to_old = old_to_new.inv();
  // The chosen normal and the votes turn with the camera between the two references.
  std::optional<Eigen::Matrix3d> turn;
  if (state->normal_reference) {
    std::vector<cv::Point2f> before, after;
    for (const auto& [id, point] : state->members) {
      before.push_back(point);
      after.push_back(Transfer(old_to_new, point));
    }
    double best = kInfinity;
    for (const PlaneMotion& m :
         DecomposePlaneHomography(old_to_new, *frame.camera, before, after)) {
      const double angle = AngleDeg(m.normal_reference, *state->normal_reference);
      if (angle < best) {
        best = angle;
        turn = m.rotation;
      }
    }
  }
  for (auto& [id, point] : state->members) {
    const int i = frame.index.at(id);
    point = frame.has_base[i] ? frame.base[i] : Transfer(old_to_new, point);
  }
  while (!state->chain.empty() && state->chain.front().first < frame.base_t_ns) {
    state->chain.pop_front();
  }
  for (auto& [t, h] : state->chain) h = h * new_to_old;
  state->chain.back().second = state->homography = state->recent;
  state->previous_reference_t_ns = state->reference_t_ns;
  state->previous_to_reference = old_to_new;
  state->reference_t_ns = frame.base_t_ns;
  if (turn) {
    state->normal_reference = *turn * *state->normal_reference;
    for (auto& candidates : state->votes) {
      for (Eigen::Vector3d& n : candidates) n = *turn * n;
    }
  } else {
    state->normal_reference.reset();
    state->votes.clear();
  }
}

void PlaneTracker::Orient(State* state, const Frame& frame) const {
  std::vector<cv::Point2f> reference, current;
  for (const auto& [id, point] : state->members) {
    reference.push_back(point);
    current.push_back(frame.now[frame.index.at(id)]);
  }
  const std::vector<PlaneMotion> candidates =
      DecomposePlaneHomography(state->homography, *frame.camera, reference, current);
  state->motion.reset();
  if (candidates.empty() || NarrowSpread(current, frame.size()) < options_.min_spread) return;
  if (Parallax(candidates, *frame.camera) >= options_.min_parallax_px) {
    std::vector<Eigen::Vector3d> normals;
    for (const PlaneMotion& m : candidates) normals.push_back(m.normal_reference);
    state->votes.push_back(std::move(normals));
    while (int(state->votes.size()) > options_.normal_votes) state->votes.pop_front();
    // The true normal is the same in every frame; the other solution moves with the
    // direction of travel. The candidate most earlier frames agree with wins, once it
    // has a clear majority.
    std::vector<int> support(candidates.size(), 0);
    for (size_t c = 0; c < candidates.size(); ++c) {
      for (const auto& earlier : state->votes) {
        for (const Eigen::Vector3d& n : earlier) {
          if (AngleDeg(n, candidates[c].normal_reference) <= options_.normal_agreement_deg) {
            ++support[c];
            break;
          }
        }
      }
    }
    const size_t b = std::max_element(support.begin(), support.end()) - support.begin();
    bool rival = false;
    for (size_t c = 0; c < candidates.size(); ++c) {
      rival |= c != b && support[c] >= support[b] &&
               AngleDeg(candidates[c].normal_reference, candidates[b].normal_reference) >
                   options_.normal_agreement_deg;
    }
    if (!rival && 2 * support[b] > int(state->votes.size())) {
      state->normal_reference = candidates[b].normal_reference;
    }
  }
  if (!state->normal_reference) return;
  // The decomposition of this frame that agrees with the chosen normal.
  double best = kInfinity;
  for (const PlaneMotion& m : candidates) {
    const double angle = AngleDeg(m.normal_reference, *state->normal_reference);
    if (angle < best) {
      best = angle;
      state->motion = m;
    }
  }
}

DominantPlane PlaneTracker::Describe(const State& state, const Frame& frame) const {
  DominantPlane plane;
  plane.id = state.id;
  plane.age = state.age;
  plane.reference_t_ns = state.reference_t_ns;
  plane.homography = state.homography;
  plane.previous_reference_t_ns = state.previous_reference_t_ns;
  plane.previous_to_reference = state.previous_to_reference;
  for (const auto& [id, point] : state.members) {
    plane.track_ids.push_back(id);
    plane.points.push_back((*frame.tracks)[frame.index.at(id)].current());
    plane.reference_points.push_back(point);
  }
  plane.outline = Hull(plane.points);
  plane.area_fraction = AreaFraction(plane.outline, frame.size());
  plane.motion = state.motion;
  if (state.motion) plane.normal = state.motion->rotation * *state.normal_reference;
  return plane;
}

void PlaneTracker::Update(int64_t t_ns, const std::vector<Track>& tracks,
                          const CameraIntrinsics& camera) {
  frame_times_.push_back(t_ns);
  while (int(frame_times_.size()) >
         std::max(options_.max_reference_frames + options_.baseline_frames,
                  options_.long_baseline_frames) +
             2) {
    frame_times_.pop_front();
  }

  // Undistorted histories: only the newest point of each track is new, unless the
  // calibration changed.
  const bool same_camera = camera == ideal_camera_;
  std::map<int, std::vector<cv::Point2f>> ideal;
  std::vector<cv::Point2f> raw;
  std::vector<std::pair<int, int>> slots;  // (track id, index in its history)
  for (const Track& track : tracks) {
    std::vector<cv::Point2f>& points = ideal[track.id];
    points.resize(track.history.size());
    const auto old = ideal_.find(track.id);
    size_t fresh = 0;
    if (same_camera && old != ideal_.end() && old->second.size() + 1 >= track.history.size()) {
      std::copy(old->second.end() - (track.history.size() - 1), old->second.end(), points.begin());
      fresh = track.history.size() - 1;
    }
    for (size_t k = fresh; k < track.history.size(); ++k) {
      raw.push_back(track.history[k].pixel);
      slots.emplace_back(track.id, int(k));
    }
  }
  const std::vector<cv::Point2f> undistorted = UndistortPixels(raw, camera);
  for (size_t k = 0; k < slots.size(); ++k) ideal[slots[k].first][slots[k].second] = undistorted[k];
  ideal_ = std::move(ideal);
  ideal_camera_ = camera;

  planes_.clear();
  if (int(frame_times_.size()) <= options_.baseline_frames) return;
  Frame frame;
  frame.t_ns = t_ns;
  frame.base_t_ns = frame_times_[frame_times_.size() - 1 - options_.baseline_frames];
  frame.tracks = &tracks;
  frame.camera = &camera;
  frame.now.resize(tracks.size());
  frame.magnification.assign(tracks.size(), 1.0f);
  if (Distorted(camera)) {
    // The undistortion's local scale: one over the root of the distortion's Jacobian
    // determinant at the track's ideal point (the camera matrix's scales cancel).
    const auto d = camera.Distortion();
    for (size_t i = 0; i < tracks.size(); ++i) {
      const cv::Point2f& p = ideal_.at(tracks[i].id).back();
      const double x = (p.x - camera.cx) / camera.fx, y = (p.y - camera.cy) / camera.fy;
      double j[4];
      DistortionJacobian(d.data(), x, y, j);
      frame.magnification[i] = float(1.0 / std::sqrt(std::abs(j[0] * j[3] - j[1] * j[2])));
    }
  }
  frame.base.resize(tracks.size());
  frame.has_base.resize(tracks.size());
  frame.start.resize(tracks.size());
  frame.start_t_ns.resize(tracks.size());
  if (options_.long_baseline_frames > 0 &&
      int(frame_times_.size()) > options_.long_baseline_frames) {
    frame.far_t_ns = frame_times_[frame_times_.size() - 1 - options_.long_baseline_frames];
  }
  frame.far.resize(tracks.size());
  frame.has_far.resize(tracks.size());
  for (size_t i = 0; i < tracks.size(); ++i) {
    const std::vector<cv::Point2f>& points = ideal_.at(tracks[i].id);
    frame.index.emplace(tracks[i].id, int(i));
    frame.now[i] = points.back();
    const TrackPoint* at_base = tracks[i].At(frame.base_t_ns);
    frame.has_base[i] = at_base != nullptr;
    if (at_base) frame.base[i] = points[at_base - tracks[i].history.data()];
    // A track's history holds its whole life while it is younger than the baseline.
    const bool young =
        !at_base && options_.young_frames > 0 && tracks[i].age >= options_.young_frames;
    frame.start[i] = points.front();
    frame.start_t_ns[i] = young ? tracks[i].history.front().t_ns : -1;
    const TrackPoint* at_far = frame.far_t_ns >= 0 ? tracks[i].At(frame.far_t_ns) : nullptr;
    frame.has_far[i] = at_far != nullptr;
    if (at_far) frame.far[i] = points[at_far - tracks[i].history.data()];
  }

  std::erase_if(states_, [&](State& state) { return !FollowRecent(&state, frame); });
  const std::vector<std::vector<int>> joiners = Assign(frame);
  std::vector<State> followed;
  for (size_t s = 0; s < states_.size(); ++s) {
    if (int(states_[s].members.size()) >= options_.min_tracks_to_keep &&
        FollowReference(&states_[s], frame, joiners[s])) {
      followed.push_back(std::move(states_[s]));
    }
  }
  states_ = std::move(followed);
  for (State& state : states_) {
    const auto reference =
        std::lower_bound(frame_times_.begin(), frame_times_.end(), state.reference_t_ns);
    if (frame_times_.end() - reference > options_.max_reference_frames) Reanchor(&state, frame);
  }
  Merge(frame);
  Detect(frame);
  for (State& state : states_) {
    Orient(&state, frame);
    planes_.push_back(Describe(state, frame));
  }
}

std::vector<ShotPlane> FindPlanesBetweenShots(const KeypointSet& a, const KeypointSet& b,
                                              const CameraIntrinsics& camera,
                                              const PlaneOptions& options,
                                              const FeatureOptions& features) {
  std::vector<cv::DMatch> matches = MatchKeypoints(a, b, features);
  std::vector<cv::Point2f> raw_a, raw_b;
  for (const cv::DMatch& m : matches) {
    raw_a.push_back(a.keypoints[m.queryIdx].pt);
    raw_b.push_back(b.keypoints[m.trainIdx].pt);
  }
  std::vector<cv::Point2f> ideal_a = UndistortPixels(raw_a, camera);
  std::vector<cv::Point2f> ideal_b = UndistortPixels(raw_b, camera);
  auto pick = [](const std::vector<cv::Point2f>& points, const std::vector<int>& indices) {
    std::vector<cv::Point2f> picked;
    for (int i : indices) picked.push_back(points[i]);
    return picked;
  };

  // One robust fit after another on the matches left over.
  struct Found {
    cv::Matx33d homography;
    std::vector<int> inliers;  // Indices into `matches`.
  };
  std::vector<Found> found;
  // With guided matching, every keypoint's ideal position, and which are matched on a plane.
  std::vector<cv::Point2f> all_a, all_b, ideal_all_a, ideal_all_b;
  std::vector<bool> taken_a, taken_b;
  if (options.shot_guided_matching) {
    for (const cv::KeyPoint& k : a.keypoints) all_a.push_back(k.pt);
    for (const cv::KeyPoint& k : b.keypoints) all_b.push_back(k.pt);
    ideal_all_a = UndistortPixels(all_a, camera);
    ideal_all_b = UndistortPixels(all_b, camera);
    taken_a.assign(all_a.size(), false);
    taken_b.assign(all_b.size(), false);
  }
  // A plane's guided matches, twice (the first refine the homography that finds the
  // farther ones); the positions of the matches are extended with them.
  const auto grow = [&](Found* plane) {
    for (int k : plane->inliers) taken_a[matches[k].queryIdx] = taken_b[matches[k].trainIdx] = true;
    for (int round = 0; round < 2; ++round) {
      const size_t before = matches.size();
      if (GuidedMatches(a, b, ideal_all_a, ideal_all_b, plane->homography,
                        options.shot_inlier_threshold_px, &taken_a, &taken_b, &matches,
                        &plane->inliers) == 0) {
        return;
      }
      for (size_t k = before; k < matches.size(); ++k) {
        raw_a.push_back(all_a[matches[k].queryIdx]);
        raw_b.push_back(all_b[matches[k].trainIdx]);
        ideal_a.push_back(ideal_all_a[matches[k].queryIdx]);
        ideal_b.push_back(ideal_all_b[matches[k].trainIdx]);
      }
      if (const auto refit =
              FitHomography(pick(ideal_a, plane->inliers), pick(ideal_b, plane->inliers))) {
        plane->homography = *refit;
      }
    }
  };
  // A seed of repetitive texture holds few distinct matches: fewer than a plane needs do to
  // start one that guided matching then brings to min_inliers.
  const int min_seed = options.shot_guided_matching ? std::min(options.min_inliers, kMinGuidedSeed)
                                                    : options.min_inliers;
  std::vector<int> pool(matches.size());
  std::iota(pool.begin(), pool.end(), 0);
  for (int attempt = 0; attempt < kDetectAttempts + options.max_planes &&
                        int(found.size()) < options.max_planes && int(pool.size()) >= min_seed;
       ++attempt) {
    std::vector<uchar> mask;
    const std::optional<cv::Matx33d> h = FitHomographyRansac(
        pick(ideal_a, pool), pick(ideal_b, pool), options.shot_inlier_threshold_px,
        options.ransac_iterations, kRansacConfidence, &mask);
    if (!h) break;
    Found plane{*h, {}};
    std::vector<int> rest;
    for (size_t k = 0; k < pool.size(); ++k) (mask[k] ? plane.inliers : rest).push_back(pool[k]);
    if (int(plane.inliers.size()) < min_seed) break;
    pool = std::move(rest);
    if (options.shot_guided_matching) {
      const std::vector<bool> kept_a = taken_a, kept_b = taken_b;
      const size_t kept_matches = matches.size();
      grow(&plane);
      if (int(plane.inliers.size()) < options.min_inliers) {
        // Not a plane after all: its seed's matches stay out of the pool, as a refused
        // plane's do, and its guided matches are undone.
        taken_a = kept_a;
        taken_b = kept_b;
        matches.resize(kept_matches);
        raw_a.resize(kept_matches);
        raw_b.resize(kept_matches);
        ideal_a.resize(kept_matches);
        ideal_b.resize(kept_matches);
        continue;
      }
    } else if (int(plane.inliers.size()) < options.min_inliers) {
      break;
    }
    if (AreaFraction(Hull(pick(raw_b, plane.inliers)), {camera.width, camera.height}) >=
        options.min_area_fraction) {
      found.push_back(std::move(plane));
    }
  }
  // Keypoints far from their image's detail scale miss a tight threshold: a plane whose
  // matches an earlier one explains within twice it is the same plane.
  for (size_t i = 0; i < found.size(); ++i) {
    for (size_t j = i + 1; j < found.size();) {
      const auto fits = std::count_if(found[j].inliers.begin(), found[j].inliers.end(), [&](int k) {
        return Distance(Transfer(found[i].homography, ideal_a[k]), ideal_b[k]) <=
               2.0 * options.shot_inlier_threshold_px;
      });
      if (fits < options.merge_fraction * found[j].inliers.size()) {
        ++j;
        continue;
      }
      found[i].inliers.insert(found[i].inliers.end(), found[j].inliers.begin(),
                              found[j].inliers.end());
      const auto refit =
          FitHomography(pick(ideal_a, found[i].inliers), pick(ideal_b, found[i].inliers));
      if (refit) found[i].homography = *refit;
      found.erase(found.begin() + j);
    }
  }

  std::vector<ShotPlane> planes;
  for (const Found& f : found) {
    ShotPlane plane;
    plane.homography = f.homography;
    for (int k : f.inliers) plane.matches.push_back(matches[k]);
    plane.outline_a = Hull(pick(raw_a, f.inliers));
    plane.outline_b = Hull(pick(raw_b, f.inliers));
    plane.motions = DecomposePlaneHomography(f.homography, camera, pick(ideal_a, f.inliers),
                                             pick(ideal_b, f.inliers));
    planes.push_back(std::move(plane));
  }

  // Every plane saw the same camera motion: of each plane's decompositions keep the one
  // whose rotation the other planes agree with, where that is clear.
  std::vector<std::vector<PlaneMotion>> chosen(planes.size());
  for (size_t p = 0; p < planes.size(); ++p) {
    chosen[p] = planes[p].motions;
    if (planes[p].motions.size() < 2) continue;
    std::vector<double> disagreement;
    for (const PlaneMotion& candidate : planes[p].motions) {
      double total = 0.0;
      for (size_t q = 0; q < planes.size(); ++q) {
        if (q == p || planes[q].motions.empty()) continue;
        double closest = kInfinity;
        for (const PlaneMotion& other : planes[q].motions) {
          closest = std::min(closest, RotationAngleDeg(candidate.rotation, other.rotation));
        }
        total += closest;
      }
      disagreement.push_back(total);
    }
    const size_t best =
        std::min_element(disagreement.begin(), disagreement.end()) - disagreement.begin();
    const double next = [&] {
      double n = kInfinity;
      for (size_t c = 0; c < disagreement.size(); ++c) {
        if (c != best) n = std::min(n, disagreement[c]);
      }
      return n;
    }();
    // A degree or more apart: the rotations of the two solutions differ by far more than
    // the noise of the fit.
    if (next - disagreement[best] >= 1.0) chosen[p] = {planes[p].motions[best]};
  }
  for (size_t p = 0; p < planes.size(); ++p) planes[p].motions = std::move(chosen[p]);
  return planes;
}

}  // namespace autocal
