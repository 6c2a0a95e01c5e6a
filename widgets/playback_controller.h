// The one time cursor of the workbench: which frame is current, whether it plays and how
// fast. Every view follows its signals; it knows nothing of widgets.
#pragma once

#include <cstdint>
#include <vector>

#include <QElapsedTimer>
#include <QObject>
#include <QTimer>

namespace autocal {

class Sequence;

// Where "time 0" of a recording is: its first frame or first accelerometer sample,
// whichever comes first, so video and plot share one time axis.
int64_t RecordingStartNs(const Sequence& sequence);

class PlaybackController : public QObject {
  Q_OBJECT

 public:
  static constexpr double kMinSpeed = 0.25;
  static constexpr double kMaxSpeed = 4.0;

  explicit PlaybackController(QObject* parent = nullptr);

  // Replaces the timeline (sorted frame timestamps) and goes to frame 0, paused.
  // Times are reported in seconds since `start_ns`.
  void setTimeline(std::vector<int64_t> frame_times_ns, int64_t start_ns);

  int frameCount() const { return static_cast<int>(frame_times_ns_.size()); }
  int frameIndex() const { return index_; }
  // Seconds since the start of the recording of the current frame (0 when empty).
  double currentTime() const;
  // Seconds since the start of the recording of frame `index`.
  double frameTime(int index) const;
  // The frame whose timestamp is nearest to `seconds` (clamped to the recording).
  int frameAtTime(double seconds) const;
  bool isPlaying() const { return playing_; }
  double speed() const { return speed_; }

 public slots:
  void play();
  void pause();
  void togglePlaying();
  void stepForward();
  void stepBackward();
  void seekToStart();
  void seekToEnd();
  void seekToIndex(int index);
  void seekToTime(double seconds);
  // Clamped to [kMinSpeed, kMaxSpeed]; takes effect at once, without a jump in time.
  void setSpeed(double speed);

 signals:
  void frameChanged(int index);
  void timeChanged(double seconds);
  void playingChanged(bool playing);
  void speedChanged(double speed);

 private:
  void setIndex(int index);
  // Ties media time to wall-clock time at the current frame, so playback follows the
  // real timestamps and never drifts however late the timer fires.
  void anchorClock();
  void scheduleNextFrame();
  void onTimer();

  std::vector<int64_t> frame_times_ns_;
  int64_t start_ns_ = 0;
  int index_ = 0;
  bool playing_ = false;
  double speed_ = 1.0;
  QTimer timer_;
  QElapsedTimer wall_clock_;
  int64_t anchor_media_ns_ = 0;
};

}  // namespace autocal
