#include "widgets/playback_controller.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "devices/sequence.h"

namespace autocal {

int64_t RecordingStartNs(const Sequence& sequence) {
  int64_t start = sequence.frame_count() > 0 ? sequence.frame_time_ns(0) : 0;
  if (!sequence.accel().empty()) {
    const int64_t accel_start = sequence.accel().front().t_ns;
    start = sequence.frame_count() > 0 ? std::min(start, accel_start) : accel_start;
  }
  return start;
}

PlaybackController::PlaybackController(QObject* parent) : QObject(parent) {
  timer_.setSingleShot(true);
  timer_.setTimerType(Qt::PreciseTimer);
  connect(&timer_, &QTimer::timeout, this, &PlaybackController::onTimer);
}

void PlaybackController::setTimeline(std::vector<int64_t> frame_times_ns, int64_t start_ns) {
  pause();
  frame_times_ns_ = std::move(frame_times_ns);
  start_ns_ = start_ns;
  index_ = 0;
  emit frameChanged(index_);
  emit timeChanged(currentTime());
}

double PlaybackController::currentTime() const { return frameTime(index_); }

double PlaybackController::frameTime(int index) const {
  if (index < 0 || index >= frameCount()) return 0.0;
  return static_cast<double>(frame_times_ns_[static_cast<size_t>(index)] - start_ns_) * 1e-9;
}

int PlaybackController::frameAtTime(double seconds) const {
  if (frame_times_ns_.empty()) return 0;
  const auto t = start_ns_ + static_cast<int64_t>(std::llround(seconds * 1e9));
  const auto after = std::lower_bound(frame_times_ns_.begin(), frame_times_ns_.end(), t);
  if (after == frame_times_ns_.begin()) return 0;
  if (after == frame_times_ns_.end()) return frameCount() - 1;
  const auto before = after - 1;
  const auto nearest = (t - *before <= *after - t) ? before : after;
  return static_cast<int>(nearest - frame_times_ns_.begin());
}

void PlaybackController::play() {
  if (playing_ || frameCount() < 2) return;
  // Play from the start again once the end was reached, as media players do.
  if (index_ == frameCount() - 1) setIndex(0);
  playing_ = true;
  anchorClock();
  scheduleNextFrame();
  emit playingChanged(true);
}

void PlaybackController::pause() {
  if (!playing_) return;
  playing_ = false;
  timer_.stop();
  emit playingChanged(false);
}

void PlaybackController::togglePlaying() {
  if (playing_) {
    pause();
  } else {
    play();
  }
}

void PlaybackController::stepForward() {
  pause();
  seekToIndex(index_ + 1);
}

void PlaybackController::stepBackward() {
  pause();
  seekToIndex(index_ - 1);
}

void PlaybackController::seekToStart() { seekToIndex(0); }

void PlaybackController::seekToEnd() { seekToIndex(frameCount() - 1); }

void PlaybackController::seekToIndex(int index) {
  if (frameCount() == 0) return;
  setIndex(std::clamp(index, 0, frameCount() - 1));
  if (playing_) {
    anchorClock();
    scheduleNextFrame();
  }
}

void PlaybackController::seekToTime(double seconds) { seekToIndex(frameAtTime(seconds)); }

void PlaybackController::setSpeed(double speed) {
  speed = std::clamp(speed, kMinSpeed, kMaxSpeed);
  if (speed == speed_) return;
  speed_ = speed;
  if (playing_) {
    anchorClock();
    scheduleNextFrame();
  }
  emit speedChanged(speed_);
}

void PlaybackController::setIndex(int index) {
  if (index == index_) return;
  index_ = index;
  emit frameChanged(index_);
  emit timeChanged(currentTime());
}

void PlaybackController::anchorClock() {
  wall_clock_.start();
  anchor_media_ns_ = frame_times_ns_[static_cast<size_t>(index_)];
}

void PlaybackController::scheduleNextFrame() {
  if (index_ + 1 >= frameCount()) {
    pause();
    return;
  }
  const double media_wait_ns =
      static_cast<double>(frame_times_ns_[static_cast<size_t>(index_) + 1] - anchor_media_ns_);
  const double due_ms = media_wait_ns / speed_ * 1e-6;
  const double wait_ms = due_ms - static_cast<double>(wall_clock_.nsecsElapsed()) * 1e-6;
  timer_.start(std::max(0, static_cast<int>(std::ceil(wait_ms))));
}

void PlaybackController::onTimer() {
  if (!playing_) return;
  // Media time now; when the GUI thread was late, frames in between are skipped.
  const auto now_ns =
      anchor_media_ns_ +
      static_cast<int64_t>(std::llround(static_cast<double>(wall_clock_.nsecsElapsed()) * speed_));
  const auto upto = std::upper_bound(frame_times_ns_.begin(), frame_times_ns_.end(), now_ns) - 1;
  const int due = static_cast<int>(upto - frame_times_ns_.begin());
  setIndex(std::max(due, index_));
  if (playing_) scheduleNextFrame();  // A view may have paused in reaction to the frame.
}

}  // namespace autocal
