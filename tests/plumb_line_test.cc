#include "pipeline/plumb_line.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <stdexcept>
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

// Every entry within 1e-6 of the geometric mean of the two sigmas it pairs.
void ExpectCovariancesMatch(const Eigen::MatrixXd& ours, const Eigen::MatrixXd& theirs) {
  ASSERT_EQ(ours.rows(), theirs.rows());
  for (int a = 0; a < ours.rows(); ++a) {
    for (int b = 0; b < ours.cols(); ++b) {
      EXPECT_NEAR(ours(a, b), theirs(a, b), 1e-6 * std::sqrt(theirs(a, a) * theirs(b, b)))
          << "entry (" << a << ", " << b << ")";
    }
  }
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
  ExpectCovariancesMatch(ours, theirs);
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
  AddPlumbLineResiduals(lines, truth, new ceres::CauchyLoss(1.0), intrinsics, &problem, ordering,
                        &arena);
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

// A problem laid out as box 10 lays out its own: a plane's points seen from several views,
// each point on its ray in the plane's reference view (eliminated), the views and the plane
// in group 1, the reference view held and the plane's distance from it (the gauge), straight
// lines as well; fx, fy, cx, cy, k1, k2 free. `noise(point, view)` displaces each observed
// pixel. Solved on construction.
class PlaneSeenFromViews {
 public:
  // Views turned about the plane's centre, 2 m ahead, by up to 29 deg.
  static std::vector<Eigen::Vector3d> ScatteredTurns() {
    return {Eigen::Vector3d(0.4, 0.0, 0.1), Eigen::Vector3d(0.0, 0.45, 0.0),
            Eigen::Vector3d(-0.3, -0.3, 0.2), Eigen::Vector3d(0.2, -0.45, -0.1),
            Eigen::Vector3d(-0.35, 0.3, 0.0)};
  }

  PlaneSeenFromViews(const CameraIntrinsics& truth, cv::RNG& rng,
                     const std::function<Eigen::Vector2d(int, int)>& noise,
                     const std::vector<Eigen::Vector3d>& turns = ScatteredTurns())
      : observed_lines_(SampleLines(truth, 6, 0, 0.3, rng)) {
    std::vector<const LineObservation*> lines;
    for (const LineObservation& line : observed_lines_) lines.push_back(&line);
    std::vector<Eigen::Vector2d> points;
    for (double u = 0.0; u <= 1.6; u += 0.2) {
      for (double v = 0.0; v <= 1.2; v += 0.2) points.emplace_back(u, v);
    }
    // The views turned by `turns` about the plane's centre, 2 m ahead.
    std::vector<std::array<double, 6>> views = {{0.0, 0.0, 0.0, 0.0, 0.0, 0.0}};
    for (const Eigen::Vector3d& turn : turns) {
      const Eigen::Vector3d ahead(0.0, 0.0, 2.0);
      const Eigen::Vector3d shift =
          ahead - Eigen::AngleAxisd(turn.norm(), turn.normalized()) * ahead;
      views.push_back({turn.x(), turn.y(), turn.z(), shift.x(), shift.y(), shift.z()});
    }
    const std::array<double, 3> plane = {0.0, 0.0, 0.5};  // z = 2 in view 0.

    arena_ = std::make_unique<ParameterArena>(kNumIntrinsics + 6 * views.size() + 3 +
                                              2 * points.size() + PlumbLineParameterCount(lines));
    intrinsics = arena_->Add(truth.Packed());
    std::vector<double*> view_blocks;
    for (const auto& view : views) view_blocks.push_back(arena_->Add(view));
    double* const plane_block = arena_->Add(plane);
    for (const Eigen::Vector2d& point : points) {
      ray_blocks.push_back(
          arena_->Add(std::array{(point.x() - 0.8) / 2.0, (point.y() - 0.6) / 2.0}));
    }
    ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (size_t p = 0; p < ray_blocks.size(); ++p) {
      double* const ray = ray_blocks[p];
      Eigen::Vector2d pixel;
      const double* seen[] = {intrinsics, ray};
      if (!ReferenceRayCost(Eigen::Vector2d::Zero()).Evaluate(seen, pixel.data(), nullptr)) {
        throw std::logic_error("a point's ray does not project");
      }
      problem.AddResidualBlock(new ReferenceRayCost(pixel + noise(int(p), 0)),
                               new ceres::CauchyLoss(1.0), intrinsics, ray);
      for (size_t v = 1; v < view_blocks.size(); ++v) {
        if (!PlanePointCost(Eigen::Vector2d::Zero())
                 .Residual(intrinsics, view_blocks[v], view_blocks[0], plane_block, ray,
                           pixel.data())) {
          throw std::logic_error("a point does not project into a view");
        }
        problem.AddResidualBlock(new PlanePointCost(pixel + noise(int(p), int(v))),
                                 new ceres::CauchyLoss(1.0), intrinsics, view_blocks[v],
                                 view_blocks[0], plane_block, ray);
      }
      ordering->AddElementToGroup(ray, 0);
    }
    problem.SetParameterBlockConstant(view_blocks[0]);
    for (double* view : view_blocks) ordering->AddElementToGroup(view, 1);
    problem.SetManifold(plane_block, new ceres::SphereManifold<3>());
    ordering->AddElementToGroup(plane_block, 1);
    line_blocks = AddPlumbLineResiduals(lines, truth, new ceres::CauchyLoss(1.0), intrinsics,
                                        &problem, ordering.get(), arena_.get());
    problem.SetManifold(intrinsics, new ceres::SubsetManifold(kNumIntrinsics, {kP1, kP2, kK3}));
    ordering->AddElementToGroup(intrinsics, 1);
    ceres::Solver::Options options;
    options.linear_solver_type = ceres::DENSE_SCHUR;
    options.linear_solver_ordering = ordering;
    ceres::Solve(options, &problem, &summary);
  }

  ceres::Problem problem;
  std::shared_ptr<ceres::ParameterBlockOrdering> ordering;
  ceres::Solver::Summary summary;
  double* intrinsics = nullptr;
  std::vector<double*> ray_blocks;   // One per point.
  std::vector<double*> line_blocks;  // One per line.

 private:
  std::vector<LineObservation> observed_lines_;
  std::unique_ptr<ParameterArena> arena_;
};

// The Schur complement gathers eliminated rays and lines, and keeps views, a plane and the
// intrinsics.
TEST(PlumbLine, MarginalCovarianceOfAPlaneSeenFromSeveralViewsAgreesWithCeresDenseSvd) {
  const CameraIntrinsics truth = test::SonnarLikeCamera(-0.2, 0.05);
  cv::RNG rng(3);
  PlaneSeenFromViews solved(
      truth, rng, [&](int, int) { return Eigen::Vector2d(rng.gaussian(0.2), rng.gaussian(0.2)); });
  ASSERT_TRUE(solved.summary.IsSolutionUsable()) << solved.summary.BriefReport();

  const std::optional<Eigen::MatrixXd> ours =
      MarginalCovariance(&solved.problem, *solved.ordering, solved.intrinsics);
  ASSERT_TRUE(ours.has_value());
  ASSERT_EQ(ours->rows(), 6);  // fx, fy, cx, cy, k1, k2.
  ExpectCovarianceMatchesCeresDenseSvd(&solved.problem, solved.intrinsics, *ours);
  // fx is known from the views (the lines alone leave it free).
  EXPECT_LT(std::sqrt((*ours)(0, 0)), 0.02 * truth.fx);
}

// The clustered covariance against the sandwich formed whole: the dense Jacobian J of every
// free parameter, H = J^T J, each point's and each line's residuals one cluster and the
// rest one each, H^-1 (sum of J_c^T r_c r_c^T J_c) H^-1 over the intrinsics, times n/(n-1).
TEST(PlumbLine, ClusteredCovarianceAgreesWithTheWholeSandwich) {
  const CameraIntrinsics truth = test::SonnarLikeCamera(-0.2, 0.05);
  cv::RNG rng(4);
  PlaneSeenFromViews solved(
      truth, rng, [&](int, int) { return Eigen::Vector2d(rng.gaussian(0.3), rng.gaussian(0.3)); });
  ASSERT_TRUE(solved.summary.IsSolutionUsable()) << solved.summary.BriefReport();
  Eigen::MatrixXd ours;
  ASSERT_TRUE(
      MarginalCovariance(&solved.problem, *solved.ordering, solved.intrinsics, &ours).has_value());

  // The free blocks with the intrinsics last; residual blocks in an order whose clusters
  // are known.
  std::vector<double*> blocks;
  solved.problem.GetParameterBlocks(&blocks);
  std::erase_if(blocks, [&](double* block) {
    return block == solved.intrinsics || solved.problem.IsParameterBlockConstant(block);
  });
  blocks.push_back(solved.intrinsics);
  std::vector<ceres::ResidualBlockId> residual_blocks;
  std::vector<int> cluster_of_block;
  int clusters = 0;
  for (const auto& group : {solved.ray_blocks, solved.line_blocks}) {
    for (double* block : group) {
      std::vector<ceres::ResidualBlockId> seeing;
      solved.problem.GetResidualBlocksForParameterBlock(block, &seeing);
      for (ceres::ResidualBlockId id : seeing) {
        residual_blocks.push_back(id);
        cluster_of_block.push_back(clusters);
      }
      ++clusters;
    }
  }
  std::vector<ceres::ResidualBlockId> all;
  solved.problem.GetResidualBlocks(&all);
  for (ceres::ResidualBlockId id : all) {
    if (std::find(residual_blocks.begin(), residual_blocks.end(), id) == residual_blocks.end()) {
      residual_blocks.push_back(id);
      cluster_of_block.push_back(-1);
    }
  }
  ceres::Problem::EvaluateOptions evaluate;
  evaluate.parameter_blocks = blocks;
  evaluate.residual_blocks = residual_blocks;
  std::vector<double> residuals;
  ceres::CRSMatrix crs;
  ASSERT_TRUE(solved.problem.Evaluate(evaluate, nullptr, &residuals, nullptr, &crs));
  Eigen::MatrixXd jacobian = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int row = 0; row < crs.num_rows; ++row) {
    for (int k = crs.rows[row]; k < crs.rows[row + 1]; ++k) {
      jacobian(row, crs.cols[k]) = crs.values[k];
    }
  }
  const Eigen::Map<const Eigen::VectorXd> r(residuals.data(), Eigen::Index(residuals.size()));
  std::vector<Eigen::VectorXd> gradients(clusters, Eigen::VectorXd::Zero(crs.num_cols));
  int row = 0;
  for (size_t b = 0; b < residual_blocks.size(); ++b) {
    const int size =
        solved.problem.GetCostFunctionForResidualBlock(residual_blocks[b])->num_residuals();
    for (int i = 0; i < size; ++i, ++row) {
      const Eigen::VectorXd g = jacobian.row(row).transpose() * r(row);
      if (cluster_of_block[b] >= 0) {
        gradients[cluster_of_block[b]] += g;
      } else {
        gradients.push_back(g);
      }
    }
  }
  ASSERT_EQ(row, crs.num_rows);
  Eigen::MatrixXd scatter = Eigen::MatrixXd::Zero(crs.num_cols, crs.num_cols);
  for (const Eigen::VectorXd& g : gradients) scatter += g * g.transpose();
  const Eigen::MatrixXd inverse = (jacobian.transpose() * jacobian).inverse();
  const int free = int(ours.rows());
  ASSERT_EQ(free, 6);
  const Eigen::MatrixXd rows = inverse.bottomRows(free);
  const double n = double(gradients.size());
  ExpectCovariancesMatch(ours, rows * scatter * rows.transpose() * n / (n - 1.0));
}

// Where each point's error carries over from view to view (a random walk, as Lucas-Kanade's
// drift), the clustered sigma of fx is what fx scatters by over many draws of the noise,
// and the sigma that takes the views for independent is too small.
TEST(PlumbLine, ClusteredSigmaIsWhatTheFocalLengthScattersByWhenTracksDrift) {
  const CameraIntrinsics truth = test::SonnarLikeCamera(-0.2, 0.05);
  cv::RNG rng(7);
  constexpr int kDraws = 80;
  // A sweep of 15 views, turning on two axes by 2 deg a view.
  std::vector<Eigen::Vector3d> sweep;
  for (int view = 1; view < 20; ++view) {
    sweep.push_back(Eigen::Vector3d(0.0225, -0.015, 0.004) * view);
  }
  double sum_sq_error = 0.0, sum_clustered = 0.0, sum_independent = 0.0;
  for (int draw = 0; draw < kDraws; ++draw) {
    std::vector<Eigen::Vector2d> drift;
    PlaneSeenFromViews solved(
        truth, rng,
        [&](int point, int view) {
          if (view == 0) drift.emplace_back(0.0, 0.0);
          drift[point] += Eigen::Vector2d(rng.gaussian(0.1), rng.gaussian(0.1));
          return drift[point];
        },
        sweep);
    ASSERT_TRUE(solved.summary.IsSolutionUsable()) << solved.summary.BriefReport();
    Eigen::MatrixXd clustered;
    const std::optional<Eigen::MatrixXd> unit =
        MarginalCovariance(&solved.problem, *solved.ordering, solved.intrinsics, &clustered);
    ASSERT_TRUE(unit.has_value());
    // The independent sigma as box 10 used to scale it: by the residuals' RMS.
    const double rms_sq = 2.0 * solved.summary.final_cost / solved.summary.num_residuals;
    sum_sq_error += std::pow(solved.intrinsics[kFx] - truth.fx, 2);
    sum_clustered += clustered(0, 0);
    sum_independent += rms_sq * (*unit)(0, 0);
  }
  const double scatter = std::sqrt(sum_sq_error / kDraws);
  const double clustered = std::sqrt(sum_clustered / kDraws);
  const double independent = std::sqrt(sum_independent / kDraws);
  EXPECT_NEAR(clustered / scatter, 1.0, 0.3)
      << "scatter " << scatter << " px, clustered " << clustered << " px";
  EXPECT_LT(independent / scatter, 0.65)
      << "scatter " << scatter << " px, independent " << independent << " px";
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
