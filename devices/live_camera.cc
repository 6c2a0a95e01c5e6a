#include "devices/live_camera.h"

#include <unistd.h>

#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include <opencv2/videoio.hpp>

#include "devices/usb/bounded_queue.h"
#include "devices/usb/usb_accelerometer.h"
#include "devices/video_devices.h"
#include "pipeline/error.h"

namespace fs = std::filesystem;

namespace autocal {
namespace {

// Intervals the reported frame rate is measured over.
constexpr size_t kRateWindow = 30;
// A driver buffer time older than this at grab is not trusted as the capture time.
constexpr int64_t kMaxDriverLatencyNs = 1'000'000'000;

bool IsV4l2Node(const std::string& device) { return device.starts_with("/dev/video"); }

std::string SizeText(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

}  // namespace

bool LiveCameraOptions::Check(std::string* error) const {
  if (device.empty()) {
    *error = "device: empty";
  } else if (width < 0 || height < 0 || (width == 0) != (height == 0)) {
    *error = "width, height: both positive, or both 0 for the camera's choice";
  } else if (!(fps >= 0.0) || !std::isfinite(fps)) {
    *error = "fps: must be 0 or positive";
  } else if (!fourcc.empty() && fourcc.size() != 4) {
    *error = "fourcc: four characters, e.g. MJPG";
  } else if (queue_capacity == 0) {
    *error = "queue_capacity: at least 1";
  } else if (reconnect_interval.count() <= 0) {
    *error = "reconnect_interval: must be positive";
  } else {
    return true;
  }
  return false;
}

class LiveCamera::Impl {
 public:
  explicit Impl(LiveCameraOptions options)
      : options_(std::move(options)), frames_(options_.queue_capacity) {}
  ~Impl() { Stop(); }

  void Start();
  void Stop();
  bool running() const { return running_; }
  std::vector<CameraFrame> Drain() { return frames_.Drain(); }
  bool WaitForFrames(size_t count, std::chrono::milliseconds timeout) {
    return frames_.WaitFor(count, timeout);
  }
  std::vector<CameraEvent> TakeEvents() {
    std::lock_guard lock(state_mutex_);
    return std::exchange(events_, {});
  }
  LiveCameraStats stats() const {
    std::lock_guard lock(state_mutex_);
    LiveCameraStats stats = stats_;
    stats.queue_dropped = frames_.dropped();
    return stats;
  }
  std::string Describe() const {
    std::lock_guard lock(state_mutex_);
    std::ostringstream text;
    text << options_.device;
    if (!card_.empty()) text << " (" << card_ << ")";
    if (stats_.width > 0) text << ", " << SizeText(stats_.width, stats_.height);
    if (nominal_fps_ > 0) text << " at " << nominal_fps_ << " Hz";
    return text.str();
  }
  double nominal_fps() const {
    std::lock_guard lock(state_mutex_);
    return nominal_fps_;
  }

 private:
  // Opens the capture and asks for the configured mode; false if it does not open.
  bool Open();
  // Grabs and decodes one frame; false when the camera is gone or the read failed.
  bool Read(CameraFrame* frame);
  int64_t CaptureTime();
  void Run();
  void Deliver(CameraFrame frame);
  void AddEvent(CameraEvent::Kind kind, int64_t t_ns, std::string message);
  // Sleeps until `deadline` or Stop(); false when stopped.
  bool SleepUntil(std::chrono::steady_clock::time_point deadline);

  const LiveCameraOptions options_;
  BoundedQueue<CameraFrame> frames_;
  cv::VideoCapture capture_;  // Used by Start(), then only by the capture thread.
  std::thread thread_;
  std::atomic<bool> running_{false};
  std::mutex stop_mutex_;
  std::condition_variable stop_;

  // Capture thread only.
  uint64_t number_ = 0;
  int64_t last_frame_ns_ = 0;
  std::optional<int64_t> lost_after_ns_;  // Set while the camera is lost.
  std::deque<int64_t> recent_ns_;

  mutable std::mutex state_mutex_;  // The members below.
  std::vector<CameraEvent> events_;
  LiveCameraStats stats_;
  std::string card_;
  double nominal_fps_ = 0.0;
};

bool LiveCamera::Impl::Open() {
  // A missing node (or file) is an unplugged camera: no need to ask every OpenCV backend.
  std::error_code ignored;
  if (!fs::exists(options_.device, ignored)) return false;
  const bool v4l2 = IsV4l2Node(options_.device);
  if (!capture_.open(options_.device, v4l2 ? cv::CAP_V4L2 : cv::CAP_ANY)) return false;
  // Asked for after opening: a backend that cannot honour a mode (a file) still opens,
  // and the size check in Start() says what it gives instead.
  if (!options_.fourcc.empty()) {
    const std::string& f = options_.fourcc;
    capture_.set(cv::CAP_PROP_FOURCC, cv::VideoWriter::fourcc(f[0], f[1], f[2], f[3]));
  }
  if (options_.width > 0) {
    capture_.set(cv::CAP_PROP_FRAME_WIDTH, options_.width);
    capture_.set(cv::CAP_PROP_FRAME_HEIGHT, options_.height);
  }
  if (options_.fps > 0) capture_.set(cv::CAP_PROP_FPS, options_.fps);
  std::lock_guard lock(state_mutex_);
  nominal_fps_ = std::max(0.0, capture_.get(cv::CAP_PROP_FPS));
  return true;
}

int64_t LiveCamera::Impl::CaptureTime() {
  const int64_t now_ns = MonotonicNowNs();
  if (IsV4l2Node(options_.device)) {
    // OpenCV's V4L2 backend gives the buffer's driver timestamp (CLOCK_MONOTONIC for UVC
    // cameras, taken as the frame arrived) in ms; trust it only when it looks like one.
    const double ms = capture_.get(cv::CAP_PROP_POS_MSEC);
    const auto driver_ns = static_cast<int64_t>(std::llround(ms * 1e6));
    if (ms > 0 && driver_ns <= now_ns && now_ns - driver_ns < kMaxDriverLatencyNs) {
      return driver_ns;
    }
  }
  return now_ns;
}

bool LiveCamera::Impl::Read(CameraFrame* frame) {
  if (!capture_.grab()) return false;
  frame->t_ns = CaptureTime();
  if (!capture_.retrieve(frame->image) || frame->image.empty()) return false;
  // Times must increase even if the driver repeats a timestamp.
  if (number_ > 0 && frame->t_ns <= last_frame_ns_) frame->t_ns = last_frame_ns_ + 1;
  frame->number = number_;
  return true;
}

void LiveCamera::Impl::Deliver(CameraFrame frame) {
  ++number_;
  last_frame_ns_ = frame.t_ns;
  recent_ns_.push_back(frame.t_ns);
  if (recent_ns_.size() > kRateWindow + 1) recent_ns_.pop_front();
  {
    std::lock_guard lock(state_mutex_);
    ++stats_.frames;
    stats_.width = frame.image.cols;
    stats_.height = frame.image.rows;
    if (lost_after_ns_) {
      stats_.gaps.push_back({*lost_after_ns_, frame.t_ns});
      lost_after_ns_.reset();
    }
    if (recent_ns_.size() > 1) {
      stats_.rate_hz = 1e9 * static_cast<double>(recent_ns_.size() - 1) /
                       static_cast<double>(recent_ns_.back() - recent_ns_.front());
    }
  }
  frames_.Push(std::move(frame));
}

void LiveCamera::Impl::AddEvent(CameraEvent::Kind kind, int64_t t_ns, std::string message) {
  std::lock_guard lock(state_mutex_);
  events_.push_back({kind, t_ns, std::move(message)});
  if (kind == CameraEvent::Kind::kConnected) {
    stats_.connected = true;
    ++stats_.connections;
  } else {
    stats_.connected = false;
    ++stats_.disconnections;
  }
}

void LiveCamera::Impl::Start() {
  if (running_) return;
  std::string why;
  if (!options_.Check(&why)) throw Error("camera options: " + why);
  std::error_code ignored;
  if (!fs::exists(options_.device, ignored)) {
    throw Error("no camera at " + options_.device +
                "; found: " + SummarizeVideoDevices(ListVideoDevices()));
  }
  if (access(options_.device.c_str(), R_OK) != 0) {
    throw Error("cannot open " + options_.device +
                ": permission denied (add the user to the video group)");
  }
  if (IsV4l2Node(options_.device)) {
    // OpenCV waits up to this many seconds (default 10) for a frame of a stalled camera
    // before the grab fails; it reads the setting once, at its first V4L2 wait. A user's
    // own setting is kept.
    setenv("OPENCV_VIDEOIO_V4L_SELECT_TIMEOUT", "2", /*overwrite=*/0);
    const VideoDeviceInfo info = QueryVideoDevice(options_.device);
    if (!info.error.empty()) throw Error("cannot open " + options_.device + ": " + info.error);
    if (!info.can_capture) {
      throw Error(options_.device + " (" + info.card + ") is not a video capture node; found: " +
                  SummarizeVideoDevices(ListVideoDevices()));
    }
    std::lock_guard lock(state_mutex_);
    card_ = info.card;
  }
  if (!Open()) throw Error("cannot open " + options_.device + " with OpenCV");
  CameraFrame first;
  if (!Read(&first)) {
    capture_.release();
    throw Error("cannot read a frame from " + options_.device);
  }
  if (options_.width > 0 &&
      (first.image.cols != options_.width || first.image.rows != options_.height)) {
    capture_.release();
    std::string message = options_.device + " gives " +
                          SizeText(first.image.cols, first.image.rows) + ", not the " +
                          SizeText(options_.width, options_.height) + " asked for";
    if (IsV4l2Node(options_.device)) {
      message += "; it offers:\n" + DescribeVideoDevice(QueryVideoDevice(options_.device));
    }
    throw Error(message);
  }
  AddEvent(CameraEvent::Kind::kConnected, first.t_ns, "opened " + options_.device);
  Deliver(std::move(first));
  running_ = true;
  thread_ = std::thread(&Impl::Run, this);
}

bool LiveCamera::Impl::SleepUntil(std::chrono::steady_clock::time_point deadline) {
  std::unique_lock lock(stop_mutex_);
  return !stop_.wait_until(lock, deadline, [&] { return !running_; });
}

void LiveCamera::Impl::Run() {
  while (running_) {
    if (!capture_.isOpened()) {
      if (Open()) {
        AddEvent(CameraEvent::Kind::kConnected, MonotonicNowNs(), "reopened " + options_.device);
      } else {
        {
          std::lock_guard lock(state_mutex_);
          ++stats_.reconnect_attempts;
        }
        if (!SleepUntil(std::chrono::steady_clock::now() + options_.reconnect_interval)) break;
        continue;
      }
    }
    CameraFrame frame;
    if (Read(&frame)) {
      Deliver(std::move(frame));
      continue;
    }
    capture_.release();
    lost_after_ns_ = last_frame_ns_;
    AddEvent(CameraEvent::Kind::kDisconnected, MonotonicNowNs(),
             "lost " + options_.device + " (unplugged or a read failed)");
    if (!SleepUntil(std::chrono::steady_clock::now() + options_.reconnect_interval)) break;
  }
  capture_.release();
}

void LiveCamera::Impl::Stop() {
  {
    std::lock_guard lock(stop_mutex_);
    running_ = false;
  }
  stop_.notify_all();
  if (thread_.joinable()) thread_.join();
  capture_.release();
  std::lock_guard lock(state_mutex_);
  stats_.connected = false;
}

LiveCamera::LiveCamera(LiveCameraOptions options)
    : impl_(std::make_unique<Impl>(std::move(options))) {}
LiveCamera::~LiveCamera() = default;
void LiveCamera::Start() { impl_->Start(); }
void LiveCamera::Stop() { impl_->Stop(); }
bool LiveCamera::running() const { return impl_->running(); }
std::vector<CameraFrame> LiveCamera::Drain() { return impl_->Drain(); }
bool LiveCamera::WaitForFrames(size_t count, std::chrono::milliseconds timeout) {
  return impl_->WaitForFrames(count, timeout);
}
std::vector<CameraEvent> LiveCamera::TakeEvents() { return impl_->TakeEvents(); }
LiveCameraStats LiveCamera::stats() const { return impl_->stats(); }
std::string LiveCamera::Describe() const { return impl_->Describe(); }
double LiveCamera::nominal_fps() const { return impl_->nominal_fps(); }

}  // namespace autocal
