// `autocal run --stills`: the frames of a sequence (an image folder of photographs, or a
// recording) taken as still shots of one scene from different viewpoints, calibrated
// together (pipeline/still_shots.h) and judged by the calibration history as the windows
// of a video are, so that the history file, the summary and the export are those of any
// other run (devices/offline_runner.h).
#pragma once

#include <atomic>
#include <functional>
#include <string>

#include "devices/offline_runner.h"
#include "devices/sequence.h"
#include "pipeline/still_shots.h"

namespace autocal {

// The still-shot options a run's pipeline settings give: the same lens, keypoint, plane,
// calibration and material options as video (so --set reaches them), with box 10's
// min_frames lowered to 3: every shot is a distinct view, a video window's neighbours
// are not.
StillShotOptions StillShotOptionsFrom(const PipelineOptions& pipeline);

// Reads every frame of `sequence` as a shot (throws Error naming every file that cannot be
// read, and when fewer than 3 shots are left), calibrates them from settings.prior (or
// the sequence's pre-mission calibration), and judges the attempts in a history starting
// from it, one second apart after the last shot's time, each written to
// settings.history_path as soon as it is made. The report's final calibration is the
// history's; where the sequence has ground truth, the output after each attempt is
// compared with it. `step`, when given, is told what is being done. Throws Error when no
// plane is found in the shots, saying what was. When `stop` is given and becomes true
// (from a signal handler, say), the work ends after the shot, pair or attempt in hand and
// the report covers the attempts made (report.stopped; frames_in_input is the shots').
RunReport RunStillShots(const Sequence& sequence, const RunSettings& settings,
                        const std::function<void(const std::string&)>& step = {},
                        const std::atomic<bool>* stop = nullptr);

}  // namespace autocal
