// Runs boxes 1-10 (devices/runtime.h) over the open recording in the background and hands
// what they found to the GUI thread; it draws nothing.
//
// Coupling to playback: the pipeline processes the recording from its first frame as fast
// as it can, in the runtime's offline mode (every frame, results independent of thread
// timing, as `autocal run`), whatever the playback does. Each frame's snapshot comes to the
// GUI thread through a queued call and is kept in a bounded store, the frames nearest the
// one on screen kept first, so that the view shows the frame on screen with that frame's
// own findings once the pipeline has reached it. The attempts' history is written to a
// temporary SQLite file that the Calibration and History docks follow like any history
// being written.
//
// For the frame on screen the controller lays out the overlay geometry
// (pipeline/overlay_geometry.h) and, when asked, box 3's rectified image (the pipeline's own
// Rectifier, off the GUI thread).
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <QElapsedTimer>
#include <QFutureWatcher>
#include <QImage>
#include <QObject>
#include <QString>
#include <QTemporaryDir>

#include "devices/timing_stats.h"
#include "pipeline/calibration_pipeline.h"
#include "pipeline/overlay_geometry.h"

namespace autocal {

class Runtime;
class Sequence;

// What the video view shows over one frame.
struct FrameOverlays {
  int index = -1;                                    // The frame.
  std::shared_ptr<const FrameSnapshot> snapshot;     // Null until the pipeline has done it.
  std::shared_ptr<const OverlayGeometry> raw;        // On the raw frame (with the snapshot).
  std::shared_ptr<const OverlayGeometry> rectified;  // On the rectified one, when asked.
  int pipeline_frames_done = 0;                      // How far the pipeline is.
  bool running = false;                              // Whether it is still going.
  bool live = false;  // A live source's frame (LiveSession), not the recording's.
};

class PipelineController : public QObject {
  Q_OBJECT

 public:
  // Snapshots kept at most: about 10 s at 30 fps. A snapshot holds every live track's
  // history (up to 30 positions), some 100-300 kB.
  static constexpr int kMaxStoredSnapshots = 300;
  // Nice value of the pipeline's threads (Linux), so that they yield to the window.
  static constexpr int kPipelineNiceness = 10;

  explicit PipelineController(QObject* parent = nullptr);
  // Stops the run and waits for its threads (at most the frame and the solve under way).
  ~PipelineController() override;

  // Stops the run under way and starts one over `sequence` (none: stops), from the
  // calibration setPremission gave, else the sequence's own pre-mission calibration. Without
  // either, or with one for another image size, it cannot be run: failed() says so.
  void start(std::shared_ptr<const Sequence> sequence);
  // The calibration runs start from, given by hand (none: each recording's own); applies
  // from the next start().
  void setPremission(std::optional<CameraIntrinsics> premission) {
    premission_ = std::move(premission);
  }
  // Stops the run under way; what it found stays.
  void stop();
  // The options runs start with (PipelineOptions' defaults until set).
  const PipelineOptions& options() const { return options_; }

  bool isRunning() const { return running_; }
  int framesDone() const { return frames_done_; }
  int frameCount() const { return frame_count_; }
  // Frames per second of wall-clock time since the run started (to its end once ended).
  double framesPerSecond() const;
  // The snapshot of frame `index` if the pipeline has done it and it is still kept.
  std::shared_ptr<const FrameSnapshot> snapshot(int index) const;
  // The run's judged attempts in judging order, the one judged after the last frame's
  // snapshot included once the run has ended: the boards overlay picks from these.
  const std::vector<std::shared_ptr<const AttemptOutcome>>& attempts() const { return attempts_; }
  // The temporary history file of the run (empty until it holds the run's start).
  const QString& historyPath() const { return history_path_; }
  // What is on screen for the current frame.
  const FrameOverlays& current() const { return current_; }
  // Each box's time over the frames the run has done so far.
  std::map<std::string, TimingStats> timingStats() const { return timings_.Stats(); }

 public slots:
  // The frame on screen changed (its decoded image: the rectified view is made from it).
  void setCurrentFrame(int index, const QImage& image);
  // Whether the rectified image and its overlay are wanted.
  void setRectifiedWanted(bool wanted);
  // Live: a live source's frame `image`, numbered `index`, is on screen instead of the
  // recording's, with its own `snapshot` (null when no pipeline runs on the source) and the
  // boards of `boards_attempt`. The recording's run and snapshots are left as they are.
  void setLiveFrame(int index, const QImage& image,
                    std::shared_ptr<const autocal::FrameSnapshot> snapshot,
                    std::shared_ptr<const autocal::AttemptOutcome> boards_attempt);
  // Back to the recording: its next setCurrentFrame is shown.
  void endLive();
  // Options for the run under way, from its next frame (Runtime::SetOptions), and for the
  // runs after it. What the runtime refuses (acceptance thresholds during a run) is said by
  // optionsRefused and applies from the next run.
  void setOptions(const autocal::PipelineOptions& options);

 signals:
  void started(int frames);
  // Every frame the pipeline has done, in frame order, on the GUI thread.
  void snapshotReady(std::shared_ptr<const autocal::FrameSnapshot> snapshot);
  // historyPath() holds the run's start: before its first frame.
  void historyStarted(const QString& path);
  // Once the run has ended, the attempt judged after the last frame's snapshot (which no
  // snapshot carries): the calibration in effect after it, and gravity in the camera frame
  // at the last frame, if known.
  void attemptAfterLastFrame(std::shared_ptr<const autocal::AttemptOutcome> attempt,
                             const autocal::CameraIntrinsics& calibration,
                             const std::optional<Eigen::Vector3d>& gravity_cam);
  void finished(int frames, double seconds);
  void failed(const QString& message);
  void optionsRefused(const QString& message);
  // The overlays of the frame on screen changed (its snapshot arrived, a later attempt
  // placed boards on it, or another frame is on screen).
  void overlaysChanged(const autocal::FrameOverlays& overlays);
  // Box 3's rectified image of frame `index`.
  void rectifiedReady(int index, const QImage& image);

 private:
  struct Run {
    uint64_t generation = 0;
    std::atomic<bool> stop{false};
    std::thread thread;
    std::mutex runtime_mutex;
    Runtime* runtime = nullptr;  // While it exists, for setOptions.
  };
  struct Rectified {
    int index = -1;
    QImage image;
  };

  void onSnapshot(uint64_t generation, std::shared_ptr<const FrameSnapshot> snapshot);
  void onAttemptRecorded(uint64_t generation, const QString& path);
  void onAttemptAfterLastFrame(uint64_t generation, std::shared_ptr<const AttemptOutcome> attempt,
                               const CameraIntrinsics& calibration,
                               const std::optional<Eigen::Vector3d>& gravity_cam);
  void onEnded(uint64_t generation, const QString& error);
  void evictFarthest();
  // Lays out the current frame's overlays again and says so.
  void updateCurrent();
  // The boards of the newest attempt whose views reach frame time `t_ns`.
  std::vector<PlacedBoard> boardsAt(int64_t t_ns) const;
  void requestRectified();
  void onRectified();

  std::shared_ptr<const Sequence> sequence_;
  std::optional<CameraIntrinsics> premission_;
  std::unique_ptr<Run> run_;
  std::vector<std::unique_ptr<Run>> stopping_;  // Stopped, not yet ended.
  uint64_t generation_ = 0;  // Of the newest run; older runs' reports are dropped.
  bool running_ = false;
  int frames_done_ = 0;
  int frame_count_ = 0;
  QElapsedTimer clock_;
  double elapsed_s_ = 0.0;  // Of an ended run.
  PipelineOptions options_;
  std::unique_ptr<QTemporaryDir> history_dir_;
  QString history_path_;

  std::map<int, std::shared_ptr<const FrameSnapshot>> snapshots_;
  std::vector<std::shared_ptr<const AttemptOutcome>> attempts_;  // In judging order.
  BoxTimingLog timings_;

  FrameOverlays current_;
  QImage current_image_;
  // Live (current_.live): the frame's snapshot, and the attempt whose boards it shows.
  std::shared_ptr<const FrameSnapshot> live_snapshot_;
  std::shared_ptr<const AttemptOutcome> live_boards_attempt_;
  bool rectified_wanted_ = false;
  // One rectification at a time; a newer frame waits for it and replaces older requests.
  std::unique_ptr<Rectifier> rectifier_;
  QFutureWatcher<Rectified> rectify_watcher_;
  bool rectify_pending_ = false;
};

}  // namespace autocal

Q_DECLARE_METATYPE(autocal::FrameOverlays)
Q_DECLARE_METATYPE(std::shared_ptr<const autocal::FrameSnapshot>)
