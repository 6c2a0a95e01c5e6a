#include "devices/inspect.h"

#include <algorithm>
#include <iomanip>
#include <sstream>

#include <opencv2/core.hpp>

#include "devices/session_io.h"
#include "pipeline/error.h"

namespace autocal {
namespace {

// Gaps listed one by one in the text report; the rest are counted.
constexpr size_t kMaxListedGaps = 10;

std::string Fixed(double value, int decimals) {
  std::ostringstream text;
  text << std::fixed << std::setprecision(decimals) << value;
  return text.str();
}

double Seconds(int64_t t_ns, int64_t origin_ns) {
  return 1e-9 * static_cast<double>(t_ns - origin_ns);
}

double MedianInterval(const std::vector<int64_t>& times_ns) {
  std::vector<int64_t> intervals;
  intervals.reserve(times_ns.size());
  for (size_t i = 1; i < times_ns.size(); ++i) intervals.push_back(times_ns[i] - times_ns[i - 1]);
  if (intervals.empty()) return 0.0;
  const size_t middle = intervals.size() / 2;
  std::nth_element(intervals.begin(), intervals.begin() + middle, intervals.end());
  const double upper = static_cast<double>(intervals[middle]);
  if (intervals.size() % 2 == 1) return upper;
  const double lower =
      static_cast<double>(*std::max_element(intervals.begin(), intervals.begin() + middle));
  return 0.5 * (lower + upper);
}

StreamStats Stats(const std::vector<int64_t>& times_ns, double gap_factor) {
  StreamStats stats;
  stats.count = times_ns.size();
  if (times_ns.empty()) return stats;
  stats.first_ns = times_ns.front();
  stats.last_ns = times_ns.back();
  stats.duration_s = Seconds(stats.last_ns, stats.first_ns);
  const double median = MedianInterval(times_ns);
  if (median <= 0.0) return stats;
  stats.median_rate_hz = 1e9 / median;
  for (size_t i = 1; i < times_ns.size(); ++i) {
    if (static_cast<double>(times_ns[i] - times_ns[i - 1]) > gap_factor * median) {
      stats.gaps.push_back({times_ns[i - 1], times_ns[i]});
    }
  }
  return stats;
}

void AddGapFindings(const char* stream, const StreamStats& stats, int64_t origin_ns,
                    const InspectOptions& options, std::vector<Finding>* findings) {
  if (stats.gaps.empty()) return;
  const TimeGap longest = *std::max_element(
      stats.gaps.begin(), stats.gaps.end(),
      [](const TimeGap& a, const TimeGap& b) { return a.seconds() < b.seconds(); });
  const bool too_long = longest.seconds() > options.max_gap_s;
  findings->push_back(
      {too_long ? Severity::kError : Severity::kWarning,
       std::to_string(stats.gaps.size()) + " " + stream + " gap(s) longer than " +
           Fixed(options.gap_factor, 1) + " median intervals; the longest, " +
           Fixed(longest.seconds(), 3) + " s at " + Fixed(Seconds(longest.start_ns, origin_ns), 3) +
           " s" + (too_long ? ", is longer than " + Fixed(options.max_gap_s, 3) + " s" : "")});
}

// Decodes a frame to check that it can be read and has the session's size.
void CheckFrame(const Sequence& sequence, size_t index, std::vector<Finding>* findings) {
  const std::string which = "frame " + std::to_string(index + 1);
  try {
    const cv::Mat frame = sequence.LoadFrame(index);
    const SessionInfo& session = sequence.session();
    if (frame.cols != session.width || frame.rows != session.height) {
      findings->push_back({Severity::kError, which + " is " + std::to_string(frame.cols) + "x" +
                                                 std::to_string(frame.rows) +
                                                 " but the session says " +
                                                 std::to_string(session.width) + "x" +
                                                 std::to_string(session.height)});
    }
  } catch (const std::exception& e) {
    findings->push_back({Severity::kError, which + " cannot be read: " + e.what()});
  }
}

std::string FormatStream(const StreamStats& stats, const char* unit, int rate_decimals) {
  return std::to_string(stats.count) + " " + unit + " over " + Fixed(stats.duration_s, 3) +
         " s, median rate " + Fixed(stats.median_rate_hz, rate_decimals) + " Hz";
}

std::string FormatGaps(const StreamStats& stats, int64_t origin_ns) {
  if (stats.gaps.empty()) return "none";
  std::string text = std::to_string(stats.gaps.size()) + ":";
  for (size_t i = 0; i < stats.gaps.size() && i < kMaxListedGaps; ++i) {
    const TimeGap& gap = stats.gaps[i];
    text += " " + Fixed(gap.seconds(), 3) + " s at " + Fixed(Seconds(gap.start_ns, origin_ns), 3) +
            " s" + (i + 1 < stats.gaps.size() ? "," : "");
  }
  if (stats.gaps.size() > kMaxListedGaps) {
    text += " and " + std::to_string(stats.gaps.size() - kMaxListedGaps) + " more";
  }
  return text;
}

std::string FormatIntrinsics(const CameraIntrinsics& c) {
  std::ostringstream text;
  text << std::setprecision(6) << c.width << "x" << c.height << " fx " << c.fx << " fy " << c.fy
       << " cx " << c.cx << " cy " << c.cy << " k1 " << c.k1 << " k2 " << c.k2 << " p1 " << c.p1
       << " p2 " << c.p2 << " k3 " << c.k3;
  return text.str();
}

void WriteStream(cv::FileStorage& fs, const char* key, const StreamStats& stats,
                 int64_t origin_ns) {
  fs << key << "{";
  cv::write(fs, "count", static_cast<int>(stats.count));
  cv::write(fs, "start_s", Seconds(stats.first_ns, origin_ns));
  cv::write(fs, "duration_s", stats.duration_s);
  cv::write(fs, "median_rate_hz", stats.median_rate_hz);
  fs << "gaps"
     << "[";
  for (const TimeGap& gap : stats.gaps) {
    fs << "{";
    cv::write(fs, "start_s", Seconds(gap.start_ns, origin_ns));
    cv::write(fs, "end_s", Seconds(gap.end_ns, origin_ns));
    cv::write(fs, "length_s", gap.seconds());
    fs << "}";
  }
  fs << "]"
     << "}";
}

}  // namespace

bool InspectOptions::Check(std::string* error) const {
  std::string why;
  if (!(gap_factor > 1.0)) {
    why = "gap_factor must be above 1";
  } else if (!(max_gap_s > 0.0)) {
    why = "max_gap_s must be positive";
  } else if (!(min_accel_rate_hz >= 0.0)) {
    why = "min_accel_rate_hz must not be negative";
  } else if (!(min_overlap_fraction >= 0.0 && min_overlap_fraction <= 1.0)) {
    why = "min_overlap_fraction must be between 0 and 1";
  }
  if (why.empty()) return true;
  if (error) *error = why;
  return false;
}

const char* SeverityName(Severity severity) {
  switch (severity) {
    case Severity::kInfo:
      return "info";
    case Severity::kWarning:
      return "warning";
    case Severity::kError:
      return "error";
  }
  return "unknown";
}

int64_t SequenceReport::origin_ns() const {
  return frames.count > 0 ? frames.first_ns : accel.first_ns;
}

bool HasErrors(const SequenceReport& report) {
  return std::any_of(report.findings.begin(), report.findings.end(),
                     [](const Finding& f) { return f.severity == Severity::kError; });
}

double MedianRateHz(const std::vector<int64_t>& times_ns) {
  const double median = MedianInterval(times_ns);
  return median > 0.0 ? 1e9 / median : 0.0;
}

SequenceReport InspectSequence(const Sequence& sequence, const InspectOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw Error("inspect options: " + why);

  SequenceReport report;
  report.description = sequence.Describe();
  const SessionInfo& session = sequence.session();
  report.width = session.width;
  report.height = session.height;
  report.premission_calibration = session.premission_calibration;
  report.readout_ms = session.readout_ms;
  report.warnings = sequence.warnings();

  std::vector<int64_t> frame_times(sequence.frame_count());
  for (size_t i = 0; i < frame_times.size(); ++i) frame_times[i] = sequence.frame_time_ns(i);
  std::vector<int64_t> accel_times;
  accel_times.reserve(sequence.accel().size());
  for (const AccelSample& sample : sequence.accel()) accel_times.push_back(sample.t_ns);
  report.frames = Stats(frame_times, options.gap_factor);
  report.accel = Stats(accel_times, options.gap_factor);
  const int64_t origin = report.origin_ns();

  std::vector<Finding>& findings = report.findings;
  for (const std::string& warning : report.warnings) {
    findings.push_back({Severity::kWarning, "read only up to a fault: " + warning});
  }
  if (report.frames.count == 0) findings.push_back({Severity::kError, "no frames"});
  if (report.accel.count == 0) findings.push_back({Severity::kError, "no accelerometer samples"});
  if (report.accel.count > 1 && report.accel.median_rate_hz < options.min_accel_rate_hz) {
    findings.push_back(
        {Severity::kError, "accelerometer rate " + Fixed(report.accel.median_rate_hz, 1) +
                               " Hz is below " + Fixed(options.min_accel_rate_hz, 1) + " Hz"});
  }
  AddGapFindings("frame", report.frames, origin, options, &findings);
  AddGapFindings("accelerometer", report.accel, origin, options, &findings);

  if (report.frames.count > 0 && report.accel.count > 0) {
    report.overlap_start_ns = std::max(report.frames.first_ns, report.accel.first_ns);
    report.overlap_end_ns = std::min(report.frames.last_ns, report.accel.last_ns);
    report.has_overlap = report.overlap_start_ns <= report.overlap_end_ns;
    if (!report.has_overlap) {
      report.overlap_fraction = 0.0;
    } else if (report.frames.last_ns > report.frames.first_ns) {
      report.overlap_fraction =
          static_cast<double>(report.overlap_end_ns - report.overlap_start_ns) /
          static_cast<double>(report.frames.last_ns - report.frames.first_ns);
    } else {
      report.overlap_fraction = 1.0;
    }
    if (!report.has_overlap) {
      findings.push_back(
          {Severity::kError, "camera and accelerometer do not overlap in time: frames " +
                                 Fixed(Seconds(report.frames.first_ns, origin), 3) + " to " +
                                 Fixed(Seconds(report.frames.last_ns, origin), 3) +
                                 " s, accelerometer " +
                                 Fixed(Seconds(report.accel.first_ns, origin), 3) + " to " +
                                 Fixed(Seconds(report.accel.last_ns, origin), 3) + " s"});
    } else if (report.overlap_fraction < options.min_overlap_fraction) {
      findings.push_back({Severity::kWarning, "the accelerometer covers only " +
                                                  Fixed(100.0 * report.overlap_fraction, 1) +
                                                  "% of the frame span"});
    }
  }

  const std::vector<GroundTruthFrame>* truth = sequence.ground_truth();
  report.has_ground_truth = truth != nullptr;
  if (truth && truth->size() != report.frames.count) {
    findings.push_back({Severity::kError, "ground truth has " + std::to_string(truth->size()) +
                                              " entries for " +
                                              std::to_string(report.frames.count) + " frames"});
  }
  if (!report.premission_calibration) {
    findings.push_back({Severity::kInfo, "no pre-mission calibration to compare against"});
  }
  if (report.frames.count > 0) {
    CheckFrame(sequence, 0, &findings);
    if (report.frames.count > 1) CheckFrame(sequence, report.frames.count - 1, &findings);
  }
  std::stable_sort(findings.begin(), findings.end(), [](const Finding& a, const Finding& b) {
    return static_cast<int>(a.severity) > static_cast<int>(b.severity);
  });
  return report;
}

std::string FormatReport(const SequenceReport& report) {
  const int64_t origin = report.origin_ns();
  std::ostringstream text;
  text << report.description << "\n";
  text << "resolution       " << report.width << "x" << report.height << "\n";
  text << "frames           " << FormatStream(report.frames, "frames", 2) << "\n";
  text << "frame gaps       " << FormatGaps(report.frames, origin) << "\n";
  text << "accelerometer    " << FormatStream(report.accel, "samples", 1) << "\n";
  text << "accel gaps       " << FormatGaps(report.accel, origin) << "\n";
  text << "overlap          ";
  if (report.has_overlap) {
    text << Fixed(Seconds(report.overlap_start_ns, origin), 3) << " to "
         << Fixed(Seconds(report.overlap_end_ns, origin), 3) << " s, "
         << Fixed(100.0 * report.overlap_fraction, 1) << "% of the frame span\n";
  } else {
    text << "none\n";
  }
  text << "ground truth     " << (report.has_ground_truth ? "yes" : "no") << "\n";
  text << "pre-mission      "
       << (report.premission_calibration ? FormatIntrinsics(*report.premission_calibration)
                                         : std::string("none"))
       << "\n";
  text << "shutter          "
       << (report.readout_ms > 0
               ? "rolling, rows read over " + Fixed(report.readout_ms, 2) + " ms"
               : std::string("global, or not known"))
       << "\n";
  text << "times in seconds from " << Fixed(1e-9 * static_cast<double>(origin), 6) << "\n";
  if (report.findings.empty()) {
    text << "findings         none\n";
  } else {
    text << "findings\n";
    for (const Finding& finding : report.findings) {
      text << "  " << SeverityName(finding.severity) << ": " << finding.message << "\n";
    }
  }
  return text.str();
}

std::string ReportToJson(const SequenceReport& report) {
  const int64_t origin = report.origin_ns();
  cv::FileStorage fs(
      ".json", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_JSON);
  WriteJsonText(fs, "description", report.description);
  cv::write(fs, "origin_s", 1e-9 * static_cast<double>(origin));
  cv::write(fs, "width", report.width);
  cv::write(fs, "height", report.height);
  WriteStream(fs, "frames", report.frames, origin);
  WriteStream(fs, "accel", report.accel, origin);
  fs << "overlap"
     << "{";
  cv::write(fs, "present", report.has_overlap ? 1 : 0);
  cv::write(fs, "start_s", Seconds(report.overlap_start_ns, origin));
  cv::write(fs, "end_s", Seconds(report.overlap_end_ns, origin));
  cv::write(fs, "fraction", report.overlap_fraction);
  fs << "}";
  cv::write(fs, "ground_truth", report.has_ground_truth ? 1 : 0);
  if (const auto& c = report.premission_calibration) {
    WriteJsonIntrinsics(fs, "premission_calibration", *c);
  }
  cv::write(fs, "readout_ms", report.readout_ms);
  fs << "warnings"
     << "[";
  for (const std::string& warning : report.warnings) WriteJsonText(fs, "", warning);
  fs << "]";
  fs << "findings"
     << "[";
  for (const Finding& finding : report.findings) {
    fs << "{";
    cv::write(fs, "severity", std::string(SeverityName(finding.severity)));
    WriteJsonText(fs, "message", finding.message);
    fs << "}";
  }
  fs << "]";
  cv::write(fs, "errors", HasErrors(report) ? 1 : 0);
  return fs.releaseAndGetString();
}

}  // namespace autocal
