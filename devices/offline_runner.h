// Runs a recorded or simulated sequence through boxes 1-10 headless on the threaded
// runtime (devices/runtime.h) in its offline mode, as fast as the machine allows and with
// results that do not depend on thread timing, feeding the accelerometer ahead of the
// frames, recording every calibration attempt in the history file, and measuring the
// result against the ground truth where the sequence has it. `autocal run` and the
// end-to-end tests use it. RunSource does the same for a live source (a camera, or a
// recording played in real time) in the runtime's live mode.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "devices/runtime.h"
#include "devices/sequence.h"
#include "devices/source.h"
#include "devices/timing_stats.h"
#include "pipeline/calibration_error.h"
#include "pipeline/calibration_pipeline.h"
#include "pipeline/history_store.h"

namespace autocal {

struct RunSettings {
  PipelineOptions pipeline;
  // The calibration to start from; without one, the sequence's pre-mission calibration.
  std::optional<CameraIntrinsics> prior;
  std::string history_path;  // SQLite history file to write (new or empty); empty: none.
  // Added to accelerometer timestamps to put them on the camera's clock.
  double accel_time_offset_s = 0.0;
  // Threads and queues (its accel_time_offset_s is replaced by the one above).
  RuntimeOptions runtime;
  // Box 10; empty: SelfCalibrate with pipeline.calibration.
  Runtime::Solver solve;
  // Where the truth is known: "converged" once the output is within these of it.
  CalibrationTolerance convergence;
};

// The output against the truth, frame by frame and in summary.
struct GroundTruthReport {
  std::vector<int64_t> t_ns;             // Each frame...
  std::vector<CalibrationError> errors;  // ...the output's error after it.
  CalibrationError final;                // After the last frame.
  std::optional<double> converged_at_s;  // From the first frame; never when absent.
  std::optional<CalibrationError> worst_after_convergence;  // Largest magnitude per field.
};

// What a live run adds: what was lost on the way and what the devices did.
struct LiveRunReport {
  uint64_t frames_received = 0;   // Frames the source delivered.
  uint64_t pipeline_dropped = 0;  // Never started: the pipeline was behind (runtime's queue).
  uint64_t source_dropped = 0;    // Dropped in the source's own queue before delivery.
  uint64_t accel_dropped = 0;     // Samples dropped in the source's queue.
  double camera_rate_hz = 0.0;    // Measured by the source.
  double accel_rate_hz = 0.0;
  std::vector<TimeGap> camera_gaps;  // Unplug to re-plug.
  int camera_disconnections = 0;
  int accel_disconnections = 0;
  std::vector<SourceEvent> events;  // Oldest first.
  std::string ended_by;             // "the source ended", "--seconds", "a stop request".
  uint64_t frames_dropped() const { return pipeline_dropped + source_dropped; }
};

struct RunReport {
  std::string input;  // Sequence::Describe() or FrameSource::Describe().
  size_t frames = 0;  // Processed.
  // RunSequence: the sequence's frames, and whether a stop request ended the run before
  // the last of them.
  size_t frames_in_input = 0;
  bool stopped = false;
  double seconds = 0.0;       // Span of the frame timestamps.
  double wall_seconds = 0.0;  // Processing time.
  double fps = 0.0;           // Frames processed per wall-clock second.
  CameraIntrinsics prior;
  FilteredCalibration final;
  double final_rms_px = 0.0;  // Of the newest accepted attempt (0 when none).
  int attempts = 0;
  std::map<Verdict, int> verdicts;
  std::vector<Alarm> alarms;
  // Attempts that made no update, by the cause their reason names (NoUpdateCause), in
  // order of first use.
  struct CauseCount {
    std::string cause;
    int count = 0;
    std::string latest;  // The newest such attempt's reason, with its figures.
  };
  std::vector<CauseCount> no_update_causes;
  // Box 2's newest plumb-line estimate, taken or not (what its lines constrain), if one was
  // made.
  std::optional<PlumbLineResult> plumb_line;
  // By box (BoxTimings::Named); "frame": boxes 1-9 and the judgement (box 10's solve runs
  // on its own worker); "update_latency": from the frame that closed an attempt's window
  // entering the runtime to the attempt's judgement in effect.
  std::map<std::string, TimingStats> timing;
  std::optional<GroundTruthReport> truth;
  std::optional<LiveRunReport> live;  // RunSource only.
  // CPU seconds of the runtime's threads, by name (kLensThreadName...; RuntimeStats).
  std::vector<std::pair<std::string, double>> thread_cpu_s;
  // Wall-clock seconds the per-frame threads waited, by thread and what for ("boxes 1-3
  // for frames", "boxes 1-3 for boxes 4-9", "boxes 4-9 for boxes 1-3", "boxes 4-9 for box
  // 10"; RuntimeStats).
  std::vector<std::pair<std::string, double>> thread_wait_s;
};

struct RunProgress {
  size_t frame = 0;   // Frames done.
  size_t frames = 0;  // RunSequence: in the sequence; RunSource: received so far.
  double wall_seconds = 0.0;
  const FrameSnapshot* snapshot = nullptr;  // The newest frame's (null before the first).
  // RunSource: frames dropped so far (pipeline and source) and the source's counts.
  uint64_t frames_dropped = 0;
  const SourceStats* source = nullptr;
};

// The options a run on a recording or a source starts from: the defaults, with the rolling shutter
// its camera states (session.json readout_ms), which settings given after may still change.
PipelineOptions RecordingDefaults(const SessionInfo& session);

// Processes every frame of `sequence`. Throws Error on bad settings, unreadable frames or
// a history file it cannot write. `progress`, when given, is called after every frame.
// When `stop` is given and becomes true (from a signal handler, say), no frame is fed
// after it: the frames already fed are finished, their attempts judged and written, and
// the report covers them (report.stopped).
RunReport RunSequence(const Sequence& sequence, const RunSettings& settings,
                      const std::function<void(const RunProgress&)>& progress = {},
                      const std::atomic<bool>* stop = nullptr);

// How a live run is told to end and what it reports while it runs.
struct LiveRunControl {
  double seconds = 0.0;  // Wall-clock seconds from the start; 0: until the source ends or stop.
  const std::atomic<bool>* stop = nullptr;  // May be null; set it from a signal handler.
  double progress_interval_s = 1.0;
  // Both on the caller's thread: progress every progress_interval_s, events as they come.
  std::function<void(const RunProgress&)> progress;
  std::function<void(const SourceEvent&)> on_event;
};

// Starts `source` (which throws Error saying what is missing and what was found) and runs
// everything it delivers through boxes 1-10 on the runtime in live mode (settings.runtime's
// `live` is set when the source is live) until the source ends, control.seconds pass or
// *control.stop is set, then stops the source and finishes the frames already queued. The
// history holds every attempt judged; report.live what was dropped and what the devices
// did; report.truth, where the source plays a recording with ground truth, the error of
// each processed frame. The prior is settings.prior or the source's pre-mission
// calibration. Throws Error as RunSequence does.
RunReport RunSource(FrameSource& source, const RunSettings& settings,
                    const LiveRunControl& control = {});

// The pieces of a run that other runs (still shots, devices/still_shot_run.h) share.
// The calibration a run starts from: `prior`, else the session's pre-mission calibration,
// checked against the frames' size. Throws Error, saying that one is given with
// `how_to_give` when there is none.
CameraIntrinsics StartingCalibration(const std::string& input, const SessionInfo& session,
                                     const std::optional<CameraIntrinsics>& prior,
                                     const std::string& how_to_give = "--prior");
// settings.history_path opened for a new run (null when empty); throws Error when the file
// already holds a history.
std::unique_ptr<HistoryStore> OpenNewHistory(const RunSettings& settings);
// The final (filtered) calibration at `end_ns`, the attempts by verdict, the reasons for
// "no update" and the alarms of `history`.
void SummarizeHistory(const CalibrationHistory& history, int64_t end_ns, RunReport* report);
// The outputs at `times` against the truth at those times (one each).
GroundTruthReport CompareWithTruth(const std::vector<int64_t>& times,
                                   const std::vector<CameraIntrinsics>& outputs,
                                   const std::vector<GroundTruthFrame>& truth,
                                   const CalibrationTolerance& tolerance);
// DESIGN.md section 6: frames, seconds, fps, final, updates, alarms, timing_ms and, where
// the truth is known, error; for a recording's run, `stopped` (with `frames_in_input` when
// true); for a live run, `live` (frames received and dropped, camera gaps,
// disconnections, device events, what ended it). Throws Error naming the file when it
// cannot be written.
std::string SummaryJson(const RunReport& report);
void WriteSummary(const std::string& path, const RunReport& report);

}  // namespace autocal
