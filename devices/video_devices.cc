#include "devices/video_devices.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <sstream>

namespace fs = std::filesystem;

namespace autocal {
namespace {

// ioctl, retried when a signal interrupts it.
int Xioctl(int fd, unsigned long request, void* arg) {
  int r;
  do {
    r = ioctl(fd, request, arg);
  } while (r == -1 && errno == EINTR);
  return r;
}

std::string FourccText(uint32_t code) {
  std::string text;
  for (int shift = 0; shift < 32; shift += 8) {
    const char c = static_cast<char>((code >> shift) & 0xff);
    if (c != ' ' && c != '\0') text += c;
  }
  return text;
}

// V4L2 fills fixed-size byte arrays that are NUL-terminated only when shorter.
template <size_t N>
std::string Text(const __u8 (&bytes)[N]) {
  const auto* begin = reinterpret_cast<const char*>(bytes);
  return std::string(begin, strnlen(begin, N));
}

std::vector<double> DiscreteRates(int fd, uint32_t pixel_format, int width, int height) {
  std::vector<double> rates;
  v4l2_frmivalenum interval{};
  interval.pixel_format = pixel_format;
  interval.width = static_cast<uint32_t>(width);
  interval.height = static_cast<uint32_t>(height);
  for (interval.index = 0; Xioctl(fd, VIDIOC_ENUM_FRAMEINTERVALS, &interval) == 0;
       ++interval.index) {
    if (interval.type != V4L2_FRMIVAL_TYPE_DISCRETE) break;
    const v4l2_fract& f = interval.discrete;  // Seconds per frame.
    if (f.numerator > 0) rates.push_back(static_cast<double>(f.denominator) / f.numerator);
  }
  return rates;
}

void ListFormats(int fd, VideoDeviceInfo* device) {
  v4l2_fmtdesc description{};
  description.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  for (description.index = 0; Xioctl(fd, VIDIOC_ENUM_FMT, &description) == 0; ++description.index) {
    VideoFormat format;
    format.fourcc = FourccText(description.pixelformat);
    format.description = Text(description.description);
    v4l2_frmsizeenum size{};
    size.pixel_format = description.pixelformat;
    for (size.index = 0; Xioctl(fd, VIDIOC_ENUM_FRAMESIZES, &size) == 0; ++size.index) {
      if (size.type == V4L2_FRMSIZE_TYPE_DISCRETE) {
        const int w = static_cast<int>(size.discrete.width);
        const int h = static_cast<int>(size.discrete.height);
        format.sizes.push_back({w, h, DiscreteRates(fd, description.pixelformat, w, h)});
      } else {
        // Stepwise or continuous: the only entry, a range.
        format.stepwise = true;
        const v4l2_frmsize_stepwise& s = size.stepwise;
        format.sizes.push_back({static_cast<int>(s.min_width), static_cast<int>(s.min_height), {}});
        format.sizes.push_back({static_cast<int>(s.max_width), static_cast<int>(s.max_height), {}});
        break;
      }
    }
    device->formats.push_back(std::move(format));
  }
}

}  // namespace

VideoDeviceInfo QueryVideoDevice(const std::string& path) {
  VideoDeviceInfo device;
  device.path = path;
  // Non-blocking so that a node held by another process does not stall the listing.
  const int fd = open(device.path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    device.error = errno == EACCES ? "permission denied (is the user in the video group?)"
                                   : std::strerror(errno);
    return device;
  }
  v4l2_capability capability{};
  if (Xioctl(fd, VIDIOC_QUERYCAP, &capability) != 0) {
    device.error = errno == ENOTTY ? "not a V4L2 device" : std::strerror(errno);
    close(fd);
    return device;
  }
  device.card = Text(capability.card);
  device.driver = Text(capability.driver);
  device.bus_info = Text(capability.bus_info);
  // device_caps describes this node; capabilities the whole physical device.
  const uint32_t caps = (capability.capabilities & V4L2_CAP_DEVICE_CAPS) ? capability.device_caps
                                                                         : capability.capabilities;
  device.can_capture = (caps & V4L2_CAP_VIDEO_CAPTURE) != 0;
  if (device.can_capture) ListFormats(fd, &device);
  close(fd);
  return device;
}

namespace {

// The number after "video", or -1.
int NodeNumber(const std::string& name) {
  if (!name.starts_with("video") || name.size() == 5) return -1;
  int number = 0;
  for (size_t i = 5; i < name.size(); ++i) {
    if (name[i] < '0' || name[i] > '9' || number > 100000) return -1;
    number = number * 10 + (name[i] - '0');
  }
  return number;
}

std::string RateText(double hz) {
  std::ostringstream text;
  text << hz;
  return text.str();
}

}  // namespace

std::vector<VideoDeviceInfo> ListVideoDevices(const std::string& dev_dir) {
  std::vector<std::pair<int, fs::path>> nodes;
  std::error_code error;
  for (fs::directory_iterator it(dev_dir, error), end; !error && it != end; it.increment(error)) {
    const int number = NodeNumber(it->path().filename().string());
    if (number >= 0) nodes.emplace_back(number, it->path());
  }
  std::sort(nodes.begin(), nodes.end());
  std::vector<VideoDeviceInfo> devices;
  for (const auto& [number, path] : nodes) devices.push_back(QueryVideoDevice(path.string()));
  return devices;
}

std::string SummarizeVideoDevices(const std::vector<VideoDeviceInfo>& devices) {
  if (devices.empty()) return "none";
  std::string text;
  for (const VideoDeviceInfo& device : devices) {
    if (!text.empty()) text += ", ";
    text += device.path + " (";
    if (!device.error.empty()) {
      text += device.error;
    } else {
      text += device.card + ", " + device.driver;
      if (!device.can_capture) text += ", not a capture node";
    }
    text += ")";
  }
  return text;
}

std::string DescribeVideoDevice(const VideoDeviceInfo& device) {
  std::ostringstream text;
  text << device.path;
  if (!device.error.empty()) {
    text << ": " << device.error << "\n";
    return text.str();
  }
  text << ": " << device.card << " (driver " << device.driver << ", " << device.bus_info << ")";
  if (!device.can_capture) {
    text << ", not a capture node\n";
    return text.str();
  }
  text << "\n";
  for (const VideoFormat& format : device.formats) {
    text << "  " << format.fourcc << " (" << format.description << "):";
    if (format.stepwise && format.sizes.size() == 2) {
      text << " " << format.sizes[0].width << "x" << format.sizes[0].height << " to "
           << format.sizes[1].width << "x" << format.sizes[1].height;
    } else {
      for (const VideoFrameSize& size : format.sizes) {
        text << " " << size.width << "x" << size.height;
        if (!size.rates_hz.empty()) {
          text << "@";
          for (size_t i = 0; i < size.rates_hz.size(); ++i) {
            text << (i > 0 ? "/" : "") << RateText(size.rates_hz[i]);
          }
        }
      }
    }
    text << "\n";
  }
  return text.str();
}

}  // namespace autocal
