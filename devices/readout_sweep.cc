#include "devices/readout_sweep.h"

#include <algorithm>
#include <cmath>
#include <iterator>

namespace autocal {

ReadoutEstimate BestReadout(std::vector<ReadoutTrial> trials) {
  ReadoutEstimate estimate;
  estimate.trials = trials;
  std::erase_if(trials, [](const ReadoutTrial& t) { return t.solved == 0; });
  std::sort(trials.begin(), trials.end(), [](const ReadoutTrial& a, const ReadoutTrial& b) {
    return a.readout_ms < b.readout_ms;
  });
  if (trials.size() < 3) {
    estimate.why =
        "fewer than three readouts gave a solved attempt: the recording may be too "
        "short or the camera too still";
    return estimate;
  }
  const auto best = std::min_element(
      trials.begin(), trials.end(),
      [](const auto& a, const auto& b) { return a.median_rms_px < b.median_rms_px; });
  bool any_nearly = false;  // The trials are in readout order.
  for (const ReadoutTrial& t : trials) {
    if (t.median_rms_px > (1 + ReadoutEstimate::kNearlyAsWell) * best->median_rms_px) continue;
    if (!any_nearly) estimate.nearly_as_well_from_ms = t.readout_ms;
    estimate.nearly_as_well_to_ms = t.readout_ms;
    any_nearly = true;
  }
  if (best == trials.begin()) {
    if (best->readout_ms == 0.0) {
      estimate.readout_ms = 0.0;
      estimate.why = "the tracks fit best with no readout: a global shutter, or one under " +
                     std::to_string(std::lround(std::next(best)->readout_ms)) + " ms";
    } else {
      estimate.why = "the tracks fit best at the smallest readout tried: try smaller ones";
    }
    return estimate;
  }
  if (std::next(best) == trials.end()) {
    estimate.why = "the tracks fit best at the largest readout tried: try larger ones";
    return estimate;
  }
  // The parabola y = a x^2 + b x + c through the best and its neighbours: its vertex.
  const double x0 = std::prev(best)->readout_ms, x1 = best->readout_ms,
               x2 = std::next(best)->readout_ms;
  const double y0 = std::prev(best)->median_rms_px, y1 = best->median_rms_px,
               y2 = std::next(best)->median_rms_px;
  const double slope_left = (y1 - y0) / (x1 - x0), slope_right = (y2 - y1) / (x2 - x1);
  const double a = (slope_right - slope_left) / (x2 - x0);
  const double b = slope_left - a * (x0 + x1);
  estimate.readout_ms = a > 0 ? std::clamp(-b / (2 * a), x0, x2) : x1;
  estimate.why = "the tracks fit best near " + std::to_string(std::lround(x1)) +
                 " ms (median RMS " + std::to_string(y1) + " px)";
  return estimate;
}

ReadoutEstimate MeasureReadout(
    const Sequence& sequence, RunSettings settings, const std::vector<double>& candidates_ms,
    const std::function<void(size_t, size_t, size_t, size_t)>& progress) {
  settings.history_path.clear();
  std::vector<ReadoutTrial> trials;
  for (size_t k = 0; k < candidates_ms.size(); ++k) {
    settings.pipeline.calibration.readout_ms = candidates_ms[k];
    ReadoutTrial trial;
    trial.readout_ms = candidates_ms[k];
    std::vector<double> rms;
    const RunReport report = RunSequence(sequence, settings, [&](const RunProgress& p) {
      if (progress) progress(k, candidates_ms.size(), p.frame, p.frames);
      if (!p.snapshot || !p.snapshot->attempt) return;
      const AttemptRecord& record = p.snapshot->attempt->record;
      if (record.usable && record.rms_px > 0) rms.push_back(record.rms_px);
      if (record.verdict == Verdict::kAccepted) ++trial.accepted;
    });
    trial.attempts = report.attempts;
    trial.solved = int(rms.size());
    if (!rms.empty()) {
      std::nth_element(rms.begin(), rms.begin() + rms.size() / 2, rms.end());
      trial.median_rms_px = rms[rms.size() / 2];
    }
    trials.push_back(trial);
  }
  return BestReadout(std::move(trials));
}

}  // namespace autocal
