// What `autocal info` reports about a sequence: counts, rates, gaps, how the camera and
// accelerometer overlap in time, and findings (with a severity) that make a recording
// unfit or suspect for calibration.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "devices/sequence.h"

namespace autocal {

struct InspectOptions {
  // An interval longer than this many median intervals is a gap.
  double gap_factor = 1.5;
  // Gaps longer than this many seconds are errors rather than warnings.
  double max_gap_s = 0.5;
  // Motion integration needs at least this accelerometer rate (Hz); below it is an error.
  double min_accel_rate_hz = 100.0;
  // The accelerometer covering less of the frame span than this fraction is a warning.
  double min_overlap_fraction = 0.95;

  bool Check(std::string* error) const;
};

enum class Severity { kInfo, kWarning, kError };
// "info", "warning", "error".
const char* SeverityName(Severity severity);

struct Finding {
  Severity severity = Severity::kInfo;
  std::string message;
};

// An interval between two successive samples that is longer than expected.
struct TimeGap {
  int64_t start_ns = 0;  // The sample before the gap.
  int64_t end_ns = 0;    // The sample after it.
  double seconds() const { return 1e-9 * static_cast<double>(end_ns - start_ns); }
};

// Timing of one stream (frames or accelerometer samples).
struct StreamStats {
  size_t count = 0;
  int64_t first_ns = 0;
  int64_t last_ns = 0;
  double duration_s = 0.0;      // last - first.
  double median_rate_hz = 0.0;  // 1 / the median interval; 0 with fewer than two samples.
  std::vector<TimeGap> gaps;
};

struct SequenceReport {
  std::string description;
  int width = 0;  // Resolution the session states.
  int height = 0;
  StreamStats frames;
  StreamStats accel;
  // Where the accelerometer covers the frames: [overlap_start_ns, overlap_end_ns], and the
  // fraction of the frame span that is (1 for a single frame inside the accelerometer span).
  bool has_overlap = false;
  int64_t overlap_start_ns = 0;
  int64_t overlap_end_ns = 0;
  double overlap_fraction = 0.0;
  bool has_ground_truth = false;
  std::optional<CameraIntrinsics> premission_calibration;
  double readout_ms = 0.0;  // SessionInfo::readout_ms.
  std::vector<std::string> warnings;  // Faults the reader skipped (truncate_at_fault).
  std::vector<Finding> findings;      // Worst first.

  // Time origin of the rendered reports: the first frame, else the first sample.
  int64_t origin_ns() const;
};

// True when a finding is an error: the recording is unfit for calibration.
bool HasErrors(const SequenceReport& report);

// 1 / the median interval between successive times (Hz); 0 with fewer than two.
double MedianRateHz(const std::vector<int64_t>& times_ns);

// Inspects timestamps and session, and decodes the first and last frames to check that
// they can be read and have the session's size. Throws Error if `options` are invalid.
SequenceReport InspectSequence(const Sequence& sequence, const InspectOptions& options = {});

// Plain text, one item a line, times in seconds from the report's origin.
std::string FormatReport(const SequenceReport& report);
// The same as a JSON object (cv::FileStorage); flags are 0 or 1.
std::string ReportToJson(const SequenceReport& report);

}  // namespace autocal
