// HID report descriptors (HID 1.11, section 6.2.2) and the accelerometer reports they
// describe: pure functions, no USB. A device following the HID Sensor usage tables
// (usage page 0x20) announces an Accelerometer 3D collection whose input report carries
// the X/Y/Z acceleration fields; a device that does not gets the same layout from a
// mapping file (devices/usb/accel_mapping.h).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace autocal {

// Usages from the HID Sensor usage page, as page << 16 | id.
inline constexpr uint32_t kHidUsageAccelerometer3D = 0x00200073;
inline constexpr uint32_t kHidUsageAccelerationX = 0x00200453;
inline constexpr uint32_t kHidUsageAccelerationY = 0x00200454;
inline constexpr uint32_t kHidUsageAccelerationZ = 0x00200455;

// Standard gravity: HID sensor accelerations are in G unless the unit item says otherwise.
inline constexpr double kStandardGravity = 9.80665;

// One value of an input report, as the descriptor lays it out.
struct HidInputField {
  uint8_t report_id = 0;  // 0 when the device uses no report ids.
  uint32_t usage = 0;     // Page << 16 | id; 0 for constants and array items.
  int bit_offset = 0;     // From the start of the report, after its report id byte if any.
  int bit_size = 0;
  bool is_constant = false;  // Padding or a constant value.
  bool is_variable = true;   // false: an array item (the value is a usage index).
  int32_t logical_minimum = 0;
  int32_t logical_maximum = 0;
  uint32_t unit = 0;      // The HID unit item, as coded (0: none).
  int unit_exponent = 0;  // Decoded power of ten.
  // Usages of the collections enclosing the field, outermost first.
  std::vector<uint32_t> collections;

  // Values are two's complement when the logical range reaches below zero.
  bool is_signed() const { return logical_minimum < 0; }
};

struct HidReportDescriptor {
  bool uses_report_ids = false;
  std::vector<HidInputField> inputs;
  // Length of each input report in bytes, its report id byte included.
  std::map<uint8_t, int> input_report_bytes;
};

// Parses a report descriptor: global, local and main items, push/pop, collections, long
// items (skipped). Throws Error naming the byte offset of the first malformed item
// (truncated item, unbalanced collection, pop without push, report too long).
HidReportDescriptor ParseHidReportDescriptor(std::span<const uint8_t> descriptor);

// Where one value sits in a report as received (report id byte included) and how it
// becomes m/s^2.
struct ReportField {
  int bit_offset = 0;
  int bit_size = 0;  // 1 to 32.
  bool is_signed = true;
  bool big_endian = false;  // Mapping files only; whole bytes then.
  double scale = 1.0;       // m/s^2 per count; negative to flip the axis.
};

// How to turn one input report into a specific-force sample.
struct AccelReportLayout {
  uint8_t report_id = 0;  // 0: reports carry no report id byte.
  // The accelerometer's x, y, z, in that order.
  std::array<ReportField, 3> axes;

  // Shortest report holding every axis, in bytes.
  int min_report_bytes() const;
  // "report 1, x: bits 8+16 signed * 0.0980665 m/s^2, y: ...".
  std::string Describe() const;
};

// m/s^2 per count of a HID Sensor acceleration field: G when `unit` is 0, else the unit
// item must be a length over time squared (SI: cm/s^2, English: in/s^2); times 10^exponent.
// Throws Error for any other unit.
double HidAccelerationScale(uint32_t unit, int unit_exponent);

// Finds the X/Y/Z acceleration inputs of the first Accelerometer 3D collection, all
// in one report. Throws Error saying what is missing.
AccelReportLayout FindAccelerometerLayout(const HidReportDescriptor& descriptor);

// Decodes one report as received from the interrupt endpoint; nullopt when it is another
// report (report id) or too short.
std::optional<Eigen::Vector3d> DecodeAccelReport(const AccelReportLayout& layout,
                                                 std::span<const uint8_t> report);

}  // namespace autocal
