// USB HID devices emulated at the usbfs level with umockdev, for testing the libusb
// accelerometer driver without hardware or root. The test binary must run under
// umockdev-wrapper, and the testbed must exist before libusb_init (see
// docs/usb_accelerometer.md).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace autocal::test {

// What the emulated device reports about itself.
struct EmulatedHidDevice {
  uint16_t vendor_id = 0x1234;
  uint16_t product_id = 0x5678;
  std::string manufacturer = "Acme";
  std::string product = "Sensor Hub";
  std::vector<uint8_t> report_descriptor;
  uint8_t interface_subclass = 0;  // 1 with protocol 1 or 2: a boot keyboard or mouse.
  uint8_t interface_protocol = 0;
  uint8_t in_endpoint = 0x81;
  uint16_t max_packet_size = 64;
  // Name GETDRIVER reports for the interface until it is detached; empty: none bound.
  std::string kernel_driver = "usbhid";
  // Also expose the report descriptor in sysfs, as the kernel's HID core does.
  bool report_descriptor_in_sysfs = true;
  // false: the device node has mode 0000, as without the udev rules (root ignores it).
  bool node_accessible = true;
};

// A umockdev testbed with USB devices plugged into bus 1. Create it before libusb_init.
class UsbTestbed {
 public:
  UsbTestbed();
  ~UsbTestbed();
  UsbTestbed(const UsbTestbed&) = delete;
  UsbTestbed& operator=(const UsbTestbed&) = delete;

  // Adds the device with the next free device number (like a re-plug, which gets a new
  // address) and announces it with an "add" uevent. Returns its id.
  int Plug(const EmulatedHidDevice& device);
  // Fails the device's pending URBs with -ENODEV, as the kernel does, sends the "remove"
  // uevent and removes it from sysfs.
  void Unplug(int id);

  // Hands `report` to the next interrupt IN URB the driver submits; true once libusb has
  // reaped it, false after `timeout`.
  bool SendReport(int id, const std::vector<uint8_t>& report,
                  std::chrono::milliseconds timeout = std::chrono::milliseconds(2000));

  // Control requests for the HID report descriptor the device has answered.
  int report_descriptor_requests(int id) const;
  // Whether the kernel driver was detached from the interface.
  bool kernel_driver_detached(int id) const;
  // Whether the interface is claimed through usbfs right now.
  bool interface_claimed(int id) const;

 private:
  struct Port;
  Port& port(int id) const;

  struct Testbed;
  std::unique_ptr<Testbed> testbed_;
  std::vector<std::unique_ptr<Port>> ports_;
  int next_devnum_ = 2;
};

// A HID Sensor Accelerometer 3D: report 1 holds the sensor state, the sensor event, then
// X, Y, Z as 16-bit signed counts of 0.01 g.
EmulatedHidDevice HidSensorHub();
// One input report of it (`report_id` other than 1: another sensor's report).
std::vector<uint8_t> HidSensorAccelReport(int x, int y, int z, uint8_t report_id = 1);

// True when the process runs under umockdev-wrapper (libumockdev-preload is loaded).
bool RunningUnderUmockdevWrapper();

}  // namespace autocal::test
