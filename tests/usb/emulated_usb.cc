#include "tests/usb/emulated_usb.h"

// <sys/ioctl.h> must come before <linux/usbdevice_fs.h>, which uses its macros.
#include <sys/ioctl.h>
#include <sys/stat.h>
// clang-format off
#include <linux/usbdevice_fs.h>
// clang-format on

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <mutex>
#include <stdexcept>
#include <thread>

#include <umockdev.h>

namespace autocal::test {
namespace {

constexpr uint8_t kDescriptorTypeHidReport = 0x22;

std::string Hex(const std::vector<uint8_t>& bytes) {
  static const char kDigits[] = "0123456789ABCDEF";  // umockdev reads upper case only.
  std::string out;
  for (uint8_t b : bytes) {
    out += kDigits[b >> 4];
    out += kDigits[b & 15];
  }
  return out;
}

void PutLe16(std::vector<uint8_t>* out, unsigned value) {
  out->push_back(value & 0xff);
  out->push_back((value >> 8) & 0xff);
}

// Device, configuration, interface, HID and endpoint descriptors back to back: what the
// kernel's sysfs `descriptors` attribute holds and libusb reads.
std::vector<uint8_t> UsbDescriptors(const EmulatedHidDevice& device) {
  std::vector<uint8_t> d = {18, 0x01, 0x00, 0x02, 0, 0, 0, 64};
  PutLe16(&d, device.vendor_id);
  PutLe16(&d, device.product_id);
  d.insert(d.end(), {0x00, 0x01, 1, 2, 0, 1});
  d.insert(d.end(), {9, 0x02, 9 + 9 + 9 + 7, 0, 1, 1, 0, 0x80, 50});
  d.insert(d.end(),
           {9, 0x04, 0, 0, 1, 0x03, device.interface_subclass, device.interface_protocol, 0});
  d.insert(d.end(), {9, 0x21, 0x11, 0x01, 0, 1, kDescriptorTypeHidReport});
  PutLe16(&d, device.report_descriptor.size());
  d.insert(d.end(), {7, 0x05, device.in_endpoint, 0x03});
  PutLe16(&d, device.max_packet_size);
  d.push_back(1);  // bInterval: 1 ms.
  return d;
}

void Check(bool ok, const std::string& what) {
  if (!ok) throw std::runtime_error("umockdev testbed: " + what);
}

// The message of a GError, which is freed.
std::string TakeMessage(GError** error) {
  const std::string message = *error != nullptr ? (*error)->message : "";
  g_clear_error(error);
  return message;
}

// The client memory a pointer at `offset` of `data` points to; a new reference, or null
// when it cannot be read.
UMockdevIoctlData* Resolve(UMockdevIoctlData* data, size_t offset, size_t length) {
  GError* error = nullptr;
  UMockdevIoctlData* resolved = umockdev_ioctl_data_resolve(data, offset, length, &error);
  g_clear_error(&error);
  return resolved;
}

}  // namespace

struct UsbTestbed::Testbed {
  UMockdevTestbed* bed = nullptr;
};

// One plugged device: its sysfs path, device node and the usbfs state its ioctl handler
// keeps. The handler runs on umockdev's thread, the test on its own: mutex.
struct UsbTestbed::Port {
  struct Urb {
    UMockdevIoctlData* urb = nullptr;     // struct usbdevfs_urb in the client.
    UMockdevIoctlData* buffer = nullptr;  // Its data buffer.
  };

  EmulatedHidDevice device;
  std::string syspath;
  std::string devnode;
  UMockdevIoctlBase* handler = nullptr;

  mutable std::mutex mutex;
  std::deque<Urb> interrupt_urbs;            // Submitted, waiting for a report.
  std::deque<Urb> completed;                 // Ready to be reaped.
  std::deque<std::vector<uint8_t>> reports;  // Sent by the test, not yet reaped.
  int reports_reaped = 0;
  bool unplugged = false;
  bool driver_detached = false;
  bool claimed = false;
  int report_descriptor_requests = 0;

  ~Port() {
    for (auto* list : {&interrupt_urbs, &completed}) {
      for (Urb& urb : *list) Release(&urb);
    }
  }

  static void Release(Urb* urb) {
    g_clear_object(&urb->buffer);
    g_clear_object(&urb->urb);
  }

  // SUBMITURB: control transfers are answered at once, interrupt IN ones wait for a
  // report. The buffer of a control transfer begins with the 8 setup bytes.
  int Submit(UMockdevIoctlData* arg) {
    UMockdevIoctlData* urb_data = Resolve(arg, 0, sizeof(usbdevfs_urb));
    if (urb_data == nullptr) return -EFAULT;
    auto* urb = reinterpret_cast<usbdevfs_urb*>(urb_data->data);
    UMockdevIoctlData* buffer =
        Resolve(urb_data, offsetof(usbdevfs_urb, buffer), urb->buffer_length);
    if (buffer == nullptr) {
      g_object_unref(urb_data);
      return -EFAULT;
    }
    if (unplugged) {
      g_object_unref(buffer);
      g_object_unref(urb_data);
      return -ENODEV;
    }
    Urb entry{urb_data, buffer};
    if (urb->type == USBDEVFS_URB_TYPE_CONTROL) {
      AnswerControl(urb, buffer->data, urb->buffer_length);
      completed.push_back(entry);
    } else if (urb->type == USBDEVFS_URB_TYPE_INTERRUPT && urb->endpoint == device.in_endpoint) {
      interrupt_urbs.push_back(entry);
    } else {
      urb->status = -EPIPE;
      completed.push_back(entry);
    }
    return 0;
  }

  // GET_DESCRIPTOR(HID report) on the interface; anything else stalls.
  void AnswerControl(usbdevfs_urb* urb, uint8_t* buffer, int length) {
    urb->actual_length = 0;
    urb->status = -EPIPE;
    if (length < 8) return;
    const int request_type = buffer[0];
    const int request = buffer[1];
    const int value = buffer[2] | (buffer[3] << 8);
    const int index = buffer[4] | (buffer[5] << 8);
    const int wanted = buffer[6] | (buffer[7] << 8);
    if (request_type == 0x81 && request == 0x06 && value == (kDescriptorTypeHidReport << 8) &&
        index == 0) {
      const int n =
          std::min<int>({wanted, length - 8, static_cast<int>(device.report_descriptor.size())});
      std::memcpy(buffer + 8, device.report_descriptor.data(), n);
      urb->actual_length = n;
      urb->status = 0;
      ++report_descriptor_requests;
    }
  }

  // REAPURBNDELAY: hands back a completed URB, the next interrupt URB filled with a
  // report, or after an unplug every pending URB failed with -ENODEV, then ENODEV.
  int Reap(UMockdevIoctlData* arg) {
    if (completed.empty() && !interrupt_urbs.empty() && (!reports.empty() || unplugged)) {
      Urb entry = interrupt_urbs.front();
      interrupt_urbs.pop_front();
      auto* urb = reinterpret_cast<usbdevfs_urb*>(entry.urb->data);
      if (unplugged) {
        urb->status = -ENODEV;
        urb->actual_length = 0;
      } else {
        const std::vector<uint8_t>& report = reports.front();
        const int n = std::min<int>(report.size(), urb->buffer_length);
        std::memcpy(entry.buffer->data, report.data(), n);
        urb->status = 0;
        urb->actual_length = n;
        reports.pop_front();
        ++reports_reaped;
      }
      completed.push_back(entry);
    }
    if (completed.empty()) return unplugged ? -ENODEV : -EAGAIN;

    UMockdevIoctlData* pointer = Resolve(arg, 0, sizeof(void*));

    if (pointer == nullptr) return -EFAULT;
    Urb entry = completed.front();
    completed.pop_front();
    umockdev_ioctl_data_set_ptr(pointer, 0, entry.urb);
    g_object_unref(pointer);
    Release(&entry);
    return 0;
  }

  // DISCARDURB: the argument is the URB's address in the client.
  int Discard(UMockdevIoctlData* arg) {
    const auto address = *reinterpret_cast<gulong*>(arg->data);
    for (auto it = interrupt_urbs.begin(); it != interrupt_urbs.end(); ++it) {
      if (it->urb->client_addr != address) continue;
      reinterpret_cast<usbdevfs_urb*>(it->urb->data)->status = -ENOENT;
      completed.push_back(*it);
      interrupt_urbs.erase(it);
      return 0;
    }
    return -EINVAL;
  }

  int GetDriver(UMockdevIoctlData* arg) {
    UMockdevIoctlData* data = Resolve(arg, 0, sizeof(usbdevfs_getdriver));
    if (data == nullptr) return -EFAULT;
    int result = -ENODATA;
    if (claimed) {
      std::strcpy(reinterpret_cast<usbdevfs_getdriver*>(data->data)->driver, "usbfs");
      result = 0;
    } else if (!driver_detached && !device.kernel_driver.empty()) {
      std::strncpy(reinterpret_cast<usbdevfs_getdriver*>(data->data)->driver,
                   device.kernel_driver.c_str(), USBDEVFS_MAXDRIVERNAME);
      result = 0;
    }
    g_object_unref(data);
    return result;
  }

  // USBDEVFS_IOCTL carrying DISCONNECT (detach the kernel driver) or CONNECT.
  int DriverIoctl(UMockdevIoctlData* arg) {
    UMockdevIoctlData* data = Resolve(arg, 0, sizeof(usbdevfs_ioctl));
    if (data == nullptr) return -EFAULT;
    const auto code =
        static_cast<unsigned long>(reinterpret_cast<usbdevfs_ioctl*>(data->data)->ioctl_code);
    g_object_unref(data);
    if (code == USBDEVFS_DISCONNECT) {
      if (device.kernel_driver.empty() || driver_detached) return -ENODATA;
      driver_detached = true;
      return 0;
    }
    if (code == USBDEVFS_CONNECT) {
      driver_detached = false;
      return 0;
    }
    return -ENOTTY;
  }

  int Handle(unsigned long request, UMockdevIoctlData* arg) {
    std::lock_guard lock(mutex);
    switch (request) {
      case USBDEVFS_GET_CAPABILITIES: {
        UMockdevIoctlData* data = Resolve(arg, 0, sizeof(uint32_t));
        if (data == nullptr) return -EFAULT;
        // No DISCONNECT_CLAIM: libusb then detaches with GETDRIVER + DISCONNECT.
        const uint32_t caps = USBDEVFS_CAP_ZERO_PACKET | USBDEVFS_CAP_BULK_CONTINUATION |
                              USBDEVFS_CAP_NO_PACKET_SIZE_LIM | USBDEVFS_CAP_REAP_AFTER_DISCONNECT;
        std::memcpy(data->data, &caps, sizeof(caps));
        g_object_unref(data);
        return 0;
      }
      case USBDEVFS_CLAIMINTERFACE:
        if (unplugged) return -ENODEV;
        if (!device.kernel_driver.empty() && !driver_detached) return -EBUSY;
        claimed = true;
        return 0;
      case USBDEVFS_RELEASEINTERFACE:
        if (unplugged) return -ENODEV;
        claimed = false;
        return 0;
      case USBDEVFS_GETDRIVER:
        return unplugged ? -ENODEV : GetDriver(arg);
      case USBDEVFS_IOCTL:
        return unplugged ? -ENODEV : DriverIoctl(arg);
      case USBDEVFS_SUBMITURB:
        return Submit(arg);
      case USBDEVFS_REAPURB:
      case USBDEVFS_REAPURBNDELAY:
        return Reap(arg);
      case USBDEVFS_DISCARDURB:
        return Discard(arg);
      case USBDEVFS_SETINTERFACE:
      case USBDEVFS_CLEAR_HALT:
      case USBDEVFS_RESETEP:
        return unplugged ? -ENODEV : 0;
      default:
        return -ENOTTY;
    }
  }

  static gboolean OnIoctl(UMockdevIoctlBase* /*handler*/, UMockdevIoctlClient* client,
                          gpointer self) {
    const int result = static_cast<Port*>(self)->Handle(umockdev_ioctl_client_get_request(client),
                                                        umockdev_ioctl_client_get_arg(client));
    umockdev_ioctl_client_complete(client, result < 0 ? -1 : result, result < 0 ? -result : 0);
    return TRUE;
  }
};

UsbTestbed::UsbTestbed() : testbed_(std::make_unique<Testbed>()) {
  testbed_->bed = umockdev_testbed_new();
  Check(umockdev_in_mock_environment(),
        "not in a mock environment: run the test binary through umockdev-wrapper");
}

UsbTestbed::~UsbTestbed() {
  for (auto& p : ports_) {
    umockdev_testbed_detach_ioctl(testbed_->bed, p->devnode.c_str(), nullptr);
    g_object_unref(p->handler);
  }
  ports_.clear();
  g_object_unref(testbed_->bed);
}

UsbTestbed::Port& UsbTestbed::port(int id) const {
  Check(id >= 0 && id < static_cast<int>(ports_.size()), "no device " + std::to_string(id));
  return *ports_[id];
}

int UsbTestbed::Plug(const EmulatedHidDevice& device) {
  auto port = std::make_unique<Port>();
  port->device = device;
  const int devnum = next_devnum_++;
  char devnum3[8];
  std::snprintf(devnum3, sizeof(devnum3), "%03d", devnum);
  char vendor[8];
  char product[8];
  std::snprintf(vendor, sizeof(vendor), "%04x", device.vendor_id);
  std::snprintf(product, sizeof(product), "%04x", device.product_id);
  const std::string bus_dev = std::string("bus/usb/001/") + devnum3;
  const std::string name = "1-" + std::to_string(devnum - 1);
  port->syspath = "/sys/devices/pci0000:00/0000:00:14.0/usb1/" + name;
  port->devnode = "/dev/" + bus_dev;

  // sysfs numeric attributes end in a newline, as the kernel writes them.
  const std::string num = std::to_string(devnum);
  std::string text = "P: " + port->syspath.substr(4) + "\n" + "N: " + bus_dev + "=" +
                     Hex(UsbDescriptors(device)) + "\n" +
                     "E: SUBSYSTEM=usb\n"
                     "E: DEVTYPE=usb_device\n"
                     "E: DEVNAME=" +
                     port->devnode + "\n" +
                     "E: BUSNUM=001\n"
                     "E: DEVNUM=" +
                     devnum3 + "\n" +
                     "E: MAJOR=189\n"
                     "E: MINOR=" +
                     num + "\n" +
                     "A: busnum=1\\n\n"
                     "A: devnum=" +
                     num + "\\n\n" +
                     "A: speed=12\\n\n"
                     "A: bConfigurationValue=1\\n\n"
                     "A: bNumInterfaces= 1\\n\n"
                     "A: idVendor=" +
                     vendor + "\\n\n" + "A: idProduct=" + product + "\\n\n" +
                     "A: manufacturer=" + device.manufacturer + "\\n\n" +
                     "A: product=" + device.product + "\\n\n" + "A: dev=189:" + num + "\\n\n" +
                     "H: descriptors=" + Hex(UsbDescriptors(device)) + "\n";
  if (device.report_descriptor_in_sysfs) {
    // The interface and the HID device the kernel's HID core puts below it, described
    // first: each paragraph is announced as it is added, and by the time a program hears
    // of a real device its interfaces are usually there.
    const std::string interface = port->syspath.substr(4) + "/" + name + ":1.0";
    char hid[64];
    std::snprintf(hid, sizeof(hid), "0003:%04X:%04X.%04X", device.vendor_id, device.product_id,
                  devnum);
    text = "P: " + interface + "/" + hid + "\n" +
           "E: SUBSYSTEM=hid\n"
           "H: report_descriptor=" +
           Hex(device.report_descriptor) +
           "\n"
           "\nP: " +
           interface + "\n" +
           "E: SUBSYSTEM=usb\n"
           "E: DEVTYPE=usb_interface\n"
           "A: bInterfaceNumber=00\\n\n"
           "A: bInterfaceClass=03\\n\n"
           "\n" +
           text;
  }
  // The handler first: adding the device announces it, and a node opened before the
  // handler is attached would be a plain file that fails every ioctl with ENOTTY.
  port->handler = umockdev_ioctl_base_new();
  g_signal_connect(port->handler, "handle-ioctl", G_CALLBACK(&Port::OnIoctl), port.get());
  GError* error = nullptr;
  const bool attached =
      umockdev_testbed_attach_ioctl(testbed_->bed, port->devnode.c_str(), port->handler, &error);
  Check(attached,
        "cannot attach the ioctl handler to " + port->devnode + ": " + TakeMessage(&error));
  const bool added = umockdev_testbed_add_from_string(testbed_->bed, text.c_str(), &error);
  Check(added, "cannot add device: " + TakeMessage(&error));
  if (!device.node_accessible) {
    gchar* root = umockdev_testbed_get_root_dir(testbed_->bed);
    const std::string node = std::string(root) + port->devnode;
    g_free(root);
    Check(chmod(node.c_str(), 0) == 0, "cannot chmod " + node);
  }
  ports_.push_back(std::move(port));
  return static_cast<int>(ports_.size()) - 1;
}

void UsbTestbed::Unplug(int id) {
  Port& p = port(id);
  {
    std::lock_guard lock(p.mutex);
    p.unplugged = true;
  }
  umockdev_testbed_uevent(testbed_->bed, p.syspath.c_str(), "remove");
  umockdev_testbed_remove_device(testbed_->bed, p.syspath.c_str());
}

bool UsbTestbed::SendReport(int id, const std::vector<uint8_t>& report,
                            std::chrono::milliseconds timeout) {
  Port& p = port(id);
  int target = 0;
  {
    std::lock_guard lock(p.mutex);
    p.reports.push_back(report);
    target = p.reports_reaped + static_cast<int>(p.reports.size());
  }
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    {
      std::lock_guard lock(p.mutex);
      if (p.reports_reaped >= target) return true;
    }
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  return false;
}

int UsbTestbed::report_descriptor_requests(int id) const {
  Port& p = port(id);
  std::lock_guard lock(p.mutex);
  return p.report_descriptor_requests;
}

bool UsbTestbed::kernel_driver_detached(int id) const {
  Port& p = port(id);
  std::lock_guard lock(p.mutex);
  return p.driver_detached;
}

bool UsbTestbed::interface_claimed(int id) const {
  Port& p = port(id);
  std::lock_guard lock(p.mutex);
  return p.claimed;
}

bool RunningUnderUmockdevWrapper() {
  const char* preload = std::getenv("LD_PRELOAD");
  return preload != nullptr && std::strstr(preload, "libumockdev-preload") != nullptr;
}

EmulatedHidDevice HidSensorHub() {
  // clang-format off
  const std::vector<uint8_t> descriptor = {
      0x05, 0x20, 0x09, 0x73, 0xA1, 0x00,        // Sensors, Accelerometer 3D, Collection
      0x85, 0x01,                                //   Report ID (1)
      0x0A, 0x01, 0x02, 0x15, 0x00, 0x25, 0x06,  //   Sensor State, 0..6
      0x75, 0x08, 0x95, 0x01,                    //   8 bits x 1
      0xA1, 0x02, 0x0A, 0x00, 0x08, 0x0A, 0x01, 0x08, 0x81, 0x00, 0xC0,
      0x0A, 0x02, 0x02, 0x25, 0x05,              //   Sensor Event, 0..5
      0xA1, 0x02, 0x0A, 0x10, 0x08, 0x0A, 0x13, 0x08, 0x81, 0x00, 0xC0,
      0x0A, 0x53, 0x04, 0x0A, 0x54, 0x04, 0x0A, 0x55, 0x04,  // Acceleration X, Y, Z
      0x16, 0x01, 0x80, 0x26, 0xFF, 0x7F,        //   -32767..32767
      0x75, 0x10, 0x95, 0x03, 0x55, 0x0E,        //   16 bits x 3, exponent -2
      0x81, 0x02,                                //   Input (Data, Variable, Absolute)
      0xC0,
  };
  // clang-format on
  EmulatedHidDevice device;
  device.report_descriptor = descriptor;
  return device;
}

std::vector<uint8_t> HidSensorAccelReport(int x, int y, int z, uint8_t report_id) {
  std::vector<uint8_t> report = {report_id, 0x01, 0x03};  // State Ready, event Data Updated.
  for (int v : {x, y, z}) {
    report.push_back(static_cast<uint8_t>(v & 0xff));
    report.push_back(static_cast<uint8_t>((v >> 8) & 0xff));
  }
  return report;
}

}  // namespace autocal::test
