// Scenario files compiled into the binary (resources/scenarios/*.yaml).
#pragma once

#include <vector>

namespace autocal {

struct BuiltInScenario {
  const char* name;  // File name without extension: "office", "drift", ...
  const char* yaml;  // The file's text.
};

const std::vector<BuiltInScenario>& BuiltInScenarios();

}  // namespace autocal
