// A live USB accelerometer read through libusb: a HID Sensor accelerometer (layout from
// its HID report descriptor) or any HID-like device described by a mapping file. Reports
// are read asynchronously on a libusb event thread, stamped on arrival with
// CLOCK_MONOTONIC, converted to m/s^2 and queued for a consumer. Unplugging is reported
// and a re-plug resumes the stream. See docs/usb_accelerometer.md.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "devices/sequence.h"

namespace autocal {

struct UsbAccelerometerOptions {
  // Only this device (both 0: any HID Sensor accelerometer). A mapping file names its own.
  uint16_t vendor_id = 0;
  uint16_t product_id = 0;
  // Mapping file (YAML or JSON) for a device that does not follow the HID Sensor usage
  // tables; empty: the layout comes from the device's HID report descriptor.
  std::string mapping_file;
  // Samples kept for the consumer; when full the oldest are dropped, and counted.
  size_t queue_capacity = 8192;
  // Interrupt IN transfers kept submitted, so no report waits for a resubmission.
  int transfers_in_flight = 4;
  // false: Start() fails when no accelerometer is plugged in; true: it waits for one.
  bool wait_for_device = false;
  // Timeout of the report descriptor request, ms.
  int control_timeout_ms = 1000;

  // The message names the offending field.
  bool Check(std::string* error) const;
};

// A change of the connection, in the order it happened.
struct UsbAccelerometerEvent {
  enum class Kind { kConnected, kDisconnected, kError };
  Kind kind = Kind::kConnected;
  int64_t t_ns = 0;  // CLOCK_MONOTONIC, like the samples.
  std::string message;
};

struct UsbAccelerometerStats {
  bool connected = false;
  uint64_t reports = 0;          // Input reports received.
  uint64_t samples = 0;          // Reports decoded into samples.
  uint64_t other_reports = 0;    // Reports of another report id (a sensor hub's other sensors).
  uint64_t queue_dropped = 0;    // Samples dropped, oldest first, because nobody drained them.
  uint64_t late_reports = 0;     // Samples after a gap over 1.5 median intervals.
  uint64_t missing_reports = 0;  // Samples those gaps should have held (estimate).
  uint64_t transfer_errors = 0;  // Failed transfers other than unplug and cancel.
  int connections = 0;           // Times a device was opened: 1 + re-plugs.
  int disconnections = 0;
  double rate_hz = 0.0;  // Samples per second over the last 64 intervals.
};

// The clock samples and events are stamped with: CLOCK_MONOTONIC in ns.
int64_t MonotonicNowNs();

class UsbAccelerometer {
 public:
  explicit UsbAccelerometer(UsbAccelerometerOptions options = {});
  ~UsbAccelerometer();  // Stops.
  UsbAccelerometer(const UsbAccelerometer&) = delete;
  UsbAccelerometer& operator=(const UsbAccelerometer&) = delete;

  // Opens the accelerometer and starts streaming. Throws Error when the options or the
  // mapping file are wrong, when no accelerometer is plugged in (unless
  // wait_for_device; the message lists the devices seen) or when it cannot be opened
  // (permission denied names the udev rules to install). Does nothing when running.
  void Start();
  // Stops streaming and releases the device; queued samples stay to be drained.
  void Stop();
  bool running() const;

  // Every queued sample, oldest first.
  std::vector<AccelSample> Drain();
  // Waits until at least `count` samples are queued; false on timeout.
  bool WaitForSamples(size_t count, std::chrono::milliseconds timeout);
  // Connection events since the last call, oldest first.
  std::vector<UsbAccelerometerEvent> TakeEvents();
  UsbAccelerometerStats stats() const;
  // The device streaming now or last: "1234:5678 Acme Sensor Hub, bus 1 device 2, ...".
  std::string Describe() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace autocal
