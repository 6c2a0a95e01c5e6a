// What a simulation is made of: scene, lens, motion, accelerometer, image effects and the
// events that disturb them (DESIGN.md section 5). Scenario files (resources/scenarios/*.yaml)
// are read into this struct; docs/simulator.md describes every field.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace autocal {

// A moment of the scenario: seconds after the first frame, or a fraction of the duration
// (written "50%" in files) so that it follows a changed `seconds`.
struct ScenarioTime {
  double value = 0.0;     // Seconds, or the fraction when `fraction` is set.
  bool fraction = false;  // value is a fraction of Scenario::seconds.

  double Seconds(double duration_s) const { return fraction ? value * duration_s : value; }
};

struct MotionOptions {
  std::string type = "walk";     // "walk" (a closed path through the scene) or "static".
  double speed_mps = 1.2;        // Mean walking speed along the path.
  double height_m = 1.4;         // Camera height above the floor while walking.
  double step_hz = 1.8;          // Step frequency; the bob runs at it, the sway at half.
  double bob_m = 0.025;          // Vertical step bob, peak to peak.
  double sway_m = 0.03;          // Lateral sway, peak to peak.
  double scan_deg = 15.0;        // Head yaw scanning amplitude around the heading.
  double scan_hz = 0.2;          // Head yaw scanning frequency.
  double pitch_deg = 10.0;       // Mean downward tilt of the camera.
  double pitch_swing_deg = 6.0;  // Pitch oscillation amplitude around the mean.
  double roll_deg = 3.0;         // Roll oscillation amplitude.
};

struct AccelerometerOptions {
  double rate_hz = 400.0;                   // Sample rate, at most 1600 Hz.
  double noise_density = 0.002;             // White noise, (m/s^2)/sqrt(Hz).
  Eigen::Vector3d bias{0.04, -0.06, 0.03};  // Constant bias per axis, m/s^2.
  double range_g = 3.0;                     // Readings saturate at +-range_g * 9.81 m/s^2.
  int bits = 16;                            // Quantization over the full range; 0: none.
  // Mounting error: rotation vector (degrees) applied after the nominal axes (x forward,
  // y left, z up when the camera looks forward).
  Eigen::Vector3d misalignment_deg{0.5, -1.0, 0.3};
};

struct ImageOptions {
  double noise_sigma = 1.5;   // Gaussian sensor noise, grey levels (0-255).
  double vignetting = 0.35;   // 0: none; 1: full cos^4 falloff of the ray angle.
  double chromatic_px = 0.5;  // Lateral colour: R moved out, B in, by this at the corner.
  int supersampling = 3;      // Sub-rays per side at plane boundaries; 1: none.
  // Rolling shutter: rows are read top to bottom, one every readout_ms / height, the middle
  // row at the frame's time (its ground-truth pose). 0: a global shutter.
  double readout_ms = 0.0;
  // Motion blur: each row gathers light over exposure_ms centred on its read time. 0: an
  // instant.
  double exposure_ms = 0.0;
};

// A change of the true intrinsics, ramping linearly from `start` to `end` (equal: a step)
// and staying afterwards. Events add up.
struct IntrinsicsEvent {
  ScenarioTime start;
  ScenarioTime end;
  double fx_scale = 1.0;  // Factor on fx reached at `end`.
  double fy_scale = 1.0;  // Factor on fy reached at `end`.
  double cx_px = 0.0;     // Principal point shift reached at `end`, pixels.
  double cy_px = 0.0;
};

// A transient image disturbance active in [start, end).
struct Disturbance {
  enum class Kind { kFog, kNoiseBurst };
  Kind kind = Kind::kFog;
  ScenarioTime start;
  ScenarioTime end;
  double blur_sigma_px = 2.5;  // Fog: Gaussian blur.
  double contrast = 0.5;       // Fog: contrast factor toward the fog's grey.
  double noise_sigma = 20.0;   // Noise burst: extra Gaussian noise, grey levels.
};

// The `checkerboard` test scene: one plane with a precise board.
struct CheckerboardOptions {
  int squares_x = 10;      // Squares along the board's first axis.
  int squares_y = 7;       // Squares along its second axis.
  double square_m = 0.04;  // Side of a square, metres.
};

inline constexpr int kMostPeople = 100;

struct Scenario {
  std::string name;              // "office", ...; file name for scenario files.
  std::string description;       // One line for humans.
  std::string scene = "office";  // office, corridor, outdoor or checkerboard.
  std::string lens = "tessar";   // LensNames(): tessar, sonnar, hologon, telephoto.
  int width = 640;               // Image size in pixels.
  int height = 480;
  double fps = 30.0;                 // Frame rate.
  double seconds = 20.0;             // Duration: frames cover [0, seconds).
  uint32_t seed = 1;                 // Seeds textures, noise and the accelerometer.
  int64_t start_ns = 1'000'000'000;  // Timestamp of the first frame.
  MotionOptions motion;
  AccelerometerOptions accelerometer;
  ImageOptions image;
  CheckerboardOptions checkerboard;
  std::vector<IntrinsicsEvent> intrinsics_events;
  std::vector<Disturbance> disturbances;
  // People walking across the camera's view, one after another over the duration (the
  // scene's only moving surfaces): a team around a vest, passers-by in front of a vehicle.
  int people = 0;
  // Strength of the fine texture (mottle, flecks, grain) on the indoor scenes' painted walls
  // and floors: 1 as drawn, 0 bare paint and plain tiles, as many real rooms are. Pictures,
  // doors, furniture, tile patterns and ceilings keep theirs; the outdoor and checkerboard
  // scenes are not changed.
  double surface_texture = 1.0;

  // Values that make sense; names the wrong field.
  bool Check(std::string* error) const;

  size_t frame_count() const;
  // start_ns + llround(index * 1e9 / fps).
  int64_t frame_time_ns(size_t index) const;
  // Seconds after the first frame.
  double SecondsAt(int64_t t_ns) const { return 1e-9 * static_cast<double>(t_ns - start_ns); }
};

}  // namespace autocal
