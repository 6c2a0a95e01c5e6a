// Box 7 on synthetic readings whose integrals, gravity and motion are known exactly.
#include "pipeline/inertial.h"

#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

namespace autocal {
namespace {

constexpr int64_t kSecond = 1'000'000'000;
constexpr double kG = 9.81;

double Radians(double degrees) { return degrees * M_PI / 180.0; }
double Degrees(double radians) { return radians * 180.0 / M_PI; }

// Readings of `force(t_s)` at `rate_hz` over [from_s, to_s] (times in seconds from 0).
template <typename Force>
std::vector<SpecificForceSample> Readings(double from_s, double to_s, double rate_hz, Force force) {
  std::vector<SpecificForceSample> samples;
  for (int k = 0;; ++k) {
    const int64_t t_ns = std::llround(from_s * 1e9 + k * 1e9 / rate_hz);
    if (t_ns > std::llround(to_s * 1e9)) break;
    samples.push_back({t_ns, force(1e-9 * static_cast<double>(t_ns))});
  }
  return samples;
}

TEST(Inertial, DefaultOptionsAreValid) {
  std::string error;
  EXPECT_TRUE(InertialOptions().Check(&error)) << error;
}

TEST(Inertial, OptionCheckNamesTheField) {
  InertialOptions options;
  options.quasi_static.window_s = 0.0;
  std::string error;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_EQ(error, "quasi_static.window_s must be positive");
  options = {};
  options.screen.max_gap_s = -1.0;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_EQ(error, "screen.max_gap_s must be positive");
  options = {};
  options.motion.forward_max_angle_deg = 90.0;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_EQ(error, "motion.forward_max_angle_deg must be in (0, 90)");
  options = {};
  options.scale.min_poses = 2;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_EQ(error, "scale.min_poses must be at least 4");
  options = {};
  options.history_s = 0.1;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_EQ(error, "history_s must be at least quasi_static.window_s");
}

TEST(Inertial, IntegralsAreExactForForceLinearInTime) {
  // f(t) = a + b t; readings off the frame times, so both ends are resampled.
  const Eigen::Vector3d a(0.3, -1.0, 9.0), b(2.0, 0.5, -4.0);
  const auto samples =
      Readings(-0.013, 1.0, 397.0, [&](double t) { return Eigen::Vector3d(a + b * t); });
  const double t0 = 0.2, t1 = 0.2333;
  AccelCalibration calibration;
  calibration.cam_from_accel =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const IntervalIntegral integral = IntegrateInterval(
      samples, std::llround(t0 * 1e9), std::llround(t1 * 1e9), calibration, AccelScreenOptions());
  ASSERT_TRUE(integral.usable()) << integral.faults.Describe();
  const double h = t1 - t0;
  const Eigen::Vector3d dv = a * h + b * (t1 * t1 - t0 * t0) / 2.0;
  // Double integral from t0 at rest: a h^2 / 2 + b (h^3 / 6 + t0 h^2 / 2).
  const Eigen::Vector3d dp = a * h * h / 2.0 + b * (h * h * h / 6.0 + t0 * h * h / 2.0);
  EXPECT_LT((integral.delta_velocity - calibration.cam_from_accel * dv).norm(), 1e-12);
  EXPECT_LT((integral.delta_position - calibration.cam_from_accel * dp).norm(), 1e-12);
  EXPECT_LT((integral.force_t0 - calibration.cam_from_accel * (a + b * t0)).norm(), 1e-9);
  EXPECT_LT((integral.force_t1 - calibration.cam_from_accel * (a + b * t1)).norm(), 1e-9);
  EXPECT_EQ(integral.readings, 13);
}

TEST(Inertial, ReadingsAreTurnedIntoTheFirstCameraFrame) {
  // The camera turns 30 degrees about its y axis over the interval while a fixed force acts
  // in the world: integrated in camera 0 it is that force times the time, within the error
  // of interpolating between readings.
  const double turn = Radians(30.0), duration = 1.0 / 30.0;
  const Eigen::Vector3d world_force(1.0, 2.0, 3.0);
  const auto samples = Readings(-0.01, 0.05, 1600.0, [&](double t) {
    const Eigen::Matrix3d cam0_from_cam =
        Eigen::AngleAxisd(turn * t / duration, Eigen::Vector3d::UnitY()).toRotationMatrix();
    return Eigen::Vector3d(cam0_from_cam.transpose() * world_force);
  });
  const Eigen::Quaterniond cam0_from_cam1(Eigen::AngleAxisd(turn, Eigen::Vector3d::UnitY()));
  const IntervalIntegral turned =
      IntegrateInterval(samples, 0, std::llround(duration * 1e9), {}, {}, cam0_from_cam1);
  const IntervalIntegral unturned =
      IntegrateInterval(samples, 0, std::llround(duration * 1e9), {}, {});
  EXPECT_LT((turned.delta_velocity - world_force * duration).norm(), 1e-5);
  EXPECT_LT((turned.delta_position - world_force * duration * duration / 2).norm(), 1e-7);
  EXPECT_GT((unturned.delta_velocity - world_force * duration).norm(), 1e-3)
      << "ignoring the turn must show";
}

TEST(Inertial, BiasDerivativesMatchReintegration) {
  const auto samples = Readings(0.0, 0.2, 400.0, [](double t) {
    return Eigen::Vector3d(std::sin(9 * t), 9.81 + std::cos(5 * t), 0.2 * t);
  });
  AccelCalibration calibration;
  calibration.cam_from_accel = Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(0.3, Eigen::Vector3d(0, 1, 1).normalized()));
  const int64_t t0 = 40'000'000, t1 = 73'333'333;
  const IntervalIntegral base = IntegrateInterval(samples, t0, t1, calibration, {}, turn);
  const Eigen::Vector3d extra(0.05, -0.02, 0.08);
  AccelCalibration biased = calibration;
  biased.bias = extra;
  const IntervalIntegral shifted = IntegrateInterval(samples, t0, t1, biased, {}, turn);
  EXPECT_LT((base.delta_velocity + base.d_velocity_d_bias * extra - shifted.delta_velocity).norm(),
            1e-14);
  EXPECT_LT((base.delta_position + base.d_position_d_bias * extra - shifted.delta_position).norm(),
            1e-15);
}

// Readings at rest, 400 Hz, a frame every 1/30 s; `fault` damages them.
struct FaultCase {
  const char* name;
  void (*fault)(std::vector<SpecificForceSample>*);
  const char* reason;
};

class InertialFaults : public ::testing::TestWithParam<FaultCase> {};

TEST_P(InertialFaults, IntervalIsSkippedWithItsReason) {
  auto samples = Readings(0.0, 1.0, 400.0, [](double) { return Eigen::Vector3d(0, 0, kG); });
  GetParam().fault(&samples);
  InertialStage stage({});
  stage.AddSamples(samples);
  int skipped = 0;
  for (int i = 0; i < 25; ++i) {
    const InertialSnapshot snapshot = stage.Process(std::llround(0.1e9 + i * 1e9 / 30));
    if (!snapshot.skipped()) continue;
    ++skipped;
    EXPECT_EQ(snapshot.skip_reason(), GetParam().reason);
    EXPECT_EQ(snapshot.interval->delta_velocity, Eigen::Vector3d::Zero()) << "nothing integrated";
    EXPECT_LE(snapshot.previous_t_ns, 500'000'000);
    EXPECT_GE(snapshot.t_ns, 500'000'000) << "only the interval holding the fault";
    EXPECT_EQ(snapshot.motion, MotionClass::kUnknown);
  }
  EXPECT_EQ(skipped, 1);
}

INSTANTIATE_TEST_SUITE_P(Cases, InertialFaults,
                         ::testing::Values(FaultCase{"NaN",
                                                     [](std::vector<SpecificForceSample>* s) {
                                                       (*s)[201].specific_force.y() =
                                                           std::numeric_limits<double>::quiet_NaN();
                                                     },
                                                     "1 reading not finite"},
                                           FaultCase{"Saturation",
                                                     [](std::vector<SpecificForceSample>* s) {
                                                       (*s)[201].specific_force.z() = 3.0 * kG;
                                                       (*s)[202].specific_force.x() = -3.0 * kG;
                                                     },
                                                     "2 readings saturated"},
                                           FaultCase{"Gap",
                                                     [](std::vector<SpecificForceSample>* s) {
                                                       s->erase(s->begin() + 203, s->begin() + 212);
                                                     },
                                                     "a gap of 0.025 s"},
                                           FaultCase{"OutOfOrder",
                                                     [](std::vector<SpecificForceSample>* s) {
                                                       std::swap((*s)[201], (*s)[202]);
                                                     },
                                                     "1 reading out of time order"}),
                         [](const ::testing::TestParamInfo<FaultCase>& param) {
                           return param.param.name;
                         });

TEST(Inertial, IntervalsBeyondTheReadingsHaveNoData) {
  const auto samples = Readings(0.0, 0.5, 400.0, [](double) { return Eigen::Vector3d(0, 0, kG); });
  const IntervalIntegral integral = IntegrateInterval(samples, 480'000'000, 520'000'000, {}, {});
  EXPECT_FALSE(integral.usable());
  EXPECT_EQ(integral.faults.Describe(), "no readings cover it");
}

TEST(Inertial, TiltFromGravityFollowsTheCameraAxes) {
  // Level, upright camera: gravity along +y (image down).
  Tilt tilt = TiltFromGravity({0, kG, 0});
  EXPECT_NEAR(tilt.roll_rad, 0, 1e-12);
  EXPECT_NEAR(tilt.pitch_rad, 0, 1e-12);
  // Looking 10 degrees down: gravity gains a +z part.
  tilt = TiltFromGravity({0, kG * std::cos(Radians(10)), kG * std::sin(Radians(10))});
  EXPECT_NEAR(Degrees(tilt.pitch_rad), 10.0, 1e-9);
  EXPECT_NEAR(tilt.roll_rad, 0, 1e-12);
  // Rolled so that image right dips 5 degrees.
  tilt = TiltFromGravity({kG * std::sin(Radians(5)), kG * std::cos(Radians(5)), 0});
  EXPECT_NEAR(Degrees(tilt.roll_rad), 5.0, 1e-9);
}

TEST(Inertial, QuasiStaticWindowMeasuresGravity) {
  cv::RNG rng(7);
  const Eigen::Vector3d down_cam = Eigen::Vector3d(0.1, 1.0, 0.2).normalized();
  AccelCalibration calibration;
  calibration.cam_from_accel = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d up_accel = calibration.cam_from_accel.transpose() * (-kG * down_cam);
  auto samples = Readings(0.0, 2.0, 400.0, [&](double t) {
    // At rest for a second, then walking (1.5 m/s^2 of bob).
    const Eigen::Vector3d noise(rng.gaussian(0.04), rng.gaussian(0.04), rng.gaussian(0.04));
    const double bob = t < 1.0 ? 0.0 : 1.5 * std::sin(2 * M_PI * 1.8 * t);
    return Eigen::Vector3d(up_accel * (1.0 + bob / kG) + noise);
  });
  const QuasiStaticOptions options;
  const QuasiStaticTest rest = TestQuasiStatic(samples, kSecond / 2, calibration, {}, options);
  ASSERT_TRUE(rest.quasi_static) << rest.norm_deviation << " " << rest.max_variance;
  EXPECT_LT(Degrees(std::acos(rest.gravity_cam.normalized().dot(down_cam))), 0.05);
  EXPECT_NEAR(rest.gravity_cam.norm(), kG, 0.01);
  EXPECT_GT(rest.sigma_deg, 0.4) << "includes the bias one cannot see";
  EXPECT_FALSE(TestQuasiStatic(samples, 3 * kSecond / 2, calibration, {}, options).quasi_static);
  // A reading lost in the window: no verdict.
  samples[200].specific_force.x() = std::numeric_limits<double>::quiet_NaN();
  const QuasiStaticTest damaged = TestQuasiStatic(samples, kSecond / 2, calibration, {}, options);
  EXPECT_FALSE(damaged.quasi_static);
  EXPECT_EQ(damaged.faults.non_finite, 1);
}

TEST(Inertial, ClassifiesFromVisionAndVelocity) {
  const MotionClassOptions options;
  MotionEvidence evidence;
  evidence.dt_s = 1.0 / 30.0;
  evidence.gravity_cam = Eigen::Vector3d(0, kG * std::cos(0.3), kG * std::sin(0.3));
  EXPECT_EQ(ClassifyMotion(evidence, options), MotionClass::kUnknown) << "nothing known";
  evidence.quasi_static = true;
  EXPECT_EQ(ClassifyMotion(evidence, options), MotionClass::kStill);
  // A smooth pan feels like rest to the accelerometer; vision sees it turn.
  VisualMotion pan;
  pan.cam1_from_cam0 = Eigen::AngleAxisd(Radians(1.0), Eigen::Vector3d::UnitY());
  evidence.visual = pan;
  EXPECT_EQ(ClassifyMotion(evidence, options), MotionClass::kRotate);
  evidence.quasi_static = false;
  // Turning 30 deg/s while moving sideways (a camera ahead of the turning axis): rotate.
  pan.translation_direction = Eigen::Vector3d::UnitX();
  evidence.visual = pan;
  EXPECT_EQ(ClassifyMotion(evidence, options), MotionClass::kRotate);
  // Turning while walking forward (the camera pitched down 17 degrees): forward.
  pan.translation_direction = Eigen::Vector3d(0.1, -std::sin(0.3), std::cos(0.3)).normalized();
  evidence.visual = pan;
  EXPECT_EQ(ClassifyMotion(evidence, options), MotionClass::kForward);
  // Not turning, moving sideways: sidestep.
  VisualMotion side;
  side.translation_direction = Eigen::Vector3d(-1, 0, 0.2).normalized();
  evidence.visual = side;
  EXPECT_EQ(ClassifyMotion(evidence, options), MotionClass::kSidestep);
  // Accelerometer only: the integrated velocity decides.
  evidence.visual.reset();
  evidence.velocity_cam = Eigen::Vector3d(0.05, 0.3, 1.0);
  EXPECT_EQ(ClassifyMotion(evidence, options), MotionClass::kForward);
  evidence.velocity_cam = Eigen::Vector3d(0.6, 0, 0.1);
  EXPECT_EQ(ClassifyMotion(evidence, options), MotionClass::kSidestep);
  evidence.velocity_cam = Eigen::Vector3d(0.05, 0, 0.05);
  EXPECT_EQ(ClassifyMotion(evidence, options), MotionClass::kUnknown) << "too slow to tell";
  evidence.velocity_cam.reset();
  EXPECT_EQ(ClassifyMotion(evidence, options), MotionClass::kUnknown) << "no still moment yet";
}

// A camera swinging on a smooth path while turning, seen by vision in a world frame of its
// own and at a scale of its own.
struct SwingingCamera {
  Eigen::Vector3d Position(double t) const {
    return {0.8 * t + 0.1 * std::sin(3 * t), 0.05 * std::cos(5 * t), 0.2 * std::sin(2 * t)};
  }
  Eigen::Vector3d Acceleration(double t) const {
    return {-0.9 * std::sin(3 * t), -1.25 * std::cos(5 * t), -0.8 * std::sin(2 * t)};
  }
  Eigen::Matrix3d WorldFromCam(double t) const {
    return (Eigen::AngleAxisd(0.6 * std::sin(t), Eigen::Vector3d::UnitZ()) *
            Eigen::AngleAxisd(0.2 + 0.1 * t, Eigen::Vector3d::UnitX()))
        .toRotationMatrix();
  }
};

TEST(Inertial, ScaleFromAnExactTrajectory) {
  const SwingingCamera camera;
  AccelCalibration calibration;
  calibration.cam_from_accel =
      Eigen::AngleAxisd(2.0, Eigen::Vector3d(1, -1, 0).normalized()).toRotationMatrix();
  const Eigen::Vector3d gravity_world(0, 0, -kG), bias(0.05, -0.04, 0.03);
  const auto samples = Readings(-0.1, 2.2, 1600.0, [&](double t) {
    const Eigen::Matrix3d accel_from_world =
        (camera.WorldFromCam(t) * calibration.cam_from_accel).transpose();
    return Eigen::Vector3d(accel_from_world * (camera.Acceleration(t) - gravity_world) + bias);
  });
  // Vision: its own world frame, and units of 0.25 m.
  const Eigen::Matrix3d vision_from_world =
      Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, 0.5, -1).normalized()).toRotationMatrix();
  const double metres_per_unit = 0.25;
  std::vector<VisualPose> poses;
  for (int i = 0; i <= 60; ++i) {
    const double t = i / 30.0;
    poses.push_back(
        {std::llround(t * 1e9), Eigen::Quaterniond(vision_from_world * camera.WorldFromCam(t)),
         vision_from_world * camera.Position(t) / metres_per_unit + Eigen::Vector3d(5, 6, 7)});
  }
  const ScaleEstimate estimate = EstimateMetricScale(samples, calibration, poses, {}, {});
  ASSERT_TRUE(estimate.usable) << estimate.message;
  // What is left comes from slerping the orientation between frames.
  EXPECT_NEAR(estimate.scale, metres_per_unit, 1e-4 * metres_per_unit) << estimate.message;
  EXPECT_LT((estimate.gravity_world - vision_from_world * gravity_world).norm(), 1e-3);
  EXPECT_LT((estimate.velocity_world - vision_from_world * Eigen::Vector3d(1.1, 0, 0.4)).norm(),
            1e-3);
  EXPECT_LT((estimate.bias - bias).norm(), 1e-3);
  EXPECT_LT(estimate.rms_m, 1e-5);

  // Without the bias among the unknowns, the part of it that the turning camera spreads
  // over the world lands on the scale: here 1.2%.
  ScaleOptions options;
  options.estimate_bias = false;
  const ScaleEstimate no_bias = EstimateMetricScale(samples, calibration, poses, {}, options);
  EXPECT_NEAR(no_bias.scale, metres_per_unit, 0.05 * metres_per_unit) << no_bias.message;
  EXPECT_GT(std::abs(no_bias.scale - metres_per_unit), 0.005 * metres_per_unit);
}

TEST(Inertial, ConstantVelocityHasNoScale) {
  std::vector<VisualPose> poses;
  for (int i = 0; i <= 60; ++i) {
    poses.push_back({std::llround(i * 1e9 / 30), Eigen::Quaterniond::Identity(),
                     Eigen::Vector3d(i / 30.0, 0, 0)});
  }
  const auto samples = Readings(-0.1, 2.1, 400.0, [](double) { return Eigen::Vector3d(0, 0, kG); });
  const ScaleEstimate estimate = EstimateMetricScale(samples, {}, poses, {}, {});
  EXPECT_FALSE(estimate.usable);
  EXPECT_NE(estimate.message.find("degenerate"), std::string::npos) << estimate.message;
}

TEST(Inertial, ScaleWindowWithAFaultIsRefused) {
  std::vector<VisualPose> poses;
  for (int i = 0; i <= 60; ++i) {
    poses.push_back({std::llround(i * 1e9 / 30), Eigen::Quaterniond::Identity(),
                     Eigen::Vector3d(std::sin(i / 10.0), 0, 0)});
  }
  auto samples = Readings(-0.1, 2.1, 400.0, [](double) { return Eigen::Vector3d(0, 0, kG); });
  samples[300].specific_force.z() = 3.0 * kG;
  const ScaleEstimate estimate = EstimateMetricScale(samples, {}, poses, {}, {});
  EXPECT_FALSE(estimate.usable);
  EXPECT_EQ(estimate.message, "accelerometer faults in the window: 1 reading saturated");
}

}  // namespace
}  // namespace autocal
