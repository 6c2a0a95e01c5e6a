// The USB accelerometer driver: its queue and stream timing, and the driver itself
// against USB devices emulated with umockdev (tests/usb/emulated_usb.h). ctest runs
// this binary through umockdev-wrapper; run by hand without it, the emulated-device
// tests skip.
#include "devices/usb/usb_accelerometer.h"

#include <unistd.h>

#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "devices/usb/bounded_queue.h"
#include "devices/usb/hid_descriptor.h"
#include "devices/usb/report_timing.h"
#include "pipeline/error.h"
#include "tests/test_util.h"
#include "tests/usb/emulated_usb.h"

namespace autocal {
namespace {

using namespace std::chrono_literals;
using Bytes = std::vector<uint8_t>;
using Kind = UsbAccelerometerEvent::Kind;

TEST(ReportTiming, SteadyStreamHasItsRateAndNoGaps) {
  ReportTiming timing;
  const int64_t jitter_ns[] = {0, 150'000, -100'000, 50'000, -150'000};
  for (int i = 0; i < 200; ++i) {
    // 1 kHz with up to 0.15 ms of jitter: intervals of 0.7 to 1.3 ms, never a gap.
    EXPECT_FALSE(timing.Add(1'000'000 * int64_t{i} + jitter_ns[i % 5]));
  }
  EXPECT_NEAR(timing.rate_hz(), 1000.0, 10.0);
  EXPECT_NEAR(timing.median_interval_ns(), 1'150'000, 1);  // Skewed jitter: the median is off.
  EXPECT_EQ(timing.late_reports(), 0u);
  EXPECT_EQ(timing.missing_reports(), 0u);
}

TEST(ReportTiming, LongGapsCountAsLateWithTheReportsTheyMissed) {
  ReportTiming timing;
  int64_t t = 0;
  for (int i = 0; i < 20; ++i) timing.Add(t += 2'000'000);  // 500 Hz.
  EXPECT_TRUE(timing.Add(t += 8'000'000));                  // 3 reports missing.
  EXPECT_FALSE(timing.Add(t += 2'000'000));
  EXPECT_FALSE(timing.Add(t += 2'800'000));  // 1.4 intervals: late, but within bounds.
  EXPECT_TRUE(timing.Add(t += 3'200'000));   // 1.6 intervals: rounds to one missing.
  EXPECT_EQ(timing.late_reports(), 2u);
  EXPECT_EQ(timing.missing_reports(), 4u);
  EXPECT_EQ(timing.median_interval_ns(), 2'000'000);
  EXPECT_NEAR(timing.rate_hz(), 23 / 0.054, 1e-6);  // Gaps included: 23 intervals in 54 ms.

  // Unplugged for a second: the stream restarts, the pause is not a gap.
  timing.Restart();
  EXPECT_FALSE(timing.Add(t += 1'000'000'000));
  EXPECT_FALSE(timing.Add(t += 2'000'000));
  EXPECT_EQ(timing.late_reports(), 2u);
}

TEST(ReportTiming, NoJudgementBeforeEnoughIntervals) {
  ReportTiming timing;
  EXPECT_EQ(timing.rate_hz(), 0.0);
  EXPECT_FALSE(timing.Add(0));
  EXPECT_FALSE(timing.Add(1'000'000));
  EXPECT_FALSE(timing.Add(50'000'000));  // Only one interval known so far.
  EXPECT_EQ(timing.late_reports(), 0u);
}

TEST(BoundedQueue, DropsTheOldestWhenFullAndCountsThem) {
  BoundedQueue<int> queue(3);
  for (int i = 1; i <= 5; ++i) queue.Push(i);
  EXPECT_EQ(queue.size(), 3u);
  EXPECT_EQ(queue.dropped(), 2u);
  EXPECT_EQ(queue.Drain(), (std::vector<int>{3, 4, 5}));
  EXPECT_EQ(queue.size(), 0u);
  EXPECT_FALSE(queue.WaitFor(1, 1ms));
  std::thread producer([&] { queue.Push(6); });
  EXPECT_TRUE(queue.WaitFor(1, 2s));
  producer.join();
  EXPECT_EQ(queue.Drain(), std::vector<int>{6});
}

TEST(UsbAccelerometerOptions, DefaultsAreValidAndMistakesNamed) {
  std::string error;
  EXPECT_TRUE(UsbAccelerometerOptions().Check(&error));
  UsbAccelerometerOptions options;
  options.vendor_id = 0x1234;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_EQ(error, "vendor_id and product_id: give both or neither");
  options = {};
  options.transfers_in_flight = 0;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_EQ(error, "transfers_in_flight must be 1 to 64");
  UsbAccelerometer accelerometer(options);
  EXPECT_THROW(accelerometer.Start(), Error);
  EXPECT_FALSE(accelerometer.running());
}

// --- Against emulated devices ------------------------------------------------------

// A vendor HID keypad: a sensor it is not.
// clang-format off
const Bytes kKeypadDescriptor = {
    0x05, 0x01, 0x09, 0x06, 0xA1, 0x01, 0x05, 0x07, 0x19, 0x00, 0x29, 0x65,
    0x15, 0x00, 0x25, 0x65, 0x75, 0x08, 0x95, 0x06, 0x81, 0x00, 0xC0,
};
// clang-format on


test::EmulatedHidDevice Keypad() {
  test::EmulatedHidDevice device;
  device.vendor_id = 0x04d9;
  device.product_id = 0x1503;
  device.manufacturer = "Holtek";
  device.product = "Keypad";
  device.report_descriptor = kKeypadDescriptor;
  return device;
}

test::EmulatedHidDevice BootMouse() {
  test::EmulatedHidDevice device = Keypad();
  device.product_id = 0xc077;
  device.product = "Mouse";
  device.interface_subclass = 1;
  device.interface_protocol = 2;
  return device;
}

// Waits for the next event of `kind`, keeping the others in `seen`.
std::optional<UsbAccelerometerEvent> WaitForEvent(UsbAccelerometer& accelerometer, Kind kind,
                                                  std::vector<UsbAccelerometerEvent>* seen,
                                                  std::chrono::milliseconds timeout = 3s) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    for (UsbAccelerometerEvent& event : accelerometer.TakeEvents()) {
      seen->push_back(event);
      if (event.kind == kind) return event;
    }
    std::this_thread::sleep_for(2ms);
  }
  return std::nullopt;
}

std::string StartError(const UsbAccelerometerOptions& options) {
  UsbAccelerometer accelerometer(options);
  try {
    accelerometer.Start();
  } catch (const Error& e) {
    return e.what();
  }
  return "started";
}

class EmulatedUsb : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!test::RunningUnderUmockdevWrapper()) {
      GTEST_SKIP() << "needs umockdev-wrapper (ctest runs it so)";
    }
  }
};

// Sends reports (x = i, y = -i, z = 100 counts) and checks they come back as samples.
void StreamAndCheck(test::UsbTestbed& bed, int id, UsbAccelerometer& accelerometer, int first,
                    int count, int64_t after_ns) {
  for (int i = first; i < first + count; ++i) {
    ASSERT_TRUE(bed.SendReport(id, test::HidSensorAccelReport(i, -i, 100))) << "report " << i;
    std::this_thread::sleep_for(500us);
  }
  ASSERT_TRUE(accelerometer.WaitForSamples(count, 3s));
  const std::vector<AccelSample> samples = accelerometer.Drain();
  ASSERT_EQ(samples.size(), static_cast<size_t>(count));
  int64_t previous = after_ns;
  for (int k = 0; k < count; ++k) {
    const double g = 0.01 * kStandardGravity;
    EXPECT_NEAR(samples[k].specific_force.x(), (first + k) * g, 1e-9);
    EXPECT_NEAR(samples[k].specific_force.y(), -(first + k) * g, 1e-9);
    EXPECT_NEAR(samples[k].specific_force.z(), kStandardGravity, 1e-9);
    EXPECT_GT(samples[k].t_ns, previous);
    previous = samples[k].t_ns;
  }
  EXPECT_LE(previous, MonotonicNowNs());
}

TEST_F(EmulatedUsb, HidSensorAccelerometerIsFoundAndStreams) {
  test::UsbTestbed bed;  // Before libusb_init, which the driver's Start() calls.
  const int keypad = bed.Plug(Keypad());
  const int mouse = bed.Plug(BootMouse());
  const int hub = bed.Plug(test::HidSensorHub());
  UsbAccelerometer accelerometer;
  const int64_t before = MonotonicNowNs();
  accelerometer.Start();
  EXPECT_TRUE(accelerometer.running());

  // The layout came from the report descriptor the device sent; the kernel driver was
  // detached for the claim, and the other HID devices were left alone.
  EXPECT_EQ(bed.report_descriptor_requests(hub), 1);
  EXPECT_TRUE(bed.kernel_driver_detached(hub));
  EXPECT_TRUE(bed.interface_claimed(hub));
  for (int other : {keypad, mouse}) {
    EXPECT_EQ(bed.report_descriptor_requests(other), 0);
    EXPECT_FALSE(bed.kernel_driver_detached(other));
  }
  EXPECT_EQ(accelerometer.Describe(),
            "1234:5678 Acme Sensor Hub, bus 1 device 4, HID sensor: report 1, x: bits 24+16 "
            "signed * 0.0980665, y: bits 40+16 signed * 0.0980665, z: bits 56+16 signed * "
            "0.0980665 m/s^2");
  std::vector<UsbAccelerometerEvent> events = accelerometer.TakeEvents();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, Kind::kConnected);

  StreamAndCheck(bed, hub, accelerometer, 0, 40, before);
  // Another sensor's report on the same endpoint is counted, not decoded.
  ASSERT_TRUE(bed.SendReport(hub, test::HidSensorAccelReport(1, 2, 3, /*report_id=*/2)));
  // It is read on the driver's event thread: wait for it to be counted.
  const auto deadline = std::chrono::steady_clock::now() + 3s;
  while (accelerometer.stats().reports < 41u && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(2ms);
  }
  const UsbAccelerometerStats stats = accelerometer.stats();
  EXPECT_TRUE(stats.connected);
  EXPECT_EQ(stats.reports, 41u);
  EXPECT_EQ(stats.samples, 40u);
  EXPECT_EQ(stats.other_reports, 1u);
  EXPECT_EQ(stats.queue_dropped, 0u);
  EXPECT_EQ(stats.transfer_errors, 0u);
  EXPECT_EQ(stats.connections, 1);
  EXPECT_GT(stats.rate_hz, 0.0);

  accelerometer.Stop();
  EXPECT_FALSE(accelerometer.running());
  EXPECT_FALSE(bed.interface_claimed(hub));
  EXPECT_FALSE(bed.kernel_driver_detached(hub));  // Re-attached on release.
}

TEST_F(EmulatedUsb, UnplugKeepsTheSamplesBeforeItAndReplugResumes) {
  test::UsbTestbed bed;
  const int first = bed.Plug(test::HidSensorHub());
  UsbAccelerometer accelerometer;
  const int64_t before = MonotonicNowNs();
  accelerometer.Start();
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(bed.SendReport(first, test::HidSensorAccelReport(i, -i, 100)));
  ASSERT_TRUE(accelerometer.WaitForSamples(20, 3s));

  // Pulled out mid-stream, with transfers pending.
  const int64_t pulled = MonotonicNowNs();
  bed.Unplug(first);
  std::vector<UsbAccelerometerEvent> events;
  const auto lost = WaitForEvent(accelerometer, Kind::kDisconnected, &events);
  ASSERT_TRUE(lost.has_value());
  EXPECT_EQ(lost->message, "1234:5678 Acme Sensor Hub unplugged");
  EXPECT_GE(lost->t_ns, pulled);
  EXPECT_FALSE(accelerometer.stats().connected);
  EXPECT_TRUE(accelerometer.running());
  const std::vector<AccelSample> kept = accelerometer.Drain();
  ASSERT_EQ(kept.size(), 20u);
  EXPECT_LT(kept.back().t_ns, lost->t_ns);
  EXPECT_GT(kept.front().t_ns, before);

  // Plugged back in (a new device address): the same session goes on.
  const int second = bed.Plug(test::HidSensorHub());
  const auto back = WaitForEvent(accelerometer, Kind::kConnected, &events);
  ASSERT_TRUE(back.has_value());
  EXPECT_NE(back->message.find("bus 1 device 3"), std::string::npos) << back->message;
  EXPECT_EQ(bed.report_descriptor_requests(second), 1);
  // The time unplugged is no gap in the stream: the first sample after it starts anew.
  const uint64_t late_before = accelerometer.stats().late_reports;
  ASSERT_TRUE(bed.SendReport(second, test::HidSensorAccelReport(99, -99, 100)));
  ASSERT_TRUE(accelerometer.WaitForSamples(1, 3s));
  EXPECT_EQ(accelerometer.stats().late_reports, late_before);
  ASSERT_GT(accelerometer.Drain().front().t_ns, lost->t_ns);
  StreamAndCheck(bed, second, accelerometer, 100, 20, lost->t_ns);

  const UsbAccelerometerStats stats = accelerometer.stats();
  EXPECT_TRUE(stats.connected);
  EXPECT_EQ(stats.samples, 41u);
  EXPECT_EQ(stats.connections, 2);
  EXPECT_EQ(stats.disconnections, 1);
  for (const UsbAccelerometerEvent& event : events) EXPECT_NE(event.kind, Kind::kError);
}

TEST_F(EmulatedUsb, NoAccelerometerListsTheDevicesSeen) {
  {
    test::UsbTestbed bed;
    EXPECT_EQ(StartError({}), "no USB accelerometer found; devices seen: none");
  }
  test::UsbTestbed bed;
  bed.Plug(Keypad());
  bed.Plug(BootMouse());
  test::EmulatedHidDevice hidden = test::HidSensorHub();
  hidden.report_descriptor_in_sysfs = false;  // Bound to a driver, nothing in sysfs.
  const int hub = bed.Plug(hidden);
  EXPECT_EQ(StartError({}),
            "no USB accelerometer found; devices seen: 04d9:1503 Holtek Keypad (HID, not an "
            "accelerometer), 04d9:c077 Holtek Mouse, 1234:5678 Acme Sensor Hub (HID, in use "
            "by a kernel driver; name it to use it)");
  EXPECT_FALSE(bed.kernel_driver_detached(hub));

  // Named, it is taken from its driver and read.
  UsbAccelerometerOptions options;
  options.vendor_id = 0x1234;
  options.product_id = 0x5678;
  UsbAccelerometer accelerometer(options);
  accelerometer.Start();
  EXPECT_TRUE(bed.kernel_driver_detached(hub));
  EXPECT_EQ(bed.report_descriptor_requests(hub), 1);
  StreamAndCheck(bed, hub, accelerometer, 0, 5, 0);

  options.product_id = 0x5679;
  EXPECT_TRUE(StartError(options).starts_with(
      "no USB accelerometer 1234:5679 found; devices seen: 04d9:1503 Holtek Keypad"));
}

TEST_F(EmulatedUsb, PermissionDeniedNamesTheUdevRules) {
  if (geteuid() == 0) GTEST_SKIP() << "root opens any device node";
  test::UsbTestbed bed;
  test::EmulatedHidDevice locked = test::HidSensorHub();
  locked.node_accessible = false;
  bed.Plug(locked);
  EXPECT_EQ(StartError({}),
            "permission denied opening 1234:5678: install installers/udev/99-autocal.rules "
            "(docs/usb_accelerometer.md)");
}

TEST_F(EmulatedUsb, WaitsForTheDeviceWhenAsked) {
  test::UsbTestbed bed;
  UsbAccelerometerOptions options;
  options.wait_for_device = true;
  UsbAccelerometer accelerometer(options);
  accelerometer.Start();
  EXPECT_FALSE(accelerometer.stats().connected);
  const int hub = bed.Plug(test::HidSensorHub());
  std::vector<UsbAccelerometerEvent> events;
  ASSERT_TRUE(WaitForEvent(accelerometer, Kind::kConnected, &events).has_value());
  StreamAndCheck(bed, hub, accelerometer, 0, 10, 0);
}

TEST_F(EmulatedUsb, MappedDeviceIsReadWithoutItsReportDescriptor) {
  test::TempDir dir;
  // A vendor device sending [x, y, z] as big-endian 16-bit counts of 1 mg, mounted so
  // that its y is our -x.
  test::WriteTextFile(dir / "vendor.yaml",
                      "vendor_id: \"04d9\"\nproduct_id: \"1503\"\nbyte_order: big\n"
                      "fields:\n"
                      "  - { byte: 0, bits: 16, signed: 1, scale: 0.00980665 }\n"
                      "  - { byte: 2, bits: 16, signed: 1, scale: 0.00980665 }\n"
                      "  - { byte: 4, bits: 16, signed: 1, scale: 0.00980665 }\n"
                      "axis_order: [1, 0, 2]\naxis_signs: [-1, 1, 1]\n");
  test::UsbTestbed bed;
  const int keypad = bed.Plug(Keypad());
  UsbAccelerometerOptions options;
  options.mapping_file = dir / "vendor.yaml";
  UsbAccelerometer accelerometer(options);
  accelerometer.Start();
  EXPECT_EQ(bed.report_descriptor_requests(keypad), 0);
  EXPECT_NE(accelerometer.Describe().find("mapped: no report id, x: bits 16+16 signed "
                                          "big-endian * -0.00980665"),
            std::string::npos)
      << accelerometer.Describe();
  ASSERT_TRUE(bed.SendReport(keypad, {0x03, 0xE8, 0xFE, 0x0C, 0x00, 0x00}));  // 1000, -500, 0
  ASSERT_TRUE(accelerometer.WaitForSamples(1, 3s));
  const std::vector<AccelSample> samples = accelerometer.Drain();
  ASSERT_EQ(samples.size(), 1u);
  EXPECT_NEAR(samples[0].specific_force.x(), 0.5 * kStandardGravity, 1e-9);
  EXPECT_NEAR(samples[0].specific_force.y(), kStandardGravity, 1e-9);
  EXPECT_NEAR(samples[0].specific_force.z(), 0.0, 1e-9);
}

TEST_F(EmulatedUsb, FullQueueDropsTheOldestSamples) {
  test::UsbTestbed bed;
  const int hub = bed.Plug(test::HidSensorHub());
  UsbAccelerometerOptions options;
  options.queue_capacity = 5;
  UsbAccelerometer accelerometer(options);
  accelerometer.Start();
  for (int i = 0; i < 12; ++i) ASSERT_TRUE(bed.SendReport(hub, test::HidSensorAccelReport(i, 0, 0)));
  const auto deadline = std::chrono::steady_clock::now() + 3s;
  while (accelerometer.stats().samples < 12 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(1ms);
  }
  const std::vector<AccelSample> samples = accelerometer.Drain();
  ASSERT_EQ(samples.size(), 5u);
  EXPECT_NEAR(samples.front().specific_force.x(), 7 * 0.01 * kStandardGravity, 1e-9);
  EXPECT_EQ(accelerometer.stats().queue_dropped, 7u);
}

}  // namespace
}  // namespace autocal
