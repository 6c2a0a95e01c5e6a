// The simulated Sequence: ground truth and accelerometer computed at construction (cheap),
// frames rendered on demand.
#include <algorithm>
#include <cstdio>
#include <deque>
#include <memory>
#include <mutex>
#include <sstream>
#include <utility>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "devices/sim/accelerometer.h"
#include "devices/sim/lens.h"
#include "devices/sim/random.h"
#include "devices/sim/renderer.h"
#include "devices/sim/scene.h"
#include "devices/sim/simulator.h"
#include "devices/sim/trajectory.h"
#include "pipeline/error.h"

namespace autocal {
namespace {

// What the scenario sets of its scene's content beyond the scene itself, for the
// recording's notes (so that a recording says it had people or bare walls); "" for none.
std::string SceneChangesText(const Scenario& scenario) {
  std::ostringstream text;
  if (scenario.people > 0) text << ", " << scenario.people << " people";
  if (scenario.surface_texture != 1.0) text << ", surface texture " << scenario.surface_texture;
  return text.str();
}

class SimulatedSequence : public Sequence {
 public:
  explicit SimulatedSequence(const Scenario& scenario)
      : scenario_(scenario), trajectory_(scenario.motion, scenario.scene) {
    const AccelerometerOptions& a = scenario.accelerometer;
    session_.camera_device = "autocal simulator (" + scenario.name + ", " + scenario.lens + ")";
    char accel[128];
    std::snprintf(accel, sizeof(accel),
                  "autocal simulated accelerometer (%.0f Hz, +-%.3g g, %d bit)", a.rate_hz,
                  a.range_g, a.bits);
    session_.accelerometer_device = accel;
    session_.width = scenario.width;
    session_.height = scenario.height;
    session_.frame_rate_hz = scenario.fps;
    session_.accel_rate_hz = a.rate_hz;
    session_.readout_ms = scenario.image.readout_ms;
    session_.premission_calibration = IntrinsicsAt(scenario, 0.0);
    session_.cam_from_accel = CamFromAccel(a);
    session_.notes = scenario.description + " (scenario " + scenario.name + ", scene " +
                     scenario.scene + ", seed " + std::to_string(scenario.seed) +
                     SceneChangesText(scenario) + ")";
    accel_ = SimulateAccelerometer(scenario, trajectory_);
    const size_t n = scenario.frame_count();
    truth_.reserve(n);
    for (size_t i = 0; i < n; ++i) {
      GroundTruthFrame frame;
      frame.t_ns = scenario.frame_time_ns(i);
      const double t = scenario.SecondsAt(frame.t_ns);
      frame.intrinsics = IntrinsicsAt(scenario, t);
      frame.world_from_cam_translation = trajectory_.PositionAt(t);
      frame.world_from_cam_rotation = Eigen::Quaterniond(trajectory_.WorldFromCamAt(t));
      truth_.push_back(frame);
    }
  }

  std::string Describe() const override {
    std::ostringstream out;
    out << "simulator scenario " << scenario_.name << " (" << scenario_.scene << ", "
        << scenario_.lens << " lens, " << scenario_.width << "x" << scenario_.height << " @ "
        << scenario_.fps << " fps, " << scenario_.seconds << " s, seed " << scenario_.seed << ")";
    return out.str();
  }
  const SessionInfo& session() const override { return session_; }
  size_t frame_count() const override { return truth_.size(); }
  int64_t frame_time_ns(size_t index) const override { return Truth(index).t_ns; }

  cv::Mat LoadFrame(size_t index) const override {
    const GroundTruthFrame& truth = Truth(index);
    {
      const std::lock_guard lock(recent_mutex_);
      for (const auto& [recent_index, image] : recent_) {
        if (recent_index == index) return image.clone();
      }
    }
    RenderOptions options;
    options.supersampling = scenario_.image.supersampling;
    options.effects = EffectsAt(scenario_, scenario_.SecondsAt(truth.t_ns));
    options.noise_seed = MixSeed(scenario_.seed, kFrameNoiseStream, index);
    options.world_from_cam_by_row = RowPoses(scenario_.SecondsAt(truth.t_ns));
    options.time = ShotTimeOf(truth);
    options.blur_instants = BlurInstants(truth);
    cv::Mat image = renderer().Render(truth.intrinsics, Pose(truth), options).image;
    const std::lock_guard lock(recent_mutex_);
    recent_.emplace_back(index, image.clone());
    if (recent_.size() > kRecentFrames) recent_.pop_front();
    return image;
  }

  const std::vector<AccelSample>& accel() const override { return accel_; }
  const std::vector<std::string>& warnings() const override { return warnings_; }
  const std::vector<GroundTruthFrame>* ground_truth() const override { return &truth_; }

  std::optional<cv::Mat> LoadPlaneLabels(size_t index) const override {
    const GroundTruthFrame& truth = Truth(index);
    return renderer().RenderLabels(truth.intrinsics, Pose(truth),
                                   RowPoses(scenario_.SecondsAt(truth.t_ns)), ShotTimeOf(truth));
  }

  std::optional<std::string> SceneDescription() const override {
    return SceneDescriptionYaml(scenario_);
  }

 private:
  // The scene's textures take a moment to build: only when a frame is first asked for,
  // so that sequences used for their accelerometer or ground truth stay cheap.
  const Renderer& renderer() const {
    std::call_once(renderer_once_,
                   [this] { renderer_ = std::make_unique<Renderer>(BuildScene(scenario_)); });
    return *renderer_;
  }

  const GroundTruthFrame& Truth(size_t index) const {
    if (index >= truth_.size()) {
      throw Error("simulator: frame " + std::to_string(index) + " requested, the sequence has " +
                  std::to_string(truth_.size()));
    }
    return truth_[index];
  }

  static Eigen::Isometry3d Pose(const GroundTruthFrame& truth) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = truth.world_from_cam_rotation.toRotationMatrix();
    pose.translation() = truth.world_from_cam_translation;
    return pose;
  }

  // The frames rendered last, kept so that a second reader of the same frame (the
  // workbench's display following its pipeline) does not render it again; copies are
  // handed out, as callers own what they get. More than the runtime's queues hold.
  static constexpr size_t kRecentFrames = 12;

  // Seconds from one row's reading to the next's; 0 for a global shutter.
  double RowPeriodS() const { return 1e-3 * scenario_.image.readout_ms / scenario_.height; }

  ShotTime ShotTimeOf(const GroundTruthFrame& truth) const {
    return {scenario_.SecondsAt(truth.t_ns), RowPeriodS()};
  }

  // A rolling shutter's pose for each row, the middle row at time t; empty for a global
  // shutter.
  std::vector<Eigen::Isometry3d> RowPoses(double t) const {
    std::vector<Eigen::Isometry3d> poses;
    const double line_s = RowPeriodS();
    if (line_s <= 0.0) return poses;
    poses.resize(scenario_.height, Eigen::Isometry3d::Identity());
    for (int v = 0; v < scenario_.height; ++v) {
      const double row_t = t + (v - 0.5 * (scenario_.height - 1)) * line_s;
      poses[v].linear() = trajectory_.WorldFromCamAt(row_t);
      poses[v].translation() = trajectory_.PositionAt(row_t);
    }
    return poses;
  }

  // Motion blur: the exposure cut into equal slices, an odd number of them so that the
  // middle one is at the frame's time, few enough that the image's centre moves about a
  // pixel from one to the next (the rotation at the focal length, the translation seen at
  // kNearestSurfaceM); the instants other than the middle one. Empty for an instant.
  std::vector<ExposureInstant> BlurInstants(const GroundTruthFrame& truth) const {
    std::vector<ExposureInstant> instants;
    const double exposure_s = 1e-3 * scenario_.image.exposure_ms;
    if (exposure_s <= 0.0) return instants;
    const double t = scenario_.SecondsAt(truth.t_ns);
    const double start = t - 0.5 * exposure_s, end = t + 0.5 * exposure_s;
    const double turn = Eigen::AngleAxisd(trajectory_.WorldFromCamAt(start).transpose() *
                                          trajectory_.WorldFromCamAt(end))
                            .angle();
    const double shift_m = (trajectory_.PositionAt(end) - trajectory_.PositionAt(start)).norm();
    const double focal_px = std::max(truth.intrinsics.fx, truth.intrinsics.fy);
    const double travel_px = focal_px * (turn + shift_m / kNearestSurfaceM);
    const int slices = std::min(kMostExposureSlices, 2 * static_cast<int>(travel_px / 2.0) + 1);
    for (int j = 0; j < slices; ++j) {
      if (2 * j + 1 == slices) continue;
      const double instant_t = t + exposure_s * ((j + 0.5) / slices - 0.5);
      ExposureInstant instant;
      instant.world_from_cam.linear() = trajectory_.WorldFromCamAt(instant_t);
      instant.world_from_cam.translation() = trajectory_.PositionAt(instant_t);
      instant.world_from_cam_by_row = RowPoses(instant_t);
      instant.time_s = instant_t;
      instants.push_back(std::move(instant));
    }
    return instants;
  }
  static constexpr double kNearestSurfaceM = 0.5;
  static constexpr int kMostExposureSlices = 31;

  Scenario scenario_;
  Trajectory trajectory_;
  mutable std::mutex recent_mutex_;
  mutable std::deque<std::pair<size_t, cv::Mat>> recent_;
  mutable std::once_flag renderer_once_;
  mutable std::unique_ptr<Renderer> renderer_;
  SessionInfo session_;
  std::vector<AccelSample> accel_;
  std::vector<GroundTruthFrame> truth_;
  std::vector<std::string> warnings_;
};

// Writes [x, y, z] as a flow sequence (after its key, if any).
void WriteVector(cv::FileStorage& out, const Eigen::Vector3d& v) {
  out << "[:" << v.x() << v.y() << v.z() << "]";
}

}  // namespace

std::unique_ptr<Sequence> MakeSimulatedSequence(const Scenario& scenario) {
  std::string why;
  if (!scenario.Check(&why)) throw Error("scenario " + scenario.name + ": " + why);
  return std::make_unique<SimulatedSequence>(scenario);
}

std::string SceneDescriptionYaml(const Scenario& scenario) {
  const std::shared_ptr<const Scene> scene = BuildScene(scenario);
  cv::FileStorage out(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  out.writeComment(
      "Planes of the simulated scene, world frame (z up, metres). A plane is the rectangle "
      "origin + a axis_u + b axis_v, 0 <= a < width, 0 <= b < height, seen from the side its "
      "normal points to; id is its value in the plane-label images (0: none). A moving plane "
      "(a person) is at origin + velocity t at t seconds after the first frame, with its "
      "corners as at t = 0, and is in the scene only for from <= t < until.");
  out << "scene" << scene->name;
  out << "seed" << static_cast<int>(scenario.seed);
  out << "planes"
      << "[";
  for (const Plane& p : scene->planes) {
    out << "{";
    out << "id" << p.id << "name" << p.name;
    out << "origin";
    WriteVector(out, p.origin);
    out << "axis_u";
    WriteVector(out, p.axis_u);
    out << "axis_v";
    WriteVector(out, p.axis_v);
    out << "normal";
    WriteVector(out, p.normal());
    out << "width" << p.width_m << "height" << p.height_m;
    if (p.moves()) {
      out << "velocity";
      WriteVector(out, p.velocity_mps);
      out << "from" << p.from_s << "until" << p.until_s;
    }
    out << "corners"
        << "[";
    for (const Eigen::Vector3d& corner : {p.Point(0, 0), p.Point(p.width_m, 0),
                                          p.Point(p.width_m, p.height_m), p.Point(0, p.height_m)}) {
      WriteVector(out, corner);
    }
    out << "]";
    out << "}";
  }
  out << "]";
  return out.releaseAndGetString();
}

}  // namespace autocal
