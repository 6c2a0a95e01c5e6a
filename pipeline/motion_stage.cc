#include "pipeline/motion_stage.h"

#include <algorithm>
#include <chrono>

namespace autocal {
namespace {

double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace

bool MotionStageOptions::Check(std::string* error) const {
  std::string nested;
  if (!flow.Check(&nested)) {
    if (error) *error = "flow." + nested;
    return false;
  }
  if (!planes.Check(&nested)) {
    if (error) *error = "planes." + nested;
    return false;
  }
  // Box 6 looks back its baselines into every track's history.
  if (flow.history_frames <= std::max(planes.baseline_frames, planes.long_baseline_frames)) {
    if (error) {
      *error = "flow.history_frames must exceed planes.baseline_frames and long_baseline_frames";
    }
    return false;
  }
  return true;
}

int MotionSnapshot::PlaneOf(int track_id) const {
  for (const DominantPlane& plane : planes) {
    if (std::binary_search(plane.track_ids.begin(), plane.track_ids.end(), track_id)) {
      return plane.id;
    }
  }
  return 0;
}

MotionStage::MotionStage(const MotionStageOptions& options)
    : options_(options), flow_(options.flow), planes_(options.planes) {}

void MotionStage::set_options(const MotionStageOptions& options) {
  options_ = options;
  flow_.set_options(options.flow);
  planes_.set_options(options.planes);
}

MotionSnapshot MotionStage::Process(int64_t t_ns, const cv::Mat& gray,
                                    const CameraIntrinsics& camera) {
  MotionSnapshot snapshot;
  snapshot.t_ns = t_ns;
  snapshot.image_size = gray.size();
  snapshot.camera = camera;
  auto start = std::chrono::steady_clock::now();
  flow_.Advance(t_ns, gray);
  snapshot.tracks_died = flow_.died();
  snapshot.flow_ms = MillisecondsSince(start);

  start = std::chrono::steady_clock::now();
  snapshot.tracks_started = flow_.Replenish();
  snapshot.features_ms = MillisecondsSince(start);

  start = std::chrono::steady_clock::now();
  planes_.Update(t_ns, flow_.tracks(), camera);
  snapshot.planes_ms = MillisecondsSince(start);

  snapshot.tracks = flow_.tracks();
  snapshot.planes = planes_.planes();
  return snapshot;
}

}  // namespace autocal
