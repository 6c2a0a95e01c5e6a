#include "tests/test_util.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sqlite3.h>

namespace autocal::test {

TempDir::TempDir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = info ? std::string(info->test_suite_name()) + "." + info->name() : "autocal";
  for (char& c : name) {
    if (c == '/') c = '_';
  }
  std::random_device device;
  path_ =
      std::filesystem::temp_directory_path() / ("autocal-" + name + "-" + std::to_string(device()));
  std::filesystem::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ignored;
  std::filesystem::remove_all(path_, ignored);
}

CameraIntrinsics SonnarLikeCamera(double k1, double k2) {
  CameraIntrinsics c;
  c.width = 640;
  c.height = 480;
  c.fx = 427.0;
  c.fy = 427.8;
  c.cx = 322.5;
  c.cy = 237.0;
  c.k1 = k1;
  c.k2 = k2;
  return c;
}

CameraIntrinsics WrongStart(const CameraIntrinsics& truth) {
  CameraIntrinsics wrong = truth;
  wrong.fx *= 1.05;
  wrong.fy *= 1.05;
  wrong.cx += 15.0;
  wrong.cy -= 10.0;
  wrong.k1 = wrong.k2 = wrong.k3 = wrong.p1 = wrong.p2 = 0.0;
  return wrong;
}

CameraIntrinsics FromOpenCv(const cv::Mat& camera_matrix, const cv::Mat& distortion,
                            cv::Size size) {
  CameraIntrinsics c;
  c.width = size.width;
  c.height = size.height;
  c.fx = camera_matrix.at<double>(0, 0);
  c.fy = camera_matrix.at<double>(1, 1);
  c.cx = camera_matrix.at<double>(0, 2);
  c.cy = camera_matrix.at<double>(1, 2);
  c.k1 = distortion.at<double>(0);
  c.k2 = distortion.at<double>(1);
  c.p1 = distortion.at<double>(2);
  c.p2 = distortion.at<double>(3);
  if (distortion.total() > 4) c.k3 = distortion.at<double>(4);
  return c;
}

cv::Mat WarpThroughLens(const cv::Mat& photo, const CameraIntrinsics& lens, double yaw_deg,
                        double pitch_deg, int jpeg_quality) {
  const Eigen::Matrix3d turn =
      (Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(pitch_deg * M_PI / 180, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  // Every pixel's ray in the photograph's camera, and the largest photograph focal length
  // that keeps them all inside it.
  cv::Mat rays(lens.height, lens.width, CV_64FC2);
  const double half_w = 0.5 * (photo.cols - 1), half_h = 0.5 * (photo.rows - 1);
  double focal = std::numeric_limits<double>::infinity();
  for (int y = 0; y < lens.height; ++y) {
    for (int x = 0; x < lens.width; ++x) {
      const auto ideal = Unproject(lens, {double(x), double(y)});
      if (!ideal) throw std::invalid_argument("WarpThroughLens: the lens folds inside its image");
      const Eigen::Vector3d ray = turn * Eigen::Vector3d(ideal->x(), ideal->y(), 1.0);
      if (!(ray.z() > 0)) throw std::invalid_argument("WarpThroughLens: turned too far");
      const double u = ray.x() / ray.z(), v = ray.y() / ray.z();
      rays.at<cv::Vec2d>(y, x) = {u, v};
      if (u != 0) focal = std::min(focal, half_w / std::abs(u));
      if (v != 0) focal = std::min(focal, half_h / std::abs(v));
    }
  }
  cv::Mat map(lens.height, lens.width, CV_32FC2);
  for (int y = 0; y < lens.height; ++y) {
    for (int x = 0; x < lens.width; ++x) {
      const cv::Vec2d ray = rays.at<cv::Vec2d>(y, x);
      map.at<cv::Vec2f>(y, x) = {float(half_w + focal * ray[0]), float(half_h + focal * ray[1])};
    }
  }
  cv::Mat warped;
  cv::remap(photo, warped, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  std::vector<uchar> jpeg;
  cv::imencode(".jpg", warped, jpeg, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality});
  return cv::imdecode(jpeg, cv::IMREAD_UNCHANGED);
}

bool ExpectJacobianMatchesCentralDifferences(const ceres::CostFunction& cost,
                                             const std::vector<double*>& parameters,
                                             const std::string& where) {
  const std::vector<int32_t>& sizes = cost.parameter_block_sizes();
  const int rows = cost.num_residuals();
  std::vector<std::vector<double>> jacobian(sizes.size());
  std::vector<double*> jacobians(sizes.size());
  for (size_t b = 0; b < sizes.size(); ++b) {
    jacobian[b].resize(size_t(rows * sizes[b]));
    jacobians[b] = jacobian[b].data();
  }
  const size_t count = size_t(rows);
  std::vector<double> residual(count), plus(count), minus(count);
  if (!cost.Evaluate(parameters.data(), residual.data(), jacobians.data())) return false;
  for (size_t b = 0; b < sizes.size(); ++b) {
    for (int c = 0; c < sizes[b]; ++c) {
      double& x = parameters[b][c];
      const double original = x, h = 1e-6 * std::max(1.0, std::abs(x));
      x = original + h;
      const bool plus_ok = cost.Evaluate(parameters.data(), plus.data(), nullptr);
      x = original - h;
      const bool minus_ok = cost.Evaluate(parameters.data(), minus.data(), nullptr);
      x = original;
      if (!plus_ok || !minus_ok) {
        ADD_FAILURE() << "cannot be evaluated a step from the point, " << where;
        continue;
      }
      for (int r = 0; r < rows; ++r) {
        const double numeric = (plus[r] - minus[r]) / (2 * h);
        EXPECT_NEAR(jacobian[b][size_t(r * sizes[b] + c)], numeric,
                    1e-5 * std::max(1.0, std::abs(numeric)))
            << "block " << b << " column " << c << " row " << r << ", " << where;
      }
    }
  }
  return true;
}

void WriteTextFile(const std::filesystem::path& path, const std::string& contents) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  out << contents;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

std::string ReadTextFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::future<void> HoldSqliteWriteLock(const std::string& path, std::shared_future<void> release) {
  std::promise<void> held;
  std::future<void> locked = held.get_future();
  std::thread([path, release, held = std::move(held)]() mutable {
    sqlite3* db = nullptr;
    const bool locking = sqlite3_open(path.c_str(), &db) == SQLITE_OK &&
                         sqlite3_exec(db, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr) == SQLITE_OK;
    EXPECT_TRUE(locking) << path << ": " << sqlite3_errmsg(db);
    held.set_value();
    release.wait();
    sqlite3_exec(db, "COMMIT", nullptr, nullptr, nullptr);
    sqlite3_close(db);
  }).detach();
  return locked;
}

}  // namespace autocal::test
