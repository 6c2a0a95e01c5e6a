#include "widgets/pipeline_controller.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <span>
#include <utility>

#ifdef __linux__
#include <sys/resource.h>
#include <unistd.h>
#endif

#include <QDir>
#include <QtConcurrent/QtConcurrentRun>
#include <opencv2/core.hpp>

#include "devices/history_writer.h"
#include "devices/offline_runner.h"
#include "devices/runtime.h"
#include "devices/sequence.h"
#include "pipeline/history_store.h"

namespace autocal {
namespace {

// A view of a QImage's pixels as the cv::Mat of the same layout (no copy).
cv::Mat PixelsOf(const QImage& image) {
  int type;
  switch (image.format()) {
    case QImage::Format_Grayscale8:
      type = CV_8UC1;
      break;
    case QImage::Format_RGB888:
      type = CV_8UC3;
      break;
    case QImage::Format_RGB32:
    case QImage::Format_ARGB32:
    case QImage::Format_RGBA8888:
      type = CV_8UC4;
      break;
    default:
      return {};
  }
  return cv::Mat(image.height(), image.width(), type, const_cast<uchar*>(image.constBits()),
                 static_cast<size_t>(image.bytesPerLine()));
}

// The rectified image in the layout of `image`: remapping moves pixels, whatever their
// channels mean.
QImage Rectify(Rectifier* rectifier, const QImage& image, const CameraIntrinsics& camera) {
  const cv::Mat pixels = PixelsOf(image);
  if (pixels.empty() || pixels.cols != camera.width || pixels.rows != camera.height) return {};
  const cv::Mat rectified = rectifier->Undistort(pixels, camera);
  QImage out(rectified.cols, rectified.rows, image.format());
  cv::Mat target(out.height(), out.width(), rectified.type(), out.bits(),
                 static_cast<size_t>(out.bytesPerLine()));
  rectified.copyTo(target);
  return out;
}

}  // namespace

PipelineController::PipelineController(QObject* parent)
    : QObject(parent), rectifier_(std::make_unique<Rectifier>()) {
  qRegisterMetaType<FrameOverlays>();
  qRegisterMetaType<std::shared_ptr<const FrameSnapshot>>();
  connect(&rectify_watcher_, &QFutureWatcher<Rectified>::finished, this,
          &PipelineController::onRectified);
}

PipelineController::~PipelineController() {
  stop();
  for (const std::unique_ptr<Run>& run : stopping_) run->thread.join();
  rectify_watcher_.waitForFinished();
}

void PipelineController::stop() {
  if (!run_) return;
  // The feeding thread stops pushing at once; the runtime then ends its frame and the solve
  // under way before its threads end, which can take a second: the run is joined when it
  // reports its end, not waited for here. Its reports until then are dropped.
  run_->stop = true;
  stopping_.push_back(std::move(run_));
  ++generation_;
  if (running_) {
    running_ = false;
    elapsed_s_ = clock_.elapsed() * 1e-3;
  }
}

void PipelineController::start(std::shared_ptr<const Sequence> sequence) {
  stop();
  sequence_ = std::move(sequence);
  snapshots_.clear();
  attempts_.clear();
  timings_ = BoxTimingLog();
  frames_done_ = 0;
  frame_count_ = sequence_ ? static_cast<int>(sequence_->frame_count()) : 0;
  elapsed_s_ = 0.0;
  history_path_.clear();
  current_ = FrameOverlays{current_.index, nullptr, nullptr, nullptr, 0, false, current_.live};
  if (!sequence_) return;

  const SessionInfo& session = sequence_->session();
  CameraIntrinsics prior;
  try {
    prior = StartingCalibration(sequence_->Describe(), session, premission_,
                                "File › Pre-mission Calibration… (or --prior)");
  } catch (const std::exception& e) {
    emit failed(QString::fromStdString(e.what()));
    return;
  }
  history_dir_ = std::make_unique<QTemporaryDir>(QDir::tempPath() +
                                                 QStringLiteral("/autocal-workbench-XXXXXX"));
  const QString history_file = history_dir_->isValid()
                                   ? history_dir_->filePath(QStringLiteral("history.sqlite"))
                                   : QString();

  const uint64_t generation = ++generation_;
  run_ = std::make_unique<Run>();
  run_->generation = generation;
  running_ = true;
  clock_.start();
  emit started(frame_count_);
  updateCurrent();

  AccelCalibration accel;
  accel.cam_from_accel = session.cam_from_accel;
  run_->thread =
      std::thread([this, generation, sequence = sequence_, prior, accel, options = options_,
                   history_file = history_file.toStdString(), run = run_.get()] {
        QString error;
#ifdef __linux__
        // The window must keep redrawing while the pipeline takes every core it can: its threads
        // (the runtime's inherit this one's niceness) give way to the GUI and the frame loader.
        setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), kPipelineNiceness);
#endif
        try {
          // The history table is told of the file once its first rows are in it.
          std::unique_ptr<HistoryWriter> history;
          if (!history_file.empty()) {
            history = std::make_unique<HistoryWriter>(
                std::make_unique<HistoryStore>(history_file),
                [this, generation, path = QString::fromStdString(history_file),
                 told = false]() mutable {
                  if (std::exchange(told, true)) return;
                  QMetaObject::invokeMethod(
                      this, [this, generation, path] { onAttemptRecorded(generation, path); },
                      Qt::QueuedConnection);
                });
          }
          std::unique_ptr<Runtime> runtime;
          // On the runtime's boxes 4-9 thread, frame after frame.
          const auto on_frame = [&](const std::shared_ptr<const FrameSnapshot>& snapshot) {
            if (snapshot->attempt && history) history->Submit(runtime->history());
            QMetaObject::invokeMethod(
                this, [this, generation, snapshot] { onSnapshot(generation, snapshot); },
                Qt::QueuedConnection);
          };
          runtime = std::make_unique<Runtime>(prior, accel, options, RuntimeOptions{}, on_frame);
          // The start in the file before the first frame, as autocal run writes it.
          if (history) history->Finish(runtime->history());
          // setOptions sees the runtime from here until just before it is destroyed, however
          // this scope ends.
          struct Published {
            Published(Run* run, Runtime* runtime) : run_(run) {
              const std::lock_guard lock(run_->runtime_mutex);
              run_->runtime = runtime;
            }
            ~Published() {
              const std::lock_guard lock(run_->runtime_mutex);
              run_->runtime = nullptr;
            }
            Run* run_;
          } published(run, runtime.get());
          if (!PushSequence(*sequence, runtime.get(), &run->stop)) {
            // Stopped, the runtime is still running: nothing of it is to be read here.
            if (history) history->Finish();
          } else {
            if (history) history->Finish(runtime->history());
            if (auto attempt = runtime->attempt_after_last_frame()) {
              const CameraIntrinsics after =
                  runtime->history().Current(attempt->record.t_ns).calibration;
              const std::shared_ptr<const FrameSnapshot> last = runtime->latest();
              std::optional<Eigen::Vector3d> gravity_cam;
              if (last) gravity_cam = last->inertial.gravity_cam;
              QMetaObject::invokeMethod(
                  this,
                  [this, generation, attempt = std::move(attempt), after, gravity_cam] {
                    onAttemptAfterLastFrame(generation, attempt, after, gravity_cam);
                  },
                  Qt::QueuedConnection);
            }
          }
        } catch (const std::exception& e) {
          error = QString::fromStdString(e.what());
        }
        QMetaObject::invokeMethod(
            this, [this, generation, error] { onEnded(generation, error); }, Qt::QueuedConnection);
      });
}

double PipelineController::framesPerSecond() const {
  const double seconds = running_ ? clock_.elapsed() * 1e-3 : elapsed_s_;
  return seconds > 0.0 ? frames_done_ / seconds : 0.0;
}

std::shared_ptr<const FrameSnapshot> PipelineController::snapshot(int index) const {
  const auto found = snapshots_.find(index);
  return found == snapshots_.end() ? nullptr : found->second;
}

void PipelineController::onSnapshot(uint64_t generation,
                                    std::shared_ptr<const FrameSnapshot> snapshot) {
  if (generation != generation_) return;
  const int index = static_cast<int>(snapshot->index);  // Offline: every frame, in order.
  frames_done_ = index + 1;
  snapshots_[index] = snapshot;
  timings_.Add(snapshot->timing);
  evictFarthest();
  const bool placed_boards = snapshot->attempt && !snapshot->attempt->boards.empty();
  if (snapshot->attempt) attempts_.push_back(snapshot->attempt);
  emit snapshotReady(snapshot);
  if (current_.live) return;  // The live frame on screen has its own findings.
  if (index == current_.index || placed_boards) {
    updateCurrent();
  } else if (!current_.snapshot) {
    current_.pipeline_frames_done = frames_done_;  // The "pipeline at frame N" note moves on.
    emit overlaysChanged(current_);
  }
}

void PipelineController::onAttemptAfterLastFrame(
    uint64_t generation, std::shared_ptr<const AttemptOutcome> attempt,
    const CameraIntrinsics& calibration, const std::optional<Eigen::Vector3d>& gravity_cam) {
  if (generation != generation_) return;
  attempts_.push_back(std::move(attempt));
  if (!current_.live && !attempts_.back()->boards.empty()) updateCurrent();
  emit attemptAfterLastFrame(attempts_.back(), calibration, gravity_cam);
}

void PipelineController::onAttemptRecorded(uint64_t generation, const QString& path) {
  if (generation != generation_) return;
  history_path_ = path;
  emit historyStarted(path);
}

void PipelineController::onEnded(uint64_t generation, const QString& error) {
  // The run's thread reported its end as its last act: joining it does not wait.
  const auto stopped = std::find_if(stopping_.begin(), stopping_.end(),
                                    [&](const auto& run) { return run->generation == generation; });
  if (stopped != stopping_.end()) {
    (*stopped)->thread.join();
    stopping_.erase(stopped);
  }
  if (generation != generation_ || !run_) return;
  running_ = false;
  elapsed_s_ = clock_.elapsed() * 1e-3;
  run_->thread.join();
  run_.reset();
  current_.running = false;
  if (!current_.live) emit overlaysChanged(current_);
  if (!error.isEmpty()) {
    emit failed(error);
  } else {
    emit finished(frames_done_, elapsed_s_);
  }
}

void PipelineController::evictFarthest() {
  while (static_cast<int>(snapshots_.size()) > kMaxStoredSnapshots) {
    const int first = snapshots_.begin()->first;
    const int last = snapshots_.rbegin()->first;
    const int cursor = std::max(current_.index, 0);
    if (std::abs(cursor - first) >= std::abs(last - cursor)) {
      snapshots_.erase(snapshots_.begin());
    } else {
      snapshots_.erase(std::prev(snapshots_.end()));
    }
  }
}

void PipelineController::setCurrentFrame(int index, const QImage& image) {
  if (current_.live) return;
  current_.index = index;
  current_image_ = image;
  updateCurrent();
}

void PipelineController::setOptions(const PipelineOptions& options) {
  options_ = options;
  if (!run_) return;
  const std::lock_guard lock(run_->runtime_mutex);
  if (!run_->runtime) return;
  try {
    run_->runtime->SetOptions(options);
  } catch (const std::exception& e) {
    emit optionsRefused(QString::fromStdString(e.what()));
  }
}

void PipelineController::setRectifiedWanted(bool wanted) {
  if (wanted == rectified_wanted_) return;
  rectified_wanted_ = wanted;
  updateCurrent();
}

void PipelineController::setLiveFrame(int index, const QImage& image,
                                      std::shared_ptr<const FrameSnapshot> snapshot,
                                      std::shared_ptr<const AttemptOutcome> boards_attempt) {
  current_.live = true;
  current_.index = index;
  current_image_ = image;
  live_snapshot_ = std::move(snapshot);
  live_boards_attempt_ = std::move(boards_attempt);
  updateCurrent();
}

void PipelineController::endLive() {
  if (!current_.live) return;
  current_.live = false;
  current_.index = -1;
  current_image_ = {};
  live_snapshot_.reset();
  live_boards_attempt_.reset();
}

std::vector<PlacedBoard> PipelineController::boardsAt(int64_t t_ns) const {
  if (current_.live) {
    return live_boards_attempt_ ? PlaceBoards(*live_boards_attempt_, t_ns)
                                : std::vector<PlacedBoard>();
  }
  return PlaceNewestBoards(attempts_, t_ns);
}

void PipelineController::updateCurrent() {
  current_.pipeline_frames_done = current_.live ? 0 : frames_done_;
  current_.running = !current_.live && running_;
  current_.snapshot = current_.live ? live_snapshot_ : snapshot(current_.index);
  current_.raw.reset();
  current_.rectified.reset();
  if (current_.snapshot) {
    const std::vector<PlacedBoard> boards = boardsAt(current_.snapshot->t_ns);
    current_.raw = std::make_shared<const OverlayGeometry>(
        MakeOverlayGeometry(*current_.snapshot, boards, options_.board, OverlaySpace::kRaw));
    if (rectified_wanted_) {
      current_.rectified = std::make_shared<const OverlayGeometry>(MakeOverlayGeometry(
          *current_.snapshot, boards, options_.board, OverlaySpace::kRectified));
      requestRectified();
    }
  }
  emit overlaysChanged(current_);
}

void PipelineController::requestRectified() {
  if (rectify_watcher_.isRunning()) {
    rectify_pending_ = true;  // onRectified asks again for whatever is current then.
    return;
  }
  rectify_pending_ = false;
  if (!current_.snapshot || current_image_.isNull()) return;
  rectify_watcher_.setFuture(QtConcurrent::run(
      [rectifier = rectifier_.get(), index = current_.index, image = current_image_,
       camera = current_.snapshot->working]() -> Rectified {
        return {index, Rectify(rectifier, image, camera)};
      }));
}

void PipelineController::onRectified() {
  const Rectified result = rectify_watcher_.result();
  if (!result.image.isNull()) emit rectifiedReady(result.index, result.image);
  if (rectify_pending_ && rectified_wanted_) requestRectified();
}

}  // namespace autocal
