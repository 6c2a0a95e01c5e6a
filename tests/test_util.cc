#include "tests/test_util.h"

#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

#include <gtest/gtest.h>

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

}  // namespace autocal::test
