#include "widgets/vest_check_controller.h"

#include <chrono>
#include <deque>
#include <exception>
#include <span>
#include <utility>

#include "devices/runtime.h"
#include "devices/source.h"
#include "pipeline/error.h"
#include "widgets/image_convert.h"

namespace autocal {

VestCheckController::VestCheckController(QString input, QString accel,
                                         std::optional<CameraIntrinsics> premission,
                                         const VestCheckOptions& options, QObject* parent)
    : QObject(parent),
      input_(std::move(input)),
      accel_(std::move(accel)),
      premission_(std::move(premission)),
      options_(options) {
  qRegisterMetaType<VestCheckResult>();
  poll_.setInterval(100);
  connect(&poll_, &QTimer::timeout, this, &VestCheckController::Poll);
}

VestCheckController::~VestCheckController() {
  cancel();
  if (worker_.joinable()) worker_.join();
}

void VestCheckController::start() {
  if (worker_.joinable()) return;
  worker_ = std::thread([this] { Run(); });
  poll_.start();
}

void VestCheckController::finishNow() { stop_ = true; }

void VestCheckController::cancel() {
  cancelled_ = true;
  stop_ = true;
  poll_.stop();
}

VestCheckProgress VestCheckController::progress() const {
  VestCheckProgress p;
  p.duration_s = options_.duration_s;
  std::lock_guard lock(mutex_);
  p.frame = frame_;
  if (!check_) {
    p.guidance = tr("Connecting…");
    return p;
  }
  p.guidance = QString::fromStdString(check_->Guidance());
  p.progress = check_->Progress();
  p.elapsed_s = check_->elapsed_s();
  p.coverage = check_->Coverage();
  return p;
}

// On the worker: the source's items into the runtime, each frame held until the
// accelerometer has reached box 7's lead past it (so box 7 sees the samples it wants, as
// PushSequence arranges offline), until the walk's time is up or the source ends.
void VestCheckController::Run() {
  std::string error;
  try {
    std::unique_ptr<FrameSource> source =
        OpenSource(input_.toStdString(), accel_.toStdString());
    source->Start();
    const SessionInfo session = source->session();
    const std::optional<CameraIntrinsics> premission =
        premission_ ? premission_ : session.premission_calibration;
    if (!premission) {
      throw Error(source->Describe() +
                  " has no pre-mission calibration: choose the vest's calibration file");
    }
    if (premission->width != session.width || premission->height != session.height) {
      throw Error("the pre-mission calibration is for " + std::to_string(premission->width) +
                  "x" + std::to_string(premission->height) + " images, the camera delivers " +
                  std::to_string(session.width) + "x" + std::to_string(session.height));
    }
    {
      std::lock_guard lock(mutex_);
      description_ = QString::fromStdString(source->Describe());
      devices_ = QString::fromStdString(session.camera_device + " + " +
                                        (session.accelerometer_device.empty()
                                             ? std::string("no accelerometer")
                                             : session.accelerometer_device));
      check_ = std::make_unique<VestCheck>(*premission, options_);
    }
    AccelCalibration accel;
    accel.cam_from_accel = session.cam_from_accel;
    RuntimeOptions runtime_options;
    runtime_options.live = source->live();
    Runtime runtime(*premission, accel, PipelineOptions{}, runtime_options,
                    [this](const std::shared_ptr<const FrameSnapshot>& snapshot) {
                      std::lock_guard lock(mutex_);
                      check_->Add(*snapshot);
                      if (check_->elapsed_s() >= options_.duration_s) stop_ = true;
                    });

    // Frames held for the accelerometer; a source without one, or one that stalls,
    // holds none beyond this many.
    constexpr size_t kMaxHeld = 30;
    const bool expect_accel = session.accel_rate_hz > 0;
    std::deque<std::pair<int64_t, cv::Mat>> held;
    std::optional<int64_t> accel_ns;
    const auto release = [&](bool all) {
      while (!held.empty() &&
             (all || !expect_accel || held.size() > kMaxHeld ||
              (accel_ns && held.front().first + runtime.accel_lead_ns() <=
                               *accel_ns + runtime.accel_offset_ns()))) {
        runtime.PushFrame(held.front().first, held.front().second);
        held.pop_front();
      }
    };
    SourceItem item;
    while (!stop_) {
      const FrameSource::Status status = source->Next(&item, std::chrono::milliseconds(100));
      if (status == FrameSource::Status::kEnd) break;
      if (status == FrameSource::Status::kTimeout) continue;
      if (item.kind == SourceItem::Kind::kAccel) {
        runtime.PushAccel(std::span(&item.accel, 1));
        accel_ns = item.accel.t_ns;
      } else if (item.kind == SourceItem::Kind::kFrame) {
        held.emplace_back(item.t_ns, item.image);
        std::lock_guard lock(mutex_);
        frame_ = MatToQImage(item.image);
      }
      release(false);
    }
    if (!cancelled_) {
      if (!stop_) release(true);  // The source ended: its last frames too.
      runtime.Finish();
    }
    source->Stop();
  } catch (const std::exception& e) {
    error = e.what();
  }
  std::lock_guard lock(mutex_);
  error_ = error;
  done_ = true;
}

void VestCheckController::Poll() {
  bool just_connected = false;
  {
    std::lock_guard lock(mutex_);
    if (check_ && !announced_) just_connected = announced_ = true;
  }
  if (just_connected) emit connected(description_);
  if (!done_) {
    emit progressed();
    return;
  }
  poll_.stop();
  worker_.join();
  if (cancelled_) return;
  if (!error_.empty()) {
    emit failed(QString::fromStdString(error_));
    return;
  }
  emit progressed();
  emit finished(check_->Result());
}

}  // namespace autocal
