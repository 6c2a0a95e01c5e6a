// Export of a calibration history: one CSV row or JSON object per entry, for spreadsheets,
// plots and scripts (docs/formats.md). Single calibrations are in calibration_io.h.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace autocal {

// One entry of a history as exported: an estimate and what was decided about it. Plain data;
// the history converts its records to these.
struct HistoryEntry {
  int64_t t_ns = 0;                                         // When, on the recording's clock.
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;            // Pixels, OpenCV's convention.
  double k1 = 0.0, k2 = 0.0, p1 = 0.0, p2 = 0.0, k3 = 0.0;  // Brown-Conrady, OpenCV's order.
  double rms_px = 0.0;                                      // Reprojection error of the estimate.
  std::string verdict;                                      // "accepted", "rejected", ...
  std::string reason;                                       // Why, in words.

  bool operator==(const HistoryEntry&) const = default;
};

enum class HistoryFormat {
  kCsv,   // RFC 4180, a header row, then one row per entry.
  kJson,  // {"history": [{...}, ...]}, one object per entry.
};

// "csv" or "json"; throws Error listing the names it knows.
HistoryFormat HistoryFormatFromName(const std::string& name);
std::vector<std::string> HistoryFormatNames();

// Writes (replacing) the file, numbers so that they read back bit for bit. Throws Error when
// it cannot.
void WriteHistory(const std::string& path, const std::vector<HistoryEntry>& history,
                  HistoryFormat format);

// Reads a CSV history as WriteHistory writes it (any line ends, quoted fields). Throws Error
// naming the file, the line and what was expected.
std::vector<HistoryEntry> ReadHistoryCsv(const std::string& path);

}  // namespace autocal
