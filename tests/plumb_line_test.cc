#include "pipeline/plumb_line.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include <ceres/ceres.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "pipeline/plane_point_cost.h"
#include "pipeline/plumb_line_problem.h"

#include "tests/test_util.h"

namespace autocal {
namespace {

// Points of random straight world lines seen through `camera`, each point displaced by
// Gaussian noise of `noise_px`; `curved` more lines bent in the world (arcs).
std::vector<LineObservation> SampleLines(const CameraIntrinsics& camera, int count, int curved,
                                         double noise_px, cv::RNG& rng) {
  std::vector<LineObservation> lines;
  for (int i = 0; i < count + curved; ++i) {
    const double angle = rng.uniform(0.0, M_PI);
    const Eigen::Vector2d normal(std::cos(angle), std::sin(angle));
    const Eigen::Vector2d direction(-normal.y(), normal.x());
    const double offset = rng.uniform(-0.9, 0.9);
    const double bend = i < count ? 0.0 : 0.15;  // Sagitta of an arc, normalized units.
    LineObservation line;
    for (double s = -1.5; s <= 1.5; s += 0.03) {
      const Eigen::Vector2d x = (offset + bend * (1 - s * s)) * normal + s * direction;
      const Eigen::Vector2d pixel = Project(camera, {x.x(), x.y(), 1.0});
      if (pixel.x() < 2 || pixel.y() < 2 || pixel.x() > camera.width - 3 ||
          pixel.y() > camera.height - 3) {
        continue;
      }
      line.points.push_back(pixel +
                            Eigen::Vector2d(rng.gaussian(noise_px), rng.gaussian(noise_px)));
    }
    if (line.points.size() >= 8) lines.push_back(line);
  }
  return lines;
}

TEST(PlumbLine, DefaultOptionsAreValid) {
  std::string error;
  EXPECT_TRUE(PlumbLineOptions().Check(&error)) << error;
  PlumbLineOptions bad;
  bad.outlier_factor = 0.5;
  EXPECT_FALSE(bad.Check(&error));
  EXPECT_NE(error.find("outlier_factor"), std::string::npos);
}

TEST(PlumbLine, RecoversStrongBarrelFromNoDistortion) {
  const CameraIntrinsics truth = test::SonnarLikeCamera(-0.3, 0.1);
  cv::RNG rng(11);
  const auto lines = SampleLines(truth, 30, 0, 0.1, rng);
  const CameraIntrinsics start = test::SonnarLikeCamera(0.0, 0.0);
  const PlumbLineResult result = EstimateDistortion(lines, start, PlumbLineOptions());
  ASSERT_TRUE(result.usable) << result.message;
  const double error = MaxDistortionDifference(result.estimate, truth, 0.9);
  std::printf("%s; worst displacement error %.3f px\n", result.message.c_str(), error);
  EXPECT_LT(error, 0.5) << "px, out to 90% of the half-diagonal";
  EXPECT_GT(result.rms_before_px, 2.0);
  EXPECT_LT(result.rms_after_px, 0.2);
  ASSERT_EQ(result.covariance.rows(), 2);
  EXPECT_GT(result.covariance(0, 0), 0.0);
  EXPECT_LT(std::sqrt(result.covariance(0, 0)), 0.01) << "k1 standard deviation";
}

TEST(PlumbLine, RejectsEdgesCurvedInTheWorld) {
  const CameraIntrinsics truth = test::SonnarLikeCamera(-0.3, 0.1);
  cv::RNG rng(5);
  const auto lines = SampleLines(truth, 30, 4, 0.1, rng);
  const PlumbLineResult result =
      EstimateDistortion(lines, test::SonnarLikeCamera(0, 0), PlumbLineOptions());
  ASSERT_TRUE(result.usable) << result.message;
  EXPECT_GE(result.lines_rejected, 3);
  EXPECT_LT(MaxDistortionDifference(result.estimate, truth, 0.9), 0.5);
}

TEST(PlumbLine, FindsNoSpuriousDistortionOnANearlyPerfectLens) {
  const CameraIntrinsics truth = test::SonnarLikeCamera(-0.001, 0.0);  // Below 0.5 px everywhere.
  cv::RNG rng(2);
  const auto lines = SampleLines(truth, 30, 0, 0.1, rng);
  const PlumbLineResult result =
      EstimateDistortion(lines, test::SonnarLikeCamera(0, 0), PlumbLineOptions());
  ASSERT_TRUE(result.usable) << result.message;
  EXPECT_LT(MaxDistortionDifference(result.estimate, test::SonnarLikeCamera(0, 0), 0.9), 0.5)
      << "against no distortion at all";
  EXPECT_LT(MaxDistortionDifference(result.estimate, truth, 0.9), 0.5);
}

TEST(PlumbLine, FreesTangentialK3AndTheCentreWhenAsked) {
  CameraIntrinsics truth = test::SonnarLikeCamera(-0.28, 0.09);
  truth.p1 = 0.002;
  truth.p2 = -0.0015;
  truth.k3 = -0.01;
  truth.cx += 8.0;
  truth.cy -= 6.0;
  cv::RNG rng(9);
  const auto lines = SampleLines(truth, 60, 0, 0.1, rng);
  CameraIntrinsics start = test::SonnarLikeCamera(0, 0);  // Centre 8 px and 6 px off.
  PlumbLineOptions options;
  options.estimate_tangential = true;
  options.estimate_k3 = true;
  options.estimate_centre = true;
  const PlumbLineResult result = EstimateDistortion(lines, start, options);
  ASSERT_TRUE(result.usable) << result.message;
  EXPECT_LT(MaxDistortionDifference(result.estimate, truth, 0.9), 0.5);
  EXPECT_NEAR(result.estimate.cx, truth.cx, 2.0);
  EXPECT_NEAR(result.estimate.cy, truth.cy, 2.0);
  EXPECT_EQ(result.covariance.rows(), 7) << "k1 k2 p1 p2 k3 cx cy free";
  EXPECT_NEAR(result.estimate.p1, truth.p1, 2e-4);
  EXPECT_NEAR(result.estimate.p2, truth.p2, 2e-4);
  // With k1, k2 alone about the wrong centre, this lens cannot be matched.
  const PlumbLineResult radial_only = EstimateDistortion(lines, start, PlumbLineOptions());
  EXPECT_GT(MaxDistortionDifference(radial_only.estimate, truth, 0.9), 1.0);
}

// `ours` against Ceres' covariance of the intrinsics by dense SVD of the whole Jacobian,
// entry by entry to 1e-6 of the entries' standard deviations.
void ExpectCovarianceMatchesCeresDenseSvd(ceres::Problem* problem, const double* intrinsics,
                                          const Eigen::MatrixXd& ours) {
  ceres::Covariance::Options svd;
  svd.algorithm_type = ceres::DENSE_SVD;
  ceres::Covariance covariance(svd);
  const std::vector<std::pair<const double*, const double*>> block = {{intrinsics, intrinsics}};
  ASSERT_TRUE(covariance.Compute(block, problem));
  Eigen::MatrixXd theirs(ours.rows(), ours.cols());
  covariance.GetCovarianceBlockInTangentSpace(intrinsics, intrinsics, theirs.data());
  for (int a = 0; a < ours.rows(); ++a) {
    for (int b = 0; b < ours.cols(); ++b) {
      EXPECT_NEAR(ours(a, b), theirs(a, b), 1e-6 * std::sqrt(theirs(a, a) * theirs(b, b)))
          << "entry (" << a << ", " << b << ")";
    }
  }
}

// The Schur-complement covariance against Ceres' own, by dense SVD of the whole Jacobian,
// on a solved plumb-line problem whose distortion and centre are free.
TEST(PlumbLine, MarginalCovarianceAgreesWithCeresDenseSvd) {
  const CameraIntrinsics truth = test::SonnarLikeCamera(-0.3, 0.1);
  cv::RNG rng(5);
  const auto observed = SampleLines(truth, 12, 0, 0.3, rng);
  std::vector<const LineObservation*> lines;
  for (const LineObservation& line : observed) lines.push_back(&line);
  ParameterArena arena(kNumIntrinsics + PlumbLineParameterCount(lines));
  double* const intrinsics = arena.Add(truth.Packed());
  ceres::Problem problem;
  auto* ordering = new ceres::ParameterBlockOrdering;
  AddPlumbLineResiduals(lines, truth, 1.0, intrinsics, &problem, ordering, &arena);
  ordering->AddElementToGroup(intrinsics, 1);
  problem.SetManifold(intrinsics, new ceres::SubsetManifold(kNumIntrinsics, {kFx, kFy, kP1, kP2}));
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_SCHUR;
  options.linear_solver_ordering.reset(ordering);
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  ASSERT_TRUE(summary.IsSolutionUsable()) << summary.BriefReport();

  const std::optional<Eigen::MatrixXd> ours = MarginalCovariance(&problem, *ordering, intrinsics);
  ASSERT_TRUE(ours.has_value());
  ASSERT_EQ(ours->rows(), 5);  // cx, cy, k1, k2, k3.
  ExpectCovarianceMatchesCeresDenseSvd(&problem, intrinsics, *ours);
}

// The same on a problem laid out as box 10 lays out its own: a plane's points seen from
// several views, each point on its ray in the plane's reference view (eliminated), the
// views and the plane in group 1, the reference view held and the plane's distance from it
// (the gauge), straight lines as well; fx, fy, cx, cy, k1, k2 free: the complement gathers
// eliminated rays and lines, and keeps views, a plane and the intrinsics.
TEST(PlumbLine, MarginalCovarianceOfAPlaneSeenFromSeveralViewsAgreesWithCeresDenseSvd) {
  const CameraIntrinsics truth = test::SonnarLikeCamera(-0.2, 0.05);
  cv::RNG rng(3);
  const auto observed = SampleLines(truth, 6, 0, 0.3, rng);
  std::vector<const LineObservation*> lines;
  for (const LineObservation& line : observed) lines.push_back(&line);
  std::vector<Eigen::Vector2d> points;
  for (double u = 0.0; u <= 1.6; u += 0.2) {
    for (double v = 0.0; v <= 1.2; v += 0.2) points.emplace_back(u, v);
  }
  // Views turned about the plane's centre, 2 m ahead, by up to 29 deg.
  std::vector<std::array<double, 6>> views = {{0.0, 0.0, 0.0, 0.0, 0.0, 0.0}};
  for (const Eigen::Vector3d& turn :
       {Eigen::Vector3d(0.4, 0.0, 0.1), Eigen::Vector3d(0.0, 0.45, 0.0),
        Eigen::Vector3d(-0.3, -0.3, 0.2), Eigen::Vector3d(0.2, -0.45, -0.1),
        Eigen::Vector3d(-0.35, 0.3, 0.0)}) {
    const Eigen::Vector3d ahead(0.0, 0.0, 2.0);
    const Eigen::Vector3d shift = ahead - Eigen::AngleAxisd(turn.norm(), turn.normalized()) * ahead;
    views.push_back({turn.x(), turn.y(), turn.z(), shift.x(), shift.y(), shift.z()});
  }
  const std::array<double, 3> plane = {0.0, 0.0, 0.5};  // z = 2 in view 0.

  ParameterArena arena(kNumIntrinsics + 6 * views.size() + 3 + 2 * points.size() +
                       PlumbLineParameterCount(lines));
  double* const intrinsics = arena.Add(truth.Packed());
  std::vector<double*> view_blocks;
  for (const auto& view : views) view_blocks.push_back(arena.Add(view));
  double* const plane_block = arena.Add(plane);
  std::vector<double*> ray_blocks;
  for (const Eigen::Vector2d& point : points) {
    ray_blocks.push_back(arena.Add(std::array{(point.x() - 0.8) / 2.0, (point.y() - 0.6) / 2.0}));
  }
  ceres::Problem problem;
  auto* ordering = new ceres::ParameterBlockOrdering;
  const auto noisy = [&](const Eigen::Vector2d& pixel) {
    return Eigen::Vector2d(pixel.x() + rng.gaussian(0.2), pixel.y() + rng.gaussian(0.2));
  };
  for (double* ray : ray_blocks) {
    Eigen::Vector2d pixel;
    const double* seen[] = {intrinsics, ray};
    ASSERT_TRUE(ReferenceRayCost(Eigen::Vector2d::Zero()).Evaluate(seen, pixel.data(), nullptr));
    problem.AddResidualBlock(new ReferenceRayCost(noisy(pixel)), new ceres::CauchyLoss(1.0),
                             intrinsics, ray);
    for (size_t v = 1; v < view_blocks.size(); ++v) {
      ASSERT_TRUE(PlanePointCost(Eigen::Vector2d::Zero())
                      .Residual(intrinsics, view_blocks[v], view_blocks[0], plane_block, ray,
                                pixel.data()));
      problem.AddResidualBlock(new PlanePointCost(noisy(pixel)), new ceres::CauchyLoss(1.0),
                               intrinsics, view_blocks[v], view_blocks[0], plane_block, ray);
    }
    ordering->AddElementToGroup(ray, 0);
  }
  problem.SetParameterBlockConstant(view_blocks[0]);
  for (double* view : view_blocks) ordering->AddElementToGroup(view, 1);
  problem.SetManifold(plane_block, new ceres::SphereManifold<3>());
  ordering->AddElementToGroup(plane_block, 1);
  AddPlumbLineResiduals(lines, truth, 1.0, intrinsics, &problem, ordering, &arena);
  problem.SetManifold(intrinsics, new ceres::SubsetManifold(kNumIntrinsics, {kP1, kP2, kK3}));
  ordering->AddElementToGroup(intrinsics, 1);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.linear_solver_ordering.reset(ordering);
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  ASSERT_TRUE(summary.IsSolutionUsable()) << summary.BriefReport();

  const std::optional<Eigen::MatrixXd> ours = MarginalCovariance(&problem, *ordering, intrinsics);
  ASSERT_TRUE(ours.has_value());
  ASSERT_EQ(ours->rows(), 6);  // fx, fy, cx, cy, k1, k2.
  ExpectCovarianceMatchesCeresDenseSvd(&problem, intrinsics, *ours);
  // fx is known from the views (the lines alone leave it free).
  EXPECT_LT(std::sqrt((*ours)(0, 0)), 0.02 * truth.fx);
}

// The residual runs from the observed pixel to the nearest point of the line's image: as
// long as the shortest of a dense sampling of the line, and square to the line's image
// there. On a strong barrel with tangential terms (every intrinsics column is exercised),
// at points near the centre and out in the corners, the search starting well off.
TEST(PlumbLine, LinePointCostRunsToTheNearestPointOfTheLinesImage) {
  CameraIntrinsics camera = test::SonnarLikeCamera(-0.31, 0.12);
  camera.p1 = 0.002;
  camera.p2 = -0.0015;
  camera.k3 = -0.02;
  const std::array<double, kNumIntrinsics> intrinsics = camera.Packed();
  const auto pixel_at = [&](double theta, double rho, double s) {
    const Eigen::Vector2d point = rho * Eigen::Vector2d(std::cos(theta), std::sin(theta)) +
                                  s * Eigen::Vector2d(-std::sin(theta), std::cos(theta));
    return Project(camera, {point.x(), point.y(), 1.0});
  };
  for (const auto& [theta, rho, s] : {std::array{0.3, 0.05, -0.1}, std::array{1.9, -0.45, 0.6},
                                      std::array{-2.6, 0.7, -0.55}}) {
    // 3 px off the line's image, across it.
    const Eigen::Vector2d on = pixel_at(theta, rho, s);
    const Eigen::Vector2d tangent = (pixel_at(theta, rho, s + 1e-6) - on).normalized();
    const Eigen::Vector2d observed = on + 3.0 * Eigen::Vector2d(-tangent.y(), tangent.x());
    const LinePointCost cost(observed, s + 0.05);
    const std::array<double, 2> line = {theta, rho};
    const double* parameters[] = {intrinsics.data(), line.data()};
    double residual[2];
    ASSERT_TRUE(cost.Evaluate(parameters, residual, nullptr));
    double nearest = std::numeric_limits<double>::infinity();
    for (double t = s - 0.2; t <= s + 0.2; t += 1e-6) {
      nearest = std::min(nearest, (pixel_at(theta, rho, t) - observed).norm());
    }
    const Eigen::Vector2d r(residual[0], residual[1]);
    EXPECT_NEAR(r.norm(), nearest, 1e-6) << "line " << theta << " " << rho;
    EXPECT_NEAR(r.norm(), 3.0, 0.05);
    EXPECT_LT(std::abs(r.normalized().dot(tangent)), 1e-3) << "the residual is square to the line";
  }
}

// The Jacobian worked by hand: with the position along the line eliminated, it is the
// derivative of the residual wherever the point lies on the line's image (elsewhere it
// leaves out a term in the residual times the image's curvature, Kaufman's approximation).
// Against central differences, on the same lens, the observed pixel on the line's image
// and the search starting well off it.
TEST(PlumbLine, LinePointCostDerivativesOnTheLine) {
  CameraIntrinsics camera = test::SonnarLikeCamera(-0.31, 0.12);
  camera.p1 = 0.002;
  camera.p2 = -0.0015;
  camera.k3 = -0.02;
  for (const auto& [theta, rho, s] : {std::array{0.3, 0.05, -0.1}, std::array{1.9, -0.45, 0.6},
                                      std::array{-2.6, 0.7, -0.55}}) {
    const Eigen::Vector2d point = rho * Eigen::Vector2d(std::cos(theta), std::sin(theta)) +
                                  s * Eigen::Vector2d(-std::sin(theta), std::cos(theta));
    const LinePointCost cost(Project(camera, {point.x(), point.y(), 1.0}), s - 0.05);
    std::array<double, kNumIntrinsics> intrinsics = camera.Packed();
    std::array<double, 2> line = {theta, rho};
    EXPECT_TRUE(test::ExpectJacobianMatchesCentralDifferences(
        cost, {intrinsics.data(), line.data()},
        "line " + std::to_string(theta) + " " + std::to_string(rho) + " at " + std::to_string(s)));
  }
}

TEST(PlumbLine, SaysWhyWhenThereAreTooFewLines) {
  cv::RNG rng(1);
  const auto lines = SampleLines(test::SonnarLikeCamera(-0.3, 0.1), 3, 0, 0.1, rng);
  const PlumbLineResult result =
      EstimateDistortion(lines, test::SonnarLikeCamera(0, 0), PlumbLineOptions());
  EXPECT_FALSE(result.usable);
  EXPECT_NE(result.message.find("lines"), std::string::npos) << result.message;
}

TEST(PlumbLine, ScalingToAnotherFocalKeepsThePixelMap) {
  CameraIntrinsics camera = test::SonnarLikeCamera(-0.3, 0.1);
  camera.fy = camera.fx;
  const CameraIntrinsics scaled =
      ScaleDistortionToFocal(camera, 1.05 * camera.fx, 1.05 * camera.fy);
  // Undistorted pixel positions relative to the centre agree for every pixel.
  for (int y = 0; y < camera.height; y += 40) {
    for (int x = 0; x < camera.width; x += 40) {
      const auto a = Unproject(camera, {x, y}), b = Unproject(scaled, {x, y});
      ASSERT_TRUE(a && b);
      EXPECT_NEAR(camera.fx * a->x(), scaled.fx * b->x(), 1e-6);
      EXPECT_NEAR(camera.fy * a->y(), scaled.fy * b->y(), 1e-6);
    }
  }
}

}  // namespace
}  // namespace autocal
