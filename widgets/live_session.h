// The workbench's live session, without drawing: connects to a source (a camera with a USB
// accelerometer, or any input the command line takes, played in real time), reads it on a
// thread of its own into the calibration runtime in live mode (devices/runtime.h: frames the
// pipeline cannot take are dropped and counted, capture never waits), measures what the
// devices deliver, and on request records the stream to a native recording folder through
// devices/recorder.h on another thread, fed through a SourceBranch so that a slow disk drops
// recorded frames rather than holding capture back. widgets/device_panel.h shows and drives
// it; the main window draws the live video from latestFrame() when frameReady() says so.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <QObject>
#include <QString>
#include <opencv2/core.hpp>

#include "devices/recorder.h"
#include "devices/source.h"
#include "devices/timing_stats.h"
#include "pipeline/calibration_pipeline.h"

namespace autocal {

class LiveSession : public QObject {
  Q_OBJECT

 public:
  enum class DeviceState { kAbsent, kConnecting, kConnected, kDisconnected, kError };

  struct DeviceStatus {
    DeviceState state = DeviceState::kAbsent;
    QString message;       // What the device is, or the event or error that changed its state.
    double rate_hz = 0.0;  // Measured: frames/s for the camera, samples/s for the accelerometer.
  };

  // Everything the panel shows, taken at once.
  struct Status {
    bool connected = false;  // The source started and has not been disconnected.
    QString source;          // FrameSource::Describe().
    DeviceStatus camera, accelerometer;
    uint64_t frames_received = 0;
    uint64_t frames_done = 0;     // Through boxes 1-9.
    uint64_t frames_dropped = 0;  // Never processed: the pipeline's queue and the source's.
    uint64_t accel_dropped = 0;   // Samples dropped by the source's queue.
    // USB accelerometer: reports that came late (after a gap) and those the gaps lost.
    uint64_t accel_late_reports = 0;
    uint64_t accel_missing_reports = 0;
    uint64_t late_items = 0;  // Delivered later than the reordering window allows.
    // Why the pipeline is not running on this source (no calibration to start from, or one
    // for another frame size); empty when it is.
    QString calibration_note;
    bool recording = false;
    QString recording_dir;
    RecorderProgress recorded;  // The last progress of the recording (or of the last one).
  };

  // A frame for the live video: the newest the pipeline has done, with its snapshot, so that
  // the overlays drawn on it are its own; without the pipeline, the newest received.
  struct LiveFrame {
    uint64_t number = 0;  // Frames received before it in this session.
    int64_t t_ns = 0;
    cv::Mat image;  // As the source gave it (BGR or grey); shared, never written to.
    std::shared_ptr<const FrameSnapshot> snapshot;  // Null without the pipeline.
    // The newest attempt that placed virtual boards (their poses are box 10's views).
    std::shared_ptr<const AttemptOutcome> boards_attempt;
  };

  explicit LiveSession(QObject* parent = nullptr);
  // Stops a recording and disconnects, waiting for both (a recording's last frames are
  // written first).
  ~LiveSession() override;

  // Opens `input` with `accel` (OpenSource's --input and --accel values; a recorded input
  // is played in real time) and starts it on the session's thread: connected() or
  // connectFailed() follow. The pipeline starts from `prior` when given, else from the
  // source's pre-mission calibration; without either it does not run (calibration_note
  // says why) and the source can still be recorded. Returns false with `error` set when
  // already connected or the values do not parse.
  bool connectSource(const QString& input, const QString& accel,
                     const std::optional<CameraIntrinsics>& prior, QString* error);
  // Stops a recording (its files complete), then the source and the pipeline. Waits.
  void disconnectSource();
  bool isConnected() const;

  // Seconds added to accelerometer timestamps to put them on the camera's clock (the
  // runtime's accel_time_offset_s, which is fixed at its construction: the session shifts
  // the samples itself, so a change applies to every sample read from then on).
  double accelTimeOffset() const { return accel_offset_s_.load(); }
  void setAccelTimeOffset(double seconds) { accel_offset_s_.store(seconds); }

  // Starts writing the stream to the native recording folder `dir` (which must not exist
  // or be empty) on a thread of its own; recordingStarted() or recordingFailed() follow.
  // False with `error` set when not connected or already recording.
  bool startRecording(const QString& dir, QString* error);
  // Asks the recording to end; recordingStopped() follows once its files are complete.
  void stopRecording();
  bool isRecording() const;

  // Safe from any thread.
  Status status() const;
  // The newest processed frame (null before the first, or when the pipeline is not
  // running); safe from any thread, and the snapshot never changes.
  std::shared_ptr<const FrameSnapshot> latestSnapshot() const;
  // Each box's time over the frames the live pipeline processed since connecting.
  std::map<std::string, TimingStats> timingStats() const;
  // The newest live frame (empty image before the first); safe from any thread. Taking it
  // lets the next frameReady() be sent.
  LiveFrame latestFrame();

  // Seconds of accelerometer samples kept for the live plot (a tenth more before trimming).
  static constexpr double kAccelHistorySeconds = 60.0;
  struct AccelHistory {
    std::vector<AccelSample> samples;  // In time order, on the camera's clock (offset added).
    int64_t start_ns = 0;              // The session's first frame or sample: the plot's zero.
  };
  // The accelerometer's last kAccelHistorySeconds; safe from any thread.
  AccelHistory recentAccel() const;

 signals:
  void connected(const QString& description);
  // Nothing usable: the message says what is missing and what was found.
  void connectFailed(const QString& message);
  // The source ended or was disconnected.
  void disconnected();
  // A newer frame for latestFrame(). Coalesced: none is sent again until it was taken, so a
  // slow window never queues frames.
  void frameReady();
  // A device unplugged, back, or in error: "camera disconnected: lost /dev/video0 (...)".
  void deviceEvent(const QString& text);
  // About four times a second while connected, and after every change of state.
  void statusChanged();
  void recordingStarted(const QString& dir);
  // The folder is complete; `summary` says what it holds and what was lost.
  void recordingStopped(const QString& dir, const QString& summary);
  void recordingFailed(const QString& message);

 private:
  void ReadLoop(std::shared_ptr<FrameSource> source, std::optional<CameraIntrinsics> prior);
  void RecordLoop(std::shared_ptr<SourceBranch> branch, QString dir);
  void JoinRecorder();
  void UpdateDeviceStatus(const SourceEvent& event);
  // On the pipeline's thread: pairs the snapshot with its frame.
  void OnSnapshot(const std::shared_ptr<const FrameSnapshot>& snapshot);
  // Publishes `frame` as the newest (mutex_ held) and tells the GUI thread once.
  void PublishFrame(LiveFrame frame);
  // Queued to the GUI thread.
  void Post(std::function<void()> call);
  // Adds a sample to recentAccel()'s (on the reader's thread); the first item of the
  // session sets the plot's zero.
  void KeepForPlot(const AccelSample& sample, bool first_item);

  std::atomic<double> accel_offset_s_{0.0};

  // Set on the GUI thread, read by the session's threads.
  std::shared_ptr<FrameSource> source_;
  std::thread reader_;
  std::atomic<bool> stop_reading_{false};
  std::atomic<bool> reading_{false};  // From connectSource to the reader's end.
  std::thread recorder_;
  std::atomic<bool> stop_recording_{false};

  mutable std::mutex mutex_;  // The members below.
  Status status_;
  std::shared_ptr<SourceBranch> branch_;  // The recording's feed while it runs.
  std::shared_ptr<const FrameSnapshot> latest_;
  BoxTimingLog timings_;
  AccelHistory accel_history_;
  // Frames pushed to the pipeline and not yet done, by time, to pair with their snapshots.
  std::deque<LiveFrame> in_pipeline_;
  std::shared_ptr<const AttemptOutcome> boards_attempt_;
  LiveFrame latest_frame_;
  std::atomic<bool> frame_announced_{false};  // frameReady sent, latestFrame not yet called.
};

}  // namespace autocal
