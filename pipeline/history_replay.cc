#include "pipeline/history_replay.h"

namespace autocal {

SelfCalibrationResult ResultOfRecord(const AttemptRecord& record) {
  SelfCalibrationResult result;
  result.usable = record.usable;
  result.reason = record.solver_report;
  result.estimate = record.estimate;
  result.covariance = record.covariance;
  result.free_parameters = record.free_parameters;
  result.rms_px = record.rms_px;
  result.rotation_spread_deg = record.rotation_spread_deg;
  result.frames_used = record.frames;
  result.planes_used = record.planes;
  result.points_used = record.points;
  result.observations_used = record.observations;
  result.lines_used = record.lines;
  return result;
}

CalibrationHistory ReplayHistory(const StoredHistory& stored, std::vector<int>* differing) {
  CalibrationHistory history(stored.premission, stored.options);
  if (differing != nullptr) differing->clear();
  for (const AttemptRecord& record : stored.attempts) {
    const Verdict verdict = history.Judge(record.t_ns, ResultOfRecord(record));
    if (differing != nullptr && verdict != record.verdict) differing->push_back(record.id);
  }
  return history;
}

HistoryEntry ToHistoryEntry(const AttemptRecord& record) {
  const CameraIntrinsics& e = record.estimate;
  HistoryEntry entry;
  entry.t_ns = record.t_ns;
  entry.fx = e.fx;
  entry.fy = e.fy;
  entry.cx = e.cx;
  entry.cy = e.cy;
  entry.k1 = e.k1;
  entry.k2 = e.k2;
  entry.p1 = e.p1;
  entry.p2 = e.p2;
  entry.k3 = e.k3;
  entry.rms_px = record.rms_px;
  entry.verdict = VerdictName(record.verdict);
  entry.reason = record.reason;
  return entry;
}

}  // namespace autocal
