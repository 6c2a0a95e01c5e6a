#include "devices/sim/scenario.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "devices/sim/lens.h"
#include "devices/sim/scene.h"

namespace autocal {
namespace {

bool Contains(const std::vector<std::string>& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

std::string Join(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& name : names) out += (out.empty() ? "" : ", ") + name;
  return out;
}

std::string TimeText(const ScenarioTime& t) {
  std::ostringstream out;
  if (t.fraction) {
    out << t.value * 100.0 << "%";
  } else {
    out << t.value << " s";
  }
  return out.str();
}

}  // namespace

size_t Scenario::frame_count() const {
  const double frames = std::ceil(seconds * fps - 1e-9);
  return frames >= 1.0 ? static_cast<size_t>(frames) : 1;
}

int64_t Scenario::frame_time_ns(size_t index) const {
  return start_ns + std::llround(static_cast<double>(index) * 1e9 / fps);
}

bool Scenario::Check(std::string* error) const {
  std::ostringstream why;
  auto in = [](double value, double lo, double hi) { return value >= lo && value <= hi; };
  const AccelerometerOptions& a = accelerometer;
  const MotionOptions& m = motion;
  if (!Contains(SceneNames(), scene)) {
    why << "scene: unknown scene '" << scene << "', expected one of " << Join(SceneNames());
  } else if (!Contains(LensNames(), lens)) {
    why << "lens: unknown lens '" << lens << "', expected one of " << Join(LensNames());
  } else if (width < 32 || height < 32 || width > 8192 || height > 8192) {
    why << "resolution: width and height must be in [32, 8192], got " << width << "x" << height;
  } else if (!in(fps, 0.1, 1000.0)) {
    why << "fps: must be in [0.1, 1000], got " << fps;
  } else if (!in(seconds, 1e-3, 3600.0)) {
    why << "seconds: must be in (0, 3600], got " << seconds;
  } else if (m.type != "walk" && m.type != "static") {
    why << "motion.type: expected walk or static, got '" << m.type << "'";
  } else if (m.type == "walk" && scene == "checkerboard") {
    why << "motion.type: the checkerboard scene has no walking path, use static";
  } else if (!in(m.speed_mps, 0.05, 5.0)) {
    why << "motion.speed: must be in [0.05, 5] m/s, got " << m.speed_mps;
  } else if (!in(m.height_m, 0.2, 3.0)) {
    why << "motion.height: must be in [0.2, 3] m, got " << m.height_m;
  } else if (!in(m.step_hz, 0.0, 5.0) || !in(m.bob_m, 0.0, 0.2) || !in(m.sway_m, 0.0, 0.3)) {
    why << "motion: step_hz must be in [0, 5], bob in [0, 0.2] m, sway in [0, 0.3] m";
  } else if (!in(std::abs(m.scan_deg), 0.0, 90.0) || !in(m.scan_hz, 0.0, 5.0) ||
             !in(std::abs(m.pitch_deg), 0.0, 60.0) || !in(std::abs(m.pitch_swing_deg), 0.0, 30.0) ||
             !in(std::abs(m.roll_deg), 0.0, 30.0)) {
    why << "motion: angles out of range (scan <= 90 deg, pitch <= 60, pitch_swing <= 30, "
           "roll <= 30, scan_hz <= 5)";
  } else if (!(a.rate_hz > 0.0 && a.rate_hz <= 1600.0)) {
    why << "accelerometer.rate_hz: must be in (0, 1600] Hz, got " << a.rate_hz;
  } else if (!in(a.noise_density, 0.0, 1.0)) {
    why << "accelerometer.noise_density: must be in [0, 1] (m/s^2)/sqrt(Hz), got "
        << a.noise_density;
  } else if (!a.bias.allFinite() || a.bias.cwiseAbs().maxCoeff() > 5.0) {
    why << "accelerometer.bias: each axis must be within +-5 m/s^2";
  } else if (!in(a.range_g, 0.5, 64.0)) {
    why << "accelerometer.range_g: must be in [0.5, 64], got " << a.range_g;
  } else if (a.bits < 0 || a.bits > 32) {
    why << "accelerometer.bits: must be in [0, 32] (0: no quantization), got " << a.bits;
  } else if (!a.misalignment_deg.allFinite() || a.misalignment_deg.norm() > 10.0) {
    why << "accelerometer.misalignment_deg: must be at most 10 degrees";
  } else if (!in(image.noise_sigma, 0.0, 100.0)) {
    why << "image.noise_sigma: must be in [0, 100] grey levels, got " << image.noise_sigma;
  } else if (!in(image.vignetting, 0.0, 1.0)) {
    why << "image.vignetting: must be in [0, 1], got " << image.vignetting;
  } else if (!in(image.chromatic_px, -5.0, 5.0)) {
    why << "image.chromatic_px: must be in [-5, 5] pixels, got " << image.chromatic_px;
  } else if (image.supersampling < 1 || image.supersampling > 8) {
    why << "image.supersampling: must be in [1, 8], got " << image.supersampling;
  } else if (!in(image.readout_ms, 0.0, 1000.0 / fps)) {
    why << "image.readout_ms: must be in [0, " << 1000.0 / fps << "] (at most a frame period), got "
        << image.readout_ms;
  } else if (!in(image.exposure_ms, 0.0, 1000.0 / fps)) {
    why << "image.exposure_ms: must be in [0, " << 1000.0 / fps
        << "] (at most a frame period), got " << image.exposure_ms;
  } else if (checkerboard.squares_x < 3 || checkerboard.squares_y < 3 ||
             checkerboard.squares_x > 40 || checkerboard.squares_y > 40 ||
             !in(checkerboard.square_m, 0.005, 1.0)) {
    why << "checkerboard: squares must be in [3, 40] per side and square_m in [0.005, 1] m";
  } else if (people < 0 || people > kMostPeople) {
    why << "people: must be in [0, " << kMostPeople << "], got " << people;
  } else if (people > 0 && m.type != "walk") {
    why << "people: they cross the walking camera's view; motion.type must be walk";
  } else if (!in(surface_texture, 0.0, 1.0)) {
    why << "surface_texture: must be in [0, 1], got " << surface_texture;
  }
  for (size_t i = 0; why.str().empty() && i < intrinsics_events.size(); ++i) {
    const IntrinsicsEvent& e = intrinsics_events[i];
    const double start = e.start.Seconds(seconds), end = e.end.Seconds(seconds);
    if (!(start >= 0.0) || !(end >= start)) {
      why << "intrinsics_events[" << i << "]: needs 0 <= start <= end, got start "
          << TimeText(e.start) << ", end " << TimeText(e.end);
    } else if (!in(e.fx_scale, 0.5, 2.0) || !in(e.fy_scale, 0.5, 2.0)) {
      why << "intrinsics_events[" << i << "]: fx_scale and fy_scale must be in [0.5, 2]";
    } else if (!in(std::abs(e.cx_px), 0.0, 0.25 * width) ||
               !in(std::abs(e.cy_px), 0.0, 0.25 * height)) {
      why << "intrinsics_events[" << i << "]: cx_px, cy_px must be within a quarter image";
    }
  }
  for (size_t i = 0; why.str().empty() && i < disturbances.size(); ++i) {
    const Disturbance& d = disturbances[i];
    const double start = d.start.Seconds(seconds), end = d.end.Seconds(seconds);
    if (!(start >= 0.0) || !(end > start)) {
      why << "disturbances[" << i << "]: needs 0 <= start < end, got start " << TimeText(d.start)
          << ", end " << TimeText(d.end);
    } else if (!in(d.blur_sigma_px, 0.0, 50.0) || !in(d.contrast, 0.01, 1.0) ||
               !in(d.noise_sigma, 0.0, 128.0)) {
      why << "disturbances[" << i
          << "]: blur_sigma_px must be in [0, 50], contrast in [0.01, 1], noise_sigma in [0, 128]";
    }
  }
  if (why.str().empty()) return true;
  if (error) *error = why.str();
  return false;
}

}  // namespace autocal
