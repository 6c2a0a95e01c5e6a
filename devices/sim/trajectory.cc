#include "devices/sim/trajectory.h"

#include <cmath>

#include <Eigen/Geometry>

#include "pipeline/error.h"

namespace autocal {
namespace {

// A function of time truncated after its second derivative: arithmetic on these carries
// exact first and second time derivatives through the path formulas (forward-mode
// differentiation), so the accelerometer sees the analytic acceleration.
struct Taylor2 {
  double v = 0.0;   // Value.
  double d = 0.0;   // First derivative.
  double dd = 0.0;  // Second derivative.
};

Taylor2 operator+(const Taylor2& a, const Taylor2& b) {
  return {a.v + b.v, a.d + b.d, a.dd + b.dd};
}
Taylor2 operator-(const Taylor2& a, const Taylor2& b) {
  return {a.v - b.v, a.d - b.d, a.dd - b.dd};
}
Taylor2 operator+(const Taylor2& a, double b) { return {a.v + b, a.d, a.dd}; }
Taylor2 operator*(double s, const Taylor2& a) { return {s * a.v, s * a.d, s * a.dd}; }
Taylor2 operator*(const Taylor2& a, const Taylor2& b) {
  return {a.v * b.v, a.d * b.v + a.v * b.d, a.dd * b.v + 2.0 * a.d * b.d + a.v * b.dd};
}
Taylor2 operator/(const Taylor2& a, const Taylor2& b) {
  const double q = a.v / b.v;
  const double dq = (a.d - q * b.d) / b.v;
  const double ddq = (a.dd - 2.0 * dq * b.d - q * b.dd) / b.v;
  return {q, dq, ddq};
}
// f(g(t)) with f, f', f'' given at g.
Taylor2 Chain(const Taylor2& g, double f, double df, double ddf) {
  return {f, df * g.d, ddf * g.d * g.d + df * g.dd};
}
Taylor2 Sin(const Taylor2& a) {
  const double s = std::sin(a.v), c = std::cos(a.v);
  return Chain(a, s, c, -s);
}
Taylor2 Cos(const Taylor2& a) {
  const double s = std::sin(a.v), c = std::cos(a.v);
  return Chain(a, c, -s, -c);
}
Taylor2 Sqrt(const Taylor2& a) {
  const double r = std::sqrt(a.v);
  return Chain(a, r, 0.5 / r, -0.25 / (r * a.v));
}
double Sin(double a) { return std::sin(a); }
double Cos(double a) { return std::cos(a); }
double Sqrt(double a) { return std::sqrt(a); }

double Deg(double degrees) { return degrees * M_PI / 180.0; }

Eigen::Matrix3d WorldFromBody(double yaw, double pitch, double roll) {
  // Positive pitch tilts the forward axis down (rotation about body y, which points left).
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// Frequencies of the slow head motions, chosen incommensurate with each other and with the
// loop so that orientations do not repeat.
constexpr double kPitchHz = 0.13;
constexpr double kRollPhase = 0.7;
constexpr double kPitchPhase = 1.1;

}  // namespace

Eigen::Matrix3d BodyFromCam() {
  Eigen::Matrix3d m;
  // Columns: camera x (right) = body -y, camera y (down) = body -z, camera z = body x.
  m << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return m;
}

Trajectory::Trajectory(const MotionOptions& motion, const std::string& scene) : motion_(motion) {
  if (motion.type == "static") {
    if (scene == "office") {
      // On the table in the middle of the room, looking at the east wall and the floor.
      rest_position_ = {0.35, 0.1, 0.95};
      rest_yaw_deg_ = 5.0;
      rest_pitch_deg_ = 8.0;
    } else if (scene == "corridor") {
      rest_position_ = {-11.0, 0.3, 1.0};
      rest_yaw_deg_ = 2.0;
      rest_pitch_deg_ = 6.0;
    } else if (scene == "outdoor") {
      rest_position_ = {0.0, 0.0, 1.0};
      rest_yaw_deg_ = 10.0;
      rest_pitch_deg_ = 3.0;
    } else if (scene == "checkerboard") {
      // Half a metre in front of the board (see scene.cc), looking straight at it.
      rest_position_ = {0.0, 0.0, 1.0};
    } else {
      throw Error("no rest pose for scene '" + scene + "'");
    }
    return;
  }
  if (motion.type != "walk") {
    throw Error("unknown motion type '" + motion.type + "', expected walk or static");
  }
  walking_ = true;
  if (scene == "office") {
    // A rounded-rectangle loop round the table, at least a metre from the walls.
    harmonics_ = {{1, 2.7, 0.0, 0.0, 1.75}, {2, 0.0, 0.0, 0.12, 0.0}, {3, -0.3, 0.0, 0.0, 0.2}};
  } else if (scene == "corridor") {
    // Down the corridor and back, turning round near each end; the warp evens out the
    // speed along the straight parts.
    harmonics_ = {{1, 11.5, 0.0, 0.0, 0.3}};
    warp_ = 0.2;
  } else if (scene == "outdoor") {
    centre_ = {2.0, -1.0};
    harmonics_ = {{1, 9.0, 0.0, 0.0, 6.0}, {2, 1.2, 0.0, 0.0, 0.8}, {3, 0.0, -0.6, 0.5, 0.0}};
  } else {
    throw Error("no walking path in scene '" + scene + "', expected office, corridor or outdoor");
  }
  // Mean speed = path length / period: integrate |dP/dphi| over one loop.
  constexpr int kSteps = 20000;
  double length = 0.0;
  for (int i = 0; i < kSteps; ++i) {
    const double phi = 2.0 * M_PI * (i + 0.5) / kSteps;
    double dx = 0.0, dy = 0.0;
    for (const Harmonic& h : harmonics_) {
      const double c = std::cos(h.k * phi), s = std::sin(h.k * phi);
      dx += h.k * (-h.ax * s + h.bx * c);
      dy += h.k * (-h.ay * s + h.by * c);
    }
    length += std::hypot(dx, dy) * 2.0 * M_PI / kSteps;
  }
  omega_ = 2.0 * M_PI * motion.speed_mps / length;
}

double Trajectory::loop_period_s() const { return walking_ ? 2.0 * M_PI / omega_ : 0.0; }

template <typename T>
void Trajectory::Evaluate(const T& t, T* x, T* y, T* z) const {
  const T phi = omega_ * t + warp_ * Sin(2.0 * omega_ * t);
  T px = 0.0 * t + centre_.x(), py = 0.0 * t + centre_.y();
  T dx = 0.0 * t, dy = 0.0 * t;  // Derivatives with respect to phi.
  for (const Harmonic& h : harmonics_) {
    const T c = Cos(static_cast<double>(h.k) * phi), s = Sin(static_cast<double>(h.k) * phi);
    px = px + h.ax * c + h.bx * s;
    py = py + h.ay * c + h.by * s;
    dx = dx + static_cast<double>(h.k) * (h.bx * c - h.ax * s);
    dy = dy + static_cast<double>(h.k) * (h.by * c - h.ay * s);
  }
  // Sway to the left and right of the path, at half the step frequency.
  const T norm = Sqrt(dx * dx + dy * dy);
  const T sway = (0.5 * motion_.sway_m) * Sin((M_PI * motion_.step_hz) * t);
  *x = px - sway * dy / norm;
  *y = py + sway * dx / norm;
  *z = (0.5 * motion_.bob_m) * Sin((2.0 * M_PI * motion_.step_hz) * t) + motion_.height_m;
}

Eigen::Vector3d Trajectory::PositionAt(double t_s) const {
  if (!walking_) return rest_position_;
  double x, y, z;
  Evaluate(t_s, &x, &y, &z);
  return {x, y, z};
}

double Trajectory::HeadingAt(double t_s) const {
  const double phi = omega_ * t_s + warp_ * std::sin(2.0 * omega_ * t_s);
  double dx = 0.0, dy = 0.0;
  for (const Harmonic& h : harmonics_) {
    const double c = std::cos(h.k * phi), s = std::sin(h.k * phi);
    dx += h.k * (h.bx * c - h.ax * s);
    dy += h.k * (h.by * c - h.ay * s);
  }
  return std::atan2(dy, dx);
}

Eigen::Matrix3d Trajectory::WorldFromCamAt(double t_s) const {
  if (!walking_) {
    return WorldFromBody(Deg(rest_yaw_deg_), Deg(rest_pitch_deg_), 0.0) * BodyFromCam();
  }
  const double yaw =
      HeadingAt(t_s) + Deg(motion_.scan_deg) * std::sin(2.0 * M_PI * motion_.scan_hz * t_s);
  const double pitch =
      Deg(motion_.pitch_deg) +
      Deg(motion_.pitch_swing_deg) * std::sin(2.0 * M_PI * kPitchHz * t_s + kPitchPhase);
  const double roll = Deg(motion_.roll_deg) * std::sin(M_PI * motion_.step_hz * t_s + kRollPhase);
  return WorldFromBody(yaw, pitch, roll) * BodyFromCam();
}

BodyState Trajectory::At(double t_s) const {
  BodyState state;
  state.world_from_cam = WorldFromCamAt(t_s);
  if (!walking_) {
    state.position = rest_position_;
    return state;
  }
  Taylor2 x, y, z;
  Evaluate(Taylor2{t_s, 1.0, 0.0}, &x, &y, &z);
  state.position = {x.v, y.v, z.v};
  state.velocity = {x.d, y.d, z.d};
  state.acceleration = {x.dd, y.dd, z.dd};
  return state;
}

}  // namespace autocal
