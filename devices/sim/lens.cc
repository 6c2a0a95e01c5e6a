#include "devices/sim/lens.h"

#include <algorithm>
#include <cmath>

#include "pipeline/error.h"

namespace autocal {
namespace {

struct LensSpec {
  const char* name;
  double horizontal_fov_deg;
  double k1, k2;
};

// tessar: nearly distortion free (under 0.25 px at 640x480). sonnar: strong barrel, still
// monotonic over the whole image (1 + 3 k1 r^2 + 5 k2 r^4 > 0 for every r), so every
// pixel has exactly one ray. hologon: an ultra-wide angle, its barrel monotonic too
// (1 - 1.05 r^2 + 0.6 r^4 > 0). telephoto: narrow, with pincushion distortion.
constexpr LensSpec kLenses[] = {
    {"tessar", 75.0, -0.0006, 0.0},
    {"sonnar", 85.0, -0.3, 0.1},
    {"hologon", 110.0, -0.35, 0.12},
    {"telephoto", 55.0, 0.08, 0.0},
};

// Reference width the pixel offsets of the principal point are given for.
constexpr double kReferenceWidth = 640.0;
constexpr double kCxOffsetPx = 4.0;
constexpr double kCyOffsetPx = -3.0;
constexpr double kFyOverFx = 1.002;

const LensSpec& FindLens(const std::string& lens) {
  for (const LensSpec& spec : kLenses) {
    if (lens == spec.name) return spec;
  }
  std::string names;
  for (const LensSpec& spec : kLenses) names += std::string(names.empty() ? "" : ", ") + spec.name;
  throw Error("unknown lens '" + lens + "', expected one of: " + names);
}

// 0 before `start`, 1 from `end` on, linear in between (a step when they coincide).
double Ramp(double t, double start, double end) {
  if (t < start) return 0.0;
  if (t >= end) return 1.0;
  return (t - start) / (end - start);
}

bool Active(double t, double start, double end) { return t >= start && t < end; }

}  // namespace

std::vector<std::string> LensNames() {
  std::vector<std::string> names;
  for (const LensSpec& spec : kLenses) names.push_back(spec.name);
  return names;
}

double LensFieldOfViewDeg(const std::string& lens) { return FindLens(lens).horizontal_fov_deg; }

CameraIntrinsics LensIntrinsics(const std::string& lens, int width, int height) {
  const LensSpec& spec = FindLens(lens);
  const double r = std::tan(0.5 * spec.horizontal_fov_deg * M_PI / 180.0);
  const double r2 = r * r;
  const double distorted_r = r * (1.0 + r2 * (spec.k1 + r2 * spec.k2));
  const double scale = width / kReferenceWidth;
  CameraIntrinsics c;
  c.width = width;
  c.height = height;
  c.fx = 0.5 * width / distorted_r;
  c.fy = kFyOverFx * c.fx;
  c.cx = 0.5 * (width - 1) + kCxOffsetPx * scale;
  c.cy = 0.5 * (height - 1) + kCyOffsetPx * scale;
  c.k1 = spec.k1;
  c.k2 = spec.k2;
  return c;
}

CameraIntrinsics IntrinsicsAt(const Scenario& scenario, double t_s) {
  CameraIntrinsics c = LensIntrinsics(scenario.lens, scenario.width, scenario.height);
  double fx_scale = 1.0, fy_scale = 1.0, cx_shift = 0.0, cy_shift = 0.0;
  for (const IntrinsicsEvent& event : scenario.intrinsics_events) {
    const double ramp =
        Ramp(t_s, event.start.Seconds(scenario.seconds), event.end.Seconds(scenario.seconds));
    fx_scale *= 1.0 + (event.fx_scale - 1.0) * ramp;
    fy_scale *= 1.0 + (event.fy_scale - 1.0) * ramp;
    cx_shift += event.cx_px * ramp;
    cy_shift += event.cy_px * ramp;
  }
  c.fx *= fx_scale;
  c.fy *= fy_scale;
  c.cx += cx_shift;
  c.cy += cy_shift;
  return c;
}

FrameEffects EffectsAt(const Scenario& scenario, double t_s) {
  FrameEffects effects;
  effects.vignetting = scenario.image.vignetting;
  effects.chromatic_px = scenario.image.chromatic_px;
  double noise_variance = scenario.image.noise_sigma * scenario.image.noise_sigma;
  for (const Disturbance& d : scenario.disturbances) {
    if (!Active(t_s, d.start.Seconds(scenario.seconds), d.end.Seconds(scenario.seconds))) continue;
    switch (d.kind) {
      case Disturbance::Kind::kFog:
        effects.fog_blur_sigma_px = std::max(effects.fog_blur_sigma_px, d.blur_sigma_px);
        effects.fog_contrast *= d.contrast;
        break;
      case Disturbance::Kind::kNoiseBurst:
        noise_variance += d.noise_sigma * d.noise_sigma;
        break;
    }
  }
  effects.noise_sigma = std::sqrt(noise_variance);
  return effects;
}

}  // namespace autocal
