// The vest check on a source (docs/vest_check.md): opens it (OpenSource: "camera:0" with a
// USB accelerometer, "sim:office", a recording), runs boxes 1-10 on a runtime of its own
// (live for a live source), hands every frame's snapshot to a VestCheck, and stops when the
// walk's time is up, the source ends, or the caller says so. The workbench's dialog and
// `autocal check` both run it.
#pragma once

#include <atomic>
#include <functional>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "pipeline/camera_model.h"
#include "pipeline/vest_check.h"

namespace autocal {

struct VestCheckHooks {
  // The source opened: its description and the camera's and accelerometer's ids.
  std::function<void(const std::string& description, const std::string& devices)> connected;
  // After every frame, on the runtime's thread: the check as it stands.
  std::function<void(const VestCheck& check)> checked;
  // Every camera frame as it arrives (8-bit BGR), on the calling thread.
  std::function<void(const cv::Mat& frame)> image;
};

// `premission`: the calibration the vest was sent out with; without one, the source's own
// (session.json, the simulator's lens). `readout_ms`: the camera's rolling-shutter readout;
// without one, what the source states (a recording's session.json; a live camera states
// none: a global shutter). `stop`, when set, ends the walk early; the verdict is on what was
// seen. Throws Error when the source cannot be opened or read, or has no pre-mission
// calibration of its image size, or the readout is out of range.
VestCheckResult RunVestCheck(const std::string& input, const std::string& accel,
                             const std::optional<CameraIntrinsics>& premission,
                             std::optional<double> readout_ms, const VestCheckOptions& options,
                             const std::atomic<bool>& stop, const VestCheckHooks& hooks = {});

}  // namespace autocal
