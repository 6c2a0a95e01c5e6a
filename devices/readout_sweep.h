// A rolling shutter's readout measured from a recording: the recording is run once per
// candidate readout (calibration.readout_ms), and the one whose calibration attempts fit
// their tracks best, by the median reprojection RMS, is refined by a parabola through it
// and its neighbours. A wrong readout leaves each row's shift in the tracks, which no
// calibration fits (docs/calibration.md, "Measuring the readout").
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "devices/offline_runner.h"
#include "devices/sequence.h"

namespace autocal {

struct ReadoutTrial {
  double readout_ms = 0.0;
  int attempts = 0;
  int solved = 0;              // Attempts box 10 solved (usable).
  int accepted = 0;            // Accepted by the history.
  double median_rms_px = 0.0;  // Over the solved attempts; 0 when none.
};

struct ReadoutEstimate {
  std::vector<ReadoutTrial> trials;  // In the order tried.
  // The best fitting readout; none when it cannot be told (say why).
  std::optional<double> readout_ms;
  std::string why;
  // The readouts tried that fit nearly as well (median RMS within kNearlyAsWell of the
  // best), smallest and largest: how sharply the walk tells the readout (0 when untold).
  double nearly_as_well_from_ms = 0.0, nearly_as_well_to_ms = 0.0;
  static constexpr double kNearlyAsWell = 0.05;
};

// Refines the trial with the lowest median RMS by the parabola through it and its two
// neighbours (in readout order). At the smallest readout tried, when that is 0: 0 (a global
// shutter, or a readout under the next one tried). At the largest: none, the RMS may fall
// further. None when fewer than three trials solved anything.
ReadoutEstimate BestReadout(std::vector<ReadoutTrial> trials);

// Runs `sequence` offline with `settings` once per readout in `candidates_ms` (no history
// written) and picks the best (BestReadout). `progress(trial, trials, frame, frames)` after
// every frame. Throws Error as RunSequence does.
ReadoutEstimate MeasureReadout(
    const Sequence& sequence, RunSettings settings, const std::vector<double>& candidates_ms,
    const std::function<void(size_t, size_t, size_t, size_t)>& progress = {});

}  // namespace autocal
