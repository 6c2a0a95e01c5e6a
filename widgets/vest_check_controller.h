// Runs a vest check (pipeline/vest_check.h) on a source: opens it (devices/source.h's
// OpenSource: "camera:0" with "usb" for the vest, "sim:office" for the simulated one, or a
// recording), feeds its frames and accelerometer samples to a runtime of its own
// (devices/runtime.h) on a worker thread, hands every snapshot to the check, and reports to
// the GUI thread by signals: progress while the walk lasts, the result when the walk's time
// is up or the source ends. A non-widget QObject so the dialog only shows what it says.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <QImage>
#include <QObject>
#include <QString>
#include <QTimer>

#include "pipeline/camera_model.h"
#include "pipeline/vest_check.h"

namespace autocal {

class FrameSource;

// What the walk page shows, taken together under one lock.
struct VestCheckProgress {
  QString guidance;
  double progress = 0.0;  // 0-1, VestCheck::Progress.
  double elapsed_s = 0.0;
  double duration_s = 0.0;
  std::vector<VestNeedStatus> coverage;
  QImage frame;  // The newest camera frame.
};

class VestCheckController : public QObject {
  Q_OBJECT

 public:
  // `input` and `accel` as OpenSource takes them. `premission`: the calibration the vest was
  // sent out with; without one, the source's own (a recording's session.json, the
  // simulator's lens).
  VestCheckController(QString input, QString accel, std::optional<CameraIntrinsics> premission,
                      const VestCheckOptions& options, QObject* parent = nullptr);
  ~VestCheckController() override;

  // Opens the source and starts the walk; connected() or failed() follows.
  void start();
  // Ends the walk now; finished() follows with the verdict on what was seen.
  void finishNow();
  // Abandons the walk: nothing more is emitted.
  void cancel();

  VestCheckProgress progress() const;
  bool running() const { return worker_.joinable() && !done_; }
  QString sourceDescription() const { return description_; }
  QString deviceIds() const { return devices_; }
  const VestCheckOptions& options() const { return options_; }

 signals:
  // The source opened: its description.
  void connected(const QString& description);
  void progressed();
  void finished(const autocal::VestCheckResult& result);
  void failed(const QString& message);

 private:
  void Run();
  void Poll();

  const QString input_, accel_;
  const std::optional<CameraIntrinsics> premission_;
  const VestCheckOptions options_;
  QString description_, devices_;

  std::unique_ptr<FrameSource> source_;
  std::thread worker_;
  std::atomic<bool> stop_{false}, done_{false}, cancelled_{false};
  QTimer poll_;  // Coalesces the worker's frames into ten updates a second.

  mutable std::mutex mutex_;  // Guards what follows.
  std::unique_ptr<VestCheck> check_;
  QImage frame_;
  std::string error_;
  bool announced_ = false;  // connected() was emitted.
};

}  // namespace autocal

Q_DECLARE_METATYPE(autocal::VestCheckResult)
