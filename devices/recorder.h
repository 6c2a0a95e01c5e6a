// Records any FrameSource into a native recording folder (devices/recording_writer.h)
// while it runs: the caller's thread takes items from the source, a writer thread encodes
// and appends them, every row flushed, so that a killed process leaves a recording
// readable up to its last written row. A live source is never held back by the disk: when
// the writer falls behind, the oldest queued frame is dropped and counted. Device events
// (a camera unplugged and back) go to events.csv in the recording, and at the end of a live
// recording session.json is rewritten with the rates measured. See docs/devices.md.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "devices/source.h"

namespace autocal {

struct RecorderOptions {
  // Seconds to record: of source time from the first frame for a recorded source, of
  // wall-clock time from the start for a live one. 0: until the source ends or the stop
  // flag is set.
  double seconds = 0.0;
  // Frames waiting for the writer. When full, a live source's oldest queued frame is
  // dropped; a recorded source waits.
  size_t writer_queue_frames = 32;
  // Time between progress reports.
  double progress_interval_s = 1.0;
  // The camera's rolling-shutter readout (ms) to state in session.json, where a camera
  // cannot tell it (`autocal readout` measures it); none: the source's own.
  std::optional<double> readout_ms;

  bool Check(std::string* error) const;
};

struct RecorderProgress {
  double elapsed_s = 0.0;           // Wall-clock time since the source started.
  double recorded_s = 0.0;          // Source time from the first written frame to the last.
  uint64_t frames_written = 0;      // Rows flushed to cam0/data.csv.
  uint64_t accel_written = 0;       // Rows flushed to accel0/data.csv.
  uint64_t frames_dropped = 0;      // By the writer queue (the disk was too slow).
  uint64_t items_refused = 0;       // Not later than the previous one of their stream.
  SourceStats source;               // The source's own counts (its drops, gaps).
  std::vector<SourceEvent> events;  // Device events so far, oldest first.
};

using RecorderCallback = std::function<void(const RecorderProgress&)>;

// Starts `source`, creates the recording folder `dir` (which must not exist or be empty)
// once the source is running, records until RecorderOptions::seconds, the end of the
// source, or `*stop` (may be null; set it from a signal handler), and stops the source.
// `progress` is called from the caller's thread every progress_interval_s and once at the
// end. Throws Error when the source cannot start (no folder is created then) or a write
// fails (what was flushed before stays readable).
RecorderProgress Record(FrameSource& source, const std::string& dir, const RecorderOptions& options,
                        const RecorderCallback& progress = {},
                        const std::atomic<bool>* stop = nullptr);

}  // namespace autocal
