// Box 7: what kind of motion a frame interval holds (still, forward, sidestep, rotate),
// from the accelerometer and, where available, the rotation and translation direction
// that vision measured (docs/inertial.md).
#pragma once

#include <optional>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace autocal {

// Kinds of camera motion, as they matter to calibration: still gives gravity, rotation
// about the centre gives homographies that fix K, translation gives parallax.
enum class MotionClass {
  kUnknown,   // Not enough evidence (no still moment yet and no vision, a fault, ...).
  kStill,     // Neither translating nor turning.
  kForward,   // Translating along the optical axis (forward or back, horizontally).
  kSidestep,  // Translating across the optical axis.
  kRotate,    // Turning, with no more translation than a turn on the spot makes.
};
const char* MotionClassName(MotionClass motion);

// What vision measured over one frame interval (box 6): how the camera turned and the
// direction it moved in (two views fix no scale).
struct VisualMotion {
  // Rotation taking vectors in the camera frame at the interval's start to its end.
  Eigen::Quaterniond cam1_from_cam0 = Eigen::Quaterniond::Identity();
  // Unit direction of the translation, in the camera frame at the start; zero when vision
  // saw no parallax.
  Eigen::Vector3d translation_direction = Eigen::Vector3d::Zero();
};

struct MotionClassOptions {
  double still_max_rotation_deg_s = 5.0;  // Vision turning faster: not still, at rest or not.
  double rotate_min_deg_s = 20.0;         // Turning faster, not moving forward: rotate.
  double forward_max_angle_deg = 45.0;    // Horizontal translation this near the optical axis
                                          // (either way) is forward, farther is sidestep.
  double min_horizontal_fraction = 0.5;   // Translation less horizontal than this: unknown.
  double min_speed_m_s = 0.15;            // Accelerometer only: slower is not classified.

  bool Check(std::string* error) const;
};

// Everything known about one frame interval.
struct MotionEvidence {
  double dt_s = 0.0;
  bool quasi_static = false;  // The accelerometer's window test (inertial_gravity.h).
  std::optional<VisualMotion> visual;
  std::optional<Eigen::Vector3d> gravity_cam;  // Down in the camera frame, any length.
  // Velocity in the camera frame from the accelerometer, integrated since the body was last
  // still (unknown before that: an accelerometer cannot tell a steady walk from rest).
  std::optional<Eigen::Vector3d> velocity_cam;
};

// Still when the accelerometer is quasi-static and vision (if any) sees no turn. With
// vision: forward when it moves along the optical axis, else rotate when it turns fast,
// else sidestep. Without vision, from the direction of the integrated velocity; turns are
// then invisible (an accelerometer on the axis of a turn feels nothing), never kRotate.
MotionClass ClassifyMotion(const MotionEvidence& evidence, const MotionClassOptions& options);

}  // namespace autocal
