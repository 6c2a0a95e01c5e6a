#include "pipeline/lens_stage.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <iterator>
#include <optional>

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "pipeline/stopwatch.h"

namespace autocal {
namespace {

Eigen::Vector2d Middle(const RadonSnake& snake) {
  return snake.vertices[snake.vertices.size() / 2];
}

// A rolling shutter read each hinge of `now` at its row's time, `line_s` a row from the
// middle row's: the frame's time saw it moved back by its edge's motion over that delay.
// Only the motion across the line changes a shape (along it a hinge stays on its line),
// and that is the shape's displacement across its chord since `before`, `interval_s`
// earlier: fitted along the chord by a quadratic, as a turn's image motion is quadratic
// in the image coordinates. Nothing when the two do not overlap over most of `now`.
std::optional<std::vector<Eigen::Vector2d>> AtFrameTime(std::vector<Eigen::Vector2d> now,
                                                        const std::vector<Eigen::Vector2d>& before,
                                                        double interval_s, double line_s,
                                                        int height) {
  constexpr int kMinPoints = 5;
  constexpr double kMinOverlap = 0.7;  // Of the newer shape's chord.
  if (now.size() < size_t(kMinPoints) || before.size() < 2 || !(interval_s > 0)) {
    return std::nullopt;
  }
  const Eigen::Vector2d origin = now.front();
  const double length = (now.back() - origin).norm();
  if (!(length > 0)) return std::nullopt;
  const Eigen::Vector2d along = (now.back() - origin) / length;
  const Eigen::Vector2d across(-along.y(), along.x());
  std::vector<Eigen::Vector2d> earlier;  // (along, across) from the newer shape's first hinge.
  for (const Eigen::Vector2d& p : before) {
    earlier.emplace_back(along.dot(p - origin), across.dot(p - origin));
  }
  if (earlier.front().x() > earlier.back().x()) std::reverse(earlier.begin(), earlier.end());
  for (size_t k = 1; k < earlier.size(); ++k) {
    if (!(earlier[k].x() > earlier[k - 1].x())) return std::nullopt;  // Folded back on itself.
  }
  // Along the chord scaled to [-1, 1], so that the quadratic's columns are alike.
  const auto scaled = [&](const Eigen::Vector2d& p) {
    return 2 * along.dot(p - origin) / length - 1;
  };
  std::vector<Eigen::Vector3d> rows;
  std::vector<double> displacement;
  double first = 1, last = -1;
  for (const Eigen::Vector2d& p : now) {
    const double u = along.dot(p - origin);
    const auto next =
        std::upper_bound(earlier.begin(), earlier.end(), u,
                         [](double x, const Eigen::Vector2d& e) { return x < e.x(); });
    if (next == earlier.begin() || next == earlier.end()) continue;
    const Eigen::Vector2d& a = *(next - 1);
    const double w_before = a.y() + (next->y() - a.y()) * (u - a.x()) / (next->x() - a.x());
    const double s = scaled(p);
    rows.emplace_back(1, s, s * s);
    displacement.push_back(across.dot(p - origin) - w_before);
    first = std::min(first, s);
    last = std::max(last, s);
  }
  if (rows.size() < size_t(kMinPoints) || last - first < 2 * kMinOverlap) return std::nullopt;
  Eigen::MatrixXd design(rows.size(), 3);
  for (size_t i = 0; i < rows.size(); ++i) design.row(i) = rows[i].transpose();
  const Eigen::Vector3d fit = design.colPivHouseholderQr().solve(
      Eigen::Map<const Eigen::VectorXd>(displacement.data(), Eigen::Index(displacement.size())));
  for (Eigen::Vector2d& p : now) {
    const double s = scaled(p);
    const double delay_s = (p.y() - 0.5 * (height - 1)) * line_s;
    p -= across * (fit.dot(Eigen::Vector3d(1, s, s * s)) * delay_s / interval_s);
  }
  return now;
}

}  // namespace

bool LensOptions::Check(std::string* error) const {
  std::string nested;
  if (!lines.Check(&nested)) {
    if (error) *error = "lines." + nested;
    return false;
  }
  if (!snakes.Check(&nested)) {
    if (error) *error = "snakes." + nested;
    return false;
  }
  if (!plumb_line.Check(&nested)) {
    if (error) *error = "plumb_line." + nested;
    return false;
  }
  if (!rectify.Check(&nested)) {
    if (error) *error = "rectify." + nested;
    return false;
  }
  std::string why;
  if (observe_every_frames < 1) {
    why = "observe_every_frames must be at least 1";
  } else if (!(min_observation_shift_px >= 0)) {
    why = "min_observation_shift_px must not be negative";
  } else if (pool_grid < 1 || pool_grid > 64) {
    why = "pool_grid must be in [1, 64]";
  } else if (pool_per_cell < 1) {
    why = "pool_per_cell must be at least 1";
  } else if (estimate_every_frames < 1) {
    why = "estimate_every_frames must be at least 1";
  } else if (estimate_lag_frames < 0 || estimate_lag_frames >= estimate_every_frames) {
    why = "estimate_lag_frames must be in [0, estimate_every_frames)";
  } else if (estimate_per_cell < 1) {
    why = "estimate_per_cell must be at least 1";
  } else if (still_rounds < 1) {
    why = "still_rounds must be at least 1";
  } else if (still_max_lines < 1) {
    why = "still_max_lines must be at least 1";
  } else if (still_max_snakes < 1) {
    why = "still_max_snakes must be at least 1";
  }
  if (why.empty()) return true;
  if (error) *error = why;
  return false;
}

LensStage::LensStage(const LensOptions& options)
    : options_(options), rectifier_(options.rectify), tracker_(options.snakes) {}

void LensStage::set_options(const LensOptions& options) {
  options_ = options;
  rectifier_.set_options(options.rectify);
  tracker_.set_options(options.snakes);
}

void LensStage::AddShape(std::vector<Eigen::Vector2d> points, cv::Size image_size, bool capped) {
  if (points.size() < 2) return;
  const Eigen::Vector2d middle = points[points.size() / 2];
  const Eigen::Vector2d chord = points.back() - points.front();
  const int orientation =
      std::clamp(int(4 * std::fmod(std::atan2(chord.y(), chord.x()) + M_PI, M_PI) / M_PI), 0, 3);
  const int columns = options_.pool_grid;
  const int rows =
      std::max(1, int(std::lround(columns * double(image_size.height) / image_size.width)));
  const int column = std::clamp(int(middle.x() * columns / image_size.width), 0, columns - 1);
  const int row = std::clamp(int(middle.y() * rows / image_size.height), 0, rows - 1);
  std::deque<LineObservation>& bin = pool_[(row * columns + column) * 4 + orientation];
  bin.push_back({std::move(points)});
  ++pool_version_;
  while (capped && int(bin.size()) > options_.pool_per_cell) bin.pop_front();
}

size_t LensStage::pooled_shapes() const {
  size_t count = 0;
  for (const auto& [key, bin] : pool_) count += bin.size();
  return count;
}

void LensStage::Pool(const RadonSnake& snake, cv::Size image_size, int64_t t_ns) {
  auto last = std::find_if(last_pooled_.begin(), last_pooled_.end(),
                           [&](const auto& entry) { return entry.first == snake.id; });
  if (last != last_pooled_.end() &&
      (Middle(snake) - last->second).norm() < options_.min_observation_shift_px) {
    return;
  }
  std::vector<Eigen::Vector2d> shape = snake.InnerVertices();
  if (readout_ms_ > 0) {
    // Without its motion the shape's bend from the shutter cannot be told apart.
    const auto before = std::find_if(previous_snakes_.begin(), previous_snakes_.end(),
                                     [&](const RadonSnake& s) { return s.id == snake.id; });
    if (before == previous_snakes_.end()) return;
    std::optional<std::vector<Eigen::Vector2d>> at_frame_time =
        AtFrameTime(std::move(shape), before->InnerVertices(), 1e-9 * double(t_ns - previous_t_ns_),
                    1e-3 * readout_ms_ / image_size.height, image_size.height);
    if (!at_frame_time) return;
    shape = std::move(*at_frame_time);
  }
  if (last == last_pooled_.end()) {
    last_pooled_.emplace_back(snake.id, Middle(snake));
  } else {
    last->second = Middle(snake);
  }
  AddShape(std::move(shape), image_size);
}

std::vector<LineObservation> LensStage::NewestShapes(int per_bin) const {
  std::vector<LineObservation> shapes;
  for (const auto& [key, bin] : pool_) {
    shapes.insert(shapes.end(), bin.end() - std::min<std::ptrdiff_t>(per_bin, std::ssize(bin)),
                  bin.end());
  }
  return shapes;
}

std::vector<LineObservation> LensStage::PooledShapes() const {
  std::vector<LineObservation> shapes;
  for (const auto& [key, bin] : pool_) shapes.insert(shapes.end(), bin.begin(), bin.end());
  return shapes;
}

PlumbLineResult LensStage::EstimateNow(const CameraIntrinsics& initial) const {
  return EstimateDistortion(PooledShapes(), initial, options_.plumb_line);
}

LensSnapshot LensStage::Process(int64_t t_ns, const cv::Mat& raw,
                                const CameraIntrinsics& calibration, cv::Mat* rectified) {
  LensSnapshot snapshot;
  snapshot.t_ns = t_ns;
  auto start = std::chrono::steady_clock::now();
  const cv::Mat channel = rectifier_.Channel(raw);
  const Gradients gradients(channel, 1.0);
  snapshot.lines = DetectLines(gradients, options_.lines);
  tracker_.Update(gradients, snapshot.lines, {calibration.cx, calibration.cy}, channel.size());
  snapshot.snakes = tracker_.snakes();
  // Forget snakes that are gone.
  std::erase_if(last_pooled_, [&](const auto& entry) {
    return std::none_of(snapshot.snakes.begin(), snapshot.snakes.end(),
                        [&](const RadonSnake& s) { return s.id == entry.first; });
  });
  for (const RadonSnake& snake : snapshot.snakes) {
    if (snake.age > 0 && snake.age % options_.observe_every_frames == 0)
      Pool(snake, channel.size(), t_ns);
  }
  if (readout_ms_ > 0) {
    previous_snakes_ = snapshot.snakes;
    previous_t_ns_ = t_ns;
  }
  snapshot.lines_ms = MillisecondsSince(start);

  ++frames_;
  if (begin_estimates_ && frames_ % options_.estimate_every_frames == 0 && !estimating_.valid()) {
    std::vector<LineObservation> newest = NewestShapes(options_.estimate_per_cell);
    if (int(newest.size()) >= options_.plumb_line.min_lines) {
      estimating_ = std::async(std::launch::async, [shapes = std::move(newest), calibration,
                                                    plumb_line = options_.plumb_line] {
        const auto begun = std::chrono::steady_clock::now();
        PlumbLineResult result = EstimateDistortion(shapes, calibration, plumb_line);
        return TimedEstimate{std::move(result), MillisecondsSince(begun)};
      });
      estimate_due_ = frames_ + options_.estimate_lag_frames;
    }
  }
  if (estimating_.valid() && frames_ >= estimate_due_ &&
      (wait_for_estimates_ ||
       estimating_.wait_for(std::chrono::seconds(0)) == std::future_status::ready)) {
    TimedEstimate estimate = estimating_.get();
    latest_ = std::move(estimate.result);
    snapshot.distortion_ms = estimate.ms;
  }
  snapshot.distortion = latest_;
  snapshot.pooled_shapes = static_cast<int>(pooled_shapes());

  if (rectified) {
    start = std::chrono::steady_clock::now();
    *rectified = rectifier_.Undistort(rectifier_.Equalize(channel), calibration);
    snapshot.rectify_ms = MillisecondsSince(start);
  }
  return snapshot;
}

SnakeOptions LensStage::StillSnakes() const {
  SnakeOptions snakes = options_.snakes;
  snakes.max_snakes = std::max(snakes.max_snakes, options_.still_max_snakes);
  snakes.adaptive_bend = true;
  return snakes;
}

LineDetectorOptions LensStage::StillLines() const {
  LineDetectorOptions lines = options_.lines;
  lines.max_lines = std::max(lines.max_lines, options_.still_max_lines);
  return lines;
}

void LensStage::GrowStill(SnakeTracker* tracker, const Gradients& gradients,
                          cv::Size size) const {
  // The image does not move: each round only grows the snakes along their edges.
  const int rounds = 1 + std::max(size.width, size.height) /
                             std::max(1, int(options_.snakes.spacing_px *
                                             std::max(1, options_.snakes.max_grow_per_frame)));
  for (int round = 0; round < rounds; ++round) {
    tracker->Update(gradients, {}, Eigen::Vector2d::Zero(), size);
  }
}

LensSnapshot LensStage::ProcessStill(const cv::Mat& raw, const CameraIntrinsics& calibration) {
  LensSnapshot snapshot;
  const auto start = std::chrono::steady_clock::now();
  const cv::Mat channel = rectifier_.Channel(raw);
  const Gradients gradients(channel, 1.0);
  snapshot.lines = DetectLines(gradients, StillLines());
  SnakeTracker tracker(StillSnakes());
  tracker.Update(gradients, snapshot.lines, {calibration.cx, calibration.cy}, channel.size());
  GrowStill(&tracker, gradients, channel.size());
  snapshot.snakes = tracker.snakes();
  for (const RadonSnake& snake : snapshot.snakes) {
    AddShape(snake.InnerVertices(), channel.size(), false);
  }
  snapshot.pooled_shapes = static_cast<int>(pooled_shapes());
  snapshot.lines_ms = MillisecondsSince(start);
  return snapshot;
}

LensSnapshot LensStage::ProcessStillThrough(const cv::Mat& raw, const CameraIntrinsics& lens,
                                            const cv::Mat& map1, const cv::Mat& map2,
                                            const CameraIntrinsics& pinhole) {
  LensSnapshot snapshot;
  const auto start = std::chrono::steady_clock::now();
  const cv::Mat channel = rectifier_.Channel(raw);
  cv::Mat undistorted;
  cv::remap(channel, undistorted, map1, map2, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  // Lines are looked for where the undistorted view has image: beyond the raw frame it is
  // black, and its border would read as lines.
  std::vector<LineSegment> found = DetectLines(undistorted, StillLines());
  std::vector<std::vector<Eigen::Vector2d>> polylines;
  const double step_px = 2.0;  // Along the undistorted line: finer than any hinge spacing.
  for (const LineSegment& line : found) {
    std::vector<Eigen::Vector2d> raw_points;
    const int steps = std::max(1, int(line.Length() / step_px));
    for (int k = 0; k <= steps; ++k) {
      const Eigen::Vector2d q = line.start + (line.end - line.start) * (double(k) / steps);
      const Eigen::Vector3d ray((q.x() - pinhole.cx) / pinhole.fx, (q.y() - pinhole.cy) / pinhole.fy,
                                1.0);
      raw_points.push_back(Project(lens, ray));
    }
    polylines.push_back(std::move(raw_points));
  }
  // Longest first: where two lines of the view fall on one edge, the longer seeds it.
  std::sort(polylines.begin(), polylines.end(), [](const auto& a, const auto& b) {
    return (a.back() - a.front()).squaredNorm() > (b.back() - b.front()).squaredNorm();
  });
  const Gradients gradients(channel, 1.0);
  SnakeTracker tracker(StillSnakes());
  // The tentative lens may be a few pixels off where the lines reached least.
  constexpr double kSeedSearchPx = 3.0;
  tracker.Seed(gradients, polylines, kSeedSearchPx, channel.size());
  GrowStill(&tracker, gradients, channel.size());
  snapshot.lines = std::move(found);
  snapshot.snakes = tracker.snakes();
  for (const RadonSnake& snake : snapshot.snakes) {
    AddShape(snake.InnerVertices(), channel.size(), false);
  }
  snapshot.pooled_shapes = static_cast<int>(pooled_shapes());
  snapshot.lines_ms = MillisecondsSince(start);
  return snapshot;
}

LensStage::StillsResult LensStage::EstimateFromStills(const std::vector<cv::Mat>& raws,
                                                      const CameraIntrinsics& initial,
                                                      const std::function<bool()>& stop) {
  StillsResult out;
  const auto stopped = [&] { return stop && stop(); };
  pool_.clear();
  for (const cv::Mat& raw : raws) {
    if (stopped()) return out;
    out.snapshots.push_back(ProcessStill(raw, initial));
  }
  out.distortion = EstimateNow(initial);
  out.rounds = 1;
  while (out.rounds < options_.still_rounds && out.distortion.solved != initial) {
    const CameraIntrinsics lens = out.distortion.solved;
    // A pinhole view of the whole raw frame: its focal length shrunk until every raw border
    // pixel falls inside (a barrel spreads the border outward).
    double scale = 1.0;
    const int w = lens.width, h = lens.height;
    for (int k = 0; k <= 64; ++k) {
      const double a = double(k) / 64;
      for (const Eigen::Vector2d& border :
           {Eigen::Vector2d(a * (w - 1), 0), Eigen::Vector2d(a * (w - 1), h - 1),
            Eigen::Vector2d(0, a * (h - 1)), Eigen::Vector2d(w - 1, a * (h - 1))}) {
        const auto ideal = UndistortPixel(lens, border);
        if (!ideal) continue;  // Beyond the fold: not imaged by this lens.
        const Eigen::Vector2d d = *ideal - Eigen::Vector2d(lens.cx, lens.cy);
        if (std::abs(d.x()) > 1e-9)
          scale = std::min(scale, (d.x() > 0 ? w - 1 - lens.cx : lens.cx) / std::abs(d.x()));
        if (std::abs(d.y()) > 1e-9)
          scale = std::min(scale, (d.y() > 0 ? h - 1 - lens.cy : lens.cy) / std::abs(d.y()));
      }
    }
    constexpr double kSmallestScale = 0.25;
    CameraIntrinsics pinhole = lens;
    pinhole.k1 = pinhole.k2 = pinhole.k3 = pinhole.p1 = pinhole.p2 = 0.0;
    pinhole.fx *= std::max(scale, kSmallestScale);
    pinhole.fy *= std::max(scale, kSmallestScale);
    cv::Mat map1, map2;
    cv::Mat distortion = (cv::Mat_<double>(1, 5) << lens.k1, lens.k2, lens.p1, lens.p2, lens.k3);
    cv::Mat lens_matrix, pinhole_matrix;
    cv::eigen2cv(lens.CameraMatrix(), lens_matrix);
    cv::eigen2cv(pinhole.CameraMatrix(), pinhole_matrix);
    cv::initUndistortRectifyMap(lens_matrix, distortion, cv::noArray(), pinhole_matrix,
                                {w, h}, CV_16SC2, map1, map2);

    auto previous_pool = std::move(pool_);
    pool_.clear();
    std::vector<LensSnapshot> snapshots;
    for (const cv::Mat& raw : raws) {
      if (stopped()) return out;
      snapshots.push_back(ProcessStillThrough(raw, lens, map1, map2, pinhole));
    }
    PlumbLineResult next = EstimateNow(initial);
    ++out.rounds;
    const double reach = std::max(next.observability.covered_radius, 0.1);
    // A round whose lines disagree with the last round's estimate, which they were found
    // through, by more than both say they are sure of has followed edges that are not the
    // lines of the last round (a board's grid printed on a sheet that is not flat, a
    // texture's false lines): the round before is kept.
    const double disagreement = MaxDistortionDifference(next.solved, lens, reach);
    const DistortionObservability& before = out.distortion.observability;
    if (out.distortion.usable &&
        (!next.usable ||
         disagreement > std::max(1.0, 3.0 * (before.shift_sigma_px +
                                             next.observability.shift_sigma_px)))) {
      pool_ = std::move(previous_pool);
      ++pool_version_;
      break;
    }
    const bool settled =
        next.lines_used <= out.distortion.lines_used * 1.05 && disagreement < 0.1;
    out.distortion = std::move(next);
    out.snapshots = std::move(snapshots);
    if (settled) break;
  }
  return out;
}

}  // namespace autocal
