#include "devices/device_list.h"

#include "devices/usb/usb_accelerometer.h"
#include "pipeline/error.h"

namespace autocal {

std::vector<std::string> DeviceListing::CameraInputs() const {
  std::vector<std::string> inputs;
  for (const VideoDeviceInfo& camera : cameras) {
    if (camera.can_capture) inputs.push_back("camera:" + camera.path);
  }
  return inputs;
}

bool DeviceListing::AnyDevice() const { return !CameraInputs().empty() || !accelerometer.empty(); }

std::string DeviceListing::Text() const {
  std::string text = "cameras:\n";
  if (cameras.empty()) text += "  none (no /dev/video* device)\n";
  for (const VideoDeviceInfo& camera : cameras) text += "  " + DescribeVideoDevice(camera);
  text += "accelerometer:\n";
  text +=
      accelerometer.empty() ? "  none: " + accelerometer_error + "\n" : "  " + accelerometer + "\n";
  return text;
}

DeviceListing ListDevices(const std::string& dev_dir) {
  DeviceListing listing;
  listing.cameras = ListVideoDevices(dev_dir);
  try {
    UsbAccelerometer accelerometer;
    accelerometer.Start();
    listing.accelerometer = accelerometer.Describe();
  } catch (const Error& error) {
    listing.accelerometer_error = error.what();
  }
  return listing;
}

}  // namespace autocal
