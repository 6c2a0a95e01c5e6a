// Helpers shared by the tests.
#pragma once

#include <filesystem>
#include <string>

namespace autocal::test {

// A fresh empty folder for this test, removed when the object goes out of scope.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// Writes `contents` to `path`, creating parent folders.
void WriteTextFile(const std::filesystem::path& path, const std::string& contents);
std::string ReadTextFile(const std::filesystem::path& path);

}  // namespace autocal::test
