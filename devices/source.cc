#include "devices/source.h"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <charconv>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <exception>
#include <filesystem>
#include <mutex>
#include <thread>
#include <utility>

#include <opencv2/imgcodecs.hpp>

#include "devices/live_camera.h"
#include "devices/recording_reader.h"
#include "devices/usb/usb_accelerometer.h"
#include "pipeline/error.h"

namespace fs = std::filesystem;

namespace autocal {
namespace {

const char* DeviceName(SourceEvent::Device device) {
  return device == SourceEvent::Device::kCamera ? "camera" : "accelerometer";
}

// Parses all of `text` as a number; nothing when it does not parse.
template <typename T>
std::optional<T> ParseNumber(const std::string& text, int base = 10) {
  T value{};
  const char* end = text.data() + text.size();
  std::from_chars_result result;
  if constexpr (std::is_floating_point_v<T>) {
    result = std::from_chars(text.data(), end, value);
  } else {
    result = std::from_chars(text.data(), end, value, base);
  }
  if (text.empty() || result.ec != std::errc() || result.ptr != end) return std::nullopt;
  return value;
}

std::vector<std::string> Split(const std::string& text, char separator) {
  std::vector<std::string> parts;
  size_t begin = 0;
  for (size_t end; (end = text.find(separator, begin)) != std::string::npos; begin = end + 1) {
    parts.push_back(text.substr(begin, end - begin));
  }
  parts.push_back(text.substr(begin));
  return parts;
}

bool IsImageFile(const fs::path& path) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const char* known : {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff"}) {
    if (extension == known) return true;
  }
  return false;
}

// A sequence with another accelerometer stream (a CSV given with --accel, or none).
class AccelOverrideSequence : public Sequence {
 public:
  AccelOverrideSequence(std::unique_ptr<Sequence> base, std::vector<AccelSample> accel,
                        std::string accel_source, std::vector<std::string> warnings)
      : base_(std::move(base)),
        accel_(std::move(accel)),
        description_(base_->Describe() + " with accelerometer " + accel_source),
        warnings_(base_->warnings()) {
    warnings_.insert(warnings_.end(), warnings.begin(), warnings.end());
  }

  std::string Describe() const override { return description_; }
  const SessionInfo& session() const override { return base_->session(); }
  size_t frame_count() const override { return base_->frame_count(); }
  int64_t frame_time_ns(size_t index) const override { return base_->frame_time_ns(index); }
  cv::Mat LoadFrame(size_t index) const override { return base_->LoadFrame(index); }
  std::string FrameName(size_t index) const override { return base_->FrameName(index); }
  const std::vector<AccelSample>& accel() const override { return accel_; }
  const std::vector<std::string>& warnings() const override { return warnings_; }
  const std::vector<GroundTruthFrame>* ground_truth() const override {
    return base_->ground_truth();
  }
  std::optional<cv::Mat> LoadPlaneLabels(size_t index) const override {
    return base_->LoadPlaneLabels(index);
  }
  std::optional<std::string> SceneDescription() const override { return base_->SceneDescription(); }

 private:
  std::unique_ptr<Sequence> base_;
  std::vector<AccelSample> accel_;
  std::string description_;
  std::vector<std::string> warnings_;
};

// A recorded sequence streamed: frames are decoded (or rendered) on a read-ahead thread,
// accelerometer samples up to each frame's time leave before it.
class SequenceSource : public FrameSource {
 public:
  SequenceSource(std::unique_ptr<Sequence> sequence, size_t read_ahead)
      : sequence_(std::move(sequence)), read_ahead_(read_ahead) {}
  ~SequenceSource() override { Stop(); }

  std::string Describe() const override { return sequence_->Describe(); }
  bool live() const override { return false; }
  SessionInfo session() const override { return sequence_->session(); }
  const Sequence* sequence() const override { return sequence_.get(); }

  void Start() override {
    std::lock_guard lock(mutex_);
    if (started_) return;
    started_ = true;
    reader_ = std::thread(&SequenceSource::ReadAhead, this);
  }

  void Stop() override {
    {
      std::lock_guard lock(mutex_);
      stopped_ = true;
    }
    changed_.notify_all();
    if (reader_.joinable()) reader_.join();
  }

  Status Next(SourceItem* item, std::chrono::milliseconds timeout) override {
    Start();
    const std::vector<AccelSample>& accel = sequence_->accel();
    const size_t frames = sequence_->frame_count();
    std::unique_lock lock(mutex_);
    if (stopped_) return Status::kEnd;
    if (next_accel_ < accel.size() &&
        (next_frame_ >= frames ||
         accel[next_accel_].t_ns <= sequence_->frame_time_ns(next_frame_))) {
      item->kind = SourceItem::Kind::kAccel;
      item->accel = accel[next_accel_++];
      item->t_ns = item->accel.t_ns;
      ++stats_.accel_samples;
      return Status::kItem;
    }
    if (next_frame_ >= frames) return Status::kEnd;
    if (!changed_.wait_for(lock, timeout, [&] { return !ready_.empty() || stopped_; })) {
      return Status::kTimeout;
    }
    if (stopped_) return Status::kEnd;
    Loaded loaded = std::move(ready_.front());
    ready_.pop_front();
    changed_.notify_all();
    if (loaded.failure) std::rethrow_exception(loaded.failure);
    item->kind = SourceItem::Kind::kFrame;
    item->frame_number = next_frame_;
    item->t_ns = sequence_->frame_time_ns(next_frame_++);
    item->image = std::move(loaded.image);
    ++stats_.frames;
    return Status::kItem;
  }

  SourceStats stats() const override {
    std::lock_guard lock(mutex_);
    return stats_;
  }

 private:
  struct Loaded {
    cv::Mat image;
    std::exception_ptr failure;
  };

  // Loads frames in index order, up to read_ahead_ ahead of the consumer. In order, not
  // in parallel: a video decodes forward without seeking, and the simulator's renderer
  // already uses every core for one frame.
  void ReadAhead() {
    for (size_t i = 0; i < sequence_->frame_count(); ++i) {
      {
        std::unique_lock lock(mutex_);
        changed_.wait(lock, [&] { return ready_.size() < read_ahead_ || stopped_; });
        if (stopped_) return;
      }
      Loaded loaded;
      try {
        loaded.image = sequence_->LoadFrame(i);
      } catch (...) {
        loaded.failure = std::current_exception();
      }
      const bool failed = loaded.failure != nullptr;
      {
        std::lock_guard lock(mutex_);
        ready_.push_back(std::move(loaded));
      }
      changed_.notify_all();
      if (failed) return;  // The consumer stops at the failed frame.
    }
  }

  const std::unique_ptr<Sequence> sequence_;
  const size_t read_ahead_;
  std::thread reader_;
  mutable std::mutex mutex_;  // The members below.
  std::condition_variable changed_;
  bool started_ = false;
  bool stopped_ = false;
  std::deque<Loaded> ready_;  // Frames next_frame_, next_frame_ + 1, ...
  size_t next_frame_ = 0;
  size_t next_accel_ = 0;
  SourceStats stats_;
};

// A recorded source played as a live one: a thread takes its items as they come due in
// real time and queues them for the consumer, dropping the oldest frames (and samples)
// beyond the queues' sizes when the consumer falls behind, as a camera's driver would.
class PacedSource : public FrameSource {
 public:
  PacedSource(std::unique_ptr<SequenceSource> recorded, const SourceOptions& options)
      : recorded_(std::move(recorded)),
        speed_(options.real_time_speed),
        queue_(options.frame_queue, options.accel_queue) {}
  ~PacedSource() override { Stop(); }

  std::string Describe() const override { return recorded_->Describe() + ", played in real time"; }
  bool live() const override { return true; }
  SessionInfo session() const override { return recorded_->session(); }
  const Sequence* sequence() const override { return recorded_->sequence(); }

  void Start() override {
    std::lock_guard lock(mutex_);
    if (started_) return;
    started_ = true;
    player_ = std::thread(&PacedSource::Play, this);
  }

  void Stop() override {
    {
      std::lock_guard lock(mutex_);
      stopped_ = true;
    }
    stop_.notify_all();
    if (player_.joinable()) player_.join();
    recorded_->Stop();
    queue_.Close();
  }

  Status Next(SourceItem* item, std::chrono::milliseconds timeout) override {
    const Status status = queue_.Pop(item, timeout);
    std::lock_guard lock(mutex_);
    if (status == Status::kEnd && failure_)
      std::rethrow_exception(std::exchange(failure_, nullptr));
    if (status == Status::kItem)
      ++(item->kind == SourceItem::Kind::kFrame ? delivered_frames_ : delivered_accel_);
    return status;
  }

  SourceStats stats() const override {
    std::lock_guard lock(mutex_);
    SourceStats stats;
    stats.frames = delivered_frames_;
    stats.accel_samples = delivered_accel_;
    stats.frames_dropped = queue_.frames_dropped();
    stats.accel_dropped = queue_.accel_dropped();
    const auto rate = [](const Arrivals& a) {
      const double seconds = std::chrono::duration<double>(a.last - a.first).count();
      return a.count > 1 && seconds > 0 ? double(a.count - 1) / seconds : 0.0;
    };
    stats.camera_rate_hz = rate(frames_in_);
    stats.accel_rate_hz = rate(accel_in_);
    return stats;
  }

 private:
  using Clock = std::chrono::steady_clock;
  static constexpr auto kLateness = std::chrono::milliseconds(20);
  struct Arrivals {
    uint64_t count = 0;
    Clock::time_point first, last;
    void Add(Clock::time_point now) {
      if (count++ == 0) first = now;
      last = now;
    }
  };

  void Play() {
    std::optional<int64_t> first_ns;
    Clock::time_point start;
    try {
      SourceItem item;
      while (true) {
        const Status status = recorded_->Next(&item, std::chrono::milliseconds(100));
        if (status == Status::kEnd) break;
        std::unique_lock lock(mutex_);
        if (stopped_) break;
        if (status == Status::kTimeout) continue;
        if (!first_ns) {
          first_ns = item.t_ns;
          start = Clock::now();
        }
        const Clock::time_point due =
            start +
            std::chrono::duration_cast<Clock::duration>(
                std::chrono::duration<double, std::nano>(double(item.t_ns - *first_ns) / speed_));
        // Later than that (the recording reads slower than real time): the pace goes on
        // from here, without a burst to catch up, as a camera's would.
        if (const Clock::time_point now = Clock::now(); now > due + kLateness) {
          start += now - due;
        }
        if (stop_.wait_until(lock, due, [&] { return stopped_; })) break;
        (item.kind == SourceItem::Kind::kFrame ? frames_in_ : accel_in_).Add(Clock::now());
        lock.unlock();
        queue_.Push(std::move(item));
      }
    } catch (...) {
      std::lock_guard lock(mutex_);
      failure_ = std::current_exception();
    }
    queue_.Close();
  }

  const std::unique_ptr<SequenceSource> recorded_;
  const double speed_;
  DroppingItemQueue queue_;
  std::thread player_;
  mutable std::mutex mutex_;  // The members below.
  std::condition_variable stop_;
  bool started_ = false, stopped_ = false;
  std::exception_ptr failure_;     // From the recording, thrown by Next once the queue is empty.
  Arrivals frames_in_, accel_in_;  // Queued, for the rates.
  uint64_t delivered_frames_ = 0, delivered_accel_ = 0;
};

// A live camera with, optionally, a USB accelerometer on the same monotonic clock.
class LiveSource : public FrameSource {
 public:
  LiveSource(const CameraSpec& camera, const AccelSpec& accel, const SourceOptions& options)
      : merger_(std::chrono::nanoseconds(options.reorder_window).count(), true,
                accel.kind == AccelSpec::Kind::kUsb) {
    LiveCameraOptions camera_options;
    camera_options.device = camera.device;
    camera_options.width = camera.width;
    camera_options.height = camera.height;
    camera_options.fps = camera.fps;
    camera_options.fourcc = camera.fourcc;
    camera_options.queue_capacity = options.frame_queue;
    camera_ = std::make_unique<LiveCamera>(camera_options);
    if (accel.kind == AccelSpec::Kind::kUsb) {
      UsbAccelerometerOptions accel_options;
      accel_options.vendor_id = accel.vendor_id;
      accel_options.product_id = accel.product_id;
      accel_options.mapping_file = accel.mapping_file;
      accel_options.queue_capacity = options.accel_queue;
      accelerometer_ = std::make_unique<UsbAccelerometer>(accel_options);
    }
  }
  ~LiveSource() override { Stop(); }

  std::string Describe() const override {
    std::string text = "camera " + camera_->Describe();
    if (accelerometer_) text += " + USB accelerometer " + accelerometer_->Describe();
    return text;
  }
  bool live() const override { return true; }

  // Opens both devices, so that one message says everything that is missing.
  void Start() override {
    std::vector<std::string> failures;
    try {
      camera_->Start();
    } catch (const Error& e) {
      failures.push_back(e.what());
    }
    if (accelerometer_) {
      try {
        accelerometer_->Start();
      } catch (const Error& e) {
        failures.push_back(e.what());
      }
    }
    if (failures.empty()) return;
    Stop();
    std::string message = failures.front();
    for (size_t i = 1; i < failures.size(); ++i) message += "; and " + failures[i];
    throw Error(message);
  }

  void Stop() override {
    camera_->Stop();
    if (accelerometer_) accelerometer_->Stop();
    stopped_ = true;
  }

  SessionInfo session() const override {
    SessionInfo session;
    const LiveCameraStats camera = camera_->stats();
    session.camera_device = camera_->Describe();
    session.width = camera.width;
    session.height = camera.height;
    session.frame_rate_hz = camera_->nominal_fps() > 0 ? camera_->nominal_fps() : camera.rate_hz;
    if (accelerometer_) {
      session.accelerometer_device = accelerometer_->Describe();
      session.accel_rate_hz = accelerometer_->stats().rate_hz;
    }
    session.notes = "recorded live; timestamps are CLOCK_MONOTONIC";
    return session;
  }

  Status Next(SourceItem* item, std::chrono::milliseconds timeout) override {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (true) {
      Pump();
      if (!events_.empty()) {
        item->kind = SourceItem::Kind::kEvent;
        item->event = std::move(events_.front());
        item->t_ns = item->event.t_ns;
        events_.pop_front();
        return Status::kItem;
      }
      if (std::optional<SourceItem> next = merger_.Pop(MonotonicNowNs())) {
        return Deliver(std::move(*next), item);
      }
      if (stopped_) {
        if (flushed_.empty()) {
          std::vector<SourceItem> rest = merger_.Flush();
          flushed_.assign(std::make_move_iterator(rest.begin()),
                          std::make_move_iterator(rest.end()));
        }
        if (flushed_.empty()) return Status::kEnd;
        SourceItem next = std::move(flushed_.front());
        flushed_.pop_front();
        return Deliver(std::move(next), item);
      }
      const auto now = std::chrono::steady_clock::now();
      if (now >= deadline) return Status::kTimeout;
      // Short waits: frames wake us at once, samples and held frames within 2 ms.
      camera_->WaitForFrames(
          1, std::min(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now),
                      std::chrono::milliseconds(2)));
    }
  }

  SourceStats stats() const override {
    std::lock_guard lock(stats_mutex_);
    SourceStats stats = stats_;
    const LiveCameraStats camera = camera_->stats();
    stats.frames_dropped = camera.queue_dropped;
    stats.camera_gaps = camera.gaps;
    stats.camera_disconnections = camera.disconnections;
    stats.camera_rate_hz = camera.rate_hz;
    if (accelerometer_) {
      const UsbAccelerometerStats accel = accelerometer_->stats();
      stats.accel_dropped = accel.queue_dropped;
      stats.accel_late_reports = accel.late_reports;
      stats.accel_missing_reports = accel.missing_reports;
      stats.accel_disconnections = accel.disconnections;
      stats.accel_rate_hz = accel.rate_hz;
    }
    return stats;
  }

 private:
  // Moves what the devices queued into the merger and the event list.
  void Pump() {
    for (CameraEvent& e : camera_->TakeEvents()) {
      events_.push_back({SourceEvent::Device::kCamera,
                         e.kind == CameraEvent::Kind::kConnected ? SourceEvent::Kind::kConnected
                                                                 : SourceEvent::Kind::kDisconnected,
                         e.t_ns, std::move(e.message)});
    }
    for (CameraFrame& frame : camera_->Drain()) {
      merger_.AddFrame(frame.t_ns, frame.number, std::move(frame.image));
    }
    if (!accelerometer_) return;
    for (UsbAccelerometerEvent& e : accelerometer_->TakeEvents()) {
      const SourceEvent::Kind kind =
          e.kind == UsbAccelerometerEvent::Kind::kConnected      ? SourceEvent::Kind::kConnected
          : e.kind == UsbAccelerometerEvent::Kind::kDisconnected ? SourceEvent::Kind::kDisconnected
                                                                 : SourceEvent::Kind::kError;
      events_.push_back({SourceEvent::Device::kAccelerometer, kind, e.t_ns, std::move(e.message)});
    }
    for (const AccelSample& sample : accelerometer_->Drain()) merger_.AddAccel(sample);
  }

  Status Deliver(SourceItem next, SourceItem* item) {
    {
      std::lock_guard lock(stats_mutex_);
      if (next.kind == SourceItem::Kind::kFrame) {
        ++stats_.frames;
      } else {
        ++stats_.accel_samples;
      }
      stats_.out_of_order = merger_.out_of_order();  // The merger is the consumer's alone.
    }
    *item = std::move(next);
    return Status::kItem;
  }

  std::unique_ptr<LiveCamera> camera_;
  std::unique_ptr<UsbAccelerometer> accelerometer_;
  // Consumer thread only.
  TimeOrderMerger merger_;
  std::deque<SourceEvent> events_;
  std::deque<SourceItem> flushed_;
  std::atomic<bool> stopped_{false};
  mutable std::mutex stats_mutex_;
  SourceStats stats_;
};

}  // namespace

std::string FormatSourceEvent(const SourceEvent& event) {
  const char* kind = event.kind == SourceEvent::Kind::kConnected      ? "connected"
                     : event.kind == SourceEvent::Kind::kDisconnected ? "disconnected"
                                                                      : "error";
  return std::string(DeviceName(event.device)) + " " + kind + ": " + event.message;
}

AccelSpec ParseAccelSpec(const std::string& spec) {
  AccelSpec result;
  if (spec.empty()) return result;
  if (spec == "none") {
    result.kind = AccelSpec::Kind::kNone;
    return result;
  }
  if (spec == "usb" || spec.starts_with("usb:")) {
    result.kind = AccelSpec::Kind::kUsb;
    if (spec == "usb") return result;
    const std::string rest = spec.substr(4);
    if (rest.starts_with("mapping=")) {
      result.mapping_file = rest.substr(8);
      if (result.mapping_file.empty()) throw Error("--accel " + spec + ": mapping= needs a file");
      return result;
    }
    const std::vector<std::string> ids = Split(rest, ':');
    const auto vendor = ids.size() == 2 ? ParseNumber<uint16_t>(ids[0], 16) : std::nullopt;
    const auto product = ids.size() == 2 ? ParseNumber<uint16_t>(ids[1], 16) : std::nullopt;
    if (!vendor || !product || ids[0].size() > 4 || ids[1].size() > 4) {
      throw Error("--accel " + spec +
                  ": expected usb, usb:VID:PID (hexadecimal, e.g. usb:1234:5678) or "
                  "usb:mapping=FILE");
    }
    result.vendor_id = *vendor;
    result.product_id = *product;
    return result;
  }
  std::error_code ignored;
  if (!fs::is_regular_file(spec, ignored)) {
    throw Error("--accel " + spec +
                ": not a file, and not none, usb, usb:VID:PID or usb:mapping=FILE");
  }
  result.kind = AccelSpec::Kind::kCsv;
  result.csv_path = spec;
  return result;
}

std::optional<CameraSpec> ParseCameraSpec(const std::string& input) {
  constexpr std::string_view kPrefix = "camera:";
  if (!input.starts_with(kPrefix)) return std::nullopt;
  const std::vector<std::string> parts = Split(input.substr(kPrefix.size()), ',');
  CameraSpec camera;
  const std::string& device = parts.front();
  if (const auto index = ParseNumber<int>(device); index && *index >= 0) {
    camera.device = "/dev/video" + device;
  } else if (device.starts_with("/")) {
    camera.device = device;
  } else {
    throw Error(input + ": expected camera:N or camera:/dev/videoN");
  }
  for (size_t i = 1; i < parts.size(); ++i) {
    const size_t equals = parts[i].find('=');
    const std::string key = parts[i].substr(0, equals);
    const std::string value = equals == std::string::npos ? "" : parts[i].substr(equals + 1);
    if (key == "size") {
      const size_t x = value.find('x');
      const auto w = ParseNumber<int>(value.substr(0, x));
      const auto h = x == std::string::npos ? std::nullopt : ParseNumber<int>(value.substr(x + 1));
      if (!w || !h || *w <= 0 || *h <= 0) throw Error(input + ": size takes WxH, e.g. 1280x720");
      camera.width = *w;
      camera.height = *h;
    } else if (key == "fps") {
      const auto fps = ParseNumber<double>(value);
      if (!fps || !(*fps > 0)) throw Error(input + ": fps takes a positive number");
      camera.fps = *fps;
    } else if (key == "format") {
      if (value.size() != 4) throw Error(input + ": format takes a fourcc, e.g. MJPG");
      camera.fourcc = value;
    } else {
      throw Error(input + ": unknown camera option '" + key + "' (size=WxH, fps=F, format=FOURCC)");
    }
  }
  return camera;
}

std::unique_ptr<Sequence> OpenImageFolder(const std::string& dir, double fps_hz) {
  if (!(fps_hz > 0)) throw Error(dir, 0, "image folder: the frame rate must be positive");
  std::vector<fs::path> images;
  std::error_code error;
  for (fs::directory_iterator it(dir, error), end; !error && it != end; it.increment(error)) {
    if (it->is_regular_file() && IsImageFile(it->path())) images.push_back(it->path());
  }
  if (images.empty()) {
    throw Error(dir, 0,
                "holds no images (png, jpg, jpeg, bmp, tif, tiff) and is no known recording");
  }
  std::sort(images.begin(), images.end());

  ImageFileSequence::Contents contents;
  contents.description = "image folder " + dir;
  std::vector<int64_t> named_ns;
  for (const fs::path& image : images) {
    if (const auto t = ParseNumber<int64_t>(image.stem().string())) named_ns.push_back(*t);
  }
  // Integer names sort as text, not as numbers: order by time when they are times.
  if (named_ns.size() == images.size()) {
    std::vector<size_t> order(images.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(),
              [&](size_t a, size_t b) { return named_ns[a] < named_ns[b]; });
    for (size_t i = 0; i < order.size(); ++i) {
      if (i > 0 && named_ns[order[i]] == named_ns[order[i - 1]]) {
        throw Error(images[order[i]].string(), 0, "two images name the same time");
      }
      contents.frame_times_ns.push_back(named_ns[order[i]]);
      contents.frame_paths.push_back(images[order[i]]);
    }
    contents.session.notes = "image folder; frame times from the file names (ns)";
  } else {
    for (size_t i = 0; i < images.size(); ++i) {
      contents.frame_times_ns.push_back(std::llround(static_cast<double>(i) * 1e9 / fps_hz));
    }
    contents.frame_paths = images;
    contents.session.notes =
        "image folder; frames timed at an assumed " + std::to_string(fps_hz) + " Hz";
  }
  const cv::Mat first = cv::imread(contents.frame_paths.front().string(), cv::IMREAD_COLOR);
  if (first.empty())
    throw Error(contents.frame_paths.front().string(), 0, "cannot decode as an image");
  contents.session.camera_device = "image folder";
  contents.session.width = first.cols;
  contents.session.height = first.rows;
  contents.session.frame_rate_hz = fps_hz;
  return std::make_unique<ImageFileSequence>(std::move(contents));
}

bool SourceOptions::Check(std::string* error) const {
  if (frame_queue == 0) {
    *error = "frame_queue: at least 1";
  } else if (accel_queue == 0) {
    *error = "accel_queue: at least 1";
  } else if (reorder_window.count() < 0) {
    *error = "reorder_window: must not be negative";
  } else if (read_ahead == 0) {
    *error = "read_ahead: at least 1";
  } else if (!(real_time_speed > 0) || !std::isfinite(real_time_speed)) {
    *error = "real_time_speed: must be positive";
  } else {
    return true;
  }
  return false;
}

std::unique_ptr<FrameSource> OpenSource(const std::string& input, const std::string& accel,
                                        const SourceOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw Error("source options: " + why);
  const AccelSpec accel_spec = ParseAccelSpec(accel);
  if (const std::optional<CameraSpec> camera = ParseCameraSpec(input)) {
    if (accel_spec.kind == AccelSpec::Kind::kCsv) {
      throw Error("--accel " + accel +
                  ": a live camera needs a live accelerometer (usb...): a recorded CSV is on "
                  "another clock");
    }
    return std::make_unique<LiveSource>(*camera, accel_spec, options);
  }
  if (accel_spec.kind == AccelSpec::Kind::kUsb) {
    throw Error("--accel " + accel +
                ": a USB accelerometer needs a live camera input (camera:N); " + input +
                " is recorded, on another clock");
  }

  std::unique_ptr<Sequence> sequence;
  std::error_code ignored;
  const bool folder = fs::is_directory(input, ignored);
  ReadOptions read_options;
  read_options.without_accel = accel_spec.kind == AccelSpec::Kind::kNone;
  // A video takes the CSV as its own: its frames may be timed from it.
  const bool video = fs::is_regular_file(input, ignored);
  if (video && accel_spec.kind == AccelSpec::Kind::kCsv)
    read_options.accel_csv = accel_spec.csv_path;
  try {
    sequence = OpenSequence(input, read_options);
  } catch (const Error&) {
    // A folder of nothing but images is read as one; anything else keeps its error.
    if (!folder || LooksLikeRecording(input)) throw;
    sequence = OpenImageFolder(input);
  }
  if (accel_spec.kind == AccelSpec::Kind::kCsv && !video) {
    std::vector<std::string> warnings;
    std::vector<AccelSample> samples = ReadAccelCsv(accel_spec.csv_path, {}, &warnings);
    sequence = std::make_unique<AccelOverrideSequence>(std::move(sequence), std::move(samples),
                                                       accel_spec.csv_path, std::move(warnings));
  } else if (accel_spec.kind == AccelSpec::Kind::kNone) {
    sequence = std::make_unique<AccelOverrideSequence>(
        std::move(sequence), std::vector<AccelSample>{}, "none", std::vector<std::string>{});
  }
  return PlaySequence(std::move(sequence), options);
}

std::unique_ptr<FrameSource> PlaySequence(std::unique_ptr<Sequence> sequence,
                                          const SourceOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw Error("source options: " + why);
  auto recorded = std::make_unique<SequenceSource>(std::move(sequence), options.read_ahead);
  if (options.real_time) return std::make_unique<PacedSource>(std::move(recorded), options);
  return recorded;
}

DroppingItemQueue::DroppingItemQueue(size_t frames, size_t samples)
    : frame_capacity_(frames), accel_capacity_(samples) {}

void DroppingItemQueue::Push(SourceItem item) {
  {
    std::lock_guard lock(mutex_);
    if (closed_) return;
    const SourceItem::Kind kind = item.kind;
    if (kind != SourceItem::Kind::kEvent) {
      const bool frame = kind == SourceItem::Kind::kFrame;
      size_t& held = frame ? frames_ : samples_;
      if (held == (frame ? frame_capacity_ : accel_capacity_)) {
        items_.erase(std::find_if(items_.begin(), items_.end(),
                                  [&](const SourceItem& queued) { return queued.kind == kind; }));
        --held;
        ++(frame ? frames_dropped_ : accel_dropped_);
      }
      ++held;
    }
    items_.push_back(std::move(item));
  }
  changed_.notify_all();
}

FrameSource::Status DroppingItemQueue::Pop(SourceItem* item, std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  if (!changed_.wait_for(lock, timeout, [&] { return !items_.empty() || closed_; })) {
    return FrameSource::Status::kTimeout;
  }
  if (items_.empty()) return FrameSource::Status::kEnd;
  *item = std::move(items_.front());
  items_.pop_front();
  if (item->kind == SourceItem::Kind::kFrame) --frames_;
  if (item->kind == SourceItem::Kind::kAccel) --samples_;
  return FrameSource::Status::kItem;
}

void DroppingItemQueue::Close() {
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
  }
  changed_.notify_all();
}

uint64_t DroppingItemQueue::frames_dropped() const {
  std::lock_guard lock(mutex_);
  return frames_dropped_;
}

uint64_t DroppingItemQueue::accel_dropped() const {
  std::lock_guard lock(mutex_);
  return accel_dropped_;
}

SourceBranch::SourceBranch(const FrameSource& trunk, size_t frame_queue, size_t accel_queue)
    : trunk_(trunk), queue_(frame_queue, accel_queue) {}

void SourceBranch::Feed(const SourceItem& item) {
  if (started_) queue_.Push(item);  // Frames share their pixels: nothing is copied.
}

std::string SourceBranch::Describe() const { return trunk_.Describe(); }

void SourceBranch::Start() { started_ = true; }

void SourceBranch::Stop() {
  started_ = false;
  queue_.Close();
}

SessionInfo SourceBranch::session() const { return trunk_.session(); }

FrameSource::Status SourceBranch::Next(SourceItem* item, std::chrono::milliseconds timeout) {
  return queue_.Pop(item, timeout);
}

SourceStats SourceBranch::stats() const {
  SourceStats stats = trunk_.stats();
  stats.frames_dropped += queue_.frames_dropped();
  stats.accel_dropped += queue_.accel_dropped();
  return stats;
}

TimeOrderMerger::TimeOrderMerger(int64_t window_ns, bool expect_frames, bool expect_accel)
    : window_ns_(window_ns), expect_frames_(expect_frames), expect_accel_(expect_accel) {}

void TimeOrderMerger::AddFrame(int64_t t_ns, uint64_t number, cv::Mat image) {
  SourceItem item;
  item.kind = SourceItem::Kind::kFrame;
  item.t_ns = t_ns;
  item.frame_number = number;
  item.image = std::move(image);
  frames_.push_back(std::move(item));
  latest_frame_ns_ = latest_frame_ns_ ? std::max(*latest_frame_ns_, t_ns) : t_ns;
}

void TimeOrderMerger::AddAccel(const AccelSample& sample) {
  SourceItem item;
  item.kind = SourceItem::Kind::kAccel;
  item.t_ns = sample.t_ns;
  item.accel = sample;
  accel_.push_back(std::move(item));
  latest_accel_ns_ = latest_accel_ns_ ? std::max(*latest_accel_ns_, sample.t_ns) : sample.t_ns;
}

std::optional<SourceItem> TimeOrderMerger::Take(bool frame) {
  std::deque<SourceItem>& queue = frame ? frames_ : accel_;
  SourceItem item = std::move(queue.front());
  queue.pop_front();
  if (last_out_ns_ && item.t_ns < *last_out_ns_) {
    ++out_of_order_;
  } else {
    last_out_ns_ = item.t_ns;
  }
  return item;
}

std::optional<SourceItem> TimeOrderMerger::Pop(int64_t now_ns) {
  if (frames_.empty() && accel_.empty()) return std::nullopt;
  // Samples first at equal times: they lead up to the frame.
  const bool frame =
      accel_.empty() || (!frames_.empty() && frames_.front().t_ns < accel_.front().t_ns);
  const int64_t t_ns = (frame ? frames_ : accel_).front().t_ns;
  const bool other_expected = frame ? expect_accel_ : expect_frames_;
  const std::optional<int64_t>& other_latest = frame ? latest_accel_ns_ : latest_frame_ns_;
  if (!other_expected || (other_latest && *other_latest >= t_ns) || now_ns - t_ns >= window_ns_) {
    return Take(frame);
  }
  return std::nullopt;
}

std::vector<SourceItem> TimeOrderMerger::Flush() {
  std::vector<SourceItem> items;
  while (!frames_.empty() || !accel_.empty()) {
    const bool frame =
        accel_.empty() || (!frames_.empty() && frames_.front().t_ns < accel_.front().t_ns);
    items.push_back(*Take(frame));
  }
  return items;
}

}  // namespace autocal
