#include "pipeline/lens_stage.h"

#include <algorithm>
#include <chrono>

namespace autocal {
namespace {

double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

Eigen::Vector2d Middle(const RadonSnake& snake) { return snake.vertices[snake.vertices.size() / 2]; }

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
  } else if (pool_size < plumb_line.min_lines) {
    why = "pool_size must hold at least plumb_line.min_lines shapes";
  } else if (estimate_every_frames < 1) {
    why = "estimate_every_frames must be at least 1";
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

void LensStage::Pool(const RadonSnake& snake) {
  auto last = std::find_if(last_pooled_.begin(), last_pooled_.end(),
                           [&](const auto& entry) { return entry.first == snake.id; });
  if (last != last_pooled_.end() &&
      (Middle(snake) - last->second).norm() < options_.min_observation_shift_px) {
    return;
  }
  if (last == last_pooled_.end()) {
    last_pooled_.emplace_back(snake.id, Middle(snake));
  } else {
    last->second = Middle(snake);
  }
  pool_.push_back({snake.vertices});
  while (int(pool_.size()) > options_.pool_size) pool_.pop_front();
}

PlumbLineResult LensStage::EstimateNow(const CameraIntrinsics& initial) const {
  const std::vector<LineObservation> shapes(pool_.begin(), pool_.end());
  return EstimateDistortion(shapes, initial, options_.plumb_line);
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
    if (snake.age > 0 && snake.age % options_.observe_every_frames == 0) Pool(snake);
  }
  snapshot.lines_ms = MillisecondsSince(start);

  ++frames_;
  if (frames_ % options_.estimate_every_frames == 0 &&
      int(pool_.size()) >= options_.plumb_line.min_lines) {
    start = std::chrono::steady_clock::now();
    latest_ = EstimateNow(calibration);
    snapshot.distortion_ms = MillisecondsSince(start);
  }
  snapshot.distortion = latest_;
  snapshot.pooled_shapes = static_cast<int>(pool_.size());

  if (rectified) {
    start = std::chrono::steady_clock::now();
    *rectified = rectifier_.Undistort(channel, calibration);
    snapshot.rectify_ms = MillisecondsSince(start);
  }
  return snapshot;
}

LensSnapshot LensStage::ProcessStill(const cv::Mat& raw, const CameraIntrinsics& calibration) {
  LensSnapshot snapshot;
  const auto start = std::chrono::steady_clock::now();
  const cv::Mat channel = rectifier_.Channel(raw);
  const Gradients gradients(channel, 1.0);
  snapshot.lines = DetectLines(gradients, options_.lines);
  SnakeTracker tracker(options_.snakes);
  tracker.Update(gradients, snapshot.lines, {calibration.cx, calibration.cy}, channel.size());
  // The image does not move: each round only grows the snakes along their edges, until
  // they stop growing.
  const int rounds = 1 + std::max(channel.cols, channel.rows) /
                             std::max(1, int(options_.snakes.spacing_px *
                                             std::max(1, options_.snakes.max_grow_per_frame)));
  for (int round = 0; round < rounds; ++round) {
    tracker.Update(gradients, {}, {calibration.cx, calibration.cy}, channel.size());
  }
  snapshot.snakes = tracker.snakes();
  for (const RadonSnake& snake : snapshot.snakes) pool_.push_back({snake.vertices});
  while (int(pool_.size()) > options_.pool_size) pool_.pop_front();
  snapshot.pooled_shapes = static_cast<int>(pool_.size());
  snapshot.lines_ms = MillisecondsSince(start);
  return snapshot;
}

}  // namespace autocal
