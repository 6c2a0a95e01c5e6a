#include "devices/vest_check_run.h"

#include <chrono>
#include <deque>
#include <memory>
#include <span>
#include <utility>

#include "devices/offline_runner.h"
#include "devices/runtime.h"
#include "devices/source.h"
#include "pipeline/error.h"
#include "pipeline/self_calibration.h"

namespace autocal {

VestCheckResult RunVestCheck(const std::string& input, const std::string& accel,
                             const std::optional<CameraIntrinsics>& premission,
                             std::optional<double> readout_ms, const VestCheckOptions& options,
                             const std::atomic<bool>& stop, const VestCheckHooks& hooks) {
  // Before the camera opens: a bad number is the news, not a device.
  if (readout_ms && !IsReadoutMs(*readout_ms)) {
    throw Error("the rolling-shutter readout must be in [0, " + std::to_string(int(kMaxReadoutMs)) +
                "] ms, got " + std::to_string(*readout_ms));
  }
  const std::unique_ptr<FrameSource> source = OpenSource(input, accel);
  source->Start();
  const SessionInfo session = source->session();
  const std::optional<CameraIntrinsics> start =
      premission ? premission : session.premission_calibration;
  if (!start) {
    throw Error(source->Describe() +
                " has no pre-mission calibration: give the vest's calibration file");
  }
  if (start->width != session.width || start->height != session.height) {
    throw Error("the pre-mission calibration is for " + std::to_string(start->width) + "x" +
                std::to_string(start->height) + " images, the camera delivers " +
                std::to_string(session.width) + "x" + std::to_string(session.height));
  }
  VestCheck check(*start, options);
  if (hooks.connected) {
    hooks.connected(source->Describe(),
                    session.camera_device + " + " +
                        (session.accelerometer_device.empty() ? std::string("no accelerometer")
                                                              : session.accelerometer_device));
  }

  AccelCalibration accel_calibration;
  accel_calibration.cam_from_accel = session.cam_from_accel;
  RuntimeOptions runtime_options;
  runtime_options.live = source->live();
  PipelineOptions pipeline = RecordingDefaults(session);
  if (readout_ms) pipeline.calibration.readout_ms = *readout_ms;
  std::atomic<bool> time_up{false};
  Runtime runtime(*start, accel_calibration, pipeline, runtime_options,
                  [&](const std::shared_ptr<const FrameSnapshot>& snapshot) {
                    check.Add(*snapshot);
                    if (check.elapsed_s() >= options.duration_s) time_up = true;
                    if (hooks.checked) hooks.checked(check);
                  });

  // Each frame is held until the accelerometer has reached box 7's lead past it, so box 7
  // sees the samples it wants (as PushSequence arranges offline); a source without an
  // accelerometer, or one that stalls, holds no more than this many.
  constexpr size_t kMaxHeld = 30;
  const bool expect_accel = session.accel_rate_hz > 0;
  std::deque<std::pair<int64_t, cv::Mat>> held;
  std::optional<int64_t> accel_ns;
  const auto release = [&](bool all) {
    while (!held.empty() && (all || !expect_accel || held.size() > kMaxHeld ||
                             (accel_ns && held.front().first + runtime.accel_lead_ns() <=
                                              *accel_ns + runtime.accel_offset_ns()))) {
      runtime.PushFrame(held.front().first, held.front().second);
      held.pop_front();
    }
  };
  SourceItem item;
  bool ended = false;
  while (!stop && !time_up) {
    const FrameSource::Status status = source->Next(&item, std::chrono::milliseconds(100));
    if (status == FrameSource::Status::kEnd) {
      ended = true;
      break;
    }
    if (status == FrameSource::Status::kTimeout) continue;
    if (item.kind == SourceItem::Kind::kAccel) {
      runtime.PushAccel(std::span(&item.accel, 1));
      accel_ns = item.accel.t_ns;
    } else if (item.kind == SourceItem::Kind::kFrame) {
      if (hooks.image) hooks.image(item.image);
      held.emplace_back(item.t_ns, item.image);
    }
    release(false);
  }
  if (ended) release(true);  // The source's last frames, with no more samples to come.
  runtime.Finish();
  source->Stop();
  VestCheckResult result = check.Result();
  result.readout_ms = pipeline.calibration.readout_ms;
  return result;
}

}  // namespace autocal
