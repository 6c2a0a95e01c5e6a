// Runs a vest check (devices/vest_check_run.h: its own runtime on the source, "camera:0"
// with "usb" for the vest, "sim:office" for the simulated one, or a recording) on a worker
// thread, and reports to the GUI thread by signals: progress while the walk lasts, the
// result when the walk's time is up or the source ends. A non-widget QObject, so the dialog
// only shows what it says.
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
#include <opencv2/core.hpp>

#include "pipeline/camera_model.h"
#include "pipeline/vest_check.h"

namespace autocal {

// What the walk page shows, taken together under one lock.
struct VestCheckProgress {
  QString guidance;
  double progress = 0.0;  // 0-1, VestCheck::Progress.
  double elapsed_s = 0.0;
  double duration_s = 0.0;
  std::vector<VestNeedStatus> coverage;
  QImage frame;  // The newest camera frame (null before the first).
};

class VestCheckController : public QObject {
  Q_OBJECT

 public:
  // `input` and `accel` as OpenSource takes them. `premission`: the calibration the vest was
  // sent out with; without one, the source's own (a recording's session.json, the
  // simulator's lens). `readout_ms`: the camera's rolling-shutter readout; without one, what
  // the source states.
  VestCheckController(QString input, QString accel, std::optional<CameraIntrinsics> premission,
                      std::optional<double> readout_ms, const VestCheckOptions& options,
                      QObject* parent = nullptr);
  ~VestCheckController() override;

  // Opens the source and starts the walk; connected() or failed() follows.
  void start();
  // Ends the walk now; finished() follows with the verdict on what was seen.
  void finishNow();
  // Abandons the walk: nothing more is emitted.
  void cancel();

  VestCheckProgress progress() const;
  QString sourceDescription() const;
  QString deviceIds() const;

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
  const std::optional<double> readout_ms_;
  const VestCheckOptions options_;

  std::thread worker_;
  std::atomic<bool> stop_{false}, done_{false}, cancelled_{false};
  QTimer poll_;  // Coalesces the worker's frames into ten updates a second.

  mutable std::mutex mutex_;  // Guards what follows, written by the worker.
  QString description_, devices_;
  bool connected_ = false;
  VestCheckProgress progress_;  // Its frame left empty: converted from frame_ on demand.
  cv::Mat frame_;
  std::string error_;
  std::optional<VestCheckResult> result_;
  bool announced_ = false;  // connected() was emitted (GUI thread).
};

}  // namespace autocal

Q_DECLARE_METATYPE(autocal::VestCheckResult)
