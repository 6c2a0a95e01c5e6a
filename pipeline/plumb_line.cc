#include "pipeline/plumb_line.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string_view>

#include <ceres/ceres.h>
#include <Eigen/Cholesky>

#include "pipeline/line_detector.h"
#include "pipeline/plumb_line_problem.h"
#include "pipeline/text_format.h"

namespace autocal {

bool PlumbLineOptions::Check(std::string* error) const {
  std::ostringstream why;
  if (!(loss_scale_px > 0)) {
    why << "loss_scale_px must be positive";
  } else if (!(outlier_factor > 1)) {
    why << "outlier_factor must be above 1";
  } else if (min_lines < 2) {
    why << "min_lines must be at least 2";
  } else if (min_points_per_line < 3) {
    why << "min_points_per_line must be at least 3";
  } else if (max_iterations < 1) {
    why << "max_iterations must be at least 1";
  } else if (!(min_covered_radius >= 0 && min_covered_radius <= 1.5)) {
    why << "min_covered_radius must be in [0, 1.5]";
  } else if (!(max_direction_share > 0 && max_direction_share <= 1)) {
    why << "max_direction_share must be in (0, 1]";
  } else if (!(max_sigma_px > 0)) {
    why << "max_sigma_px must be positive";
  } else if (!(min_straightening >= 0 && min_straightening < 1)) {
    why << "min_straightening must be in [0, 1)";
  }
  if (why.str().empty()) return true;
  if (error) *error = why.str();
  return false;
}

namespace {

// Newton steps inside the residual: converges to machine precision from the distorted
// point for the barrel lenses we meet (|k1| <= 0.4 out to the image corners).
constexpr int kNewtonSteps = 10;

// Scale of the robust loss while far from the answer, px.
constexpr double kCoarseLossPx = 5.0;

// The least median straightness a line is judged against, px: below it a snake's shape is
// as straight as its edge localization allows, and a pool of such lines would otherwise
// call good lines curved on their noise.
constexpr double kLineNoiseFloorPx = 0.05;

std::vector<Eigen::Vector2d> Undistorted(const LineObservation& line, const CameraIntrinsics& c) {
  std::vector<Eigen::Vector2d> points;
  const auto dist = c.Distortion();
  for (const Eigen::Vector2d& p : line.points) {
    double x, y;
    UndistortNormalizedNewton(dist.data(), (p.x() - c.cx) / c.fx, (p.y() - c.cy) / c.fy,
                              kNewtonSteps, &x, &y);
    points.emplace_back(x, y);
  }
  return points;
}

// RMS distance (px) of each line's undistorted points to its own best straight line.
std::vector<double> PerLineRms(const std::vector<const LineObservation*>& lines,
                               const CameraIntrinsics& camera) {
  std::vector<double> rms;
  for (const LineObservation* line : lines) {
    rms.push_back(camera.fx * FitLine(Undistorted(*line, camera)).rms);
  }
  return rms;
}

double PooledRms(const std::vector<const LineObservation*>& lines,
                 const std::vector<double>& per_line) {
  double sum = 0.0;
  size_t count = 0;
  for (size_t i = 0; i < lines.size(); ++i) {
    sum += per_line[i] * per_line[i] * lines[i]->points.size();
    count += lines[i]->points.size();
  }
  return count ? std::sqrt(sum / double(count)) : 0.0;
}

struct Solve {
  bool converged = false;
  std::string report;
  std::array<double, kNumIntrinsics> intrinsics;
  Eigen::MatrixXd covariance;
};

// `with_covariance`: only the last solve's is kept.
Solve SolveOnce(const std::vector<const LineObservation*>& lines, const CameraIntrinsics& start,
                const PlumbLineOptions& options, double loss_scale_px, bool with_covariance) {
  Solve solve;
  ParameterArena arena(kNumIntrinsics + PlumbLineParameterCount(lines));
  double* const intrinsics = arena.Add(start.Packed());
  // One loss for every residual, outliving the problem: not one allocated for each.
  ceres::CauchyLoss loss(loss_scale_px);
  ceres::Problem problem(UnownedLosses());
  auto* ordering = new ceres::ParameterBlockOrdering;
  AddPlumbLineResiduals(lines, start, &loss, intrinsics, &problem, ordering, &arena);
  ordering->AddElementToGroup(intrinsics, 1);
  std::vector<int> fixed = {kFx, kFy};
  if (!options.estimate_centre) fixed.insert(fixed.end(), {kCx, kCy});
  if (!options.estimate_tangential) fixed.insert(fixed.end(), {kP1, kP2});
  if (!options.estimate_k3) fixed.push_back(kK3);
  problem.SetManifold(intrinsics, new ceres::SubsetManifold(kNumIntrinsics, fixed));

  ceres::Solver::Options solver_options;
  // The lines are eliminated first (Schur complement), as points in bundle adjustment.
  solver_options.linear_solver_type = ceres::SPARSE_SCHUR;
  solver_options.linear_solver_ordering.reset(ordering);
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  solve.converged = summary.IsSolutionUsable();
  solve.report = summary.BriefReport();
  if (!solve.converged) return solve;
  std::copy_n(intrinsics, kNumIntrinsics, solve.intrinsics.begin());

  if (!with_covariance) return solve;
  // A line's points are one cluster: an edge's localization errors run along it. The unit
  // covariance at 0.01 px keeps noiseless material from claiming certainty.
  Eigen::MatrixXd clustered;
  if (auto covariance = MarginalCovariance(&problem, *ordering, intrinsics, &clustered)) {
    solve.covariance = clustered + 1e-4 * *covariance;
  }
  return solve;
}

// A change of the lens this large (px) must show in the lines' straightness: a refinement
// of a good initial lens by a pixel or so barely moves the residual, and is no sign.
constexpr double kLargeChangePx = 2.0;

// Pixels at which an estimate's shift is judged: rings about the principal point out to
// `radius` (px), those inside the image.
std::vector<Eigen::Vector2d> SamplePixels(const CameraIntrinsics& camera, double radius) {
  constexpr int kRings = 8, kAngles = 24;
  std::vector<Eigen::Vector2d> pixels;
  for (int ring = 1; ring <= kRings; ++ring) {
    const double r = radius * ring / kRings;
    for (int a = 0; a < kAngles; ++a) {
      const double angle = 2.0 * M_PI * a / kAngles;
      const Eigen::Vector2d p(camera.cx + r * std::cos(angle), camera.cy + r * std::sin(angle));
      if (p.x() >= 0 && p.y() >= 0 && p.x() <= camera.width - 1 && p.y() <= camera.height - 1) {
        pixels.push_back(p);
      }
    }
  }
  return pixels;
}

// The free intrinsics of a solve, in its covariance's order.
std::vector<int> FreeIntrinsics(const PlumbLineOptions& options) {
  std::vector<int> free;
  if (options.estimate_centre) free.insert(free.end(), {kCx, kCy});
  free.insert(free.end(), {kK1, kK2});
  if (options.estimate_tangential) free.insert(free.end(), {kP1, kP2});
  if (options.estimate_k3) free.push_back(kK3);
  return free;
}

DistortionObservability Assess(const std::vector<const LineObservation*>& lines,
                               const CameraIntrinsics& initial, const CameraIntrinsics& estimate,
                               const Eigen::MatrixXd& covariance, double rms_before,
                               double rms_after, const PlumbLineOptions& options) {
  DistortionObservability o;
  const double half_diagonal = 0.5 * std::hypot(estimate.width, estimate.height);
  std::vector<double> radii;
  struct Direction {
    double theta;
    int points;
  };
  std::vector<Direction> directions;
  int total = 0;
  for (const LineObservation* line : lines) {
    for (const Eigen::Vector2d& p : line->points) {
      const double r = std::hypot(p.x() - estimate.cx, p.y() - estimate.cy) / half_diagonal;
      radii.push_back(r);
      ++o.radial_points[std::min(int(r * o.kRadialBins), o.kRadialBins - 1)];
    }
    directions.push_back({FitLine(Undistorted(*line, estimate)).theta, int(line->points.size())});
    total += int(line->points.size());
  }
  if (!radii.empty()) {
    const size_t at = std::min(radii.size() - 1, size_t(0.95 * double(radii.size())));
    std::nth_element(radii.begin(), radii.begin() + at, radii.end());
    o.covered_radius = radii[at];
  }
  constexpr double kSameDirection = 20.0 * M_PI / 180.0;
  for (const Direction& a : directions) {
    int share = 0;
    for (const Direction& b : directions) {
      const double d = std::abs(std::remainder(a.theta - b.theta, M_PI));
      if (d <= kSameDirection) share += b.points;
    }
    o.direction_share = std::max(o.direction_share, total ? double(share) / total : 0.0);
  }

  // The shift (raw pixel to the pinhole image of its ray) and its spread under the
  // covariance, by central differences over each free parameter's own sigma.
  const std::vector<int> free = FreeIntrinsics(options);
  const bool have_covariance = covariance.rows() == Eigen::Index(free.size()) &&
                               covariance.cols() == Eigen::Index(free.size());
  const auto shift_at = [](const CameraIntrinsics& camera, const Eigen::Vector2d& pixel) {
    return UndistortPixel(camera, pixel);
  };
  bool undistortable = true;
  for (const Eigen::Vector2d& pixel : SamplePixels(estimate, o.covered_radius * half_diagonal)) {
    const auto ideal = shift_at(estimate, pixel);
    if (!ideal) {
      undistortable = false;
      continue;
    }
    o.max_shift_px = std::max(o.max_shift_px, (pixel - *ideal).norm());
    if (const auto ray = Unproject(estimate, pixel)) {
      o.change_px = std::max(o.change_px, (Project(initial, {ray->x(), ray->y(), 1.0}) - pixel).norm());
    }
    if (!have_covariance) continue;
    Eigen::MatrixXd jacobian(2, Eigen::Index(free.size()));
    bool differentiable = true;
    for (size_t i = 0; i < free.size(); ++i) {
      const double step = std::max(1e-3 * std::sqrt(std::max(covariance(i, i), 0.0)), 1e-12);
      auto packed = estimate.Packed();
      packed[free[i]] += step;
      const auto plus = shift_at(CameraIntrinsics::FromPacked(packed, estimate.width, estimate.height), pixel);
      packed[free[i]] -= 2 * step;
      const auto minus = shift_at(CameraIntrinsics::FromPacked(packed, estimate.width, estimate.height), pixel);
      if (!plus || !minus) {
        differentiable = false;
        break;
      }
      jacobian.col(Eigen::Index(i)) = (*plus - *minus) / (2 * step);
    }
    if (!differentiable) continue;
    const Eigen::Matrix2d spread = jacobian * covariance * jacobian.transpose();
    o.shift_sigma_px = std::max(o.shift_sigma_px,
                                std::sqrt(std::max(spread.selfadjointView<Eigen::Upper>().eigenvalues().maxCoeff(), 0.0)));
  }

  std::ostringstream why, brief;
  why << std::fixed << std::setprecision(0);
  brief << std::fixed << std::setprecision(0);
  const double covered_percent = std::round(100 * o.covered_radius);
  if (o.covered_radius < options.min_covered_radius) {
    why << "the lines reach only " << covered_percent << "% of the half-diagonal from the principal point ("
        << 100 * options.min_covered_radius << "% needed), where the lens bends them little";
    brief << "lines reach only " << covered_percent << "%";
  } else if (o.direction_share > options.max_direction_share) {
    why << 100 * o.direction_share << "% of the line points run within 20 deg of one direction ("
        << 100 * options.max_direction_share << "% allowed): one direction only";
    brief << "lines in one direction only";
  } else if (!have_covariance) {
    why << "the lines leave the distortion free (singular covariance)";
    brief << "lines leave it free";
  } else if (!undistortable) {
    why << "the estimate folds the image within " << covered_percent << "% of the half-diagonal";
    brief << "the estimate folds the image";
  } else if (o.shift_sigma_px > options.max_sigma_px) {
    why << "the shift within " << covered_percent << "% of the half-diagonal is uncertain by "
        << std::setprecision(2) << o.shift_sigma_px << " px (1-sigma; " << options.max_sigma_px
        << " px allowed)";
    brief << std::setprecision(1) << "uncertain by " << o.shift_sigma_px << " px";
  } else if (o.change_px > std::max(kLargeChangePx, 5.0 * o.shift_sigma_px) &&
             rms_after > (1.0 - options.min_straightening) * rms_before) {
    why << std::setprecision(3) << "the lines are about as straight under the initial lens ("
        << rms_before << " px) as under the estimate (" << rms_after << " px), which moves it by "
        << std::setprecision(1) << o.change_px << " px within " << std::setprecision(0)
        << covered_percent << "% of the half-diagonal";
    brief << "lines as straight without it";
  }
  o.brief_reason = brief.str();
  o.reason = why.str();
  o.observable = o.reason.empty();
  return o;
}

}  // namespace

double* ParameterArena::Add(std::span<const double> initial) {
  if (values_.size() + initial.size() > values_.capacity()) {
    throw std::logic_error("ParameterArena: more parameters than its capacity");
  }
  const size_t start = values_.size();
  values_.insert(values_.end(), initial.begin(), initial.end());
  return values_.data() + start;
}

// The Gauss-Newton Hessian is never formed whole: each group-0 block's rows are gathered,
// the block eliminated on the spot, and what it leaves added to a dense matrix over the
// other columns (views, planes, intrinsics: about 150 on a 2 s window), which is then
// factored. Ceres' Covariance factors the whole Jacobian by sparse QR instead: most of a
// solve's time, and on TBB threads it sums in an order that varies between runs. Eigen's
// sparse products and a sparse LDLT of the same complement took 8-10 ms of a box 10 solve
// at 640x480; this takes 3.6 ms less on average (outdoor walk, 58 solves: 49.6 -> 46.0 ms).
std::optional<Eigen::MatrixXd> MarginalCovariance(ceres::Problem* problem,
                                                  const ceres::ParameterBlockOrdering& ordering,
                                                  double* intrinsics, Eigen::MatrixXd* clustered) {
  std::vector<double*> blocks;
  std::vector<int> offsets;  // Of each block's first column.
  int columns = 0;
  auto take = [&](double* block) {
    if (block == intrinsics || problem->IsParameterBlockConstant(block)) return;
    blocks.push_back(block);
    offsets.push_back(columns);
    columns += problem->ParameterBlockTangentSize(block);
  };
  for (double* block : ordering.group_to_elements().at(0)) take(block);
  const int eliminated_blocks = int(blocks.size());
  const int eliminated = columns;
  for (double* block : ordering.group_to_elements().at(1)) take(block);
  const int intrinsics_column = columns;
  blocks.push_back(intrinsics);
  columns += problem->ParameterBlockTangentSize(intrinsics);

  ceres::Problem::EvaluateOptions evaluate;
  evaluate.parameter_blocks = blocks;
  ceres::CRSMatrix crs;
  std::vector<double> residuals;
  if (!problem->Evaluate(evaluate, nullptr, clustered ? &residuals : nullptr, nullptr, &crs) ||
      crs.num_cols != columns) {
    return std::nullopt;
  }
  std::vector<int> block_of_column(eliminated);
  for (int b = 0; b < eliminated_blocks; ++b) {
    const int end = b + 1 < eliminated_blocks ? offsets[b + 1] : eliminated;
    std::fill(block_of_column.begin() + offsets[b], block_of_column.begin() + end, b);
  }

  // J_c^T J_c row by row, and each row filed under the group-0 block it sees, if any. Only
  // the upper triangle is summed, here and below; the lower is copied from it at the end.
  const int kept = columns - eliminated;
  Eigen::MatrixXd schur = Eigen::MatrixXd::Zero(kept, kept);
  // The clusters' gradients reduced to the kept columns (the eliminated blocks' share moved
  // onto them as the Schur complement moves their stiffness), summed as outer products.
  Eigen::MatrixXd scatter;
  int clusters = 0;
  if (clustered) scatter = Eigen::MatrixXd::Zero(kept, kept);
  std::vector<std::vector<int>> rows_of_block(eliminated_blocks);
  for (int row = 0; row < crs.num_rows; ++row) {
    const int first = crs.rows[row], last = crs.rows[row + 1];
    int block = -1;
    for (int k = first; k < last; ++k) {
      const int column = crs.cols[k];
      if (column < eliminated) {
        if (block >= 0 && block != block_of_column[column]) {
          throw std::logic_error("MarginalCovariance: a residual sees two eliminated blocks");
        }
        block = block_of_column[column];
        continue;
      }
      for (int l = k; l < last; ++l) {
        if (crs.cols[l] < eliminated) continue;
        const int a = column - eliminated, b = crs.cols[l] - eliminated;
        schur(std::min(a, b), std::max(a, b)) += crs.values[k] * crs.values[l];
      }
    }
    if (block >= 0) {
      rows_of_block[block].push_back(row);
    } else if (clustered) {
      for (int k = first; k < last; ++k) {
        for (int l = k; l < last; ++l) {
          const int a = crs.cols[k] - eliminated, b = crs.cols[l] - eliminated;
          scatter(std::min(a, b), std::max(a, b)) +=
              crs.values[k] * crs.values[l] * residuals[row] * residuals[row];
        }
      }
      ++clusters;
    }
  }

  // Less H_ce H_ee^-1 H_ec, block by block over the columns the block's rows reach (in
  // increasing order, so that pairs i <= j fall in the upper triangle).
  std::vector<int> local_of_column(kept, -1);
  std::vector<int> reached;
  for (int b = 0; b < eliminated_blocks; ++b) {
    if (rows_of_block[b].empty()) continue;
    const int at = offsets[b];
    const int size = (b + 1 < eliminated_blocks ? offsets[b + 1] : eliminated) - at;
    reached.clear();
    for (int row : rows_of_block[b]) {
      for (int k = crs.rows[row]; k < crs.rows[row + 1]; ++k) {
        const int column = crs.cols[k] - eliminated;
        if (column >= 0 && local_of_column[column] < 0) {
          local_of_column[column] = 0;
          reached.push_back(column);
        }
      }
    }
    std::sort(reached.begin(), reached.end());
    for (size_t i = 0; i < reached.size(); ++i) local_of_column[reached[i]] = int(i);
    Eigen::MatrixXd hee = Eigen::MatrixXd::Zero(size, size);
    Eigen::MatrixXd hec = Eigen::MatrixXd::Zero(size, Eigen::Index(reached.size()));
    Eigen::VectorXd gradient_e = Eigen::VectorXd::Zero(size);
    Eigen::VectorXd gradient_c = Eigen::VectorXd::Zero(Eigen::Index(reached.size()));
    for (int row : rows_of_block[b]) {
      const int first = crs.rows[row], last = crs.rows[row + 1];
      for (int k = first; k < last; ++k) {
        if (clustered) {
          const int column = crs.cols[k];
          const double g = crs.values[k] * residuals[row];
          if (column < eliminated) {
            gradient_e(column - at) += g;
          } else {
            gradient_c(local_of_column[column - eliminated]) += g;
          }
        }
        if (crs.cols[k] >= eliminated) continue;
        const int i = crs.cols[k] - at;
        for (int l = first; l < last; ++l) {
          const int column = crs.cols[l];
          if (column < eliminated) {
            hee(i, column - at) += crs.values[k] * crs.values[l];
          } else {
            hec(i, local_of_column[column - eliminated]) += crs.values[k] * crs.values[l];
          }
        }
      }
    }
    for (int column : reached) local_of_column[column] = -1;
    // A point seen along a single ray has a singular block and is left out, as it says
    // nothing about the rest.
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(hee);
    if (ldlt.info() != Eigen::Success || ldlt.vectorD().minCoeff() <= 1e-12 * hee.trace()) {
      continue;
    }
    const Eigen::MatrixXd solved = ldlt.solve(hec);
    for (Eigen::Index j = 0; j < hec.cols(); ++j) {
      for (Eigen::Index i = 0; i <= j; ++i) {
        schur(reached[i], reached[j]) -= hec.col(i).dot(solved.col(j));
      }
    }
    if (clustered) {
      const Eigen::VectorXd reduced = gradient_c - solved.transpose() * gradient_e;
      for (Eigen::Index j = 0; j < reduced.size(); ++j) {
        for (Eigen::Index i = 0; i <= j; ++i) {
          scatter(reached[i], reached[j]) += reduced(i) * reduced(j);
        }
      }
      ++clusters;
    }
  }
  schur = schur.selfadjointView<Eigen::Upper>().toDenseMatrix();

  // Scaled to a unit diagonal, so that the damping below is relative to each column's own
  // stiffness. A direction left free by the gauge would make the matrix singular; the
  // damping, far below anything measured, gives it a huge variance instead, which the
  // intrinsics only inherit if they share it.
  const Eigen::VectorXd scale =
      schur.diagonal().unaryExpr([](double d) { return d > 0.0 ? 1.0 / std::sqrt(d) : 1.0; });
  schur = scale.asDiagonal() * schur * scale.asDiagonal();
  schur.diagonal().array() += 1e-12;
  const Eigen::LDLT<Eigen::MatrixXd> factor(schur);
  if (factor.info() != Eigen::Success || factor.vectorD().minCoeff() <= 0.0) return std::nullopt;
  const int free = columns - intrinsics_column;
  Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(kept, free);
  unit.bottomRows(free) = scale.tail(free).asDiagonal();
  // Columns: the scaled complement's inverse times the intrinsics' scale, so that the
  // intrinsics' rows of the complement's inverse are solved^T scale.
  const Eigen::MatrixXd solved = factor.solve(unit);
  Eigen::MatrixXd covariance = scale.tail(free).asDiagonal() * solved.bottomRows(free);
  covariance = 0.5 * (covariance + covariance.transpose()).eval();
  if (!covariance.allFinite() || covariance.diagonal().minCoeff() <= 0.0) return std::nullopt;
  if (clustered) {
    const Eigen::MatrixXd influence = scale.asDiagonal() * solved;  // Kept x free.
    const Eigen::MatrixXd full_scatter = scatter.selfadjointView<Eigen::Upper>();
    *clustered = influence.transpose() * full_scatter * influence;
    if (clusters > 1) *clustered *= double(clusters) / double(clusters - 1);
    *clustered = 0.5 * (*clustered + clustered->transpose()).eval();
  }
  return covariance;
}

bool LinePointCost::Evaluate(double const* const* parameters, double* residuals,
                             double** jacobians) const {
  const double* intrinsics = parameters[0];
  const double theta = parameters[1][0], rho = parameters[1][1];
  const double nx = std::cos(theta), ny = std::sin(theta);
  double s = position_;
  double x = 0.0, y = 0.0, by_normalized[4];
  double along[2];  // The pixel's derivative by s: the line's image's direction there.
  const auto project = [&](double* by_intrinsics) {
    x = rho * nx - s * ny;
    y = rho * ny + s * nx;
    ProjectNormalized(intrinsics, x, y, residuals, by_intrinsics, by_normalized);
    residuals[0] -= pixel_.x();
    residuals[1] -= pixel_.y();
    along[0] = -by_normalized[0] * ny + by_normalized[1] * nx;
    along[1] = -by_normalized[2] * ny + by_normalized[3] * nx;
  };
  // The nearest point: Gauss-Newton along the line. Near the solution each step cuts the
  // error by the residual over the line's image's radius of curvature; two or three do.
  constexpr int kMaxSteps = 8;
  constexpr double kDonePx = 1e-9;
  for (int step = 0; step < kMaxSteps; ++step) {
    project(nullptr);
    const double along_sq = along[0] * along[0] + along[1] * along[1];
    if (!(along_sq > 0.0)) return false;
    const double ds = -(along[0] * residuals[0] + along[1] * residuals[1]) / along_sq;
    s += ds;
    if (!std::isfinite(s)) return false;
    if (std::abs(ds) * std::sqrt(along_sq) < kDonePx) break;
  }
  project(jacobians ? jacobians[0] : nullptr);
  if (!jacobians) return true;
  const double along_norm = std::hypot(along[0], along[1]);
  if (!(along_norm > 0.0)) return false;
  const double ux = along[0] / along_norm, uy = along[1] / along_norm;
  // Each column less its component along the line's image.
  const auto across = [&](double* row0, double* row1) {
    const double d = ux * *row0 + uy * *row1;
    *row0 -= ux * d;
    *row1 -= uy * d;
  };
  if (double* j = jacobians[0]) {
    for (int c = 0; c < kNumIntrinsics; ++c) across(&j[c], &j[kNumIntrinsics + c]);
  }
  if (double* j = jacobians[1]) {
    // (x, y) by t is (-y, x), by rho the normal (nx, ny).
    const auto chain = [&](double dx, double dy, double* row0, double* row1) {
      *row0 = by_normalized[0] * dx + by_normalized[1] * dy;
      *row1 = by_normalized[2] * dx + by_normalized[3] * dy;
      across(row0, row1);
    };
    chain(-y, x, &j[0], &j[2]);
    chain(nx, ny, &j[1], &j[3]);
  }
  return true;
}

size_t PlumbLineParameterCount(const std::vector<const LineObservation*>& lines) {
  return 2 * lines.size();
}

std::vector<bool> StraightLines(const std::vector<const LineObservation*>& lines,
                                const CameraIntrinsics& camera, double factor) {
  std::vector<bool> straight(lines.size(), true);
  if (lines.empty()) return straight;
  const std::vector<double> rms = PerLineRms(lines, camera);
  std::vector<double> sorted = rms;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double limit = factor * std::max(sorted[sorted.size() / 2], kLineNoiseFloorPx);
  for (size_t i = 0; i < lines.size(); ++i) straight[i] = rms[i] <= limit;
  return straight;
}

std::vector<double*> AddPlumbLineResiduals(const std::vector<const LineObservation*>& lines,
                                           const CameraIntrinsics& start, ceres::LossFunction* loss,
                                           double* intrinsics, ceres::Problem* problem,
                                           ceres::ParameterBlockOrdering* ordering,
                                           ParameterArena* arena) {
  std::vector<double*> blocks;
  for (const LineObservation* observed : lines) {
    const std::vector<Eigen::Vector2d> ideal = Undistorted(*observed, start);
    const LineFit fit = FitLine(ideal);
    double* const line = arena->Add(std::array{fit.theta, fit.rho});
    const Eigen::Vector2d along(-std::sin(fit.theta), std::cos(fit.theta));
    for (size_t k = 0; k < ideal.size(); ++k) {
      problem->AddResidualBlock(new LinePointCost(observed->points[k], along.dot(ideal[k])), loss,
                                intrinsics, line);
    }
    ordering->AddElementToGroup(line, 0);
    blocks.push_back(line);
  }
  return blocks;
}

PlumbLineResult EstimateDistortion(const std::vector<LineObservation>& observations,
                                   const CameraIntrinsics& initial,
                                   const PlumbLineOptions& options) {
  PlumbLineResult result;
  result.estimate = result.solved = initial;
  std::vector<const LineObservation*> lines;
  for (const LineObservation& line : observations) {
    if (int(line.points.size()) >= options.min_points_per_line) lines.push_back(&line);
  }
  if (int(lines.size()) < options.min_lines) {
    std::ostringstream message;
    message << "not observable: " << lines.size() << " lines with at least "
            << options.min_points_per_line << " points, " << options.min_lines << " needed";
    result.message = message.str();
    return result;
  }

  // Coarse to fine. Far from the answer most residuals are large, and a tight robust loss
  // would write whole lines off as outliers: solve first with a loose loss, with k1, k2
  // alone (the centre and the tangential terms trade off against each other and against
  // the radial ones, so a full solve from no distortion can settle in a wrong minimum),
  // then the full model; drop the lines that stay curved (curved in the world, or
  // mistracked); and solve again with the tight loss.
  PlumbLineOptions radial = options;
  radial.estimate_centre = radial.estimate_tangential = radial.estimate_k3 = false;
  const double coarse_loss = std::max(kCoarseLossPx, options.loss_scale_px);
  Solve solve = SolveOnce(lines, initial, radial, coarse_loss, false);
  const bool richer = options.estimate_centre || options.estimate_tangential || options.estimate_k3;
  if (solve.converged && richer) {
    solve = SolveOnce(lines,
                      CameraIntrinsics::FromPacked(solve.intrinsics, initial.width, initial.height),
                      options, coarse_loss, false);
  }
  if (solve.converged) {
    const CameraIntrinsics coarse =
        CameraIntrinsics::FromPacked(solve.intrinsics, initial.width, initial.height);
    const std::vector<bool> straight = StraightLines(lines, coarse, options.outlier_factor);
    std::vector<const LineObservation*> inliers;
    for (size_t i = 0; i < lines.size(); ++i) {
      if (straight[i]) inliers.push_back(lines[i]);
    }
    if (int(inliers.size()) >= options.min_lines) {
      result.lines_rejected = static_cast<int>(lines.size() - inliers.size());
      lines = inliers;
    }
    solve = SolveOnce(lines, coarse, options, options.loss_scale_px, true);
  }
  if (!solve.converged) {
    result.message = "no estimate: the solver failed: " + solve.report;
    return result;
  }
  const CameraIntrinsics estimate =
      CameraIntrinsics::FromPacked(solve.intrinsics, initial.width, initial.height);
  result.solved = estimate;
  result.covariance = solve.covariance;
  result.lines_used = static_cast<int>(lines.size());
  for (const LineObservation* line : lines) result.points_used += int(line->points.size());
  result.rms_before_px = PooledRms(lines, PerLineRms(lines, initial));
  result.rms_after_px = PooledRms(lines, PerLineRms(lines, estimate));
  result.observability = Assess(lines, initial, estimate, result.covariance, result.rms_before_px,
                                result.rms_after_px, options);
  const DistortionObservability& o = result.observability;
  std::ostringstream message;
  message << std::setprecision(3) << "k1=" << estimate.k1 << " k2=" << estimate.k2 << " from "
          << result.lines_used << " lines (" << result.lines_rejected << " rejected), "
          << "straightness " << result.rms_before_px << " -> " << result.rms_after_px
          << " px; lines reach " << std::fixed << std::setprecision(0) << 100 * o.covered_radius
          << "% of the half-diagonal, shift there up to " << std::setprecision(1) << o.max_shift_px
          << " +- " << std::setprecision(2) << o.shift_sigma_px << " px";
  if (!o.observable) {
    result.message = "not observable: " + o.reason + " (the initial distortion is kept; " +
                     message.str() + ")";
    return result;
  }
  result.estimate = estimate;
  result.usable = true;
  result.message = message.str();
  return result;
}

std::string LensVerdict(const PlumbLineResult& result) {
  const DistortionObservability& o = result.observability;
  std::ostringstream verdict;
  verdict << std::fixed;
  if (result.usable) {
    verdict << std::setprecision(1) << "lens: " << o.max_shift_px << " \u00b1 "
            << std::setprecision(2) << o.shift_sigma_px << " px to " << std::setprecision(0)
            << 100 * o.covered_radius << "% (" << result.lines_used << " lines)";
  } else if (!o.brief_reason.empty()) {
    verdict << "lens not observable: " << o.brief_reason;
  } else {
    constexpr std::string_view kNotObservable = "not observable: ";
    const std::string_view message(result.message);
    if (message.starts_with(kNotObservable)) {
      verdict << "lens not observable: " << message.substr(kNotObservable.size());
    } else {
      verdict << "lens: " << message;
    }
  }
  return verdict.str();
}

std::string ObservabilityJson(const DistortionObservability& o) {
  std::string json = "{\"observable\": " + std::string(o.observable ? "true" : "false") +
                     ", \"reason\": " + JsonString(o.reason) + ", \"radial_points\": [";
  for (int i = 0; i < o.kRadialBins; ++i) {
    json += (i ? ", " : "") + std::to_string(o.radial_points[i]);
  }
  json += "], \"covered_radius\": " + JsonNumber(o.covered_radius) +
          ", \"direction_share\": " + JsonNumber(o.direction_share) +
          ", \"max_shift_px\": " + JsonNumber(o.max_shift_px) +
          ", \"shift_sigma_px\": " + JsonNumber(o.shift_sigma_px) +
          ", \"change_px\": " + JsonNumber(o.change_px) + "}";
  return json;
}

CameraIntrinsics ScaleDistortionToFocal(const CameraIntrinsics& camera, double fx, double fy) {
  CameraIntrinsics scaled = camera;
  const double s = 0.5 * (fx / camera.fx + fy / camera.fy);
  scaled.fx = fx;
  scaled.fy = fy;
  scaled.k1 = camera.k1 * s * s;
  scaled.k2 = camera.k2 * std::pow(s, 4);
  scaled.k3 = camera.k3 * std::pow(s, 6);
  scaled.p1 = camera.p1 * s;
  scaled.p2 = camera.p2 * s;
  return scaled;
}

CameraIntrinsics WithDistortionOf(const CameraIntrinsics& pinhole, const CameraIntrinsics& lens) {
  const CameraIntrinsics scaled = ScaleDistortionToFocal(lens, pinhole.fx, pinhole.fy);
  CameraIntrinsics combined = pinhole;
  combined.k1 = scaled.k1;
  combined.k2 = scaled.k2;
  combined.k3 = scaled.k3;
  combined.p1 = scaled.p1;
  combined.p2 = scaled.p2;
  return combined;
}

double MaxDistortionDifference(const CameraIntrinsics& lens, const CameraIntrinsics& reference,
                               double radius_fraction, int grid_step_px) {
  const Eigen::Vector2d centre(0.5 * (reference.width - 1), 0.5 * (reference.height - 1));
  const double radius = radius_fraction * 0.5 * std::hypot(reference.width, reference.height);
  double worst = 0.0;
  for (int y = 0; y < reference.height; y += grid_step_px) {
    for (int x = 0; x < reference.width; x += grid_step_px) {
      const Eigen::Vector2d pixel(x, y);
      if ((pixel - centre).norm() > radius) continue;
      const auto ray = Unproject(reference, pixel);
      if (!ray) return std::numeric_limits<double>::infinity();
      worst = std::max(worst, (Project(lens, {ray->x(), ray->y(), 1.0}) - pixel).norm());
    }
  }
  return worst;
}

}  // namespace autocal
