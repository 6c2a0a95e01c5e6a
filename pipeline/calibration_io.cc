#include "pipeline/calibration_io.h"

#include <filesystem>

#include <opencv2/core.hpp>

#include "pipeline/error.h"

namespace autocal {

CalibrationFormat CalibrationFormatFromName(const std::string& name) {
  if (name == "opencv") return CalibrationFormat::kOpenCv;
  if (name == "json") return CalibrationFormat::kJson;
  std::string known;
  for (const std::string& n : CalibrationFormatNames()) known += (known.empty() ? "" : ", ") + n;
  throw Error("unknown calibration format '" + name + "'; known: " + known);
}

std::vector<std::string> CalibrationFormatNames() { return {"opencv", "json"}; }

namespace {

double ReadNumber(const cv::FileNode& node, const std::string& path, const std::string& field) {
  if (node.empty() || (!node.isReal() && !node.isInt())) {
    throw Error(path, 0, "expected a number in field '" + field + "'");
  }
  return static_cast<double>(node);
}

int ReadInt(const cv::FileNode& node, const std::string& path, const std::string& field) {
  if (node.empty() || !node.isInt()) {
    throw Error(path, 0, "expected an integer in field '" + field + "'");
  }
  return static_cast<int>(node);
}

}  // namespace

CameraIntrinsics ReadCalibration(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw Error(path, 0, "no such calibration file");
  cv::FileStorage file;
  try {
    file.open(path, cv::FileStorage::READ);
  } catch (const cv::Exception& e) {
    throw Error(path, 0, "not a YAML, XML or JSON calibration file: " + e.msg);
  }
  if (!file.isOpened()) throw Error(path, 0, "cannot read as YAML, XML or JSON");
  const cv::FileNode root = file.root();
  CameraIntrinsics camera;
  if (!root["camera_matrix"].empty()) {
    cv::Mat k, d;
    root["camera_matrix"] >> k;
    root["distortion_coefficients"] >> d;
    if (k.rows != 3 || k.cols != 3) throw Error(path, 0, "expected a 3x3 'camera_matrix'");
    if (d.total() != 4 && d.total() != 5 && d.total() != 8) {
      throw Error(path, 0, "expected 4, 5 or 8 'distortion_coefficients' (k1 k2 p1 p2 [k3 ...])");
    }
    k.convertTo(k, CV_64F);
    d.convertTo(d, CV_64F);
    camera.width = ReadInt(root["image_width"], path, "image_width");
    camera.height = ReadInt(root["image_height"], path, "image_height");
    camera.fx = k.at<double>(0, 0);
    camera.fy = k.at<double>(1, 1);
    camera.cx = k.at<double>(0, 2);
    camera.cy = k.at<double>(1, 2);
    const double* dist = d.ptr<double>();
    camera.k1 = dist[0];
    camera.k2 = dist[1];
    camera.p1 = dist[2];
    camera.p2 = dist[3];
    camera.k3 = d.total() > 4 ? dist[4] : 0.0;
  } else if (!root["fx"].empty()) {
    camera.width = ReadInt(root["image_width"], path, "image_width");
    camera.height = ReadInt(root["image_height"], path, "image_height");
    double* fields[] = {&camera.fx, &camera.fy, &camera.cx, &camera.cy, &camera.k1,
                        &camera.k2, &camera.p1, &camera.p2, &camera.k3};
    const char* names[] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"};
    for (int i = 0; i < kNumIntrinsics; ++i) *fields[i] = ReadNumber(root[names[i]], path, names[i]);
  } else {
    throw Error(path, 0,
                "expected an OpenCV calibration (camera_matrix, distortion_coefficients) or "
                "autocal JSON (fx, fy, cx, cy, k1, k2, p1, p2, k3)");
  }
  std::string why;
  if (!camera.Check(&why)) throw Error(path, 0, why);
  return camera;
}

void WriteCalibration(const std::string& path, const CameraIntrinsics& camera,
                      CalibrationFormat format) {
  const int mode = cv::FileStorage::WRITE |
                   (format == CalibrationFormat::kJson ? cv::FileStorage::FORMAT_JSON
                                                       : cv::FileStorage::FORMAT_YAML);
  cv::FileStorage file;
  try {
    file.open(path, mode);
  } catch (const cv::Exception& e) {
    throw Error(path, 0, "cannot write: " + e.msg);
  }
  if (!file.isOpened()) throw Error(path, 0, "cannot write");
  file << "image_width" << camera.width << "image_height" << camera.height;
  if (format == CalibrationFormat::kOpenCv) {
    const cv::Mat k = (cv::Mat_<double>(3, 3) << camera.fx, 0, camera.cx, 0, camera.fy, camera.cy,
                       0, 0, 1);
    const cv::Mat d = (cv::Mat_<double>(1, 5) << camera.k1, camera.k2, camera.p1, camera.p2,
                       camera.k3);
    file << "camera_matrix" << k << "distortion_coefficients" << d;
  } else {
    file << "fx" << camera.fx << "fy" << camera.fy << "cx" << camera.cx << "cy" << camera.cy
         << "k1" << camera.k1 << "k2" << camera.k2 << "p1" << camera.p1 << "p2" << camera.p2
         << "k3" << camera.k3;
  }
  file.release();
}

}  // namespace autocal
