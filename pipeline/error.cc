#include "pipeline/error.h"

namespace autocal {
namespace {

std::string Located(const std::string& file, int line, const std::string& what) {
  std::string message = file;
  if (line > 0) message += ":" + std::to_string(line);
  return message + ": " + what;
}

}  // namespace

Error::Error(const std::string& message) : std::runtime_error(message), detail_(message) {}

Error::Error(const std::string& file, int line, const std::string& what)
    : std::runtime_error(Located(file, line, what)), file_(file), line_(line), detail_(what) {}

}  // namespace autocal
