// Box 7 on simulated walks, measured against ground-truth poses: tilt at rest, the kind of
// motion of every frame interval, metric scale over 2-second windows, and faulty readings.
//
// The simulator's walks are a closed path or rest; sidesteps, turns on the spot and stops
// are scripted here (ScriptedWalk) and read through the simulator's own specific-force
// model (TrueSpecificForce) with its accelerometer errors. Set AUTOCAL_INERTIAL_PLOT_DIR
// to get CSV files and plots of the estimates against the truth.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "devices/sim/accelerometer.h"
#include "devices/sim/simulator.h"
#include "devices/sim/trajectory.h"
#include "pipeline/inertial.h"

namespace autocal {
namespace {

double Radians(double degrees) { return degrees * M_PI / 180.0; }
double Degrees(double radians) { return radians * 180.0 / M_PI; }
double AngleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return Degrees(std::atan2(a.cross(b).norm(), a.dot(b)));
}

struct TruthFrame {
  int64_t t_ns = 0;
  Eigen::Matrix3d world_from_cam = Eigen::Matrix3d::Identity();
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
};

// Frames with their true poses and the accelerometer's readings.
struct Walk {
  std::vector<TruthFrame> frames;
  std::vector<SpecificForceSample> samples;
  AccelCalibration calibration;
};

Walk FromSequence(const Sequence& sequence) {
  Walk walk;
  for (const GroundTruthFrame& truth : *sequence.ground_truth()) {
    walk.frames.push_back({truth.t_ns, truth.world_from_cam_rotation.toRotationMatrix(),
                           truth.world_from_cam_translation});
  }
  for (const AccelSample& sample : sequence.accel()) {
    walk.samples.push_back({sample.t_ns, sample.specific_force});
  }
  walk.calibration.cam_from_accel = sequence.session().cam_from_accel;
  return walk;
}

Walk SimulatedWalk(const std::string& spec) {
  return FromSequence(*MakeSimulatedSequence(ParseScenarioSpec(spec)));
}

// ---------------------------------------------------------------------------------------
// A scripted walk: stops, forward walks, sidesteps and turns on the spot.

// A function of time with its first two derivatives (forward mode), so that the
// accelerometer reads the exact acceleration.
struct Jet {
  double v = 0.0, d = 0.0, dd = 0.0;
};
Jet operator+(const Jet& a, const Jet& b) { return {a.v + b.v, a.d + b.d, a.dd + b.dd}; }
Jet operator+(const Jet& a, double b) { return {a.v + b, a.d, a.dd}; }
Jet operator*(double s, const Jet& a) { return {s * a.v, s * a.d, s * a.dd}; }
Jet operator*(const Jet& a, const Jet& b) {
  return {a.v * b.v, a.d * b.v + a.v * b.d, a.dd * b.v + 2.0 * a.d * b.d + a.v * b.dd};
}
Jet Sin(const Jet& a) {
  return {std::sin(a.v), std::cos(a.v) * a.d, std::cos(a.v) * a.dd - std::sin(a.v) * a.d * a.d};
}
Jet Cos(const Jet& a) {
  return {std::cos(a.v), -std::sin(a.v) * a.d, -std::sin(a.v) * a.dd - std::cos(a.v) * a.d * a.d};
}

enum class Move { kStill, kForward, kSidestepLeft, kSidestepRight, kTurnLeft, kTurnRight };

struct Leg {
  Move move = Move::kStill;
  double seconds = 1.0;
  double amount = 0.0;  // Speed (m/s) of walks and sidesteps; degrees of turns.
};

class ScriptedWalk {
 public:
  // The vest camera sits this far ahead of the wearer's turning axis.
  static constexpr double kLeverM = 0.15;
  static constexpr double kHeightM = 1.4;
  static constexpr double kPitchDeg = 10.0;

  explicit ScriptedWalk(std::vector<Leg> legs) : legs_(std::move(legs)) {
    Start start{0.0, 0.0, 0.0, 0.0};
    for (size_t i = 0; i < legs_.size(); ++i) {
      starts_.push_back(start);
      Jet x, y, heading, envelope;
      Evaluate(i, {legs_[i].seconds, 0.0, 0.0}, &x, &y, &heading, &envelope);
      start = {start.t + legs_[i].seconds, x.v, y.v, heading.v};
    }
    seconds_ = start.t;
  }

  double seconds() const { return seconds_; }

  // Before the start and after the end the wearer stands still (first and last legs
  // should be stops).
  BodyState At(double t_s) const {
    const double t = std::clamp(t_s, 0.0, seconds_);
    size_t i = 0;
    while (i + 1 < legs_.size() && t >= starts_[i + 1].t) ++i;
    const double moving = t_s == t ? 1.0 : 0.0;
    Jet x, y, heading, envelope;
    Evaluate(i, {t - starts_[i].t, moving, 0.0}, &x, &y, &heading, &envelope);
    const Jet time{t, moving, 0.0};
    // Gait: bob, surge and sway while walking; smaller bobs while sidestepping and turning.
    Jet bob, surge, sway;
    const Move move = legs_[i].move;
    if (move == Move::kForward) {
      bob = (0.0125 * envelope) * Sin((2 * M_PI * 1.8) * time);
      surge = (0.02 * envelope) * Sin((2 * M_PI * 1.8) * time + 1.0);
      sway = (0.015 * envelope) * Sin((M_PI * 1.8) * time);
    } else if (move == Move::kSidestepLeft || move == Move::kSidestepRight) {
      bob = (0.01 * envelope) * Sin((2 * M_PI * 1.4) * time);
    } else if (move == Move::kTurnLeft || move == Move::kTurnRight) {
      bob = (0.005 * envelope) * Sin((2 * M_PI * 1.5) * time);
    }
    const Jet c = Cos(heading), s = Sin(heading);
    const Jet px = x + kLeverM * c + surge * c + (-1.0) * sway * s;
    const Jet py = y + kLeverM * s + surge * s + sway * c;
    const Jet pz = bob + kHeightM;
    BodyState state;
    state.position = {px.v, py.v, pz.v};
    state.velocity = {px.d, py.d, pz.d};
    state.acceleration = {px.dd, py.dd, pz.dd};
    const double pitch = Radians(kPitchDeg + 1.5 * envelope.v * std::sin(2 * M_PI * 1.8 * t));
    const double roll = Radians(2.0 * envelope.v * std::sin(M_PI * 1.8 * t + 0.7));
    state.world_from_cam = (Eigen::AngleAxisd(heading.v, Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                               .toRotationMatrix() *
                           BodyFromCam();
    return state;
  }

 private:
  struct Start {
    double t, x, y, heading;
  };

  // The wearer's axis (x, y), heading and gait envelope (0..1) at time u into leg i.
  void Evaluate(size_t i, const Jet& u, Jet* x, Jet* y, Jet* heading, Jet* envelope) const {
    const Leg& leg = legs_[i];
    const Start& start = starts_[i];
    *x = {start.x, 0, 0};
    *y = {start.y, 0, 0};
    *heading = {start.heading, 0, 0};
    *envelope = {};
    const double period = leg.seconds;
    if (leg.move == Move::kTurnLeft || leg.move == Move::kTurnRight) {
      // Cycloidal: turning rate and its derivative are zero at both ends.
      const double turn = Radians(leg.move == Move::kTurnLeft ? leg.amount : -leg.amount);
      const Jet phase = (2.0 * M_PI / period) * u;
      *heading = (turn / period) * u + (-turn / (2.0 * M_PI)) * Sin(phase) + start.heading;
      *envelope = 0.5 * ((-1.0) * Cos(phase) + 1.0);
      return;
    }
    if (leg.move == Move::kStill) return;
    // Speed ramps up and down over `ramp` seconds (raised cosines); `distance` is its
    // integral, in units of the full speed.
    const double ramp = std::min(0.6, period / 3.0);
    const double k = M_PI / ramp;
    const auto rise = [&](const Jet& w) { return 0.5 * ((-1.0) * Cos(k * w) + 1.0); };
    const auto rise_integral = [&](const Jet& w) { return 0.5 * w + (-0.5 / k) * Sin(k * w); };
    Jet distance;
    if (u.v < ramp) {
      *envelope = rise(u);
      distance = rise_integral(u);
    } else if (u.v <= period - ramp) {
      *envelope = {1.0, 0.0, 0.0};
      distance = u + (-0.5 * ramp);
    } else {
      const Jet rest = (-1.0) * u + period;
      *envelope = rise(rest);
      distance = (-1.0) * rise_integral(rest) + (period - ramp);
    }
    // Along the heading, or across it (left is +90 degrees).
    const double side = leg.move == Move::kForward        ? 0.0
                        : leg.move == Move::kSidestepLeft ? 0.5 * M_PI
                                                          : -0.5 * M_PI;
    const double dx = std::cos(start.heading + side), dy = std::sin(start.heading + side);
    *x = (leg.amount * dx) * distance + start.x;
    *y = (leg.amount * dy) * distance + start.y;
  }

  std::vector<Leg> legs_;
  std::vector<Start> starts_;
  double seconds_ = 0.0;
};

// Stops, walks, sidesteps both ways and turns on the spot both ways, 41 s.
ScriptedWalk MixedWalk() {
  return ScriptedWalk({{Move::kStill, 2.0},
                       {Move::kForward, 4.0, 1.0},
                       {Move::kStill, 1.5},
                       {Move::kSidestepRight, 3.0, 0.5},
                       {Move::kStill, 1.5},
                       {Move::kTurnLeft, 2.5, 90.0},
                       {Move::kStill, 1.5},
                       {Move::kForward, 3.0, 1.2},
                       {Move::kStill, 1.0},
                       {Move::kTurnRight, 3.0, 180.0},
                       {Move::kStill, 1.5},
                       {Move::kSidestepLeft, 3.0, 0.6},
                       {Move::kStill, 1.0},
                       {Move::kTurnLeft, 2.0, 60.0},
                       {Move::kForward, 4.0, 0.9},
                       {Move::kStill, 1.5},
                       {Move::kSidestepLeft, 2.5, 0.4},
                       {Move::kStill, 2.0}});
}

// Frames at 30 fps and readings with the simulator's accelerometer errors (its defaults:
// 400 Hz, noise, bias, misalignment, +-3 g, 16 bits), as docs/simulator.md describes them.
Walk Record(const ScriptedWalk& script, uint32_t seed) {
  const AccelerometerOptions options;
  Walk walk;
  walk.calibration.cam_from_accel = CamFromAccel(options);
  const int64_t start_ns = 1'000'000'000;
  for (int i = 0; i / 30.0 < script.seconds(); ++i) {
    const int64_t t_ns = start_ns + std::llround(i * 1e9 / 30.0);
    const BodyState state = script.At(i / 30.0);
    walk.frames.push_back({t_ns, state.world_from_cam, state.position});
  }
  cv::RNG rng(seed);
  const double sigma = options.noise_density * std::sqrt(options.rate_hz);
  const double range = options.range_g * kGravity;
  const double lsb = 2.0 * range / std::ldexp(1.0, options.bits);
  const double max_code = std::ldexp(1.0, options.bits - 1) - 1.0;
  for (int k = 0;; ++k) {
    const double t = -kAccelMarginS + k / options.rate_hz;
    if (t > script.seconds() + kAccelMarginS) break;
    Eigen::Vector3d f =
        TrueSpecificForce(script.At(t), walk.calibration.cam_from_accel) + options.bias;
    for (int axis = 0; axis < 3; ++axis) {
      const double value = std::clamp(f[axis] + rng.gaussian(sigma), -range, range);
      f[axis] = std::clamp(std::round(value / lsb), -max_code - 1.0, max_code) * lsb;
    }
    walk.samples.push_back({start_ns + std::llround(t * 1e9), f});
  }
  return walk;
}

// ---------------------------------------------------------------------------------------
// Truth and vision from the poses.

struct LabelThresholds {
  double still_speed_m_s = 0.03;
  double still_rate_deg_s = 3.0;
  double rotate_rate_deg_s = 20.0;
  double rotate_radius_m = 0.3;  // A turn moves the camera at most rate x this.
  double move_speed_m_s = 0.2;
  double axis_angle_deg =
      30.0;  // Forward within this of the optical axis, sidestep beyond 90 - it.
};

// The true kind of motion between two frames, from the translation direction in the
// camera frame against the rotation rate; kUnknown where it is in between (unlabelled).
MotionClass TruthLabel(const TruthFrame& a, const TruthFrame& b) {
  const LabelThresholds limits;
  const double dt = 1e-9 * static_cast<double>(b.t_ns - a.t_ns);
  const Eigen::Vector3d translation = a.world_from_cam.transpose() * (b.position - a.position);
  const double speed = translation.norm() / dt;
  const double rate =
      Degrees(Eigen::AngleAxisd(a.world_from_cam.transpose() * b.world_from_cam).angle()) / dt;
  if (speed < limits.still_speed_m_s && rate < limits.still_rate_deg_s) return MotionClass::kStill;
  if (rate > limits.rotate_rate_deg_s && speed < limits.rotate_radius_m * Radians(rate)) {
    return MotionClass::kRotate;
  }
  if (speed < limits.move_speed_m_s || speed < limits.rotate_radius_m * Radians(rate)) {
    return MotionClass::kUnknown;
  }
  const Eigen::Vector3d down = a.world_from_cam.transpose() * Eigen::Vector3d(0, 0, -1);
  const Eigen::Vector3d horizontal = translation - translation.dot(down) * down;
  const Eigen::Vector3d axis = Eigen::Vector3d::UnitZ() - down.z() * down;
  const double angle = Degrees(
      std::acos(std::min(1.0, std::abs(horizontal.dot(axis)) / (horizontal.norm() * axis.norm()))));
  if (angle < limits.axis_angle_deg) return MotionClass::kForward;
  if (angle > 90.0 - limits.axis_angle_deg) return MotionClass::kSidestep;
  return MotionClass::kUnknown;
}

// What vision would measure between two frames: the rotation with 0.03 deg of noise per
// axis, the translation direction with about 2 deg of noise (none without parallax).
VisualMotion VisionFromTruth(const TruthFrame& a, const TruthFrame& b, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  const auto noise = [&](double sigma) {
    Eigen::Vector3d draw;
    for (int axis = 0; axis < 3; ++axis) draw[axis] = sigma * normal(*rng);
    return draw;
  };
  VisualMotion visual;
  const Eigen::Vector3d turn = noise(Radians(0.03));
  visual.cam1_from_cam0 = Eigen::Quaterniond(Eigen::AngleAxisd(turn.norm(), turn.normalized())) *
                          Eigen::Quaterniond(b.world_from_cam.transpose() * a.world_from_cam);
  const Eigen::Vector3d translation = a.world_from_cam.transpose() * (b.position - a.position);
  if (translation.norm() > 1e-4) {
    visual.translation_direction = (translation.normalized() + noise(Radians(2.0))).normalized();
  }
  return visual;
}

std::vector<VisualPose> VisionPoses(const Walk& walk, double metres_per_unit, uint32_t seed);

// Runs the stage over the walk, readings arriving `lookahead` ahead of the frames. With
// `poses`, the scale of the newest 2 s is estimated every half second (and the bias learned).
std::vector<InertialSnapshot> RunStage(const Walk& walk, bool with_vision,
                                       const InertialOptions& options = {},
                                       const std::vector<VisualPose>* poses = nullptr,
                                       AccelCalibration* learned = nullptr) {
  InertialStage stage(walk.calibration, options);
  const auto lookahead = static_cast<int64_t>(0.5e9 * options.quasi_static.window_s) + 10'000'000;
  std::mt19937 rng(5);
  std::vector<InertialSnapshot> snapshots;
  size_t fed = 0;
  for (size_t i = 0; i < walk.frames.size(); ++i) {
    size_t end = fed;
    while (end < walk.samples.size() && walk.samples[end].t_ns <= walk.frames[i].t_ns + lookahead) {
      ++end;
    }
    stage.AddSamples(std::span(walk.samples).subspan(fed, end - fed));
    fed = end;
    std::optional<VisualMotion> visual;
    if (with_vision && i > 0) visual = VisionFromTruth(walk.frames[i - 1], walk.frames[i], &rng);
    snapshots.push_back(stage.Process(walk.frames[i].t_ns, visual));
    if (poses && i >= 60 && i % 15 == 0) {
      stage.EstimateScale(std::span(*poses).subspan(i - 60, 61));
    }
  }
  if (learned) *learned = stage.effective_calibration();
  return snapshots;
}

// Gravity errors of snapshots against the truth, degrees.
struct TiltErrors {
  int frames = 0;
  double worst_deg = 0.0;  // Angle between estimated and true gravity.
  double mean_deg = 0.0;
  double worst_roll_deg = 0.0;
  double worst_pitch_deg = 0.0;
};

// Only frames whose every interval within `rest_frames` is truly still count when
// `labels` are given.
TiltErrors MeasureTilt(const Walk& walk, const std::vector<InertialSnapshot>& snapshots,
                       GravitySource source, const std::vector<MotionClass>* labels = nullptr,
                       int rest_frames = 6) {
  TiltErrors errors;
  const auto truly_at_rest = [&](size_t i) {
    for (int j = int(i) - rest_frames; j <= int(i) + rest_frames; ++j) {
      if (j < 1 || j >= int(labels->size()) || (*labels)[j] != MotionClass::kStill) return false;
    }
    return true;
  };
  for (size_t i = 0; i < snapshots.size(); ++i) {
    if (snapshots[i].gravity_source != source) continue;
    if (labels && !truly_at_rest(i)) continue;
    const Eigen::Vector3d truth = walk.frames[i].world_from_cam.transpose() * kGravityWorld;
    const Tilt true_tilt = TiltFromGravity(truth);
    const double error = AngleBetween(*snapshots[i].gravity_cam, truth);
    ++errors.frames;
    errors.mean_deg += error;
    errors.worst_deg = std::max(errors.worst_deg, error);
    errors.worst_roll_deg = std::max(
        errors.worst_roll_deg, std::abs(Degrees(snapshots[i].tilt->roll_rad - true_tilt.roll_rad)));
    errors.worst_pitch_deg =
        std::max(errors.worst_pitch_deg,
                 std::abs(Degrees(snapshots[i].tilt->pitch_rad - true_tilt.pitch_rad)));
  }
  if (errors.frames > 0) errors.mean_deg /= errors.frames;
  return errors;
}

// Classification against the truth labels of every labelled interval.
struct Confusion {
  std::map<std::pair<MotionClass, MotionClass>, int> counts;  // (truth, estimate).
  int labelled = 0;
  int correct = 0;

  double accuracy() const { return labelled > 0 ? double(correct) / labelled : 0.0; }
  int Count(MotionClass truth) const {
    int total = 0;
    for (const auto& [key, count] : counts) total += key.first == truth ? count : 0;
    return total;
  }
  int Correct(MotionClass truth) const {
    const auto it = counts.find({truth, truth});
    return it == counts.end() ? 0 : it->second;
  }
  void Print(const char* name) const {
    std::printf("%s: %d/%d labelled intervals right (%.1f%%)\n", name, correct, labelled,
                100.0 * accuracy());
    for (MotionClass truth : {MotionClass::kStill, MotionClass::kForward, MotionClass::kSidestep,
                              MotionClass::kRotate}) {
      if (Count(truth) == 0) continue;
      std::printf("  %-8s %4d/%4d  as:", MotionClassName(truth), Correct(truth), Count(truth));
      for (const auto& [key, count] : counts) {
        if (key.first == truth) std::printf(" %s %d", MotionClassName(key.second), count);
      }
      std::printf("\n");
    }
  }
};

std::vector<MotionClass> TruthLabels(const Walk& walk) {
  std::vector<MotionClass> labels(walk.frames.size(), MotionClass::kUnknown);
  for (size_t i = 1; i < walk.frames.size(); ++i) {
    labels[i] = TruthLabel(walk.frames[i - 1], walk.frames[i]);
  }
  return labels;
}

Confusion Score(const std::vector<MotionClass>& labels,
                const std::vector<InertialSnapshot>& snapshots, bool skip_rotations = false) {
  Confusion confusion;
  for (size_t i = 1; i < snapshots.size(); ++i) {
    if (labels[i] == MotionClass::kUnknown) continue;
    if (skip_rotations && labels[i] == MotionClass::kRotate) continue;
    ++confusion.labelled;
    ++confusion.counts[{labels[i], snapshots[i].motion}];
    if (labels[i] == snapshots[i].motion) ++confusion.correct;
  }
  return confusion;
}

// ---------------------------------------------------------------------------------------
// Plots, when AUTOCAL_INERTIAL_PLOT_DIR is set.

const char* PlotDir() { return std::getenv("AUTOCAL_INERTIAL_PLOT_DIR"); }

cv::Scalar ClassColour(MotionClass motion) {
  switch (motion) {
    case MotionClass::kStill:
      return {160, 160, 160};
    case MotionClass::kForward:
      return {60, 160, 60};
    case MotionClass::kSidestep:
      return {200, 120, 40};
    case MotionClass::kRotate:
      return {40, 60, 220};
    case MotionClass::kUnknown:
      break;
  }
  return {255, 255, 255};
}

// Truth and estimated classes as two colour bands, and the tilt error at rest below.
void PlotClasses(const std::string& name, const Walk& walk, const std::vector<MotionClass>& labels,
                 const std::vector<InertialSnapshot>& snapshots) {
  if (!PlotDir()) return;
  const std::string base = std::string(PlotDir()) + "/" + name;
  std::ofstream csv(base + ".csv");
  csv << "t_s,truth,estimate,gravity_source,tilt_error_deg,roll_deg,pitch_deg,true_roll_deg,"
         "true_pitch_deg,skipped\n";
  const int width = 1400, band = 40;
  cv::Mat image(260, width, CV_8UC3, cv::Scalar(255, 255, 255));
  const double seconds = 1e-9 * static_cast<double>(walk.frames.back().t_ns - walk.frames[0].t_ns);
  const auto x_of = [&](size_t i) {
    return int(40 +
               (width - 60) * 1e-9 * double(walk.frames[i].t_ns - walk.frames[0].t_ns) / seconds);
  };
  for (size_t i = 1; i < snapshots.size(); ++i) {
    const int x0 = x_of(i - 1), x1 = std::max(x_of(i), x0 + 1);
    cv::rectangle(image, {x0, 20}, {x1, 20 + band}, ClassColour(labels[i]), cv::FILLED);
    cv::rectangle(image, {x0, 70}, {x1, 70 + band}, ClassColour(snapshots[i].motion), cv::FILLED);
    const Eigen::Vector3d truth = walk.frames[i].world_from_cam.transpose() * kGravityWorld;
    const Tilt true_tilt = TiltFromGravity(truth);
    double error = -1.0;
    if (snapshots[i].gravity_cam) {
      error = AngleBetween(*snapshots[i].gravity_cam, truth);
      const int y = 250 - int(std::min(error, 1.0) * 120);  // 1 deg = 120 px.
      cv::circle(image, {x_of(i), y}, 1,
                 snapshots[i].gravity_source == GravitySource::kMeasured ? cv::Scalar(0, 0, 0)
                                                                         : cv::Scalar(0, 140, 255),
                 cv::FILLED);
    }
    csv << 1e-9 * double(walk.frames[i].t_ns - walk.frames[0].t_ns) << ','
        << MotionClassName(labels[i]) << ',' << MotionClassName(snapshots[i].motion) << ','
        << int(snapshots[i].gravity_source) << ',' << error << ','
        << (snapshots[i].tilt ? Degrees(snapshots[i].tilt->roll_rad) : 0.0) << ','
        << (snapshots[i].tilt ? Degrees(snapshots[i].tilt->pitch_rad) : 0.0) << ','
        << Degrees(true_tilt.roll_rad) << ',' << Degrees(true_tilt.pitch_rad) << ','
        << snapshots[i].skipped() << '\n';
  }
  cv::line(image, {40, 250 - 60}, {width - 20, 250 - 60}, {0, 0, 200});  // 0.5 deg.
  cv::putText(image, "truth", {2, 45}, cv::FONT_HERSHEY_PLAIN, 0.8, {0, 0, 0});
  cv::putText(image, "box 7", {2, 95}, cv::FONT_HERSHEY_PLAIN, 0.8, {0, 0, 0});
  cv::putText(image, "tilt error (0..1 deg, red: 0.5), black measured, orange propagated",
              {40, 140}, cv::FONT_HERSHEY_PLAIN, 1.0, {0, 0, 0});
  cv::putText(image, "grey still, green forward, blue sidestep, red rotate, white unknown",
              {40, 14}, cv::FONT_HERSHEY_PLAIN, 1.0, {0, 0, 0});
  cv::imwrite(base + ".png", image);
}

// ---------------------------------------------------------------------------------------

TEST(InertialSimulated, TiltAtRestWithinHalfADegree) {
  const Walk walk = SimulatedWalk("static");
  const std::vector<InertialSnapshot> snapshots = RunStage(walk, false);
  const TiltErrors errors = MeasureTilt(walk, snapshots, GravitySource::kMeasured);
  std::printf(
      "static: gravity measured in %d/%zu frames, error mean %.3f deg, worst %.3f deg "
      "(roll %.3f, pitch %.3f)\n",
      errors.frames, snapshots.size(), errors.mean_deg, errors.worst_deg, errors.worst_roll_deg,
      errors.worst_pitch_deg);
  EXPECT_GE(errors.frames, int(snapshots.size()) - 6) << "at rest from 0.2 s on";
  EXPECT_LT(errors.worst_deg, 0.5);
  for (const InertialSnapshot& snapshot : snapshots) {
    ASSERT_EQ(snapshot.motion, MotionClass::kStill);
    if (snapshot.gravity_cam) {
      EXPECT_GT(snapshot.gravity_sigma_deg, errors.worst_deg) << "the sigma covers the bias";
    }
  }

  // The error is the accelerometer's bias across gravity; known, it goes.
  Walk calibrated = walk;
  calibrated.calibration.bias = AccelerometerOptions().bias;
  const TiltErrors known_bias =
      MeasureTilt(calibrated, RunStage(calibrated, false), GravitySource::kMeasured);
  std::printf("static, bias known: error mean %.3f deg, worst %.3f deg\n", known_bias.mean_deg,
              known_bias.worst_deg);
  EXPECT_LT(known_bias.worst_deg, 0.05);
}

TEST(InertialSimulated, MixedWalkTiltAtStillMoments) {
  const Walk walk = Record(MixedWalk(), 11);
  const std::vector<MotionClass> labels = TruthLabels(walk);
  // The accelerometer alone cannot see the camera turn or roll gently: at the edges of the
  // turns on the spot it takes those moments for rest.
  const std::vector<InertialSnapshot> alone = RunStage(walk, false);
  const TiltErrors alone_at_rest = MeasureTilt(walk, alone, GravitySource::kMeasured, &labels);
  const TiltErrors alone_all = MeasureTilt(walk, alone, GravitySource::kMeasured);
  std::printf(
      "mixed walk, accelerometer alone: gravity measured in %d frames truly at rest "
      "(mean %.3f, worst %.3f deg), in %d in all (mean %.3f, worst %.3f deg)\n",
      alone_at_rest.frames, alone_at_rest.mean_deg, alone_at_rest.worst_deg, alone_all.frames,
      alone_all.mean_deg, alone_all.worst_deg);
  EXPECT_LT(alone_at_rest.worst_deg, 0.6);

  // Vision's rotations: the accelerometer's bias sets the floor of the error.
  const std::vector<InertialSnapshot> unlearned = RunStage(walk, true);
  const TiltErrors floor = MeasureTilt(walk, unlearned, GravitySource::kMeasured, &labels);
  std::printf(
      "mixed walk, bias not learned: gravity measured in %d frames truly at rest, error "
      "mean %.3f, worst %.3f deg\n",
      floor.frames, floor.mean_deg, floor.worst_deg);
  EXPECT_LT(floor.worst_deg, 0.55);

  // Vision's poses too: scale windows learn the bias.
  const std::vector<VisualPose> poses = VisionPoses(walk, 0.37, 23);
  AccelCalibration learned;
  const std::vector<InertialSnapshot> snapshots =
      RunStage(walk, true, InertialOptions(), &poses, &learned);
  const Eigen::Vector3d bias_error = learned.bias - AccelerometerOptions().bias;
  // Truly at rest: still for 0.2 s either side, as far as the windows reach.
  const TiltErrors at_rest = MeasureTilt(walk, snapshots, GravitySource::kMeasured, &labels);
  const TiltErrors measured = MeasureTilt(walk, snapshots, GravitySource::kMeasured);
  const TiltErrors propagated = MeasureTilt(walk, snapshots, GravitySource::kPropagated);
  std::printf(
      "mixed walk, bias learned (error at the end %.4f m/s^2): gravity measured in %d "
      "frames truly at rest (mean %.3f, worst %.3f deg; roll %.3f, pitch %.3f), in %d "
      "frames in all (worst %.3f deg), carried by vision in %d (mean %.3f, worst %.3f "
      "deg)\n",
      bias_error.norm(), at_rest.frames, at_rest.mean_deg, at_rest.worst_deg,
      at_rest.worst_roll_deg, at_rest.worst_pitch_deg, measured.frames, measured.worst_deg,
      propagated.frames, propagated.mean_deg, propagated.worst_deg);
  PlotClasses("mixed_walk_learned", walk, labels, snapshots);
  EXPECT_LT(bias_error.norm(), 0.02);
  EXPECT_GT(at_rest.frames, 250);
  EXPECT_LT(at_rest.worst_deg, 0.5);
  // At the edges of a rest, motion too gentle for any threshold (a turn starting) adds a
  // little; vision's rotation noise makes carried gravity wander.
  EXPECT_LT(measured.worst_deg, 0.6);
  EXPECT_LT(propagated.worst_deg, 1.5);
}

TEST(InertialSimulated, MixedWalkMotionClasses) {
  const Walk walk = Record(MixedWalk(), 11);
  const std::vector<MotionClass> labels = TruthLabels(walk);
  const std::vector<InertialSnapshot> with_vision = RunStage(walk, true);
  const Confusion vision = Score(labels, with_vision);
  vision.Print("mixed walk, accelerometer and vision");
  PlotClasses("mixed_walk_vision", walk, labels, with_vision);
  EXPECT_GE(vision.accuracy(), 0.9);
  for (MotionClass motion :
       {MotionClass::kStill, MotionClass::kForward, MotionClass::kSidestep, MotionClass::kRotate}) {
    EXPECT_GT(vision.Count(motion), 60) << MotionClassName(motion);
    EXPECT_GE(vision.Correct(motion), 0.8 * vision.Count(motion)) << MotionClassName(motion);
  }

  // The accelerometer alone: velocity integrated from each stop tells forward from
  // sidestep; a turn about the wearer's axis is all but invisible to it.
  const std::vector<InertialSnapshot> alone = RunStage(walk, false);
  const Confusion translations = Score(labels, alone, true);
  translations.Print("mixed walk, accelerometer alone, turns left out");
  PlotClasses("mixed_walk_accel", walk, labels, alone);
  EXPECT_GE(translations.accuracy(), 0.9);
  EXPECT_EQ(Score(labels, alone).Correct(MotionClass::kRotate), 0);
}

TEST(InertialSimulated, OfficeWalkIsForward) {
  const Walk walk = SimulatedWalk("office,seconds=20");
  const std::vector<MotionClass> labels = TruthLabels(walk);
  const std::vector<InertialSnapshot> snapshots = RunStage(walk, true);
  const Confusion confusion = Score(labels, snapshots);
  confusion.Print("office walk, accelerometer and vision");
  EXPECT_GT(confusion.labelled, 500);
  EXPECT_GE(confusion.accuracy(), 0.9);
  // Never still, and gravity never measured while walking.
  for (const InertialSnapshot& snapshot : snapshots) {
    EXPECT_FALSE(snapshot.quasi_static);
    EXPECT_NE(snapshot.gravity_source, GravitySource::kMeasured);
  }
}

// Vision's trajectory: the true poses in a world frame of vision's own (turned, moved) and
// units of `metres_per_unit`, positions with noise of 1% of the mean step between frames
// and orientations with 0.05 deg per axis.
std::vector<VisualPose> VisionPoses(const Walk& walk, double metres_per_unit, uint32_t seed) {
  const Eigen::Matrix3d vision_from_world =
      Eigen::AngleAxisd(2.0, Eigen::Vector3d(0.2, -0.7, 0.4).normalized()).toRotationMatrix();
  const Eigen::Vector3d offset(3.0, -1.0, 0.5);
  double path = 0.0;
  for (size_t i = 1; i < walk.frames.size(); ++i) {
    path += (walk.frames[i].position - walk.frames[i - 1].position).norm();
  }
  const double step_units = path / double(walk.frames.size() - 1) / metres_per_unit;
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<VisualPose> poses;
  for (const TruthFrame& frame : walk.frames) {
    Eigen::Vector3d position_noise, turn;
    for (int axis = 0; axis < 3; ++axis) {
      position_noise[axis] = 0.01 * step_units * normal(rng);
      turn[axis] = Radians(0.05) * normal(rng);
    }
    VisualPose pose;
    pose.t_ns = frame.t_ns;
    pose.world_from_cam = Eigen::Quaterniond(vision_from_world * frame.world_from_cam *
                                             Eigen::AngleAxisd(turn.norm(), turn.normalized()));
    pose.position =
        (vision_from_world * frame.position + offset) / metres_per_unit + position_noise;
    poses.push_back(pose);
  }
  return poses;
}

struct ScaleErrors {
  int windows = 0;
  int usable = 0;
  std::vector<double> errors;  // Relative, of the usable windows.
  double worst = 0.0;
  double median = 0.0;
};

// Scale over every 2-second window (61 frames) starting every half second.
ScaleErrors MeasureScale(const Walk& walk, const std::vector<VisualPose>& poses,
                         double metres_per_unit, const ScaleOptions& options,
                         const std::string& plot_name = "") {
  ScaleErrors result;
  std::ofstream csv;
  if (PlotDir() && !plot_name.empty()) {
    csv.open(std::string(PlotDir()) + "/" + plot_name + ".csv");
    csv << "t_s,scale,sigma,truth,usable\n";
  }
  // Relative error (+-5% full height) and its sigma for each window.
  cv::Mat plot(300, 760, CV_8UC3, cv::Scalar(255, 255, 255));
  const auto y_of = [](double relative) { return int(150 - relative * 2800); };
  for (double level : {-0.05, 0.0, 0.05}) {
    cv::line(plot, {20, y_of(level)}, {740, y_of(level)},
             level == 0 ? cv::Scalar(0, 0, 0) : cv::Scalar(0, 0, 200));
  }
  for (size_t first = 0; first + 61 <= poses.size(); first += 15) {
    const std::span<const VisualPose> window(poses.data() + first, 61);
    const ScaleEstimate estimate =
        EstimateMetricScale(walk.samples, walk.calibration, window, {}, options);
    ++result.windows;
    if (csv.is_open()) {
      csv << 1e-9 * double(window.front().t_ns - poses[0].t_ns) << ',' << estimate.scale << ','
          << estimate.scale_sigma << ',' << metres_per_unit << ',' << estimate.usable << '\n';
      const int x = int(20 + 720 * first / double(poses.size()));
      const double error = estimate.scale / metres_per_unit - 1.0;
      const double sigma = estimate.scale_sigma / metres_per_unit;
      const cv::Scalar colour = estimate.usable ? cv::Scalar(120, 60, 0) : cv::Scalar(0, 140, 255);
      cv::line(plot, {x, y_of(error - sigma)}, {x, y_of(error + sigma)}, colour);
      cv::circle(plot, {x, y_of(error)}, 3, colour, cv::FILLED);
    }
    if (!estimate.usable) continue;
    ++result.usable;
    result.errors.push_back(std::abs(estimate.scale / metres_per_unit - 1.0));
  }
  if (csv.is_open()) {
    cv::putText(plot, plot_name + ": scale error of each 2 s window, +-1 sigma (red: +-5%)",
                {20, 20}, cv::FONT_HERSHEY_PLAIN, 1.0, {0, 0, 0});
    cv::imwrite(std::string(PlotDir()) + "/" + plot_name + ".png", plot);
  }
  if (!result.errors.empty()) {
    std::vector<double> sorted = result.errors;
    std::sort(sorted.begin(), sorted.end());
    result.worst = sorted.back();
    result.median = sorted[sorted.size() / 2];
  }
  return result;
}

TEST(InertialSimulated, ScaleWithinFivePercentOverTwoSecondWindows) {
  const double metres_per_unit = 0.37;
  for (const char* spec : {"office,seconds=20", "corridor,seconds=20", "outdoor,seconds=20"}) {
    const Walk walk = SimulatedWalk(spec);
    const std::vector<VisualPose> poses = VisionPoses(walk, metres_per_unit, 17);
    const ScaleErrors errors =
        MeasureScale(walk, poses, metres_per_unit, {},
                     "scale_" + std::string(spec).substr(0, std::string(spec).find(',')));
    std::printf("%s: %d/%d windows usable, scale error median %.2f%%, worst %.2f%%\n", spec,
                errors.usable, errors.windows, 100 * errors.median, 100 * errors.worst);
    EXPECT_EQ(errors.usable, errors.windows) << spec;
    EXPECT_LT(errors.worst, 0.05) << spec;
  }
}

// Faults in the office walk's own readings: the intervals they touch are skipped with the
// reason, every other interval is integrated exactly as without them.
TEST(InertialSimulated, FaultyReadingsAreSkippedNotIntegrated) {
  const Walk clean = SimulatedWalk("office,seconds=6");
  const std::vector<InertialSnapshot> reference = RunStage(clean, true);
  // The first reading after `offset_ns` past a frame: the faults go inside the intervals
  // ending at frames 60, 90, 120 and 150.
  const auto reading_at = [&](size_t frame, int64_t offset_ns) {
    return size_t(
        std::upper_bound(
            clean.samples.begin(), clean.samples.end(), clean.frames[frame].t_ns + offset_ns,
            [](int64_t t, const SpecificForceSample& sample) { return t < sample.t_ns; }) -
        clean.samples.begin());
  };
  Walk damaged = clean;
  damaged.samples[reading_at(60, -15'000'000)].specific_force.y() =
      std::numeric_limits<double>::quiet_NaN();
  const size_t swapped = reading_at(90, -15'000'000);
  std::swap(damaged.samples[swapped], damaged.samples[swapped + 1]);
  damaged.samples[reading_at(120, -15'000'000)].specific_force.x() = 3.0 * kGravity;
  // 9 readings lost just after frame 149: 25 ms between the readings either side.
  const size_t kept = reading_at(149, 0);
  damaged.samples.erase(damaged.samples.begin() + kept + 1, damaged.samples.begin() + kept + 10);
  const std::vector<InertialSnapshot> snapshots = RunStage(damaged, true);
  const std::map<size_t, std::string> expected = {{60, "1 reading not finite"},
                                                  {90, "1 reading out of time order"},
                                                  {120, "1 reading saturated"},
                                                  {150, "a gap of 0.025 s"}};
  for (size_t i = 1; i < snapshots.size(); ++i) {
    const auto it = expected.find(i);
    if (it != expected.end()) {
      EXPECT_TRUE(snapshots[i].skipped()) << i;
      EXPECT_EQ(snapshots[i].skip_reason(), it->second) << i;
      EXPECT_EQ(snapshots[i].motion, MotionClass::kUnknown) << i;
      continue;
    }
    ASSERT_FALSE(snapshots[i].skipped()) << i << ": " << snapshots[i].skip_reason();
    EXPECT_EQ(snapshots[i].interval->delta_velocity, reference[i].interval->delta_velocity) << i;
    EXPECT_EQ(snapshots[i].interval->delta_position, reference[i].interval->delta_position) << i;
  }
  // A scale window over a fault is refused, saying why.
  const std::vector<VisualPose> poses = VisionPoses(damaged, 0.37, 3);
  const ScaleEstimate estimate = EstimateMetricScale(damaged.samples, damaged.calibration,
                                                     std::span(poses).subspan(100, 61), {}, {});
  EXPECT_FALSE(estimate.usable);
  EXPECT_EQ(estimate.message,
            "accelerometer faults in the window: 1 reading saturated, a gap of 0.025 s");
}

// A real saturation: the same walk read by an accelerometer with a range of 1.1 g, which the
// step bob exceeds on the vertical axis.
TEST(InertialSimulated, SaturatedReadingsOfANarrowRangeAreSkipped) {
  const double range = 1.1 * kGravity;
  const Walk wide = SimulatedWalk("office,seconds=6");
  const Walk narrow = SimulatedWalk("office,seconds=6,accel_range_g=1.1");
  InertialOptions options;
  options.screen.range_m_s2 = range;
  const std::vector<InertialSnapshot> snapshots = RunStage(narrow, true, options);
  // The same noise draws: beyond the range in the wide reading, clipped in the narrow one.
  const auto beyond = [&](size_t frame, double margin) {
    for (const SpecificForceSample& sample : wide.samples) {
      if (sample.t_ns < narrow.frames[frame - 1].t_ns - 3'000'000) continue;
      if (sample.t_ns > narrow.frames[frame].t_ns + 3'000'000) break;
      if (sample.specific_force.cwiseAbs().maxCoeff() > range + margin) return true;
    }
    return false;
  };
  int skipped = 0;
  for (size_t i = 1; i < snapshots.size(); ++i) {
    if (snapshots[i].skipped()) {
      ++skipped;
      EXPECT_NE(snapshots[i].skip_reason().find("saturated"), std::string::npos) << i;
      EXPECT_TRUE(beyond(i, -0.1)) << i << ": skipped without reaching the range";
    } else {
      EXPECT_FALSE(beyond(i, 0.1)) << i << ": beyond the range but integrated";
    }
  }
  std::printf("1.1 g range: %d of %zu intervals skipped as saturated\n", skipped,
              snapshots.size() - 1);
  EXPECT_GT(skipped, 20);
}

}  // namespace
}  // namespace autocal
