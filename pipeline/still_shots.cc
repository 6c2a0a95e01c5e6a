#include "pipeline/still_shots.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>

#include <opencv2/imgproc.hpp>

#include "pipeline/error.h"
#include "pipeline/homography_ransac.h"
#include "pipeline/plumb_line.h"
#include "pipeline/stopwatch.h"

namespace autocal {

bool StillShotOptions::Check(std::string* error) const {
  std::string nested;
  std::ostringstream why;
  if (!lens.Check(&nested)) {
    why << "lens: " << nested;
  } else if (!features.Check(&nested)) {
    why << "features: " << nested;
  } else if (!planes.Check(&nested)) {
    why << "planes: " << nested;
  } else if (!calibration.Check(&nested)) {
    why << "calibration: " << nested;
  } else if (min_shared_keypoints < 1) {
    why << "min_shared_keypoints must be at least 1";
  } else if (min_shots_per_point < 2) {
    why << "min_shots_per_point must be at least 2";
  } else if (max_points_per_plane < calibration.min_points_per_plane) {
    why << "max_points_per_plane must be at least calibration.min_points_per_plane";
  } else if (!(outlier_px > 0)) {
    why << "outlier_px must be positive";
  } else if (max_lines < 0) {
    why << "max_lines must not be negative";
  } else if (max_attempts < 1) {
    why << "max_attempts must be at least 1";
  }
  if (why.str().empty()) return true;
  if (error) *error = why.str();
  return false;
}

namespace {

// Disjoint sets over 0..n-1, with path halving.
class DisjointSets {
 public:
  explicit DisjointSets(size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), 0); }
  size_t Find(size_t x) {
    while (parent_[x] != x) x = parent_[x] = parent_[parent_[x]];
    return x;
  }
  void Join(size_t a, size_t b) { parent_[Find(a)] = Find(b); }

 private:
  std::vector<size_t> parent_;
};

// The fewest tracks two shots share for a plane's homography between them to carry its
// other tracks into one of them (CompleteTracks).
constexpr int kMinSharedToComplete = 12;

// A keypoint of one shot, numbered over all shots.
struct Keypoint {
  int shot = 0;
  cv::Point2f pixel;
};

// A plane found between two shots: its matched keypoints, by their global numbers.
struct PairPlane {
  std::vector<std::pair<int, int>> links;
};

using ShotTrack = std::map<int, int>;  // Shot -> global keypoint number.

// The tracks of one chained plane: keypoints joined by the matches of its pair planes. A
// track that meets the same shot twice was chained through a wrong match: left out.
std::vector<ShotTrack> TracksOf(const std::vector<const PairPlane*>& pair_planes,
                            const std::vector<Keypoint>& keypoints, int min_shots) {
  std::map<int, size_t> local;  // Global keypoint -> index in `members`.
  std::vector<int> members;
  for (const PairPlane* plane : pair_planes) {
    for (const auto& [a, b] : plane->links) {
      for (int k : {a, b}) {
        if (local.emplace(k, members.size()).second) members.push_back(k);
      }
    }
  }
  DisjointSets sets(members.size());
  for (const PairPlane* plane : pair_planes) {
    for (const auto& [a, b] : plane->links) sets.Join(local.at(a), local.at(b));
  }
  std::map<size_t, ShotTrack> by_root;
  std::set<size_t> conflicting;
  for (size_t i = 0; i < members.size(); ++i) {
    const size_t root = sets.Find(i);
    if (!by_root[root].emplace(keypoints[members[i]].shot, members[i]).second) {
      conflicting.insert(root);
    }
  }
  std::vector<ShotTrack> tracks;
  for (auto& [root, track] : by_root) {
    if (!conflicting.count(root) && int(track.size()) >= min_shots) tracks.push_back(track);
  }
  return tracks;
}

// Where a track is in two shots (undistorted pixels), if it is in both.
std::optional<std::pair<cv::Point2f, cv::Point2f>> InBoth(const ShotTrack& track, int a, int b,
                                                         const std::vector<cv::Point2f>& ideal) {
  const auto in_a = track.find(a), in_b = track.find(b);
  if (in_a == track.end() || in_b == track.end()) return std::nullopt;
  return std::pair{ideal[in_a->second], ideal[in_b->second]};
}

// The chained tracks split into planes, one after another: the pair of shots that shares
// most of the tracks left gives a plane by a robust homography; its tracks must fit its
// homography in every other pair of shots that sees enough of them, and the tracks left that
// fit every such homography they can be judged by join it. Pair planes that share keypoints
// can hold two planes of the scene (a pair of shots with too little parallax does not set
// them apart), and a wrong match can chain a track across them: both come apart here.
std::vector<std::vector<ShotTrack>> SplitIntoPlanes(std::vector<ShotTrack> tracks,
                                                    const std::vector<cv::Point2f>& ideal,
                                                    int shot_count, const PlaneOptions& options,
                                                    int min_points) {
  const double threshold = options.shot_inlier_threshold_px;
  std::vector<std::vector<ShotTrack>> planes;
  while (int(tracks.size()) >= min_points) {
    // The seed: the best-shared pair of shots.
    int seed_a = -1, seed_b = -1, shared = 0;
    for (int a = 0; a < shot_count; ++a) {
      for (int b = a + 1; b < shot_count; ++b) {
        const int n = int(std::count_if(tracks.begin(), tracks.end(), [&](const ShotTrack& t) {
          return t.count(a) && t.count(b);
        }));
        if (n > shared) std::tie(shared, seed_a, seed_b) = std::tie(n, a, b);
      }
    }
    if (shared < options.min_inliers) break;
    std::vector<size_t> in_seed;
    std::vector<cv::Point2f> from, to;
    for (size_t t = 0; t < tracks.size(); ++t) {
      if (const auto both = InBoth(tracks[t], seed_a, seed_b, ideal)) {
        in_seed.push_back(t);
        from.push_back(both->first);
        to.push_back(both->second);
      }
    }
    std::vector<uchar> mask;
    if (!FitHomographyRansac(from, to, threshold, options.ransac_iterations, kRansacConfidence,
                             &mask)) {
      break;
    }
    std::vector<bool> member(tracks.size(), false);
    for (size_t k = 0; k < in_seed.size(); ++k) member[in_seed[k]] = mask[k] != 0;

    // Every other pair of shots: the plane's homography there, from its members; members
    // that miss it leave, and the other tracks are judged by it.
    std::vector<int> fits(tracks.size(), 0), misses(tracks.size(), 0);
    for (int a = 0; a < shot_count; ++a) {
      for (int b = a + 1; b < shot_count; ++b) {
        std::vector<size_t> members;
        from.clear();
        to.clear();
        for (size_t t = 0; t < tracks.size(); ++t) {
          if (!member[t]) continue;
          if (const auto both = InBoth(tracks[t], a, b, ideal)) {
            members.push_back(t);
            from.push_back(both->first);
            to.push_back(both->second);
          }
        }
        if (int(members.size()) < options.min_inliers) continue;
        const std::optional<cv::Matx33d> fit = FitHomographyRansac(
            from, to, threshold, options.ransac_iterations, kRansacConfidence, &mask);
        if (!fit) continue;
        const cv::Matx33d homography = *fit;
        for (size_t t = 0; t < tracks.size(); ++t) {
          const auto both = InBoth(tracks[t], a, b, ideal);
          if (!both) continue;
          const cv::Vec3d mapped = homography * cv::Vec3d(both->first.x, both->first.y, 1.0);
          const double error = std::hypot(mapped[0] / mapped[2] - both->second.x,
                                          mapped[1] / mapped[2] - both->second.y);
          ++(error <= threshold ? fits : misses)[t];
        }
      }
    }
    std::vector<ShotTrack> plane, rest;
    for (size_t t = 0; t < tracks.size(); ++t) {
      const bool joins = misses[t] == 0 && (member[t] || fits[t] > 0);
      (joins ? plane : rest).push_back(std::move(tracks[t]));
    }
    if (int(plane.size()) < min_points) break;
    planes.push_back(std::move(plane));
    tracks = std::move(rest);
  }
  return planes;
}

// A plane's homography from shot `from` to shot `to` (ideal pixels), by RANSAC over the
// tracks both see; none when they share fewer than `min_shared`.
std::optional<cv::Matx33d> HomographyBetween(const std::vector<ShotTrack>& tracks, int from, int to,
                                             const std::vector<cv::Point2f>& ideal, int min_shared,
                                             const PlaneOptions& options) {
  std::vector<cv::Point2f> a, b;
  for (const ShotTrack& t : tracks) {
    if (const auto both = InBoth(t, from, to, ideal)) {
      a.push_back(both->first);
      b.push_back(both->second);
    }
  }
  if (int(a.size()) < min_shared) return std::nullopt;
  std::vector<uchar> mask;
  return FitHomographyRansac(a, b, options.shot_inlier_threshold_px, options.ransac_iterations,
                             kRansacConfidence, &mask);
}

// A plane's tracks carried into the shots they miss. Repetitive texture (a chessboard)
// is matched only between the pairs of shots where a few distinct keypoints seeded its
// plane, and its tracks reach few of the shots that see it. For each shot, from the other
// shot sharing most of the plane's tracks with it, the homography between the two (RANSAC
// over the shared tracks) brings each track missing there within `threshold_px` of one of
// the shot's keypoints, whose descriptor is no farther from the track's there than the
// shared tracks' are: it joins the track, nearest first, one keypoint to one track.
void CompleteTracks(std::vector<ShotTrack>* tracks, const std::vector<cv::Point2f>& ideal,
                    const std::vector<int>& first_keypoint, const std::vector<KeypointSet>& sets,
                    int min_shared, const PlaneOptions& options) {
  const int shot_count = int(sets.size());
  const auto descriptor = [&](int global) {
    const auto shot = std::upper_bound(first_keypoint.begin(), first_keypoint.end(), global) - 1;
    return sets[shot - first_keypoint.begin()].descriptors.row(global - *shot);
  };
  const int norm =
      !sets.empty() && sets[0].descriptors.depth() == CV_8U ? cv::NORM_HAMMING : cv::NORM_L2;
  const double threshold = options.shot_inlier_threshold_px;
  for (int to = 0; to < shot_count; ++to) {
    // The shot sharing most tracks with `to`.
    int from = -1, shared = 0;
    for (int s = 0; s < shot_count; ++s) {
      if (s == to) continue;
      const int n = int(std::count_if(tracks->begin(), tracks->end(), [&](const ShotTrack& t) {
        return t.count(s) && t.count(to);
      }));
      if (n > shared) std::tie(shared, from) = std::tie(n, s);
    }
    if (shared < min_shared) continue;
    const std::optional<cv::Matx33d> homography =
        HomographyBetween(*tracks, from, to, ideal, min_shared, options);
    if (!homography) continue;
    double max_distance = 0.0;
    std::set<int> used;  // Keypoints of `to` already on a track.
    for (const ShotTrack& t : *tracks) {
      if (const auto in_to = t.find(to); in_to != t.end()) {
        used.insert(in_to->second);
        if (t.count(from)) {
          max_distance = std::max(
              max_distance, cv::norm(descriptor(t.at(from)), descriptor(in_to->second), norm));
        }
      }
    }
    struct Candidate {
      double offset_px;
      size_t track;
      int keypoint;
    };
    std::vector<Candidate> candidates;
    for (size_t t = 0; t < tracks->size(); ++t) {
      const ShotTrack& track = (*tracks)[t];
      if (track.count(to) || !track.count(from)) continue;
      const cv::Point2f& p = ideal[track.at(from)];
      const cv::Vec3d q = *homography * cv::Vec3d(p.x, p.y, 1.0);
      const cv::Point2f predicted(float(q[0] / q[2]), float(q[1] / q[2]));
      for (int k = first_keypoint[to]; k < first_keypoint[to + 1]; ++k) {
        const double offset = cv::norm(ideal[k] - predicted);
        if (offset > threshold || used.count(k)) continue;
        if (cv::norm(descriptor(track.at(from)), descriptor(k), norm) <= max_distance) {
          candidates.push_back({offset, t, k});
        }
      }
    }
    std::sort(candidates.begin(), candidates.end(),
              [](const Candidate& x, const Candidate& y) { return x.offset_px < y.offset_px; });
    std::set<size_t> completed;
    for (const Candidate& c : candidates) {
      if (completed.count(c.track) || used.count(c.keypoint)) continue;
      (*tracks)[c.track][to] = c.keypoint;
      completed.insert(c.track);
      used.insert(c.keypoint);
    }
  }
}

// Each track's pixel in every shot but its first, moved to where the patch around its
// first pixel, warped by the plane's homography between the two shots (through the lens),
// matches best: scale-invariant keypoints sit where a blob's response peaks, and a
// slanted view moves that peak across the blob, by a different amount in each shot; the
// aligned pixel is the image of the same scene point in every shot. A pixel whose patch
// matches poorly (correlation under 0.8) or lies more than 2 px off is left as found.
void AlignTracksToTheirFirstShot(const std::vector<ShotTrack>& tracks,
                                 const std::vector<Keypoint>& keypoints,
                                 const std::vector<cv::Point2f>& ideal,
                                 const std::vector<cv::Mat>& grey, const CameraIntrinsics& camera,
                                 int min_shared, const PlaneOptions& options,
                                 std::map<std::pair<size_t, int>, cv::Point2f>* aligned) {
  constexpr int kHalf = 7, kSearch = 3;
  constexpr double kMinCorrelation = 0.8, kMaxShiftPx = 2.0;
  const int shot_count = int(grey.size());
  const auto to_raw = [&](const cv::Point2f& p) {
    const Eigen::Vector2d raw = Project(
        camera, Eigen::Vector3d((p.x - camera.cx) / camera.fx, (p.y - camera.cy) / camera.fy, 1.0));
    return cv::Point2f(float(raw.x()), float(raw.y()));
  };
  for (int from = 0; from < shot_count; ++from) {
    for (int to = 0; to < shot_count; ++to) {
      if (to == from) continue;
      const std::optional<cv::Matx33d> h =
          HomographyBetween(tracks, from, to, ideal, min_shared, options);
      if (!h) continue;
      const auto map = [&](const cv::Point2f& raw) {
        const cv::Point2f in = UndistortPixels({raw}, camera)[0];
        const cv::Vec3d q = *h * cv::Vec3d(in.x, in.y, 1.0);
        return to_raw(cv::Point2f(float(q[0] / q[2]), float(q[1] / q[2])));
      };
      for (size_t t = 0; t < tracks.size(); ++t) {
        const ShotTrack& track = tracks[t];
        if (track.begin()->first != from || !track.count(to)) continue;
        const cv::Point2f p = keypoints[track.at(from)].pixel;
        const cv::Point2f q = keypoints[track.at(to)].pixel;
        // The map from shot `from` to shot `to` near p, as an affine.
        const cv::Point2f dx = (map(p + cv::Point2f(1, 0)) - map(p - cv::Point2f(1, 0))) * 0.5f;
        const cv::Point2f dy = (map(p + cv::Point2f(0, 1)) - map(p - cv::Point2f(0, 1))) * 0.5f;
        cv::Matx22d affine(dx.x, dy.x, dx.y, dy.y);
        if (!(std::abs(cv::determinant(affine)) > 1e-3)) continue;
        const cv::Matx22d inverse = affine.inv();
        // The patch of `from` as shot `to` would see it, centred on p's image there.
        const int side = 2 * kHalf + 1;
        cv::Mat warp = (cv::Mat_<double>(2, 3) << inverse(0, 0), inverse(0, 1),
                        p.x - inverse(0, 0) * kHalf - inverse(0, 1) * kHalf, inverse(1, 0),
                        inverse(1, 1), p.y - inverse(1, 0) * kHalf - inverse(1, 1) * kHalf);
        cv::Mat patch;
        cv::warpAffine(grey[from], patch, warp, {side, side},
                       cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REPLICATE);
        const int x0 = int(std::lround(q.x)) - kHalf - kSearch;
        const int y0 = int(std::lround(q.y)) - kHalf - kSearch;
        const cv::Rect search(x0, y0, side + 2 * kSearch, side + 2 * kSearch);
        if ((search & cv::Rect(0, 0, grey[to].cols, grey[to].rows)) != search) continue;
        cv::Mat score;
        cv::matchTemplate(grey[to](search), patch, score, cv::TM_CCOEFF_NORMED);
        cv::Point best;
        double peak = 0.0;
        cv::minMaxLoc(score, nullptr, &peak, nullptr, &best);
        if (peak < kMinCorrelation || best.x == 0 || best.y == 0 || best.x == score.cols - 1 ||
            best.y == score.rows - 1) {
          continue;
        }
        const auto vertex = [](float l, float c, float r) {
          const float d = l - 2 * c + r;
          return d < 0 ? 0.5f * (l - r) / d : 0.0f;
        };
        const float sx =
            vertex(score.at<float>(best.y, best.x - 1), score.at<float>(best.y, best.x),
                   score.at<float>(best.y, best.x + 1));
        const float sy =
            vertex(score.at<float>(best.y - 1, best.x), score.at<float>(best.y, best.x),
                   score.at<float>(best.y + 1, best.x));
        const cv::Point2f found(float(x0 + best.x + kHalf) + sx, float(y0 + best.y + kHalf) + sy);
        if (cv::norm(found - q) <= kMaxShiftPx) (*aligned)[{t, to}] = found;
      }
    }
  }
}

// The tracks of `material` that `solved` placed and reprojects within `threshold_px` in
// every shot that sees them (tracks it left out stay, they cost nothing); the number left
// out. Planes left with too few tracks go.
int LeaveOutOffPlaneTracks(const SelfCalibrationResult& solved, double threshold_px,
                           int min_points, CalibrationMaterial* material) {
  int left_out = 0;
  for (PlaneTrack& plane : material->planes) {
    const auto placed = std::find_if(solved.planes.begin(), solved.planes.end(),
                                     [&](const PlaneEstimate& p) { return p.id == plane.id; });
    if (placed == solved.planes.end()) continue;
    const std::map<int, Eigen::Vector2d> points(placed->points.begin(), placed->points.end());
    std::set<int> off;
    for (const PlaneObservation& o : plane.observations) {
      const auto point = points.find(o.point);
      const auto& pose = solved.cam_from_world[o.frame];
      if (point == points.end() || !pose) continue;
      const Eigen::Vector3d cam =
          *pose * (placed->world_from_plane * Eigen::Vector3d(point->second.x(),
                                                              point->second.y(), 0.0));
      if (!(cam.z() > 0) || (Project(solved.estimate, cam) - o.pixel).norm() > threshold_px) {
        off.insert(o.point);
      }
    }
    std::erase_if(plane.observations,
                  [&](const PlaneObservation& o) { return off.count(o.point) > 0; });
    left_out += static_cast<int>(off.size());
  }
  std::erase_if(material->planes, [&](const PlaneTrack& plane) {
    std::set<int> points;
    for (const PlaneObservation& o : plane.observations) points.insert(o.point);
    return static_cast<int>(points.size()) < min_points;
  });
  return left_out;
}

// The shots some plane's track is seen in, ascending.
std::vector<int> ShotsSeen(const CalibrationMaterial& material) {
  std::set<int> seen;
  for (const PlaneTrack& plane : material.planes) {
    for (const PlaneObservation& o : plane.observations) seen.insert(o.frame);
  }
  return {seen.begin(), seen.end()};
}

}  // namespace

std::vector<std::pair<std::string, CalibrationMaterial>> StillShotSubsets(
    const CalibrationMaterial& all, const std::vector<int>& placed, int max_attempts) {
  std::vector<std::pair<std::string, CalibrationMaterial>> subsets;
  subsets.emplace_back("all " + std::to_string(all.frame_count) + " shots", all);
  const int leave_outs = std::min(int(placed.size()), max_attempts - 1);
  for (int i = 0; i < leave_outs; ++i) {
    const int left_out = placed[i * placed.size() / leave_outs];
    CalibrationMaterial subset = all;
    subset.frame_count = all.frame_count - 1;
    for (PlaneTrack& plane : subset.planes) {
      std::erase_if(plane.observations,
                    [&](const PlaneObservation& o) { return o.frame == left_out; });
      for (PlaneObservation& o : plane.observations) o.frame -= o.frame > left_out;
    }
    subsets.emplace_back("all but shot " + std::to_string(left_out + 1), std::move(subset));
  }
  return subsets;
}

StillShotCalibration CalibrateStillShots(const std::vector<cv::Mat>& shots,
                                         const CameraIntrinsics& prior,
                                         const StillShotOptions& options,
                                         const StillShotProgress& progress) {
  const auto say = [&](const std::string& what) {
    if (progress.step) progress.step(what);
  };
  const auto stop_requested = [&] {
    return progress.stop && progress.stop->load(std::memory_order_relaxed);
  };
  std::string why;
  if (!options.Check(&why)) throw Error("still-shot options: " + why);
  if (!prior.Check(&why)) throw Error("still shots: the prior: " + why);
  if (shots.size() < 3) {
    throw Error("still shots: " + std::to_string(shots.size()) +
                " shots; at least 3 are needed (a plane seen from 3 viewpoints)");
  }
  for (size_t i = 0; i < shots.size(); ++i) {
    if (shots[i].cols != prior.width || shots[i].rows != prior.height) {
      throw Error("still shots: shot " + std::to_string(i + 1) + " is " +
                  std::to_string(shots[i].cols) + "x" + std::to_string(shots[i].rows) +
                  ", the calibration is for " + std::to_string(prior.width) + "x" +
                  std::to_string(prior.height));
    }
  }
  StillShotCalibration out;
  const int shot_count = static_cast<int>(shots.size());
  // Checked between one shot, pair or attempt and the next.
  const auto stopped = [&] { return out.stopped = out.stopped || stop_requested(); };
  const auto attempt_made = [&](StillShotAttempt attempt) {
    out.attempts.push_back(std::move(attempt));
    if (progress.attempted) progress.attempted(out.attempts.back());
  };

  // Boxes 1-2: straight lines of every shot, and the distortion that straightens them.
  say("lines and distortion (boxes 1-2) in " + std::to_string(shot_count) + " shots");
  LensStage lens(options.lens);
  {
    const auto start = std::chrono::steady_clock::now();
    LensStage::StillsResult stills = lens.EstimateFromStills(shots, prior, stopped);
    if (stopped()) return out;
    out.distortion = std::move(stills.distortion);
    for (const LensSnapshot& snapshot : stills.snapshots) {
      out.timing_ms["lines"].push_back(snapshot.lines_ms);
    }
    out.timing_ms["distortion"].push_back(MillisecondsSince(start));
  }
  // As on video: until box 10 has measured it, the planes are fitted with the plumb-line
  // distortion, measured from the images alone.
  out.working = out.distortion.usable ? WithDistortionOf(prior, out.distortion.estimate) : prior;

  say("keypoints (box 4) in " + std::to_string(shot_count) + " shots");
  // Box 4: keypoints of every shot, on the green channel (smallest colour fringes).
  std::vector<KeypointSet> sets(shots.size());
  std::vector<cv::Mat> green(shots.size());  // Kept: the tracks are aligned on it too.
  std::vector<int> first_keypoint(shots.size() + 1, 0);
  std::vector<Keypoint> keypoints;
  for (int s = 0; s < shot_count; ++s) {
    if (stopped()) return out;
    const auto start = std::chrono::steady_clock::now();
    if (shots[s].channels() == 1) {
      green[s] = shots[s];
    } else {
      cv::extractChannel(shots[s], green[s], 1);
    }
    sets[s] = DetectKeypoints(green[s], options.features);
    out.timing_ms["features"].push_back(MillisecondsSince(start));
    first_keypoint[s + 1] = first_keypoint[s] + static_cast<int>(sets[s].keypoints.size());
    for (const cv::KeyPoint& k : sets[s].keypoints) keypoints.push_back({s, k.pt});
  }
  std::vector<cv::Point2f> raw;
  for (const Keypoint& k : keypoints) raw.push_back(k.pixel);
  const std::vector<cv::Point2f> ideal = UndistortPixels(raw, out.working);

  say("planes (box 6) between " + std::to_string(shot_count * (shot_count - 1) / 2) +
      " pairs of shots");
  // Box 6 between every pair of shots.
  std::vector<PairPlane> pair_planes;
  for (int a = 0; a < shot_count; ++a) {
    for (int b = a + 1; b < shot_count; ++b) {
      if (stopped()) return out;
      const auto start = std::chrono::steady_clock::now();
      const std::vector<ShotPlane> found =
          FindPlanesBetweenShots(sets[a], sets[b], out.working, options.planes, options.features);
      out.timing_ms["planes"].push_back(MillisecondsSince(start));
      ++out.pairs;
      out.pairs_with_planes += !found.empty();
      for (const ShotPlane& plane : found) {
        PairPlane chained;
        for (const cv::DMatch& m : plane.matches) {
          chained.links.emplace_back(first_keypoint[a] + m.queryIdx,
                                     first_keypoint[b] + m.trainIdx);
        }
        pair_planes.push_back(std::move(chained));
      }
    }
  }

  // Pair planes that share keypoints are one plane of the scene.
  std::map<int, std::vector<int>> planes_of_keypoint;
  for (size_t p = 0; p < pair_planes.size(); ++p) {
    std::set<int> members;
    for (const auto& [a, b] : pair_planes[p].links) members.insert({a, b});
    for (int k : members) planes_of_keypoint[k].push_back(int(p));
  }
  std::map<std::pair<int, int>, int> shared;
  for (const auto& [k, planes] : planes_of_keypoint) {
    for (size_t i = 0; i < planes.size(); ++i) {
      for (size_t j = i + 1; j < planes.size(); ++j) ++shared[{planes[i], planes[j]}];
    }
  }
  DisjointSets same_plane(pair_planes.size());
  for (const auto& [pair, count] : shared) {
    if (count >= options.min_shared_keypoints) same_plane.Join(pair.first, pair.second);
  }
  std::map<size_t, std::vector<const PairPlane*>> chained;
  for (size_t p = 0; p < pair_planes.size(); ++p) {
    chained[same_plane.Find(p)].push_back(&pair_planes[p]);
  }

  // Each chained plane's tracks split by their homographies, the longest kept.
  std::vector<std::vector<ShotTrack>> planes;
  for (const auto& [root, members] : chained) {
    for (std::vector<ShotTrack>& tracks :
         SplitIntoPlanes(TracksOf(members, keypoints, options.min_shots_per_point), ideal,
                         shot_count, options.planes, options.calibration.min_points_per_plane)) {
      if (options.planes.shot_guided_matching) {
        CompleteTracks(&tracks, ideal, first_keypoint, sets, kMinSharedToComplete, options.planes);
      }
      std::stable_sort(tracks.begin(), tracks.end(), [](const ShotTrack& x, const ShotTrack& y) {
        return x.size() > y.size();
      });
      if (int(tracks.size()) > options.max_points_per_plane) {
        tracks.resize(options.max_points_per_plane);
      }
      planes.push_back(std::move(tracks));
    }
  }
  const auto observations = [](const std::vector<ShotTrack>& tracks) {
    size_t n = 0;
    for (const ShotTrack& t : tracks) n += t.size();
    return n;
  };
  std::stable_sort(planes.begin(), planes.end(), [&](const auto& x, const auto& y) {
    return observations(x) > observations(y);
  });

  out.material.frame_count = shot_count;
  for (size_t p = 0; p < planes.size(); ++p) {
    PlaneTrack plane;
    plane.id = static_cast<int>(p) + 1;
    std::map<std::pair<size_t, int>, cv::Point2f> aligned;
    AlignTracksToTheirFirstShot(planes[p], keypoints, ideal, green, out.working,
                                kMinSharedToComplete, options.planes, &aligned);
    for (size_t t = 0; t < planes[p].size(); ++t) {
      for (const auto& [shot, k] : planes[p][t]) {
        const auto moved = aligned.find({t, shot});
        const cv::Point2f pixel = moved != aligned.end() ? moved->second : keypoints[k].pixel;
        plane.observations.push_back({shot, static_cast<int>(t), {pixel.x, pixel.y}});
      }
    }
    out.material.planes.push_back(std::move(plane));
  }
  const std::vector<LineObservation> lines = lens.PooledShapes();
  const size_t keep = std::min(lines.size(), static_cast<size_t>(options.max_lines));
  for (size_t i = 0; i < keep; ++i) out.material.lines.push_back(lines[i * lines.size() / keep]);
  if (out.material.planes.empty()) return out;

  {
    const std::vector<int> seen = ShotsSeen(out.material);
    std::string unseen;
    for (int shot = 0, k = 0; shot < shot_count; ++shot) {
      if (k < int(seen.size()) && seen[k] == shot) {
        ++k;
      } else {
        unseen += (unseen.empty() ? "" : ", ") + std::to_string(shot + 1);
      }
    }
    say(std::to_string(out.material.planes.size()) + " planes over " +
        std::to_string(seen.size()) + " of " + std::to_string(shot_count) + " shots" +
        (unseen.empty() ? "" : " (shots " + unseen + " share no plane with the others)"));
  }
  // A first solve over all the shots finds the tracks off their planes, and the shots it
  // can place: leaving out another would repeat the attempt on all of them, and the history
  // would take the copies for agreement.
  if (stopped()) return out;
  say("self-calibration (box 10) on all the shots, to find tracks off their planes");
  std::vector<int> placed = ShotsSeen(out.material);
  {
    const auto start = std::chrono::steady_clock::now();
    SelfCalibrationResult first = SelfCalibrate(out.material, prior, options.calibration);
    out.timing_ms["calibration"].push_back(MillisecondsSince(start));
    if (!first.usable) {  // Fewer shots would not do better: the attempt on all is the one.
      attempt_made({"all " + std::to_string(shot_count) + " shots", std::move(first)});
      return out;
    }
    out.outlier_tracks = LeaveOutOffPlaneTracks(first,
                                                std::max(options.outlier_px, 3.0 * first.rms_px),
                                                options.calibration.min_points_per_plane,
                                                &out.material);
    std::erase_if(placed, [&](int shot) { return !first.cam_from_world[shot]; });
    say("box 10 placed " + std::to_string(placed.size()) + " of " + std::to_string(shot_count) +
        " shots; " + std::to_string(out.outlier_tracks) + " tracks off their planes left out");
  }

  // Box 10 over all the shots, then over all but one in turn.
  for (auto& [name, material] : StillShotSubsets(out.material, placed, options.max_attempts)) {
    if (stopped()) return out;
    say("self-calibration (box 10) on " + name);
    const auto start = std::chrono::steady_clock::now();
    SelfCalibrationResult result = SelfCalibrate(material, prior, options.calibration);
    out.timing_ms["calibration"].push_back(MillisecondsSince(start));
    attempt_made({name, std::move(result)});
  }
  return out;
}

}  // namespace autocal
