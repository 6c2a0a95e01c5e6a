#include "widgets/vest_check_controller.h"

#include <exception>
#include <utility>

#include "devices/vest_check_run.h"
#include "widgets/image_convert.h"

namespace autocal {

VestCheckController::VestCheckController(QString input, QString accel,
                                         std::optional<CameraIntrinsics> premission,
                                         std::optional<double> readout_ms,
                                         const VestCheckOptions& options, QObject* parent)
    : QObject(parent),
      input_(std::move(input)),
      accel_(std::move(accel)),
      premission_(std::move(premission)),
      readout_ms_(readout_ms),
      options_(options) {
  qRegisterMetaType<VestCheckResult>();
  progress_.guidance = tr("Connecting…");
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
  std::lock_guard lock(mutex_);
  VestCheckProgress p = progress_;
  p.duration_s = options_.duration_s;
  p.frame = MatToQImage(frame_);
  return p;
}

QString VestCheckController::sourceDescription() const {
  std::lock_guard lock(mutex_);
  return description_;
}

QString VestCheckController::deviceIds() const {
  std::lock_guard lock(mutex_);
  return devices_;
}

// On the worker: the walk, its progress copied out for the GUI thread after every frame.
void VestCheckController::Run() {
  std::string error;
  std::optional<VestCheckResult> result;
  try {
    VestCheckHooks hooks;
    hooks.connected = [this](const std::string& description, const std::string& devices) {
      std::lock_guard lock(mutex_);
      description_ = QString::fromStdString(description);
      devices_ = QString::fromStdString(devices);
      connected_ = true;
    };
    hooks.checked = [this](const VestCheck& check) {
      VestCheckProgress p;
      p.guidance = QString::fromStdString(check.Guidance());
      p.progress = check.Progress();
      p.elapsed_s = check.elapsed_s();
      p.coverage = check.Coverage();
      std::lock_guard lock(mutex_);
      progress_ = std::move(p);
    };
    hooks.image = [this](const cv::Mat& frame) {
      std::lock_guard lock(mutex_);
      frame_ = frame;  // Shared, not copied: the source hands out a new matrix per frame.
    };
    result = RunVestCheck(input_.toStdString(), accel_.toStdString(), premission_, readout_ms_,
                          options_, stop_, hooks);
  } catch (const std::exception& e) {
    error = e.what();
  }
  std::lock_guard lock(mutex_);
  error_ = error;
  result_ = std::move(result);
  done_ = true;
}

void VestCheckController::Poll() {
  bool just_connected = false;
  {
    std::lock_guard lock(mutex_);
    if (connected_ && !announced_) just_connected = announced_ = true;
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
  emit finished(*result_);
}

}  // namespace autocal
