// Video capture devices as V4L2 describes them: /dev/video* nodes, what each is (card,
// driver, bus), and the pixel formats, frame sizes and frame rates it offers. Used to
// list cameras (`autocal devices`) and to say what was found when a camera is missing.
#pragma once

#include <string>
#include <vector>

namespace autocal {

struct VideoFrameSize {
  int width = 0;
  int height = 0;
  // Discrete frame rates the driver lists for this size and format (Hz); empty when it
  // gives a continuous range or none.
  std::vector<double> rates_hz;
};

struct VideoFormat {
  std::string fourcc;       // "YUYV", "MJPG", ...
  std::string description;  // The driver's words.
  // Discrete sizes; for drivers that give a stepwise range, its smallest and largest.
  std::vector<VideoFrameSize> sizes;
  bool stepwise = false;
};

struct VideoDeviceInfo {
  std::string path;  // "/dev/video0".
  std::string card;  // "HD Pro Webcam C920".
  std::string driver;
  std::string bus_info;
  // Whether the node captures video (a UVC camera also has metadata-only nodes).
  bool can_capture = false;
  std::vector<VideoFormat> formats;
  // Why the node could not be queried ("permission denied", "not a V4L2 device"); empty
  // when it could.
  std::string error;
};

// Every video* node in `dev_dir`, in numeric order, queried with VIDIOC_QUERYCAP and,
// for capture nodes, VIDIOC_ENUM_FMT / ENUM_FRAMESIZES / ENUM_FRAMEINTERVALS.
std::vector<VideoDeviceInfo> ListVideoDevices(const std::string& dev_dir = "/dev");

// One node, as ListVideoDevices describes it.
VideoDeviceInfo QueryVideoDevice(const std::string& path);

// The devices on one line, comma separated: "/dev/video0 (HD Pro Webcam C920, uvcvideo)";
// "none" when empty.
std::string SummarizeVideoDevices(const std::vector<VideoDeviceInfo>& devices);

// Several lines: the device, then each format with its sizes and rates.
std::string DescribeVideoDevice(const VideoDeviceInfo& device);

}  // namespace autocal
