// Mapping files: how a USB accelerometer that does not follow the HID Sensor usage tables
// lays out its input reports. YAML or JSON, read with cv::FileStorage; the format is in
// docs/usb_accelerometer.md.
#pragma once

#include <cstdint>
#include <string>

#include "devices/usb/hid_descriptor.h"

namespace autocal {

struct AccelMapping {
  uint16_t vendor_id = 0;
  uint16_t product_id = 0;
  int interface_number = -1;  // -1: the first interface with an interrupt IN endpoint.
  AccelReportLayout layout;   // Axes already in output order, signs in their scales.
};

// Reads a mapping file. Throws Error naming the file and the key that is wrong.
AccelMapping LoadAccelMapping(const std::string& path);

// The same from the file's text; `name` stands for the file in messages.
AccelMapping ParseAccelMapping(const std::string& text, const std::string& name);

}  // namespace autocal
