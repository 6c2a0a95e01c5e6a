// HID report descriptor parsing, accelerometer report decoding and mapping files: pure
// functions, on report descriptors written out byte by byte.
#include "devices/usb/hid_descriptor.h"

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "devices/usb/accel_mapping.h"
#include "pipeline/error.h"
#include "tests/test_util.h"

namespace autocal {
namespace {

using Bytes = std::vector<uint8_t>;

// The smallest HID Sensor accelerometer: X, Y, Z as 16-bit signed values in one input
// report without a report id; unit exponent 0x0E (-2): one count is 0.01 g.
// clang-format off
const Bytes kPlainAccelerometer = {
    0x05, 0x20,        // Usage Page (Sensors)
    0x09, 0x73,        // Usage (Motion: Accelerometer 3D)
    0xA1, 0x01,        // Collection (Application)
    0x0A, 0x53, 0x04,  //   Usage (Acceleration Axis X)
    0x0A, 0x54, 0x04,  //   Usage (Acceleration Axis Y)
    0x0A, 0x55, 0x04,  //   Usage (Acceleration Axis Z)
    0x16, 0x01, 0x80,  //   Logical Minimum (-32767)
    0x26, 0xFF, 0x7F,  //   Logical Maximum (32767)
    0x75, 0x10,        //   Report Size (16)
    0x95, 0x03,        //   Report Count (3)
    0x55, 0x0E,        //   Unit Exponent (-2)
    0x81, 0x02,        //   Input (Data, Variable, Absolute)
    0xC0,              // End Collection
};
// clang-format on

// Laid out like the accelerometer of a sensor hub: report id 1, feature properties
// (connection type, report interval), then an input report with the sensor state and
// event (arrays) before the axes, each axis its own main item with 4-byte logical limits.
// clang-format off
const Bytes kSensorHubAccelerometer = {
    0x05, 0x20,                    // Usage Page (Sensors)
    0x09, 0x73,                    // Usage (Motion: Accelerometer 3D)
    0xA1, 0x00,                    // Collection (Physical)
    0x85, 0x01,                    //   Report ID (1)
    0x0A, 0x09, 0x03,              //   Usage (Property: Sensor Connection Type)
    0x15, 0x00,                    //   Logical Minimum (0)
    0x25, 0x02,                    //   Logical Maximum (2)
    0x75, 0x08,                    //   Report Size (8)
    0x95, 0x01,                    //   Report Count (1)
    0xA1, 0x02,                    //   Collection (Logical)
    0x0A, 0x30, 0x08,              //     Usage (Connection Type: PC Integrated)
    0x0A, 0x31, 0x08,              //     Usage (Connection Type: PC Attached)
    0x0A, 0x32, 0x08,              //     Usage (Connection Type: PC External)
    0xB1, 0x00,                    //     Feature (Data, Array, Absolute)
    0xC0,                          //   End Collection
    0x0A, 0x0E, 0x03,              //   Usage (Property: Report Interval)
    0x27, 0xFF, 0xFF, 0xFF, 0xFF,  //   Logical Maximum (-1 as 32 bits)
    0x75, 0x20,                    //   Report Size (32)
    0x55, 0x00,                    //   Unit Exponent (0)
    0xB1, 0x02,                    //   Feature (Data, Variable, Absolute)
    0x0A, 0x01, 0x02,              //   Usage (Sensor State)
    0x15, 0x00,                    //   Logical Minimum (0)
    0x25, 0x06,                    //   Logical Maximum (6)
    0x75, 0x08,                    //   Report Size (8)
    0x95, 0x01,                    //   Report Count (1)
    0xA1, 0x02,                    //   Collection (Logical)
    0x0A, 0x00, 0x08,              //     Usage (Sensor State: Undefined)
    0x0A, 0x01, 0x08,              //     Usage (Sensor State: Ready)
    0x0A, 0x02, 0x08,              //     Usage (Sensor State: Not Available)
    0x81, 0x00,                    //     Input (Data, Array, Absolute)
    0xC0,                          //   End Collection
    0x0A, 0x02, 0x02,              //   Usage (Sensor Event)
    0x25, 0x05,                    //   Logical Maximum (5)
    0xA1, 0x02,                    //   Collection (Logical)
    0x0A, 0x10, 0x08,              //     Usage (Sensor Event: Unknown)
    0x0A, 0x11, 0x08,              //     Usage (Sensor Event: State Changed)
    0x0A, 0x12, 0x08,              //     Usage (Sensor Event: Property Changed)
    0x0A, 0x13, 0x08,              //     Usage (Sensor Event: Data Updated)
    0x81, 0x00,                    //     Input (Data, Array, Absolute)
    0xC0,                          //   End Collection
    0x0A, 0x53, 0x04,              //   Usage (Acceleration Axis X)
    0x17, 0x01, 0x80, 0xFF, 0xFF,  //   Logical Minimum (-32767)
    0x27, 0xFF, 0x7F, 0x00, 0x00,  //   Logical Maximum (32767)
    0x75, 0x10,                    //   Report Size (16)
    0x95, 0x01,                    //   Report Count (1)
    0x55, 0x0E,                    //   Unit Exponent (-2)
    0x81, 0x02,                    //   Input (Data, Variable, Absolute)
    0x0A, 0x54, 0x04,              //   Usage (Acceleration Axis Y)
    0x81, 0x02,                    //   Input (Data, Variable, Absolute)
    0x0A, 0x55, 0x04,              //   Usage (Acceleration Axis Z)
    0x81, 0x02,                    //   Input (Data, Variable, Absolute)
    0xC0,                          // End Collection
};
// clang-format on

// A three-button boot mouse: HID, but not a sensor.
// clang-format off
const Bytes kMouse = {
    0x05, 0x01, 0x09, 0x02, 0xA1, 0x01, 0x09, 0x01, 0xA1, 0x00, 0x05, 0x09, 0x19, 0x01,
    0x29, 0x03, 0x15, 0x00, 0x25, 0x01, 0x95, 0x03, 0x75, 0x01, 0x81, 0x02, 0x95, 0x01,
    0x75, 0x05, 0x81, 0x01, 0x05, 0x01, 0x09, 0x30, 0x09, 0x31, 0x15, 0x81, 0x25, 0x7F,
    0x75, 0x08, 0x95, 0x02, 0x81, 0x06, 0xC0, 0xC0,
};
// clang-format on

Bytes Le16(int value) {
  return {static_cast<uint8_t>(value & 0xff), static_cast<uint8_t>((value >> 8) & 0xff)};
}

Bytes Concat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const Bytes& part : parts) out.insert(out.end(), part.begin(), part.end());
  return out;
}

std::string ParseError(const Bytes& descriptor) {
  try {
    FindAccelerometerLayout(ParseHidReportDescriptor(descriptor));
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(HidDescriptor, PlainAccelerometerIsThreeSignedSixteenBitAxesInHundredthsOfG) {
  const HidReportDescriptor parsed = ParseHidReportDescriptor(kPlainAccelerometer);
  EXPECT_FALSE(parsed.uses_report_ids);
  ASSERT_EQ(parsed.inputs.size(), 3u);
  EXPECT_EQ(parsed.input_report_bytes.at(0), 6);
  for (int i = 0; i < 3; ++i) {
    const HidInputField& field = parsed.inputs[i];
    EXPECT_EQ(field.usage, kHidUsageAccelerationX + i);
    EXPECT_EQ(field.bit_offset, 16 * i);
    EXPECT_EQ(field.bit_size, 16);
    EXPECT_TRUE(field.is_signed());
    EXPECT_EQ(field.unit_exponent, -2);
    EXPECT_EQ(field.collections, std::vector<uint32_t>{kHidUsageAccelerometer3D});
  }

  const AccelReportLayout layout = FindAccelerometerLayout(parsed);
  EXPECT_EQ(layout.report_id, 0);
  EXPECT_EQ(layout.min_report_bytes(), 6);
  for (const ReportField& axis : layout.axes) EXPECT_DOUBLE_EQ(axis.scale, 0.01 * kStandardGravity);

  // +1 g, -0.5 g, -327.67 g (the most negative value).
  const auto value = DecodeAccelReport(layout, Concat({Le16(100), Le16(-50), Le16(-32767)}));
  ASSERT_TRUE(value.has_value());
  EXPECT_NEAR((*value)[0], kStandardGravity, 1e-12);
  EXPECT_NEAR((*value)[1], -0.5 * kStandardGravity, 1e-12);
  EXPECT_NEAR((*value)[2], -327.67 * kStandardGravity, 1e-9);
}

TEST(HidDescriptor, SensorHubReportHasItsIdAndStateBeforeTheAxes) {
  const HidReportDescriptor parsed = ParseHidReportDescriptor(kSensorHubAccelerometer);
  EXPECT_TRUE(parsed.uses_report_ids);
  // Report id, state, event, X, Y, Z.
  EXPECT_EQ(parsed.input_report_bytes.at(1), 1 + 1 + 1 + 6);
  // State and event are array items: no usage of their own.
  ASSERT_EQ(parsed.inputs.size(), 5u);
  EXPECT_FALSE(parsed.inputs[0].is_variable);
  EXPECT_EQ(parsed.inputs[1].bit_offset, 8);
  // Nested in the logical collection of the state, inside the accelerometer.
  EXPECT_EQ(parsed.inputs[0].collections,
            (std::vector<uint32_t>{kHidUsageAccelerometer3D, 0x00200201}));

  const AccelReportLayout layout = FindAccelerometerLayout(parsed);
  EXPECT_EQ(layout.report_id, 1);
  EXPECT_EQ(layout.axes[0].bit_offset, 24);  // After id, state and event bytes.
  EXPECT_EQ(layout.axes[1].bit_offset, 40);
  EXPECT_EQ(layout.axes[2].bit_offset, 56);
  for (const ReportField& axis : layout.axes) {
    EXPECT_TRUE(axis.is_signed);
    EXPECT_DOUBLE_EQ(axis.scale, 0.01 * kStandardGravity);
  }

  // At rest, z up: (0.02, -0.03, 1.00) g, state Ready (1), event Data Updated (3).
  const Bytes report = Concat({{0x01, 0x01, 0x03}, Le16(2), Le16(-3), Le16(100)});
  const auto value = DecodeAccelReport(layout, report);
  ASSERT_TRUE(value.has_value());
  EXPECT_NEAR((*value)[0], 0.02 * kStandardGravity, 1e-12);
  EXPECT_NEAR((*value)[1], -0.03 * kStandardGravity, 1e-12);
  EXPECT_NEAR((*value)[2], kStandardGravity, 1e-12);

  // Another report id, or a short report, is not a sample.
  Bytes other = report;
  other[0] = 0x02;
  EXPECT_FALSE(DecodeAccelReport(layout, other).has_value());
  EXPECT_FALSE(DecodeAccelReport(layout, Bytes(report.begin(), report.end() - 1)).has_value());
  EXPECT_FALSE(DecodeAccelReport(layout, Bytes{}).has_value());
}

TEST(HidDescriptor, SiUnitsAndByteWideExponentAndLateUsagePage) {
  // cm/s^2 (SI linear: length^1 time^-2 = 0xE011) with a whole-byte exponent of -1;
  // the usages come before the Usage Page item, which applies at the main item.
  // clang-format off
  const Bytes descriptor = {
      0x05, 0x20, 0x09, 0x73, 0xA1, 0x00,  // Sensors / Accelerometer 3D / Collection
      0x05, 0x01,                          //   Usage Page (Generic Desktop), for a moment
      0x0A, 0x53, 0x04, 0x0A, 0x54, 0x04, 0x0A, 0x55, 0x04,
      0x05, 0x20,                          //   Usage Page (Sensors) before the Input
      0x17, 0x00, 0x00, 0x00, 0x80,        //   Logical Minimum (-2^31)
      0x27, 0xFF, 0xFF, 0xFF, 0x7F,        //   Logical Maximum (2^31 - 1)
      0x75, 0x20, 0x95, 0x03,              //   Report Size (32), Report Count (3)
      0x66, 0x11, 0xE0,                    //   Unit (cm/s^2)
      0x55, 0xFF,                          //   Unit Exponent (-1, as a signed byte)
      0x81, 0x02, 0xC0,
  };
  // clang-format on
  const AccelReportLayout layout = FindAccelerometerLayout(ParseHidReportDescriptor(descriptor));
  for (const ReportField& axis : layout.axes) EXPECT_DOUBLE_EQ(axis.scale, 0.001);
  const Bytes report = {0x10, 0x27, 0, 0, 0xF0, 0xD8, 0xFF, 0xFF, 0, 0, 0, 0};
  const auto value = DecodeAccelReport(layout, report);
  ASSERT_TRUE(value.has_value());
  EXPECT_NEAR((*value)[0], 10.0, 1e-12);   // 10000 * 0.1 cm/s^2.
  EXPECT_NEAR((*value)[1], -10.0, 1e-12);  // -10000.
  EXPECT_NEAR((*value)[2], 0.0, 1e-12);
}

TEST(HidDescriptor, HubWithTwoSensorsPicksTheAccelerometerReport) {
  // A gyroscope (usage 0x76) in report 1 and the accelerometer in report 2, with usages
  // 4 bytes long (page included) and a Push/Pop around the gyroscope's globals.
  // clang-format off
  const Bytes descriptor = {
      0x05, 0x20, 0x09, 0x76, 0xA1, 0x00,  // Gyrometer 3D
      0xA4,                                //   Push
      0x85, 0x01, 0x0A, 0x57, 0x04, 0x0A, 0x58, 0x04, 0x0A, 0x59, 0x04,
      0x16, 0x01, 0x80, 0x26, 0xFF, 0x7F, 0x75, 0x10, 0x95, 0x03, 0x81, 0x02,
      0xB4,                                //   Pop
      0xC0,
      0x09, 0x73, 0xA1, 0x00,              // Accelerometer 3D
      0x85, 0x02,
      0x0B, 0x53, 0x04, 0x20, 0x00,        //   Usage (0x00200453), 4 bytes
      0x0B, 0x54, 0x04, 0x20, 0x00, 0x0B, 0x55, 0x04, 0x20, 0x00,
      0x15, 0x80, 0x25, 0x7F, 0x75, 0x08, 0x95, 0x03,  // 8-bit signed
      0x55, 0x0F,                          //   Unit Exponent (-1)
      0x81, 0x02, 0xC0,
  };
  // clang-format on
  const HidReportDescriptor parsed = ParseHidReportDescriptor(descriptor);
  EXPECT_EQ(parsed.input_report_bytes.at(1), 7);
  EXPECT_EQ(parsed.input_report_bytes.at(2), 4);
  const AccelReportLayout layout = FindAccelerometerLayout(parsed);
  EXPECT_EQ(layout.report_id, 2);
  EXPECT_EQ(layout.axes[0].bit_offset, 8);
  EXPECT_EQ(layout.axes[0].bit_size, 8);
  EXPECT_DOUBLE_EQ(layout.axes[0].scale, 0.1 * kStandardGravity);
  const auto value = DecodeAccelReport(layout, Bytes{0x02, 0x0A, 0xF6, 0x00});
  ASSERT_TRUE(value.has_value());
  EXPECT_NEAR((*value)[0], kStandardGravity, 1e-12);
  EXPECT_NEAR((*value)[1], -kStandardGravity, 1e-12);
  EXPECT_FALSE(DecodeAccelReport(layout, Bytes{0x01, 0, 0, 0, 0, 0, 0}).has_value());
}

TEST(HidDescriptor, LongItemsAreSkipped) {
  Bytes descriptor = {0xFE, 0x02, 0xF0, 0xAA, 0xBB};  // A long item with 2 data bytes.
  descriptor.insert(descriptor.end(), kPlainAccelerometer.begin(), kPlainAccelerometer.end());
  EXPECT_EQ(ParseHidReportDescriptor(descriptor).inputs.size(), 3u);
}

TEST(HidDescriptor, MalformedDescriptorsAreRejectedWithWhereAndWhat) {
  // Logical Maximum announces 2 data bytes, one is there.
  EXPECT_EQ(ParseError({0x05, 0x20, 0x09, 0x73, 0xA1, 0x00, 0x26, 0xFF}),
            "HID report descriptor, byte 6: item 0x26 needs 2 data bytes, only 1 left "
            "(truncated descriptor)");
  // The whole plain descriptor without its End Collection.
  EXPECT_EQ(ParseError(Bytes(kPlainAccelerometer.begin(), kPlainAccelerometer.end() - 1)),
            "HID report descriptor, byte 4: collection (usage 0x00200073) is not closed by "
            "the end of the descriptor");
  EXPECT_EQ(ParseError({0x09, 0x73, 0xC0}),
            "HID report descriptor, byte 2: End Collection without an open collection");
  EXPECT_EQ(ParseError({0xA4, 0xB4, 0xB4}), "HID report descriptor, byte 2: Pop without a Push");
  EXPECT_EQ(ParseError({0x85, 0x00}),
            "HID report descriptor, byte 0: report id 0 (must be 1 to 255)");
  EXPECT_EQ(ParseError({0xFE, 0x04, 0x01, 0x00}),
            "HID report descriptor, byte 0: long item truncated");
  EXPECT_EQ(ParseError({0x75, 0x20, 0x96, 0x01, 0x40, 0x81, 0x02}),
            "HID report descriptor, byte 5: input report 0 longer than 64 KiB");
}

TEST(HidDescriptor, DevicesThatAreNotAccelerometersAreToldApart) {
  EXPECT_EQ(ParseError(kMouse),
            "HID report descriptor has no Accelerometer 3D input (HID Sensor usage page 0x20, "
            "usage 0x73): not a HID sensor accelerometer");
  EXPECT_NO_THROW(ParseHidReportDescriptor(kMouse));

  // An accelerometer collection without a Z axis.
  Bytes no_z = kPlainAccelerometer;
  no_z[24] = 0x02;  // Report Count (2): X and Y only.
  EXPECT_EQ(ParseError(no_z),
            "HID report descriptor: the Accelerometer 3D input report 0 has no Z acceleration "
            "(usage 0x200455)");

  // An accelerometer whose unit is not an acceleration (here: seconds).
  Bytes seconds = kPlainAccelerometer;
  seconds.insert(seconds.begin() + 27, {0x66, 0x01, 0x10});
  EXPECT_EQ(ParseError(seconds),
            "unsupported unit 0x00001001 on an acceleration field (expected none for G, or "
            "length per second squared: 0xe011 cm/s^2, 0xe013 in/s^2)");
}

TEST(HidDescriptor, AccelerationScales) {
  EXPECT_DOUBLE_EQ(HidAccelerationScale(0, 0), kStandardGravity);
  EXPECT_DOUBLE_EQ(HidAccelerationScale(0, -3), 1e-3 * kStandardGravity);
  EXPECT_DOUBLE_EQ(HidAccelerationScale(0xE011, 0), 0.01);
  EXPECT_DOUBLE_EQ(HidAccelerationScale(0xE013, 2), 2.54);
  EXPECT_THROW(HidAccelerationScale(0xF011, 0), Error);  // cm/s^-1: a speed.
}

TEST(ReportDecoding, PackedTwelveBitAxesAcrossByteBoundaries) {
  AccelReportLayout layout;
  for (int i = 0; i < 3; ++i) layout.axes[i] = {12 * i, 12, true, false, 1.0};
  // x = 0x7FF (2047), y = 0x800 (-2048), z = 0xFFF (-1): little-endian bit packing.
  const Bytes report = {0xFF, 0x07, 0x80, 0xFF, 0x0F};
  const auto value = DecodeAccelReport(layout, report);
  ASSERT_TRUE(value.has_value());
  EXPECT_EQ(*value, Eigen::Vector3d(2047, -2048, -1));
  for (ReportField& axis : layout.axes) axis.is_signed = false;
  EXPECT_EQ(*DecodeAccelReport(layout, report), Eigen::Vector3d(2047, 2048, 4095));
}

TEST(ReportDecoding, BigEndianFields) {
  AccelReportLayout layout;
  for (int i = 0; i < 3; ++i) layout.axes[i] = {8 + 16 * i, 16, true, true, 0.5};
  const auto value = DecodeAccelReport(layout, Bytes{0x00, 0x01, 0x00, 0xFF, 0xFE, 0x00, 0x02});
  ASSERT_TRUE(value.has_value());
  EXPECT_EQ(*value, Eigen::Vector3d(128, -1, 1));
}

// A vendor device that packs big-endian 16-bit counts of 1/4096 g after a report id,
// mounted so that its y is our x and its x our -y.
constexpr char kVendorMapping[] = R"(vendor_id: "0x2a03"
product_id: "00f1"
interface: 1
report_id: 3
byte_order: big
fields:
  - { byte: 1, bits: 16, signed: 1, scale: 0.00239420 }
  - { byte: 3, bits: 16, signed: true, scale: 0.00239420 }
  - { byte: 5, bits: 16, scale: 0.00239420 }
axis_order: [ 1, 0, 2 ]
axis_signs: [ 1, -1, 1 ]
)";

TEST(AccelMapping, YamlWithoutHeaderAxisOrderAndSigns) {
  const AccelMapping mapping = ParseAccelMapping(kVendorMapping, "vendor.yaml");
  EXPECT_EQ(mapping.vendor_id, 0x2a03);
  EXPECT_EQ(mapping.product_id, 0x00f1);
  EXPECT_EQ(mapping.interface_number, 1);
  EXPECT_EQ(mapping.layout.report_id, 3);
  EXPECT_EQ(mapping.layout.axes[0].bit_offset, 24);  // Device y.
  EXPECT_EQ(mapping.layout.axes[1].bit_offset, 8);   // Device x, flipped.
  EXPECT_DOUBLE_EQ(mapping.layout.axes[1].scale, -0.00239420);
  EXPECT_TRUE(mapping.layout.axes[2].big_endian);

  // Device (x, y, z) = (4096, -2048, 100) counts.
  const Bytes report = {0x03, 0x10, 0x00, 0xF8, 0x00, 0x00, 0x64};
  const auto value = DecodeAccelReport(mapping.layout, report);
  ASSERT_TRUE(value.has_value());
  EXPECT_NEAR((*value)[0], -2048 * 0.00239420, 1e-12);
  EXPECT_NEAR((*value)[1], -4096 * 0.00239420, 1e-12);
  EXPECT_NEAR((*value)[2], 100 * 0.00239420, 1e-12);
}

TEST(AccelMapping, JsonFileWithDefaults) {
  test::TempDir dir;
  test::WriteTextFile(dir / "imu.json", R"({
    "vendor_id": 4660, "product_id": "5678",
    "fields": [ { "byte": 0, "bits": 16, "scale": 0.01 },
                { "byte": 2, "bits": 16, "scale": 0.01 },
                { "byte": 4, "bit": 4, "bits": 12, "signed": "false", "scale": 0.02 } ]
  })");
  const AccelMapping mapping = LoadAccelMapping(dir / "imu.json");
  EXPECT_EQ(mapping.vendor_id, 0x1234);
  EXPECT_EQ(mapping.product_id, 0x5678);
  EXPECT_EQ(mapping.interface_number, -1);
  EXPECT_EQ(mapping.layout.report_id, 0);
  EXPECT_EQ(mapping.layout.axes[2].bit_offset, 36);
  EXPECT_FALSE(mapping.layout.axes[2].is_signed);
  EXPECT_TRUE(mapping.layout.axes[0].is_signed);
  EXPECT_FALSE(mapping.layout.axes[0].big_endian);
}

TEST(AccelMapping, MistakesNameTheFileAndKey) {
  auto error = [](const std::string& text) {
    try {
      ParseAccelMapping(text, "m.yaml");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string fields =
      "fields:\n  - { byte: 1, scale: 0.1 }\n  - { byte: 3, scale: 0.1 }\n"
      "  - { byte: 5, scale: 0.1 }\n";
  EXPECT_EQ(error("product_id: 1\n" + fields),
            "m.yaml: vendor_id: missing (the USB id, e.g. \"046d\")");
  EXPECT_EQ(error("vendor_id: \"12345\"\nproduct_id: 1\n" + fields),
            "m.yaml: vendor_id: expected a 16-bit USB id, e.g. \"046d\"");
  EXPECT_EQ(error("vendor_id: 1\nproduct_id: 1\n"),
            "m.yaml: fields: expected a list of the 3 axis fields as the device sends them");
  EXPECT_EQ(error("vendor_id: 1\nproduct_id: 1\nfields:\n  - { byte: 1 }\n  - { byte: 3 }\n"
                  "  - { byte: 5 }\n"),
            "m.yaml: fields[0].scale: missing (m/s^2 per count, e.g. 0.0011978 for 1/8192 g)");
  EXPECT_EQ(error("vendor_id: 1\nproduct_id: 1\nreport_id: 2\nfields:\n  - { byte: 0, scale: 1 }\n"
                  "  - { byte: 3, scale: 1 }\n  - { byte: 5, scale: 1 }\n"),
            "m.yaml: fields[0].byte: byte 0 holds the report id; data starts at byte 1");
  EXPECT_EQ(error("vendor_id: 1\nproduct_id: 1\naxis_order: [0, 0, 2]\n" + fields),
            "m.yaml: axis_order: expected a permutation of 0, 1, 2 (the field feeding x, y, z)");
  EXPECT_EQ(error("vendor_id: 1\nproduct_id: 1\naxis_signs: [1, 2, 1]\n" + fields),
            "m.yaml: axis_signs: expected 1 or -1");
  EXPECT_EQ(error("vendor_id: 1\nproduct_id: 1\nbyte_order: big\nfields:\n"
                  "  - { byte: 1, bits: 12, scale: 1 }\n  - { byte: 3, scale: 1 }\n"
                  "  - { byte: 5, scale: 1 }\n"),
            "m.yaml: fields[0]: big-endian fields must start on a byte and span whole bytes");
  EXPECT_EQ(error("vendor_id: 1\nproduct_id: 1\nfields:\n  - { byte: 1, bits: 40, scale: 1 }\n"
                  "  - { byte: 3, scale: 1 }\n  - { byte: 5, scale: 1 }\n"),
            "m.yaml: fields[0].bits: 40 out of range 1 to 32");
  EXPECT_THROW(LoadAccelMapping("/nonexistent/mapping.yaml"), Error);
}

}  // namespace
}  // namespace autocal
