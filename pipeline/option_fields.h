// The pipeline's options field by field, by name ("material.window_s"), with a range and a
// one-line explanation: what `autocal run --set` and settings files change, and what the
// workbench's threshold panel binds to. Each struct's Check() still has the last word.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "pipeline/calibration_pipeline.h"

namespace autocal {

struct OptionField {
  enum class Kind { kReal, kInteger, kFlag };
  std::string name;  // Path through the nested structs, e.g. "calibration.loss_px".
  std::string help;  // One line.
  Kind kind = Kind::kReal;
  double min = 0.0;  // Inclusive range (0 and 1 for flags).
  double max = 0.0;
  std::function<double(const PipelineOptions&)> get;
  std::function<void(PipelineOptions*, double)> set;
};

// Every tunable field, grouped by box.
const std::vector<OptionField>& PipelineOptionFields();

// Sets the field `name` from `value` ("0.5", "12", "true"/"false" for flags). Throws Error
// naming the field and saying what was expected: a known name (listing the close ones), a
// number of the right kind, inside the range.
void SetPipelineOption(PipelineOptions* options, const std::string& name, const std::string& value);

// A settings file: one "name = value" per line, '#' starts a comment. Throws Error naming
// the file and the line. The result passes PipelineOptions::Check().
PipelineOptions ReadPipelineSettings(const std::string& path, const PipelineOptions& base = {});
// Every field, with its explanation as a comment, so that the file documents itself.
std::string PipelineSettingsText(const PipelineOptions& options);

// The fields of `options` that differ from the defaults: (name, value as in a settings
// file), in the order of PipelineOptionFields().
std::vector<std::pair<std::string, std::string>> ChangedPipelineOptions(
    const PipelineOptions& options);

}  // namespace autocal
