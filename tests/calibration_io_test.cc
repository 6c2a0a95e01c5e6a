#include "pipeline/calibration_io.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "pipeline/error.h"
#include "tests/test_util.h"

namespace autocal {
namespace {

CameraIntrinsics Camera() {
  CameraIntrinsics c;
  c.width = 640;
  c.height = 480;
  c.fx = 427.123456789012;
  c.fy = 428.5;
  c.cx = 322.25;
  c.cy = 237.0625;
  c.k1 = -0.301234567890123;
  c.k2 = 0.1;
  c.p1 = 1e-4;
  c.p2 = -2e-4;
  c.k3 = -0.01;
  return c;
}

TEST(CalibrationIo, RoundTripsEveryFormatExactly) {
  test::TempDir dir;
  for (const std::string& name : CalibrationFormatNames()) {
    const std::string path = dir / ("camera." + std::string(name == "json" ? "json" : "yaml"));
    WriteCalibration(path, Camera(), CalibrationFormatFromName(name));
    EXPECT_EQ(ReadCalibration(path), Camera()) << name;
  }
}

TEST(CalibrationIo, OpenCvFileReadsBackWithOpenCvsOwnFieldNames) {
  test::TempDir dir;
  const std::string path = dir / "camera.yaml";
  WriteCalibration(path, Camera(), CalibrationFormat::kOpenCv);
  cv::FileStorage file(path, cv::FileStorage::READ);
  ASSERT_TRUE(file.isOpened());
  cv::Mat k, d;
  file["camera_matrix"] >> k;
  file["distortion_coefficients"] >> d;
  EXPECT_EQ(static_cast<int>(file["image_width"]), 640);
  EXPECT_EQ(static_cast<int>(file["image_height"]), 480);
  EXPECT_EQ(k.at<double>(0, 0), Camera().fx);
  EXPECT_EQ(k.at<double>(1, 2), Camera().cy);
  EXPECT_EQ(k.at<double>(2, 2), 1.0);
  ASSERT_EQ(d.total(), 5u);
  EXPECT_EQ(d.at<double>(0), Camera().k1);
  EXPECT_EQ(d.at<double>(3), Camera().p2);
  EXPECT_EQ(d.at<double>(4), Camera().k3);
}

TEST(CalibrationIo, ReadsAFourCoefficientOpenCvFile) {
  test::TempDir dir;
  const std::string path = dir / "four.yaml";
  test::WriteTextFile(path,
                      "%YAML:1.0\n---\nimage_width: 320\nimage_height: 240\n"
                      "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                      "   data: [ 200., 0., 160., 0., 201., 120., 0., 0., 1. ]\n"
                      "distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 4\n   dt: d\n"
                      "   data: [ -0.2, 0.05, 0.001, 0.002 ]\n");
  const CameraIntrinsics c = ReadCalibration(path);
  EXPECT_EQ(c.fy, 201.0);
  EXPECT_EQ(c.p2, 0.002);
  EXPECT_EQ(c.k3, 0.0);
}

TEST(CalibrationIo, ErrorsNameTheFileAndTheField) {
  test::TempDir dir;
  try {
    ReadCalibration(dir / "missing.yaml");
    FAIL() << "no error for a missing file";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.yaml"), std::string::npos) << e.what();
  }
  const std::string path = dir / "partial.json";
  test::WriteTextFile(path, "{ \"image_width\": 640, \"image_height\": 480, \"fx\": 400, "
                            "\"fy\": 400, \"cx\": 320, \"cy\": 240, \"k1\": 0, \"k2\": 0 }");
  try {
    ReadCalibration(path);
    FAIL() << "no error for a missing field";
  } catch (const Error& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_NE(std::string(e.what()).find("'p1'"), std::string::npos) << e.what();
  }
  const std::string negative = dir / "negative.json";
  WriteCalibration(negative, [] { auto c = Camera(); c.fx = -1; return c; }(),
                   CalibrationFormat::kJson);
  EXPECT_THROW(ReadCalibration(negative), Error);
  EXPECT_THROW(CalibrationFormatFromName("matlab"), Error);
}

}  // namespace
}  // namespace autocal
