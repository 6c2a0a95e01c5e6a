// A live camera read through OpenCV's V4L2 backend on its own thread. Each frame is
// stamped with CLOCK_MONOTONIC at capture (the driver's buffer time where it gives a
// plausible one, else the moment the grab returned) and queued for a consumer; a full
// queue drops its oldest frame, so a slow consumer never stalls the camera. When the
// camera goes away (unplugged, or a read fails) the session goes on: the loss is an
// event, the camera is reopened every reconnect_interval, and the gap between the last
// frame before and the first frame after is recorded.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "devices/inspect.h"

namespace autocal {

struct LiveCameraOptions {
  // A V4L2 node ("/dev/video0"), opened with OpenCV's V4L2 backend; any other path (a
  // video file) is opened with OpenCV's default backend and its end counts as an unplug,
  // which is how the tests unplug a camera.
  std::string device = "/dev/video0";
  // Frame size and rate to ask for; 0: the camera's own choice.
  int width = 0;
  int height = 0;
  double fps = 0.0;
  // Pixel format to ask for, e.g. "MJPG" (what USB cameras need for high rates); empty:
  // the driver's default.
  std::string fourcc;
  // Frames kept for the consumer; when full the oldest is dropped, and counted.
  size_t queue_capacity = 8;
  // Time between attempts to reopen a lost camera.
  std::chrono::milliseconds reconnect_interval{500};

  // The message names the offending field.
  bool Check(std::string* error) const;
};

struct CameraFrame {
  int64_t t_ns = 0;     // CLOCK_MONOTONIC at capture.
  uint64_t number = 0;  // Frames captured before this one, over all connections.
  cv::Mat image;        // 8-bit BGR.
};

struct CameraEvent {
  enum class Kind { kConnected, kDisconnected };
  Kind kind = Kind::kConnected;
  int64_t t_ns = 0;  // CLOCK_MONOTONIC.
  std::string message;
};

struct LiveCameraStats {
  bool connected = false;
  uint64_t frames = 0;         // Frames captured.
  uint64_t queue_dropped = 0;  // Frames dropped, oldest first, because nobody took them.
  int connections = 0;         // 1 + reconnections.
  int disconnections = 0;
  uint64_t reconnect_attempts = 0;  // Failed attempts to reopen a lost camera.
  // Each loss of the camera: last frame before it to first frame after it.
  std::vector<TimeGap> gaps;
  int width = 0;  // What the camera delivers.
  int height = 0;
  double rate_hz = 0.0;  // Frames per second over the last 30 intervals.
};

class LiveCamera {
 public:
  explicit LiveCamera(LiveCameraOptions options = {});
  ~LiveCamera();  // Stops.
  LiveCamera(const LiveCamera&) = delete;
  LiveCamera& operator=(const LiveCamera&) = delete;

  // Opens the camera, reads one frame to learn its size, and starts the capture thread.
  // Throws Error when the options are wrong, when there is no such device (the message
  // lists the video devices found), when it cannot be opened, or when it does not give
  // the size asked for (the message lists the sizes it offers). Does nothing if running.
  void Start();
  // Stops capturing and releases the camera; queued frames stay to be drained.
  void Stop();
  bool running() const;

  // Every queued frame, oldest first.
  std::vector<CameraFrame> Drain();
  // Waits until at least `count` frames are queued; false on timeout.
  bool WaitForFrames(size_t count, std::chrono::milliseconds timeout);
  // Connection events since the last call, oldest first.
  std::vector<CameraEvent> TakeEvents();
  LiveCameraStats stats() const;
  // "/dev/video0 (HD Pro Webcam C920), 1280x720 at 30 Hz".
  std::string Describe() const;
  // Frame rate the camera reports for its current mode; 0 when it does not say.
  double nominal_fps() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace autocal
