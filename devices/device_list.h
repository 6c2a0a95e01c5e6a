// What is plugged in: the cameras (V4L2 nodes with their modes) and the USB accelerometer,
// as `autocal devices` prints them and the workbench's device panel lists them.
#pragma once

#include <string>
#include <vector>

#include "devices/video_devices.h"

namespace autocal {

struct DeviceListing {
  std::vector<VideoDeviceInfo> cameras;  // Every /dev/video* node, capture or not.
  // The accelerometer found ("1234:5678 ..."), or empty and `accelerometer_error` saying
  // why none was: "no USB accelerometer found; devices seen: ...".
  std::string accelerometer;
  std::string accelerometer_error;

  // Nodes that capture video, as --input values ("camera:/dev/video0").
  std::vector<std::string> CameraInputs() const;
  bool AnyDevice() const;
  // "cameras:\n  ...\naccelerometer:\n  ..." (`autocal devices`).
  std::string Text() const;
};

// Queries every /dev/video* node in `dev_dir` and opens the USB accelerometer (any HID
// Sensor one) briefly to describe it.
DeviceListing ListDevices(const std::string& dev_dir = "/dev");

}  // namespace autocal
