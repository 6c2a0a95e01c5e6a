#include "devices/usb/usb_accelerometer.h"

#include <libusb.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>

#include "devices/usb/accel_mapping.h"
#include "devices/usb/bounded_queue.h"
#include "devices/usb/hid_descriptor.h"
#include "devices/usb/report_timing.h"
#include "pipeline/error.h"

namespace autocal {
namespace {

namespace fs = std::filesystem;

constexpr char kUdevHint[] = "install installers/udev/99-autocal.rules (docs/usb_accelerometer.md)";
constexpr uint8_t kHidClass = 0x03;
constexpr uint8_t kHidDescriptorType = 0x21;
constexpr uint8_t kHidReportDescriptorType = 0x22;
constexpr uint8_t kHubClass = 0x09;
// bmRequestType of GET_DESCRIPTOR for an interface: device to host, standard, interface.
constexpr uint8_t kGetInterfaceDescriptor = 0x81;
// Consecutive failed transfers after which the device is given up until it is re-plugged.
constexpr int kMaxConsecutiveErrors = 20;
// A device is announced before the kernel has added its interfaces and bound their
// drivers; a moment later sysfs shows its HID report descriptor.
constexpr int64_t kHotplugSettleNs = 200'000'000;

std::string UsbId(uint16_t vendor_id, uint16_t product_id) {
  char text[16];
  std::snprintf(text, sizeof(text), "%04x:%04x", vendor_id, product_id);
  return text;
}

std::string LibusbMessage(int code) {
  return std::string(libusb_error_name(code)) + " (" + libusb_strerror(code) + ")";
}

std::string ReadAttribute(const fs::path& path) {
  std::ifstream in(path);
  std::string text;
  std::getline(in, text);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\r')) text.pop_back();
  return text;
}

// The device's folder in sysfs, matched on bus and device numbers: manufacturer and
// product names, and the HID core's copy of the report descriptor, are readable there
// without opening the device.
std::optional<fs::path> SysfsDevice(int bus, int address) {
  std::error_code error;
  for (const fs::directory_entry& entry : fs::directory_iterator("/sys/bus/usb/devices", error)) {
    if (entry.path().filename().string().find(':') != std::string::npos) continue;
    if (ReadAttribute(entry.path() / "busnum") == std::to_string(bus) &&
        ReadAttribute(entry.path() / "devnum") == std::to_string(address)) {
      return entry.path();
    }
  }
  return std::nullopt;
}

// The report descriptor of an interface, as the kernel's HID core exposes it once a HID
// driver is bound (.../1-2:1.0/0003:1234:5678.0001/report_descriptor).
std::optional<std::vector<uint8_t>> SysfsReportDescriptor(const fs::path& device, int configuration,
                                                          int interface_number) {
  const fs::path interface =
      device / (device.filename().string() + ":" + std::to_string(configuration) + "." +
                std::to_string(interface_number));
  std::error_code error;
  for (const fs::directory_entry& entry : fs::directory_iterator(interface, error)) {
    std::ifstream in(entry.path() / "report_descriptor", std::ios::binary);
    if (!in) continue;
    return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
  }
  return std::nullopt;
}

// The length of the HID report descriptor, from the HID class descriptor that follows
// the interface descriptor (HID 1.11, 6.2.1).
int ReportDescriptorLength(const libusb_interface_descriptor& interface) {
  const uint8_t* extra = interface.extra;
  for (int pos = 0; pos + 2 <= interface.extra_length && extra[pos] >= 2; pos += extra[pos]) {
    if (extra[pos + 1] != kHidDescriptorType || pos + extra[pos] > interface.extra_length) continue;
    const int count = extra[pos] >= 6 ? extra[pos + 5] : 0;
    for (int i = 0; i < count && 6 + 3 * i + 3 <= extra[pos]; ++i) {
      const uint8_t* entry = extra + pos + 6 + 3 * i;
      if (entry[0] == kHidReportDescriptorType) return entry[1] | (entry[2] << 8);
    }
  }
  return 0;
}

const libusb_endpoint_descriptor* InterruptInEndpoint(
    const libusb_interface_descriptor& interface) {
  for (int i = 0; i < interface.bNumEndpoints; ++i) {
    const libusb_endpoint_descriptor& endpoint = interface.endpoint[i];
    if ((endpoint.bEndpointAddress & LIBUSB_ENDPOINT_IN) &&
        (endpoint.bmAttributes & 3) == LIBUSB_TRANSFER_TYPE_INTERRUPT) {
      return &endpoint;
    }
  }
  return nullptr;
}

bool IsBootKeyboardOrMouse(const libusb_interface_descriptor& interface) {
  return interface.bInterfaceSubClass == 1 &&
         (interface.bInterfaceProtocol == 1 || interface.bInterfaceProtocol == 2);
}

// Owns the config descriptor libusb hands out.
struct ConfigDescriptor {
  libusb_config_descriptor* config = nullptr;
  ~ConfigDescriptor() {
    if (config != nullptr) libusb_free_config_descriptor(config);
  }
};

}  // namespace

int64_t MonotonicNowNs() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  return int64_t{now.tv_sec} * 1'000'000'000 + now.tv_nsec;
}

bool UsbAccelerometerOptions::Check(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if ((vendor_id == 0) != (product_id == 0)) {
    return fail("vendor_id and product_id: give both or neither");
  }
  if (!mapping_file.empty() && vendor_id != 0) {
    return fail("vendor_id/product_id: the mapping file names the device; leave them 0");
  }
  if (queue_capacity < 1) return fail("queue_capacity must be at least 1");
  if (transfers_in_flight < 1 || transfers_in_flight > 64) {
    return fail("transfers_in_flight must be 1 to 64");
  }
  if (control_timeout_ms < 1) return fail("control_timeout_ms must be positive");
  return true;
}

class UsbAccelerometer::Impl {
 public:
  explicit Impl(UsbAccelerometerOptions options)
      : options_(std::move(options)), samples_(options_.queue_capacity) {}

  ~Impl() { Stop(); }

  void Start();
  void Stop();
  bool running() const { return running_; }

  std::vector<AccelSample> Drain() { return samples_.Drain(); }
  bool WaitForSamples(size_t count, std::chrono::milliseconds timeout) {
    return samples_.WaitFor(count, timeout);
  }
  std::vector<UsbAccelerometerEvent> TakeEvents() {
    std::lock_guard lock(state_mutex_);
    return std::exchange(events_, {});
  }
  UsbAccelerometerStats stats() const {
    std::lock_guard lock(state_mutex_);
    UsbAccelerometerStats stats = stats_;
    stats.queue_dropped = samples_.dropped();
    stats.late_reports = timing_.late_reports();
    stats.missing_reports = timing_.missing_reports();
    stats.rate_hz = timing_.rate_hz();
    return stats;
  }
  std::string Describe() const {
    std::lock_guard lock(state_mutex_);
    return description_;
  }

 private:
  // The device being streamed. Touched only by the thread handling libusb events (the
  // event thread; Start before it runs and Stop after it ends).
  struct Connection {
    libusb_device* device = nullptr;
    libusb_device_handle* handle = nullptr;
    int interface_number = 0;
    AccelReportLayout layout;
    std::string name;  // "1234:5678 Acme Sensor Hub"
    std::vector<std::vector<uint8_t>> buffers;
    std::vector<libusb_transfer*> transfers;
    int in_flight = 0;
    int consecutive_errors = 0;
    bool lost = false;  // Unplugged or failed: no resubmissions, close once drained.
  };

  // What trying one device gave, for the "devices seen" list.
  struct Probe {
    bool opened = false;
    bool permission_denied = false;
    std::string seen;  // "046d:c52b Logitech USB Receiver (HID, not an accelerometer)"
  };

  // One interface of one device, to stream from.
  struct Target {
    libusb_device* device = nullptr;
    std::string id;    // "1234:5678"
    std::string name;  // "1234:5678 Acme Sensor Hub"
    int interface_number = 0;
    uint8_t endpoint = 0;
    int packet_size = 0;
    int report_descriptor_length = 0;
    const AccelReportLayout* mapped = nullptr;  // From the mapping file; else read the device's.
    // Nobody named this device: trouble only notes it, and a kernel driver stays.
    bool probing = false;
  };

  static int LIBUSB_CALL OnHotplug(libusb_context* context, libusb_device* device,
                                   libusb_hotplug_event event, void* self);
  static void LIBUSB_CALL OnTransfer(libusb_transfer* transfer);

  void Run();
  void Service();
  Probe TryOpen(libusb_device* device);
  void OpenAndStream(const Target& target, Probe* probe);
  void HandleTransfer(libusb_transfer* transfer);
  void MarkLost(int64_t t_ns, const std::string& why);
  void CloseConnection();
  void Shutdown();
  void AddEvent(UsbAccelerometerEvent::Kind kind, int64_t t_ns, std::string message);

  const UsbAccelerometerOptions options_;
  std::optional<AccelMapping> mapping_;
  libusb_context* context_ = nullptr;
  libusb_hotplug_callback_handle hotplug_ = 0;  // libusb numbers them from 1.
  std::thread thread_;
  std::atomic<bool> running_{false};

  // Hot-plug notifications from libusb's callback to Service().
  std::mutex hotplug_mutex_;
  std::vector<std::pair<libusb_device*, int64_t>> arrived_;  // Referenced, with the time.
  std::vector<std::pair<libusb_device*, int64_t>> left_;     // Compared, never dereferenced.

  std::unique_ptr<Connection> connection_;

  BoundedQueue<AccelSample> samples_;
  mutable std::mutex state_mutex_;  // The members below.
  std::vector<UsbAccelerometerEvent> events_;
  UsbAccelerometerStats stats_;
  ReportTiming timing_;
  int64_t last_sample_ns_ = 0;
  std::string description_;
};

void UsbAccelerometer::Impl::Start() {
  if (running_) return;
  std::string error;
  if (!options_.Check(&error)) throw Error("USB accelerometer options: " + error);
  if (!options_.mapping_file.empty()) mapping_ = LoadAccelMapping(options_.mapping_file);

  int r = libusb_init(&context_);
  if (r != 0) throw Error("cannot initialize libusb: " + LibusbMessage(r));
  if (!libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG)) {
    Shutdown();
    throw Error("libusb has no hot-plug support on this system");
  }
  // Every device, not only the wanted one, so that a failure can list what was seen.
  // ENUMERATE reports the devices already plugged in from within this call.
  r = libusb_hotplug_register_callback(
      context_,
      static_cast<libusb_hotplug_event>(LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED |
                                        LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT),
      LIBUSB_HOTPLUG_ENUMERATE, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY,
      LIBUSB_HOTPLUG_MATCH_ANY, &Impl::OnHotplug, this, &hotplug_);
  if (r != 0) {
    Shutdown();
    throw Error("cannot register for USB hot-plug events: " + LibusbMessage(r));
  }

  std::vector<std::pair<libusb_device*, int64_t>> present;
  {
    std::lock_guard lock(hotplug_mutex_);
    present.swap(arrived_);
  }
  std::vector<std::string> seen;
  std::optional<Error> failure;
  bool permission_denied = false;
  for (const auto& [device, t_ns] : present) {
    if (connection_ == nullptr) {
      try {
        const Probe probe = TryOpen(device);
        if (!probe.seen.empty()) seen.push_back(probe.seen);
        permission_denied |= probe.permission_denied;
      } catch (const Error& e) {
        if (!failure) failure = e;
      }
    }
    libusb_unref_device(device);
  }
  if (connection_ == nullptr && !options_.wait_for_device) {
    Shutdown();
    if (failure) throw *failure;
    std::string wanted = "USB accelerometer";
    if (mapping_) {
      wanted += " " + UsbId(mapping_->vendor_id, mapping_->product_id) + " (mapping " +
                options_.mapping_file + ")";
    } else if (options_.vendor_id != 0) {
      wanted += " " + UsbId(options_.vendor_id, options_.product_id);
    }
    std::sort(seen.begin(), seen.end());
    std::string message = "no " + wanted + " found; devices seen: ";
    for (size_t i = 0; i < seen.size(); ++i) message += (i > 0 ? ", " : "") + seen[i];
    if (seen.empty()) message += "none";
    if (permission_denied) message += std::string("; permission denied on some: ") + kUdevHint;
    throw Error(message);
  }
  if (connection_ == nullptr && failure) {
    AddEvent(UsbAccelerometerEvent::Kind::kError, MonotonicNowNs(), failure->what());
  }
  running_ = true;
  thread_ = std::thread(&Impl::Run, this);
}

void UsbAccelerometer::Impl::Stop() {
  if (context_ == nullptr) return;
  if (running_.exchange(false)) {
    libusb_interrupt_event_handler(context_);
    thread_.join();
  }
  Shutdown();
}

// Cancels and reaps the transfers, closes the device, leaves libusb.
void UsbAccelerometer::Impl::Shutdown() {
  if (connection_ != nullptr) {
    for (libusb_transfer* transfer : connection_->transfers) libusb_cancel_transfer(transfer);
    const int64_t deadline = MonotonicNowNs() + 2'000'000'000;
    while (connection_->in_flight > 0 && MonotonicNowNs() < deadline) {
      timeval tv{0, 20000};
      libusb_handle_events_timeout_completed(context_, &tv, nullptr);
    }
    if (connection_->in_flight > 0) {
      // Freeing a transfer libusb still holds would corrupt it: leave them.
      connection_->transfers.clear();
    }
    CloseConnection();
  }
  if (hotplug_ != 0) {
    libusb_hotplug_deregister_callback(context_, hotplug_);
    hotplug_ = 0;
  }
  {
    std::lock_guard lock(hotplug_mutex_);
    for (const auto& [device, t_ns] : arrived_) libusb_unref_device(device);
    arrived_.clear();
    left_.clear();
  }
  libusb_exit(context_);
  context_ = nullptr;
}

int LIBUSB_CALL UsbAccelerometer::Impl::OnHotplug(libusb_context* /*context*/,
                                                  libusb_device* device, libusb_hotplug_event event,
                                                  void* self) {
  // Runs inside libusb's event handling, where opening a device or a synchronous
  // transfer is not allowed: Service() acts on it.
  auto* impl = static_cast<Impl*>(self);
  std::lock_guard lock(impl->hotplug_mutex_);
  if (event == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED) {
    impl->arrived_.emplace_back(libusb_ref_device(device), MonotonicNowNs());
  } else {
    impl->left_.emplace_back(device, MonotonicNowNs());
  }
  return 0;
}

void UsbAccelerometer::Impl::Run() {
  while (running_) {
    timeval tv{0, 100000};
    const int r = libusb_handle_events_timeout_completed(context_, &tv, nullptr);
    if (r != 0 && r != LIBUSB_ERROR_INTERRUPTED) {
      AddEvent(UsbAccelerometerEvent::Kind::kError, MonotonicNowNs(),
               "libusb event handling failed: " + LibusbMessage(r));
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    Service();
  }
}

// Between rounds of event handling: notices unplugs, closes a lost device once its
// transfers are back, and opens a newly plugged one once it has settled, if none streams.
void UsbAccelerometer::Impl::Service() {
  std::vector<std::pair<libusb_device*, int64_t>> left;
  {
    std::lock_guard lock(hotplug_mutex_);
    left.swap(left_);
  }
  if (connection_ != nullptr) {
    for (const auto& [device, t_ns] : left) {
      if (device == connection_->device) MarkLost(t_ns, "unplugged");
    }
    if (connection_->lost && connection_->in_flight == 0) CloseConnection();
  }
  std::vector<libusb_device*> ready;
  {
    std::lock_guard lock(hotplug_mutex_);
    const int64_t settled = MonotonicNowNs() - kHotplugSettleNs;
    // While a device streams, others are dropped; while a lost one drains, they wait.
    std::erase_if(arrived_, [&](const std::pair<libusb_device*, int64_t>& entry) {
      if (connection_ != nullptr ? connection_->lost : entry.second > settled) return false;
      ready.push_back(entry.first);
      return true;
    });
  }
  for (libusb_device* device : ready) {
    if (connection_ == nullptr) {
      try {
        TryOpen(device);
      } catch (const Error& e) {
        AddEvent(UsbAccelerometerEvent::Kind::kError, MonotonicNowNs(), e.what());
      }
    }
    libusb_unref_device(device);
  }
}

UsbAccelerometer::Impl::Probe UsbAccelerometer::Impl::TryOpen(libusb_device* device) {
  Probe probe;
  libusb_device_descriptor descriptor{};
  if (libusb_get_device_descriptor(device, &descriptor) != 0) return probe;
  if (descriptor.bDeviceClass == kHubClass) return probe;
  Target target;
  target.device = device;
  target.id = UsbId(descriptor.idVendor, descriptor.idProduct);
  target.name = target.id;
  const std::optional<fs::path> sysfs =
      SysfsDevice(libusb_get_bus_number(device), libusb_get_device_address(device));
  if (sysfs) {
    for (const char* attribute : {"manufacturer", "product"}) {
      const std::string text = ReadAttribute(*sysfs / attribute);
      if (!text.empty()) target.name += " " + text;
    }
  }
  probe.seen = target.name;

  // A device named by the options or the mapping file is ours: its failures are errors.
  // Any other is only probed, and left alone when in doubt.
  const uint16_t vendor_id = mapping_ ? mapping_->vendor_id : options_.vendor_id;
  const uint16_t product_id = mapping_ ? mapping_->product_id : options_.product_id;
  const bool named = vendor_id != 0;
  if (named && (descriptor.idVendor != vendor_id || descriptor.idProduct != product_id)) {
    return probe;
  }

  ConfigDescriptor config;
  const int r = libusb_get_active_config_descriptor(device, &config.config);
  if (r != 0) {
    if (named) {
      throw Error("cannot read the configuration of " + target.name + ": " + LibusbMessage(r));
    }
    return probe;
  }
  for (int i = 0; i < config.config->bNumInterfaces; ++i) {
    if (config.config->interface[i].num_altsetting < 1) continue;
    const libusb_interface_descriptor& interface = config.config->interface[i].altsetting[0];
    const libusb_endpoint_descriptor* endpoint = InterruptInEndpoint(interface);
    if (endpoint == nullptr) continue;
    target.interface_number = interface.bInterfaceNumber;
    target.endpoint = endpoint->bEndpointAddress;
    target.packet_size = endpoint->wMaxPacketSize;
    if (mapping_) {
      if (mapping_->interface_number >= 0 &&
          interface.bInterfaceNumber != mapping_->interface_number) {
        continue;
      }
      target.mapped = &mapping_->layout;
      OpenAndStream(target, &probe);
      return probe;
    }
    if (interface.bInterfaceClass != kHidClass || (!named && IsBootKeyboardOrMouse(interface))) {
      continue;
    }
    // The HID core's copy in sysfs tells an accelerometer without touching the device;
    // the device's own copy is still read, as sysfs has none when no HID driver is bound.
    bool screened = false;
    if (sysfs) {
      if (const auto bytes = SysfsReportDescriptor(*sysfs, config.config->bConfigurationValue,
                                                   interface.bInterfaceNumber)) {
        try {
          FindAccelerometerLayout(ParseHidReportDescriptor(*bytes));
          screened = true;
        } catch (const Error&) {
          if (!named) {
            probe.seen = target.name + " (HID, not an accelerometer)";
            continue;
          }
        }
      }
    }
    target.report_descriptor_length = ReportDescriptorLength(interface);
    target.probing = !named && !screened;
    OpenAndStream(target, &probe);
    if (probe.opened || probe.permission_denied) return probe;
  }
  if (named && !probe.opened) {
    throw Error(target.name + " has no " + (mapping_ ? "" : "HID ") +
                "interface with an interrupt IN endpoint" +
                (mapping_ && mapping_->interface_number >= 0
                     ? " numbered " + std::to_string(mapping_->interface_number)
                     : ""));
  }
  return probe;
}

// Opens the device, claims the interface (detaching a kernel driver), reads the report
// descriptor unless mapped, and submits the interrupt transfers. Throws Error unless
// probing, when trouble only notes the device in `probe`.
void UsbAccelerometer::Impl::OpenAndStream(const Target& target, Probe* probe) {
  auto fail = [&](const std::string& note, const std::string& message) {
    if (!target.probing) throw Error(message);
    probe->seen = target.name + " (" + note + ")";
  };
  libusb_device_handle* handle = nullptr;
  int r = libusb_open(target.device, &handle);
  if (r == LIBUSB_ERROR_ACCESS) {
    probe->permission_denied = true;
    fail("permission denied", "permission denied opening " + target.id + ": " + kUdevHint);
    return;
  }
  if (r != 0) {
    fail("cannot be opened", "cannot open " + target.name + ": " + LibusbMessage(r));
    return;
  }
  if (target.probing && libusb_kernel_driver_active(handle, target.interface_number) == 1) {
    // A kernel driver uses this HID device and the HID core did not say it is an
    // accelerometer: detaching it to look could take away someone's keyboard.
    libusb_close(handle);
    probe->seen = target.name + " (HID, in use by a kernel driver; name it to use it)";
    return;
  }
  libusb_set_auto_detach_kernel_driver(handle, 1);
  r = libusb_claim_interface(handle, target.interface_number);
  if (r != 0) {
    libusb_close(handle);
    fail("busy", "cannot claim interface " + std::to_string(target.interface_number) + " of " +
                     target.name + ": " + LibusbMessage(r) +
                     (r == LIBUSB_ERROR_BUSY ? "; another program is using it" : ""));
    return;
  }
  auto release = [&] {
    libusb_release_interface(handle, target.interface_number);
    libusb_close(handle);
  };

  AccelReportLayout layout;
  std::string kind = "mapped";
  if (target.mapped != nullptr) {
    layout = *target.mapped;
  } else {
    kind = "HID sensor";
    std::vector<uint8_t> bytes(target.report_descriptor_length > 0 ? target.report_descriptor_length
                                                                   : 4096);
    r = libusb_control_transfer(handle, kGetInterfaceDescriptor, LIBUSB_REQUEST_GET_DESCRIPTOR,
                                kHidReportDescriptorType << 8, target.interface_number,
                                bytes.data(), static_cast<uint16_t>(bytes.size()),
                                options_.control_timeout_ms);
    if (r < 0) {
      release();
      fail("no report descriptor",
           "cannot read the HID report descriptor of " + target.name + ": " + LibusbMessage(r));
      return;
    }
    bytes.resize(r);
    try {
      layout = FindAccelerometerLayout(ParseHidReportDescriptor(bytes));
    } catch (const Error& e) {
      release();
      fail("HID, not an accelerometer", target.name + ": " + e.what());
      return;
    }
  }

  auto connection = std::make_unique<Connection>();
  connection->device = libusb_ref_device(target.device);
  connection->handle = handle;
  connection->interface_number = target.interface_number;
  connection->layout = layout;
  connection->name = target.name;
  const int buffer_size = std::max(target.packet_size, layout.min_report_bytes());
  for (int i = 0; i < options_.transfers_in_flight; ++i) {
    libusb_transfer* transfer = libusb_alloc_transfer(0);
    if (transfer == nullptr) break;
    connection->buffers.emplace_back(buffer_size);
    libusb_fill_interrupt_transfer(transfer, handle, target.endpoint,
                                   connection->buffers.back().data(), buffer_size,
                                   &Impl::OnTransfer, this, 0);
    connection->transfers.push_back(transfer);
  }
  connection_ = std::move(connection);
  for (libusb_transfer* transfer : connection_->transfers) {
    r = libusb_submit_transfer(transfer);
    if (r != 0) break;
    ++connection_->in_flight;
  }
  if (connection_->in_flight == 0) {
    CloseConnection();
    fail("cannot read",
         "cannot read the interrupt endpoint of " + target.name + ": " + LibusbMessage(r));
    return;
  }
  probe->opened = true;
  probe->seen = target.name;
  char where[48];
  std::snprintf(where, sizeof(where), ", bus %d device %d, ", libusb_get_bus_number(target.device),
                libusb_get_device_address(target.device));
  const std::string description = target.name + where + kind + ": " + layout.Describe();
  {
    std::lock_guard lock(state_mutex_);
    description_ = description;
    stats_.connected = true;
    ++stats_.connections;
    timing_.Restart();
  }
  AddEvent(UsbAccelerometerEvent::Kind::kConnected, MonotonicNowNs(), description);
}

void LIBUSB_CALL UsbAccelerometer::Impl::OnTransfer(libusb_transfer* transfer) {
  static_cast<Impl*>(transfer->user_data)->HandleTransfer(transfer);
}

void UsbAccelerometer::Impl::HandleTransfer(libusb_transfer* transfer) {
  const int64_t now = MonotonicNowNs();
  Connection& c = *connection_;
  --c.in_flight;
  switch (transfer->status) {
    case LIBUSB_TRANSFER_COMPLETED: {
      c.consecutive_errors = 0;
      const std::optional<Eigen::Vector3d> value = DecodeAccelReport(
          c.layout, std::span<const uint8_t>(transfer->buffer, transfer->actual_length));
      std::lock_guard lock(state_mutex_);
      ++stats_.reports;
      if (value) {
        // Reports reaped together are stamped in completion order; a clock tie is
        // broken by 1 ns so that times stay strictly increasing.
        last_sample_ns_ = std::max(now, last_sample_ns_ + 1);
        timing_.Add(last_sample_ns_);
        samples_.Push({last_sample_ns_, *value});
        ++stats_.samples;
      } else {
        ++stats_.other_reports;
      }
      break;
    }
    case LIBUSB_TRANSFER_NO_DEVICE:
      MarkLost(now, "unplugged");
      return;
    case LIBUSB_TRANSFER_CANCELLED:
      return;
    default: {
      {
        std::lock_guard lock(state_mutex_);
        ++stats_.transfer_errors;
      }
      if (++c.consecutive_errors >= kMaxConsecutiveErrors) {
        MarkLost(now, "failing (" + std::to_string(c.consecutive_errors) +
                          " transfers in a row, last status " +
                          libusb_error_name(transfer->status) + "); re-plug it");
        return;
      }
      break;
    }
  }
  if (!running_ || c.lost) return;
  const int r = libusb_submit_transfer(transfer);
  if (r == 0) {
    ++c.in_flight;
  } else {
    MarkLost(MonotonicNowNs(), r == LIBUSB_ERROR_NO_DEVICE
                                   ? "unplugged"
                                   : "cannot resubmit a transfer: " + LibusbMessage(r));
  }
}

// The device is gone (or failing): samples so far stay, the loss is reported once with
// its time, and the connection closes when its transfers are back.
void UsbAccelerometer::Impl::MarkLost(int64_t t_ns, const std::string& why) {
  if (connection_->lost) return;
  connection_->lost = true;
  {
    std::lock_guard lock(state_mutex_);
    stats_.connected = false;
    ++stats_.disconnections;
  }
  AddEvent(UsbAccelerometerEvent::Kind::kDisconnected, t_ns, connection_->name + " " + why);
}

void UsbAccelerometer::Impl::CloseConnection() {
  for (libusb_transfer* transfer : connection_->transfers) libusb_free_transfer(transfer);
  // Releasing re-attaches the kernel driver detached at claim time.
  libusb_release_interface(connection_->handle, connection_->interface_number);
  libusb_close(connection_->handle);
  libusb_unref_device(connection_->device);
  connection_.reset();
  std::lock_guard lock(state_mutex_);
  stats_.connected = false;
}

void UsbAccelerometer::Impl::AddEvent(UsbAccelerometerEvent::Kind kind, int64_t t_ns,
                                      std::string message) {
  std::lock_guard lock(state_mutex_);
  events_.push_back({kind, t_ns, std::move(message)});
}

UsbAccelerometer::UsbAccelerometer(UsbAccelerometerOptions options)
    : impl_(std::make_unique<Impl>(std::move(options))) {}
UsbAccelerometer::~UsbAccelerometer() = default;
void UsbAccelerometer::Start() { impl_->Start(); }
void UsbAccelerometer::Stop() { impl_->Stop(); }
bool UsbAccelerometer::running() const { return impl_->running(); }
std::vector<AccelSample> UsbAccelerometer::Drain() { return impl_->Drain(); }
bool UsbAccelerometer::WaitForSamples(size_t count, std::chrono::milliseconds timeout) {
  return impl_->WaitForSamples(count, timeout);
}
std::vector<UsbAccelerometerEvent> UsbAccelerometer::TakeEvents() { return impl_->TakeEvents(); }
UsbAccelerometerStats UsbAccelerometer::stats() const { return impl_->stats(); }
std::string UsbAccelerometer::Describe() const { return impl_->Describe(); }

}  // namespace autocal
