// The one exception type of autocal. Thrown for bad input (files, options) and I/O
// failures, never for algorithmic outcomes, which come back as a status in a summary.
#pragma once

#include <stdexcept>
#include <string>

namespace autocal {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message);
  // A fault in a file: "FILE:LINE: WHAT" (line 0 when the fault is not on one line).
  Error(const std::string& file, int line, const std::string& what);

  const std::string& file() const { return file_; }
  int line() const { return line_; }
  // The message without the file and line prefix.
  const std::string& what_expected() const { return detail_; }

 private:
  std::string file_;
  int line_ = 0;
  std::string detail_;
};

}  // namespace autocal
