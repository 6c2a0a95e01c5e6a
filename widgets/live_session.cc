#include "widgets/live_session.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <span>
#include <utility>

#include "devices/runtime.h"
#include "pipeline/error.h"

namespace autocal {
namespace {

using Clock = std::chrono::steady_clock;
constexpr auto kStatusInterval = std::chrono::milliseconds(250);
// Frames kept to pair with their snapshots: more than the runtime's queues hold (live, it
// drops the oldest beyond them).
constexpr size_t kFramesInPipeline = 16;

LiveSession::DeviceState StateOf(SourceEvent::Kind kind) {
  switch (kind) {
    case SourceEvent::Kind::kConnected:
      return LiveSession::DeviceState::kConnected;
    case SourceEvent::Kind::kDisconnected:
      return LiveSession::DeviceState::kDisconnected;
    case SourceEvent::Kind::kError:
      break;
  }
  return LiveSession::DeviceState::kError;
}

QString RecordingSummary(const RecorderProgress& p) {
  QString text = QString("%1 frames and %2 accelerometer samples over %3 s")
                     .arg(p.frames_written)
                     .arg(p.accel_written)
                     .arg(p.recorded_s, 0, 'f', 1);
  const uint64_t dropped = p.frames_dropped + p.source.frames_dropped;
  if (dropped > 0) text += QString("; %1 frames dropped").arg(dropped);
  for (const TimeGap& gap : p.source.camera_gaps) {
    text += QString("; camera gap of %1 s").arg(gap.seconds(), 0, 'f', 2);
  }
  return text;
}

}  // namespace

LiveSession::LiveSession(QObject* parent) : QObject(parent) {}

LiveSession::~LiveSession() { disconnectSource(); }

void LiveSession::Post(std::function<void()> call) {
  QMetaObject::invokeMethod(this, std::move(call), Qt::QueuedConnection);
}

bool LiveSession::connectSource(const QString& input, const QString& accel,
                                const std::optional<CameraIntrinsics>& prior, QString* error) {
  if (reading_ || recorder_.joinable()) {
    *error = "already connected to " + status().source + ": disconnect first";
    return false;
  }
  if (reader_.joinable()) reader_.join();  // A session that failed to start or ended.
  source_.reset();
  SourceOptions options;
  options.real_time = true;
  try {
    source_ = OpenSource(input.toStdString(), accel.toStdString(), options);
  } catch (const Error& e) {
    *error = QString::fromStdString(e.what());
    return false;
  }
  {
    std::lock_guard lock(mutex_);
    status_ = Status();
    latest_.reset();
    timings_ = BoxTimingLog();
    accel_history_ = AccelHistory();
    latest_frame_ = LiveFrame();  // The last session's frame is not this one's.
    status_.source = QString::fromStdString(source_->Describe());
    status_.camera.state = DeviceState::kConnecting;
  }
  stop_reading_ = false;
  reading_ = true;
  reader_ = std::thread(&LiveSession::ReadLoop, this, source_, prior);
  emit statusChanged();
  return true;
}

void LiveSession::disconnectSource() {
  if (recorder_.joinable()) {
    stop_recording_ = true;
    recorder_.join();
  }
  stop_reading_ = true;
  if (reader_.joinable()) reader_.join();
  source_.reset();
}

bool LiveSession::isConnected() const { return status().connected; }

bool LiveSession::isRecording() const { return status().recording; }

LiveSession::Status LiveSession::status() const {
  std::lock_guard lock(mutex_);
  return status_;
}

std::map<std::string, TimingStats> LiveSession::timingStats() const {
  std::lock_guard lock(mutex_);
  return timings_.Stats();
}

std::shared_ptr<const FrameSnapshot> LiveSession::latestSnapshot() const {
  std::lock_guard lock(mutex_);
  return latest_;
}

LiveSession::AccelHistory LiveSession::recentAccel() const {
  std::lock_guard lock(mutex_);
  return accel_history_;
}

void LiveSession::KeepForPlot(const AccelSample& sample, bool first_item) {
  std::lock_guard lock(mutex_);
  std::vector<AccelSample>& kept = accel_history_.samples;
  if (kept.empty() && first_item) accel_history_.start_ns = sample.t_ns;
  kept.push_back(sample);
  // Trimmed by a tenth of the span at a time, not one sample each time.
  const auto span_ns = static_cast<int64_t>(kAccelHistorySeconds * 1e9);
  if (kept.back().t_ns - kept.front().t_ns > span_ns + span_ns / 10) {
    const auto first_kept = std::find_if(kept.begin(), kept.end(), [&](const AccelSample& s) {
      return kept.back().t_ns - s.t_ns <= span_ns;
    });
    kept.erase(kept.begin(), first_kept);
  }
}

LiveSession::LiveFrame LiveSession::latestFrame() {
  frame_announced_ = false;
  std::lock_guard lock(mutex_);
  return latest_frame_;
}

void LiveSession::PublishFrame(LiveFrame frame) {
  latest_frame_ = std::move(frame);
  if (!frame_announced_.exchange(true)) Post([this] { emit frameReady(); });
}

void LiveSession::OnSnapshot(const std::shared_ptr<const FrameSnapshot>& snapshot) {
  std::lock_guard lock(mutex_);
  latest_ = snapshot;
  timings_.Add(snapshot->timing);
  if (snapshot->attempt && !snapshot->attempt->boards.empty()) boards_attempt_ = snapshot->attempt;
  // Frames before it were dropped by the runtime, or done already.
  while (!in_pipeline_.empty() && in_pipeline_.front().t_ns < snapshot->t_ns) {
    in_pipeline_.pop_front();
  }
  if (in_pipeline_.empty() || in_pipeline_.front().t_ns != snapshot->t_ns) return;
  LiveFrame frame = std::move(in_pipeline_.front());
  in_pipeline_.pop_front();
  frame.snapshot = snapshot;
  frame.boards_attempt = boards_attempt_;
  PublishFrame(std::move(frame));
}

bool LiveSession::startRecording(const QString& dir, QString* error) {
  if (!isConnected()) {
    *error = "not connected: connect to a source first";
    return false;
  }
  if (recorder_.joinable()) {
    *error = "already recording to " + status().recording_dir;
    return false;
  }
  auto branch = std::make_shared<SourceBranch>(*source_);
  {
    std::lock_guard lock(mutex_);
    branch_ = branch;
    status_.recording = true;
    status_.recording_dir = dir;
    status_.recorded = RecorderProgress();
  }
  stop_recording_ = false;
  recorder_ = std::thread(&LiveSession::RecordLoop, this, std::move(branch), dir);
  emit statusChanged();
  return true;
}

void LiveSession::stopRecording() { stop_recording_ = true; }

void LiveSession::JoinRecorder() {
  if (recorder_.joinable()) recorder_.join();
  std::lock_guard lock(mutex_);
  status_.recording = false;
  branch_.reset();
}

void LiveSession::RecordLoop(std::shared_ptr<SourceBranch> branch, QString dir) {
  RecorderOptions options;
  options.progress_interval_s = 0.25;
  bool announced = false;
  try {
    const RecorderProgress result = Record(
        *branch, dir.toStdString(), options,
        [&](const RecorderProgress& progress) {
          {
            std::lock_guard lock(mutex_);
            status_.recorded = progress;
          }
          // Record creates the folder once the source runs, before its first report.
          if (!announced) Post([this, dir] { emit recordingStarted(dir); });
          announced = true;
        },
        &stop_recording_);
    const QString summary = RecordingSummary(result);
    Post([this, dir, summary] {
      JoinRecorder();
      emit recordingStopped(dir, summary);
      emit statusChanged();
    });
  } catch (const std::exception& e) {  // Error, or the file system's own.
    const QString message = QString::fromStdString(e.what());
    Post([this, message] {
      JoinRecorder();
      emit recordingFailed(message);
      emit statusChanged();
    });
  }
}

void LiveSession::UpdateDeviceStatus(const SourceEvent& event) {
  std::lock_guard lock(mutex_);
  DeviceStatus& device =
      event.device == SourceEvent::Device::kCamera ? status_.camera : status_.accelerometer;
  device.state = StateOf(event.kind);
  device.message = QString::fromStdString(event.message);
}

void LiveSession::ReadLoop(std::shared_ptr<FrameSource> source,
                           std::optional<CameraIntrinsics> prior) {
  try {
    source->Start();
  } catch (const Error& e) {
    const QString message = QString::fromStdString(e.what());
    {
      std::lock_guard lock(mutex_);
      status_.camera = {DeviceState::kError, message, 0.0};
    }
    reading_ = false;
    Post([this, message] {
      emit connectFailed(message);
      emit statusChanged();
    });
    return;
  }

  // The pipeline, when there is a calibration to start from for these frames.
  const SessionInfo session = source->session();
  std::unique_ptr<Runtime> runtime;
  QString note;
  if (!prior) prior = session.premission_calibration;
  if (!prior) {
    note =
        "no calibration to start from (the source has no pre-mission calibration): "
        "recording only";
  } else if (prior->width != session.width || prior->height != session.height) {
    note = QString("the calibration is for %1x%2 images, the source gives %3x%4: recording only")
               .arg(prior->width)
               .arg(prior->height)
               .arg(session.width)
               .arg(session.height);
  } else {
    AccelCalibration accel;
    accel.cam_from_accel = session.cam_from_accel;
    RuntimeOptions options;
    options.live = true;
    try {
      runtime = std::make_unique<Runtime>(
          *prior, accel, PipelineOptions{}, options,
          [this](const std::shared_ptr<const FrameSnapshot>& snapshot) { OnSnapshot(snapshot); });
    } catch (const Error& e) {
      note = QString::fromStdString(e.what());
    }
  }
  const Sequence* recorded = source->sequence();
  {
    std::lock_guard lock(mutex_);
    status_.connected = true;
    status_.calibration_note = note;
    status_.camera = {DeviceState::kConnected,
                      QString::fromStdString(session.camera_device.empty() ? source->Describe()
                                                                           : session.camera_device),
                      0.0};
    if (!session.accelerometer_device.empty()) {
      status_.accelerometer = {DeviceState::kConnected,
                               QString::fromStdString(session.accelerometer_device), 0.0};
    } else if (recorded && !recorded->accel().empty()) {
      status_.accelerometer = {DeviceState::kConnected, "samples of the recording", 0.0};
    } else {
      status_.accelerometer = {DeviceState::kAbsent, "none (--accel usb adds a USB one)", 0.0};
    }
  }
  const QString description = QString::fromStdString(source->Describe());
  Post([this, description] {
    emit connected(description);
    emit statusChanged();
  });

  uint64_t received = 0;
  Clock::time_point next_status = Clock::now() + kStatusInterval;
  SourceItem item;
  bool ended = false;
  while (!stop_reading_ && !ended) {
    try {
      const FrameSource::Status got = source->Next(&item, std::chrono::milliseconds(100));
      ended = got == FrameSource::Status::kEnd;
      if (got == FrameSource::Status::kItem) {
        std::shared_ptr<SourceBranch> branch;
        {
          std::lock_guard lock(mutex_);
          branch = branch_;
        }
        if (branch) branch->Feed(item);  // As the devices gave it: the offset is processing's.
        switch (item.kind) {
          case SourceItem::Kind::kFrame: {
            LiveFrame frame{received++, item.t_ns, item.image, nullptr, nullptr};
            {
              std::lock_guard lock(mutex_);
              if (received == 1 && accel_history_.samples.empty()) {
                accel_history_.start_ns = item.t_ns;  // The plot counts from the first item.
              }
              if (runtime) {
                in_pipeline_.push_back(std::move(frame));
                if (in_pipeline_.size() > kFramesInPipeline) in_pipeline_.pop_front();
              } else {
                PublishFrame(std::move(frame));
              }
            }
            if (runtime) runtime->PushFrame(item.t_ns, item.image);  // Live: never waits.
            break;
          }
          case SourceItem::Kind::kAccel: {
            AccelSample sample = item.accel;
            sample.t_ns += std::llround(accel_offset_s_.load() * 1e9);
            KeepForPlot(sample, /*first_item=*/received == 0);
            if (runtime) runtime->PushAccel(std::span(&sample, 1));
            break;
          }
          case SourceItem::Kind::kEvent: {
            UpdateDeviceStatus(item.event);
            const QString text = QString::fromStdString(FormatSourceEvent(item.event));
            Post([this, text] { emit deviceEvent(text); });
            break;
          }
        }
      }
    } catch (const Error& e) {
      // The pipeline (or a recorded frame) failed: capture and recording go on.
      runtime.reset();
      std::lock_guard lock(mutex_);
      status_.calibration_note = QString("the pipeline stopped: ") + e.what();
    }
    if (Clock::now() >= next_status || stop_reading_ || ended) {
      next_status = Clock::now() + kStatusInterval;
      const SourceStats stats = source->stats();
      const RuntimeStats run = runtime ? runtime->stats() : RuntimeStats();
      {
        std::lock_guard lock(mutex_);
        status_.frames_received = received;
        status_.frames_done = run.frames_done;
        status_.frames_dropped = run.frames_dropped + stats.frames_dropped;
        status_.accel_dropped = stats.accel_dropped;
        status_.accel_late_reports = stats.accel_late_reports;
        status_.accel_missing_reports = stats.accel_missing_reports;
        status_.late_items = stats.out_of_order;
        status_.camera.rate_hz = stats.camera_rate_hz;
        status_.accelerometer.rate_hz = stats.accel_rate_hz;
      }
      Post([this] { emit statusChanged(); });
    }
  }

  source->Stop();
  runtime.reset();
  std::shared_ptr<SourceBranch> branch;
  {
    std::lock_guard lock(mutex_);
    in_pipeline_.clear();
    boards_attempt_.reset();
    branch = branch_;
    status_.connected = false;
    const QString why = ended ? "the source ended" : "disconnected";
    for (DeviceStatus* device : {&status_.camera, &status_.accelerometer}) {
      if (device->state != DeviceState::kAbsent) *device = {DeviceState::kDisconnected, why, 0.0};
    }
  }
  if (branch) branch->Stop();  // A recording of a source that ended ends with it.
  reading_ = false;
  Post([this] {
    emit disconnected();
    emit statusChanged();
  });
}

}  // namespace autocal
