#include "pipeline/calibration_io.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

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

CameraIntrinsics WithoutK3() {
  CameraIntrinsics c = Camera();
  c.k3 = 0.0;
  return c;
}

std::string FileName(const std::string& format) {
  if (format == "colmap") return "cameras.txt";
  return format == "json" ? "camera.json" : "camera.yaml";
}

// Every format but Kalibr's holds k3.
CameraIntrinsics Expressible(const CameraIntrinsics& c, CalibrationFormat format) {
  CameraIntrinsics e = c;
  if (format == CalibrationFormat::kKalibr) e.k3 = 0.0;
  return e;
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> Words(const std::string& line) {
  std::vector<std::string> words;
  std::istringstream in(line);
  for (std::string word; in >> word;) words.push_back(word);
  return words;
}

// "[1.5, 2, -3e-05]" as numbers, parsed here independently of the library.
std::vector<double> List(std::string text) {
  EXPECT_EQ(text.front(), '[') << text;
  EXPECT_EQ(text.back(), ']') << text;
  std::vector<double> values;
  std::istringstream in(text.substr(1, text.size() - 2));
  for (std::string item; std::getline(in, item, ',');) {
    char* end = nullptr;
    values.push_back(std::strtod(item.c_str(), &end));
    EXPECT_EQ(*end, '\0') << "'" << item << "' in " << text;
  }
  return values;
}

// A two-level YAML mapping read line by line: "key" for top-level scalars, "parent.key"
// for the fields of a nested mapping.
std::map<std::string, std::string> YamlFields(const std::string& text) {
  std::map<std::string, std::string> fields;
  std::string parent;
  for (const std::string& line : Lines(text)) {
    const size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    const bool nested = line.front() == ' ';
    const std::string key =
        line.substr(line.find_first_not_of(' '), colon - line.find_first_not_of(' '));
    const std::string value = colon + 2 <= line.size() ? line.substr(colon + 2) : "";
    if (!nested) parent = key;
    fields[nested ? parent + "." + key : key] = value;
  }
  return fields;
}

// The Error thrown by reading `path`.
Error ReadError(const std::string& path) {
  try {
    ReadCalibration(path);
  } catch (const Error& e) {
    return e;
  }
  ADD_FAILURE() << "no error reading " << path << ":\n" << test::ReadTextFile(path);
  return Error("none");
}

bool Contains(const Error& e, const std::string& part) {
  return std::string(e.what()).find(part) != std::string::npos;
}

TEST(CalibrationIo, NamesEveryFormat) {
  EXPECT_EQ(CalibrationFormatNames(),
            (std::vector<std::string>{"opencv", "json", "ros", "kalibr", "colmap"}));
  try {
    CalibrationFormatFromName("matlab");
    FAIL() << "no error for an unknown format";
  } catch (const Error& e) {
    EXPECT_TRUE(Contains(e, "opencv, json, ros, kalibr, colmap")) << e.what();
  }
}

TEST(CalibrationIo, RoundTripsEveryFormatExactly) {
  test::TempDir dir;
  for (const std::string& name : CalibrationFormatNames()) {
    const CalibrationFormat format = CalibrationFormatFromName(name);
    const std::string path = dir / FileName(name);
    WriteCalibration(path, Expressible(Camera(), format), format);
    CalibrationFormat found = CalibrationFormat::kOpenCv;
    EXPECT_EQ(ReadCalibration(path, &found), Expressible(Camera(), format)) << name;
    EXPECT_EQ(found, format) << name << " recognized by its content";
  }
}

// Doubles with all 53 bits in use, of every size a calibration meets, read back bit for bit.
TEST(CalibrationIo, RoundTripsRandomCalibrationsBitForBit) {
  test::TempDir dir;
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    CameraIntrinsics c;
    c.width = 1 + static_cast<int>(4000 * unit(random));
    c.height = 1 + static_cast<int>(3000 * unit(random));
    c.fx = 100 + 2000 * unit(random);
    c.fy = c.fx * (0.99 + 0.02 * unit(random));
    c.cx = (unit(random) - 0.1) * c.width;  // Outside the image, and negative, at times.
    c.cy = unit(random) * c.height;
    c.k1 = unit(random) - 0.5;
    c.k2 = std::ldexp(unit(random) - 0.5, -static_cast<int>(20 * unit(random)));
    c.p1 = 1e-3 * (unit(random) - 0.5);
    c.p2 = 1e-9 * (unit(random) - 0.5);
    c.k3 = std::ldexp(unit(random) - 0.5, -static_cast<int>(60 * unit(random)));
    for (const std::string& name : CalibrationFormatNames()) {
      const CalibrationFormat format = CalibrationFormatFromName(name);
      const std::string path = dir / FileName(name);
      WriteCalibration(path, Expressible(c, format), format);
      ASSERT_EQ(ReadCalibration(path), Expressible(c, format))
          << name << " trial " << trial << ":\n"
          << test::ReadTextFile(path);
    }
  }
}

// COLMAP's half-pixel shift crosses a power of two here: done in binary it would lose the
// last bit of cx.
TEST(CalibrationIo, ColmapShiftKeepsEveryBitOfThePrincipalPoint) {
  CameraIntrinsics c = WithoutK3();
  c.cx = std::nextafter(512.0, 0.0);
  c.cy = std::nextafter(256.0, 0.0);
  c.width = 1024;
  ASSERT_NE((c.cx + 0.5) - 0.5, c.cx) << "not a case that binary arithmetic gets wrong";
  test::TempDir dir;
  const std::string path = dir / "cameras.txt";
  WriteCalibration(path, c, CalibrationFormat::kColmap);
  EXPECT_EQ(ReadCalibration(path), c) << test::ReadTextFile(path);
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

TEST(CalibrationIo, RosFileHasCameraInfoFieldsAndProjection) {
  test::TempDir dir;
  const std::string path = dir / "front-left.yaml";
  WriteCalibration(path, Camera(), CalibrationFormat::kRos);
  const std::string text = test::ReadTextFile(path);
  ASSERT_EQ(text.rfind("image_width: 640\n", 0), 0u) << "no %YAML header:\n" << text;
  std::map<std::string, std::string> f = YamlFields(text);
  const CameraIntrinsics c = Camera();
  EXPECT_EQ(f["image_height"], "480");
  EXPECT_EQ(f["camera_name"], "front_left") << "the file's name, as camera_info_manager uses it";
  EXPECT_EQ(f["camera_matrix.rows"], "3");
  EXPECT_EQ(f["camera_matrix.cols"], "3");
  EXPECT_EQ(List(f["camera_matrix.data"]),
            (std::vector<double>{c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1}));
  EXPECT_EQ(f["distortion_model"], "plumb_bob");
  EXPECT_EQ(f["distortion_coefficients.rows"], "1");
  EXPECT_EQ(f["distortion_coefficients.cols"], "5");
  EXPECT_EQ(List(f["distortion_coefficients.data"]),
            (std::vector<double>{c.k1, c.k2, c.p1, c.p2, c.k3}));
  EXPECT_EQ(f["rectification_matrix.rows"], "3");
  EXPECT_EQ(List(f["rectification_matrix.data"]), (std::vector<double>{1, 0, 0, 0, 1, 0, 0, 0, 1}));
  EXPECT_EQ(f["projection_matrix.rows"], "3");
  EXPECT_EQ(f["projection_matrix.cols"], "4");
  EXPECT_EQ(List(f["projection_matrix.data"]),
            (std::vector<double>{c.fx, 0, c.cx, 0, 0, c.fy, c.cy, 0, 0, 0, 1, 0}));
  // YAML 1.1 readers (PyYAML) take a number without a '.' for a string or an integer.
  EXPECT_NE(f["distortion_coefficients.data"].find("1.0e-04"), std::string::npos) << text;
}

TEST(CalibrationIo, KalibrFileIsPinholeRadtanWithFourCoefficients) {
  test::TempDir dir;
  const std::string path = dir / "camchain.yaml";
  const CameraIntrinsics c = WithoutK3();
  WriteCalibration(path, c, CalibrationFormat::kKalibr);
  const std::string text = test::ReadTextFile(path);
  ASSERT_EQ(Lines(text).front(), "cam0:") << text;
  std::map<std::string, std::string> f = YamlFields(text);
  EXPECT_EQ(f["cam0.camera_model"], "pinhole");
  EXPECT_EQ(List(f["cam0.intrinsics"]), (std::vector<double>{c.fx, c.fy, c.cx, c.cy}));
  EXPECT_EQ(f["cam0.distortion_model"], "radtan");
  EXPECT_EQ(List(f["cam0.distortion_coeffs"]), (std::vector<double>{c.k1, c.k2, c.p1, c.p2}));
  EXPECT_EQ(List(f["cam0.resolution"]), (std::vector<double>{640, 480}));
}

TEST(CalibrationIo, KalibrRefusesK3InsteadOfDroppingIt) {
  test::TempDir dir;
  const std::string path = dir / "camchain.yaml";
  try {
    WriteCalibration(path, Camera(), CalibrationFormat::kKalibr);
    FAIL() << "k3 = -0.01 written to Kalibr's radtan";
  } catch (const Error& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_TRUE(Contains(e, "k3 = -0.01")) << e.what();
    EXPECT_TRUE(Contains(e, "radtan")) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(path)) << "no partial file";
}

// Worked by hand: cx 322.25 + 0.5 = 322.75, cy 237.0625 + 0.5 = 237.5625.
TEST(CalibrationIo, ColmapFileShiftsThePrincipalPointByHalfAPixel) {
  test::TempDir dir;
  const std::string path = dir / "cameras.txt";
  WriteCalibration(path, WithoutK3(), CalibrationFormat::kColmap);
  std::vector<std::string> data;
  for (const std::string& line : Lines(test::ReadTextFile(path))) {
    if (!line.empty() && line.front() != '#') data.push_back(line);
  }
  ASSERT_EQ(data.size(), 1u);
  std::vector<std::string> w = Words(data[0]);
  ASSERT_EQ(w.size(), 4u + 8u) << data[0];
  EXPECT_EQ(w[0], "1");
  EXPECT_EQ(w[1], "OPENCV");
  EXPECT_EQ(w[2], "640");
  EXPECT_EQ(w[3], "480");
  const double expected[] = {427.123456789012,   428.5, 322.75, 237.5625,
                             -0.301234567890123, 0.1,   1e-4,   -2e-4};
  for (int i = 0; i < 8; ++i) EXPECT_EQ(std::strtod(w[4 + i].c_str(), nullptr), expected[i]) << i;

  WriteCalibration(path, Camera(), CalibrationFormat::kColmap);
  w = Words(Lines(test::ReadTextFile(path)).back());
  ASSERT_EQ(w.size(), 4u + 12u);
  EXPECT_EQ(w[1], "FULL_OPENCV") << "k3 needs COLMAP's rational model";
  EXPECT_EQ(std::strtod(w[6].c_str(), nullptr), 322.75);
  EXPECT_EQ(std::strtod(w[12].c_str(), nullptr), -0.01) << "k3";
  for (int i = 13; i < 16; ++i) EXPECT_EQ(w[i], "0") << "k4-k6";
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

// Files as the other tools write them, with the fields autocal does not use.
TEST(CalibrationIo, ReadsFilesWrittenByTheOtherTools) {
  test::TempDir dir;
  CalibrationFormat format = CalibrationFormat::kOpenCv;

  const std::string ros = dir / "ros.yaml";
  test::WriteTextFile(
      ros,
      "image_width: 752\nimage_height: 480\ncamera_name: narrow_stereo\n"
      "camera_matrix:\n  rows: 3\n  cols: 3\n"
      "  data: [458.654, 0, 367.215, 0, 457.296, 248.375, 0, 0, 1]\n"
      "distortion_model: plumb_bob\ndistortion_coefficients:\n  rows: 1\n"
      "  cols: 5\n  data: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0]\n"
      "rectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
      "projection_matrix:\n  rows: 3\n  cols: 4\n"
      "  data: [400.1, 0, 370, 0, 0, 400.2, 250, 0, 0, 0, 1, 0]\n");
  CameraIntrinsics c = ReadCalibration(ros, &format);
  EXPECT_EQ(format, CalibrationFormat::kRos);
  EXPECT_EQ(c.fy, 457.296) << "the camera matrix, not the projection's rectified one";
  EXPECT_EQ(c.p2, 1.76187114e-05);

  // kalibr_calibrate_imu_camera's camchain: extrinsics as block rows, a wrapped list.
  const std::string kalibr = dir / "camchain-imucam.yaml";
  test::WriteTextFile(
      kalibr,
      "cam0:\n  T_cam_imu:\n  - [0.0148655, -0.9998809, 0.0041216, -0.0216401]\n"
      "  - [0.9995572, 0.0150830, 0.0256277, -0.0646769]\n"
      "  - [0.0, 0.0, 0.0, 1.0]\n  cam_overlaps: []\n  camera_model: pinhole\n"
      "  distortion_coeffs: [-0.28340811, 0.07395907, 0.00019359,\n"
      "    1.76187114e-05]\n  distortion_model: radtan\n"
      "  intrinsics: [458.654, 457.296, 367.215, 248.375]  # fu fv pu pv\n"
      "  resolution: [752, 480]\n  rostopic: /cam0/image_raw\n  timeshift_cam_imu: 0.0\n");
  c = ReadCalibration(kalibr, &format);
  EXPECT_EQ(format, CalibrationFormat::kKalibr);
  EXPECT_EQ(c.width, 752);
  EXPECT_EQ(c.cx, 367.215);
  EXPECT_EQ(c.p2, 1.76187114e-05);
  EXPECT_EQ(c.k3, 0.0);

  // COLMAP's default model: one focal length, one radial coefficient.
  const std::string colmap = dir / "cameras.txt";
  test::WriteTextFile(colmap,
                      "# Camera list with one line of data per camera:\n"
                      "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
                      "# Number of cameras: 1\n3 SIMPLE_RADIAL 752 480 458.5 367.75 248.5 -0.25\n");
  c = ReadCalibration(colmap, &format);
  EXPECT_EQ(format, CalibrationFormat::kColmap);
  EXPECT_EQ(c.fx, 458.5);
  EXPECT_EQ(c.fy, 458.5);
  EXPECT_EQ(c.cx, 367.25);
  EXPECT_EQ(c.cy, 248.0);
  EXPECT_EQ(c.k1, -0.25);
  EXPECT_EQ(c.k2, 0.0);
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
  test::WriteTextFile(path,
                      "{ \"image_width\": 640, \"image_height\": 480, \"fx\": 400, "
                      "\"fy\": 400, \"cx\": 320, \"cy\": 240, \"k1\": 0, \"k2\": 0 }");
  const Error partial = ReadError(path);
  EXPECT_EQ(partial.file(), path);
  EXPECT_TRUE(Contains(partial, "'p1'")) << partial.what();
  const std::string negative = dir / "negative.json";
  WriteCalibration(negative, WithoutK3(), CalibrationFormat::kJson);
  test::WriteTextFile(negative, [&] {
    std::string text = test::ReadTextFile(negative);
    return text.replace(text.find("\"fx\": "), 6, "\"fx\": -");
  }());
  EXPECT_TRUE(Contains(ReadError(negative), "focal lengths must be positive"));
  CameraIntrinsics invalid = Camera();
  invalid.fx = -1;
  EXPECT_THROW(WriteCalibration(dir / "invalid.yaml", invalid, CalibrationFormat::kRos), Error);
}

// Bad files: the error names the file, the line where there is one, and what was expected.
TEST(CalibrationIo, BadFilesAreReportedWithLineAndExpectation) {
  test::TempDir dir;
  const std::string ros_text = [&] {
    WriteCalibration(dir / "good.yaml", Camera(), CalibrationFormat::kRos);
    return test::ReadTextFile(dir / "good.yaml");
  }();
  const auto edited = [&](const std::string& name, std::string text, const std::string& from,
                          const std::string& to) {
    const size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    test::WriteTextFile(dir / name, text.replace(at, from.size(), to));
    return dir / name;
  };

  // A missing field.
  Error e = ReadError(edited("no_distortion.yaml", ros_text,
                             "distortion_coefficients:", "distortion_coefficient:"));
  EXPECT_EQ(e.file(), dir / "no_distortion.yaml");
  EXPECT_TRUE(Contains(e, "missing field: expected 'distortion_coefficients' as a matrix"))
      << e.what();

  // A wrong matrix size, at the line of the matrix (line 4 of the ROS file).
  e = ReadError(edited("wide.yaml", ros_text, "  cols: 3\n  data: [427.123456789012, 0.0,",
                       "  cols: 4\n  data: [427.123456789012, 0.0, 0.0, 0.0, 0.0,"));
  EXPECT_EQ(e.line(), 4) << e.what();
  EXPECT_TRUE(Contains(e, "expected a 3x3 'camera_matrix', found 3x4")) << e.what();
  e = ReadError(edited("short.yaml", ros_text, "  rows: 1\n  cols: 5\n", "  rows: 1\n  cols: 4\n"));
  EXPECT_EQ(e.line(), 9) << e.what();
  EXPECT_TRUE(Contains(e, "'distortion_coefficients' is 1x4 but its data has 5 numbers"))
      << e.what();
  e = ReadError(
      edited("skew.yaml", ros_text, "[427.123456789012, 0.0,", "[427.123456789012, 0.5,"));
  EXPECT_TRUE(Contains(e, "no skew")) << e.what();
  e = ReadError(edited("model.yaml", ros_text, "plumb_bob", "equidistant"));
  EXPECT_EQ(e.line(), 8) << e.what();
  EXPECT_TRUE(Contains(e, "expected 'distortion_model' plumb_bob")) << e.what();
  e = ReadError(edited("syntax.yaml", ros_text, "  rows: 3\n", "  rows: 3\n    cols 3\n"));
  EXPECT_EQ(e.line(), 6) << e.what();

  // Coefficients the model cannot hold are refused, not dropped.
  const std::string eight = dir / "eight.yaml";
  test::WriteTextFile(eight,
                      "%YAML:1.0\n---\nimage_width: 320\nimage_height: 240\n"
                      "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                      "   data: [ 200., 0., 160., 0., 201., 120., 0., 0., 1. ]\n"
                      "distortion_coefficients: !!opencv-matrix\n   rows: 8\n   cols: 1\n   dt: d\n"
                      "   data: [ -0.2, 0.05, 0.001, 0.002, 0.01, 0.3, 0., 0. ]\n");
  e = ReadError(eight);
  EXPECT_EQ(e.line(), 10);
  EXPECT_TRUE(Contains(e, "coefficient 6 is 0.3: the model stops at k3")) << e.what();

  // COLMAP: too few parameters, a model that cannot be expressed, a second camera.
  const std::string colmap_head = "# Camera list with one line of data per camera:\n# x\n\n";
  test::WriteTextFile(dir / "few.txt", colmap_head + "1 OPENCV 640 480 400 400 320 240 0.1\n");
  e = ReadError(dir / "few.txt");
  EXPECT_EQ(e.file(), dir / "few.txt");
  EXPECT_EQ(e.line(), 4);
  EXPECT_TRUE(Contains(e, "OPENCV takes 8 parameters (fx, fy, cx, cy, k1, k2, p1, p2), found 5"))
      << e.what();
  test::WriteTextFile(dir / "fisheye.txt",
                      colmap_head + "1 OPENCV_FISHEYE 640 480 400 400 320 240 0 0 0 0\n");
  EXPECT_TRUE(Contains(ReadError(dir / "fisheye.txt"), "'OPENCV_FISHEYE' cannot be expressed"));
  test::WriteTextFile(dir / "k4.txt",
                      colmap_head + "1 FULL_OPENCV 640 480 400 400 320 240 0 0 0 0 0 0.1 0 0\n");
  EXPECT_TRUE(Contains(ReadError(dir / "k4.txt"), "k4 = 0.1: the model stops at k3"));
  test::WriteTextFile(dir / "two.txt", colmap_head +
                                           "1 PINHOLE 640 480 400 400 320 240\n"
                                           "2 PINHOLE 640 480 400 400 320 240\n");
  EXPECT_EQ(ReadError(dir / "two.txt").line(), 5);

  // Kalibr: a missing field, a fifth coefficient, a second camera.
  WriteCalibration(dir / "chain.yaml", WithoutK3(), CalibrationFormat::kKalibr);
  const std::string chain = test::ReadTextFile(dir / "chain.yaml");
  e = ReadError(edited("no_intrinsics.yaml", chain, "  intrinsics:", "  intrinsic:"));
  EXPECT_EQ(e.line(), 1);
  EXPECT_TRUE(Contains(e, "'cam0' has no 'intrinsics'")) << e.what();
  e = ReadError(edited("five.yaml", chain, "distortion_coeffs: [", "distortion_coeffs: [0.5, "));
  EXPECT_EQ(e.line(), 5);
  EXPECT_TRUE(Contains(e, "expected 'distortion_coeffs' as a list of 4 numbers")) << e.what();
  test::WriteTextFile(dir / "stereo.yaml", chain + chain.substr(0, 3) + "1" + chain.substr(4));
  e = ReadError(dir / "stereo.yaml");
  EXPECT_EQ(e.line(), 7);
  EXPECT_TRUE(Contains(e, "a second camera 'cam1'")) << e.what();

  test::WriteTextFile(dir / "other.yaml", "%YAML:1.0\nwidth: 3\n");
  EXPECT_TRUE(Contains(ReadError(dir / "other.yaml"), "expected a calibration"));
}

}  // namespace
}  // namespace autocal
