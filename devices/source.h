// Streaming sources: one interface for everything that delivers frames and accelerometer
// samples, live (a camera with a USB accelerometer) or recorded (native recordings,
// EuRoC, TUM RGB-D, video + CSV, image folders, the simulator). Items come out in time
// order. A live source captures on its own threads into bounded queues that drop their
// oldest items when the consumer falls behind (and count them), so a slow consumer never
// blocks a device; a recorded source waits for its consumer and drops nothing.
// See docs/devices.md.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "devices/inspect.h"
#include "devices/sequence.h"

namespace autocal {

// A change of a live device's connection.
struct SourceEvent {
  enum class Device { kCamera, kAccelerometer };
  enum class Kind { kConnected, kDisconnected, kError };
  Device device = Device::kCamera;
  Kind kind = Kind::kConnected;
  int64_t t_ns = 0;
  std::string message;
};

// "camera connected: opened /dev/video0".
std::string FormatSourceEvent(const SourceEvent& event);

struct SourceItem {
  enum class Kind { kFrame, kAccel, kEvent };
  Kind kind = Kind::kFrame;
  int64_t t_ns = 0;  // The frame's, the sample's or the event's time.
  // kFrame: 8-bit BGR, and its number: the index in a recorded sequence (for
  // Sequence::LoadFrame), frames captured before it for a live camera.
  cv::Mat image;
  uint64_t frame_number = 0;
  AccelSample accel;  // kAccel.
  SourceEvent event;  // kEvent.
};

struct SourceStats {
  uint64_t frames = 0;          // Frames delivered.
  uint64_t accel_samples = 0;   // Samples delivered.
  uint64_t frames_dropped = 0;  // By full queues (live sources only).
  uint64_t accel_dropped = 0;
  // USB accelerometer: samples after a gap over 1.5 median intervals, and the samples
  // those gaps should have held (estimate).
  uint64_t accel_late_reports = 0;
  uint64_t accel_missing_reports = 0;
  // Items delivered after a later one had been delivered already (a live stream that
  // arrived later than the reordering window allows).
  uint64_t out_of_order = 0;
  // Gaps in the live camera's stream (unplug to re-plug).
  std::vector<TimeGap> camera_gaps;
  int camera_disconnections = 0;
  int accel_disconnections = 0;
  double camera_rate_hz = 0.0;  // Measured, live sources only.
  double accel_rate_hz = 0.0;
};

class FrameSource {
 public:
  enum class Status { kItem, kTimeout, kEnd };

  virtual ~FrameSource() = default;

  // "camera /dev/video0 (...) + USB accelerometer 1234:5678 ...", "native recording ...".
  virtual std::string Describe() const = 0;
  // Live sources run on the monotonic clock and drop items a slow consumer leaves.
  virtual bool live() const = 0;
  // Opens the devices (or starts reading ahead). Throws Error saying what is missing and
  // what was found. Items may be lost before Start only for live sources.
  virtual void Start() = 0;
  // Stops the devices; Next then returns kEnd once the queued items are taken.
  virtual void Stop() = 0;
  // What session.json should say: frame size (known after Start), rates, devices.
  virtual SessionInfo session() const = 0;
  // The next item in time order: kItem with `item` filled, kTimeout when nothing came
  // within `timeout`, kEnd when a recorded source is exhausted or after Stop. Throws
  // Error when a recorded frame cannot be read.
  virtual Status Next(SourceItem* item, std::chrono::milliseconds timeout) = 0;
  virtual SourceStats stats() const = 0;
  // The recorded sequence behind the source (for ground truth and random access); null
  // for a live camera.
  virtual const Sequence* sequence() const { return nullptr; }
};

// Items handed from one thread to a consumer on another, in the order given. Beyond
// `frames` queued frames (or `samples` samples) the oldest of that kind is dropped and
// counted, so that the thread pushing never waits. Thread-safe.
class DroppingItemQueue {
 public:
  DroppingItemQueue(size_t frames, size_t samples);

  // Events are never dropped. Ignored once closed.
  void Push(SourceItem item);
  // kItem with `item` filled, kTimeout, or kEnd once closed and empty.
  FrameSource::Status Pop(SourceItem* item, std::chrono::milliseconds timeout);
  void Close();
  uint64_t frames_dropped() const;
  uint64_t accel_dropped() const;

 private:
  const size_t frame_capacity_, accel_capacity_;
  mutable std::mutex mutex_;  // The members below.
  std::condition_variable changed_;
  std::deque<SourceItem> items_;
  size_t frames_ = 0, samples_ = 0;
  uint64_t frames_dropped_ = 0, accel_dropped_ = 0;
  bool closed_ = false;
};

// A second reader of a live source that one thread already reads (the workbench's live
// session feeding the pipeline): that thread hands the branch every item it takes, and the
// branch delivers them to its own consumer (Record() on another thread) as a live source
// would, dropping the oldest frames beyond frame_queue when that consumer falls behind, so
// the first reader is never held back. Items fed before Start or after Stop are ignored.
class SourceBranch : public FrameSource {
 public:
  // `trunk` must outlive the branch; its session and stats are the branch's.
  explicit SourceBranch(const FrameSource& trunk, size_t frame_queue = 8,
                        size_t accel_queue = 8192);

  // From the trunk's reader.
  void Feed(const SourceItem& item);

  std::string Describe() const override;
  bool live() const override { return true; }
  void Start() override;
  void Stop() override;
  SessionInfo session() const override;
  Status Next(SourceItem* item, std::chrono::milliseconds timeout) override;
  // The trunk's, with the frames and samples this branch dropped added.
  SourceStats stats() const override;

 private:
  const FrameSource& trunk_;
  DroppingItemQueue queue_;
  std::atomic<bool> started_{false};
};

// Where accelerometer samples come from, parsed from a --accel value:
//   ""               the input's own (a recording's, or none)
//   "none"           none, even if the input has some
//   "usb"            any USB HID Sensor accelerometer
//   "usb:VID:PID"    that USB device (hexadecimal ids), HID Sensor layout
//   "usb:mapping=F"  the USB device a mapping file describes (docs/usb_accelerometer.md)
//   a file path      a CSV in the native accel0/data.csv layout
struct AccelSpec {
  enum class Kind { kInput, kNone, kUsb, kCsv };
  Kind kind = Kind::kInput;
  uint16_t vendor_id = 0;  // kUsb; both 0: any.
  uint16_t product_id = 0;
  std::string mapping_file;  // kUsb.
  std::string csv_path;      // kCsv.
};

// Throws Error naming the part that does not parse.
AccelSpec ParseAccelSpec(const std::string& spec);

// A live camera, from "camera:N" (/dev/videoN) or "camera:/dev/videoN", optionally
// followed by ",size=WxH", ",fps=F", ",format=FOURCC".
struct CameraSpec {
  std::string device;
  int width = 0;
  int height = 0;
  double fps = 0.0;
  std::string fourcc;
};

// Nothing when `input` does not start with "camera:"; throws Error when it does but
// does not parse.
std::optional<CameraSpec> ParseCameraSpec(const std::string& input);

// A folder of images (png, jpg, jpeg, bmp, tif, tiff), in name order. When every name
// (without extension) is an integer, it is the frame's time in ns (EuRoC's naming);
// otherwise frames are `1/fps_hz` apart from 0. No accelerometer samples. Throws Error
// when the folder holds no images or the first cannot be decoded.
std::unique_ptr<Sequence> OpenImageFolder(const std::string& dir, double fps_hz = 30.0);

struct SourceOptions {
  // Live: frames and samples held for a consumer before the oldest are dropped.
  size_t frame_queue = 8;
  size_t accel_queue = 8192;
  // Live: a frame is held this long for accelerometer samples up to its time, so that
  // items leave in time order although the two devices deliver with different delays.
  std::chrono::milliseconds reorder_window{100};
  // Recorded: frames decoded (rendered, for the simulator) ahead of the consumer.
  size_t read_ahead = 4;
  // Recorded: played as a live source (`autocal run --live`), paced in real time by its
  // own timestamps: each item leaves no earlier than its time after the first, and what a
  // slow consumer leaves beyond frame_queue / accel_queue is dropped (oldest first) and
  // counted, as a camera's would be. Times stay the recording's, and sequence() still
  // gives its ground truth. A source slower than real time (the simulator rendering a
  // large image) delivers as fast as it can, then keeps the pace from there without a
  // burst. Ignored for a live camera.
  bool real_time = false;
  // With real_time: the recording's seconds per wall-clock second (2: twice as fast, a
  // stream at twice its frame rate).
  double real_time_speed = 1.0;

  bool Check(std::string* error) const;
};

// Opens `input`: "camera:..." (see CameraSpec), "sim:SCENARIO[,key=value...]", anything
// OpenSequence reads (native recording, EuRoC, TUM RGB-D, video + CSV), or an image
// folder; with accelerometer samples as `accel` says (see AccelSpec). A USB
// accelerometer needs a live camera (their clocks must be the same). Nothing is opened
// before Start. Throws Error for an input or accel value that does not parse or names
// nothing usable.
std::unique_ptr<FrameSource> OpenSource(const std::string& input, const std::string& accel = "",
                                        const SourceOptions& options = {});

// A sequence already opened, as a source: streamed, or paced in real time when
// options.real_time is set (frames rendered beforehand then cost the pacing nothing).
std::unique_ptr<FrameSource> PlaySequence(std::unique_ptr<Sequence> sequence,
                                          const SourceOptions& options = {});

// Merges two time-ordered streams that arrive with different delays into one ordered
// stream. An item leaves once the other stream has reached its time (nothing earlier
// can come from it), or once it has waited `window_ns`, or at once when the other
// stream is not expected. Public so that its rules are tested on their own.
class TimeOrderMerger {
 public:
  TimeOrderMerger(int64_t window_ns, bool expect_frames, bool expect_accel);

  void AddFrame(int64_t t_ns, uint64_t number, cv::Mat image);
  void AddAccel(const AccelSample& sample);
  // The next item that may leave at `now_ns` (the clock the items are stamped with).
  std::optional<SourceItem> Pop(int64_t now_ns);
  // Every item still held, in time order (at the end of a stream).
  std::vector<SourceItem> Flush();
  // Items that left after a later one had.
  uint64_t out_of_order() const { return out_of_order_; }

 private:
  std::optional<SourceItem> Take(bool frame);

  int64_t window_ns_;
  bool expect_frames_, expect_accel_;
  std::deque<SourceItem> frames_, accel_;  // Oldest first.
  std::optional<int64_t> latest_frame_ns_, latest_accel_ns_, last_out_ns_;
  uint64_t out_of_order_ = 0;
};

}  // namespace autocal
