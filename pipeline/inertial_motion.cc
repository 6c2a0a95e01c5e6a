#include "pipeline/inertial_motion.h"

#include <cmath>

#include <Eigen/Geometry>

namespace autocal {
namespace {

double Degrees(double radians) { return radians * 180.0 / M_PI; }

// Unit down in the camera frame: gravity's direction when known, else the camera's y axis.
Eigen::Vector3d Down(const std::optional<Eigen::Vector3d>& gravity_cam) {
  return gravity_cam && gravity_cam->norm() > 0 ? gravity_cam->normalized()
                                                : Eigen::Vector3d::UnitY();
}

// Forward or sidestep from a translation (any length) in the camera frame, measured in the
// horizontal plane when gravity is known (so a camera looking down still walks forward),
// else in the camera's x-z plane.
MotionClass TranslationClass(const Eigen::Vector3d& translation,
                             const std::optional<Eigen::Vector3d>& gravity_cam,
                             const MotionClassOptions& options) {
  const Eigen::Vector3d down = Down(gravity_cam);
  const Eigen::Vector3d horizontal = translation - translation.dot(down) * down;
  const Eigen::Vector3d axis = Eigen::Vector3d::UnitZ() - down.z() * down;
  const double norm = translation.norm();
  if (norm == 0.0 || horizontal.norm() < options.min_horizontal_fraction * norm ||
      axis.norm() < 1e-6) {
    return MotionClass::kUnknown;  // Vertical motion, or a camera looking straight down.
  }
  const double cosine = std::abs(horizontal.dot(axis)) / (horizontal.norm() * axis.norm());
  return Degrees(std::acos(std::min(cosine, 1.0))) <= options.forward_max_angle_deg
             ? MotionClass::kForward
             : MotionClass::kSidestep;
}

}  // namespace

const char* MotionClassName(MotionClass motion) {
  switch (motion) {
    case MotionClass::kUnknown:
      return "unknown";
    case MotionClass::kStill:
      return "still";
    case MotionClass::kForward:
      return "forward";
    case MotionClass::kSidestep:
      return "sidestep";
    case MotionClass::kRotate:
      return "rotate";
  }
  return "unknown";
}

bool MotionClassOptions::Check(std::string* error) const {
  std::string why;
  if (!(still_max_rotation_deg_s >= 0)) {
    why = "still_max_rotation_deg_s must not be negative";
  } else if (!(rotate_min_deg_s >= still_max_rotation_deg_s)) {
    why = "rotate_min_deg_s must be at least still_max_rotation_deg_s";
  } else if (!(forward_max_angle_deg > 0 && forward_max_angle_deg < 90)) {
    why = "forward_max_angle_deg must be in (0, 90)";
  } else if (!(min_horizontal_fraction >= 0 && min_horizontal_fraction <= 1)) {
    why = "min_horizontal_fraction must be in [0, 1]";
  } else if (!(min_speed_m_s >= 0)) {
    why = "min_speed_m_s must not be negative";
  }
  if (why.empty()) return true;
  if (error) *error = why;
  return false;
}

MotionClass ClassifyMotion(const MotionEvidence& evidence, const MotionClassOptions& options) {
  double rate_deg_s = 0.0;
  if (evidence.visual && evidence.dt_s > 0) {
    rate_deg_s =
        Degrees(Eigen::AngleAxisd(evidence.visual->cam1_from_cam0).angle()) / evidence.dt_s;
  }
  if (evidence.quasi_static) {
    // No acceleration: at rest, or turning smoothly about the sensor (a pan).
    return rate_deg_s <= options.still_max_rotation_deg_s ? MotionClass::kStill
                                                          : MotionClass::kRotate;
  }
  if (evidence.visual) {
    const MotionClass translation =
        TranslationClass(evidence.visual->translation_direction, evidence.gravity_cam, options);
    if (translation == MotionClass::kForward) return translation;
    // A turn on the spot moves a camera ahead of the turning axis sideways: it is still a
    // rotation when the turn is fast.
    if (rate_deg_s >= options.rotate_min_deg_s) return MotionClass::kRotate;
    return translation;
  }
  if (!evidence.velocity_cam) return MotionClass::kUnknown;
  const Eigen::Vector3d& velocity = *evidence.velocity_cam;
  const Eigen::Vector3d down = Down(evidence.gravity_cam);
  if ((velocity - velocity.dot(down) * down).norm() < options.min_speed_m_s) {
    return MotionClass::kUnknown;
  }
  return TranslationClass(velocity, evidence.gravity_cam, options);
}

}  // namespace autocal
