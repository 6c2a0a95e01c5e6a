// A stored calibration history brought back to life, for whoever reads a history file (the
// workbench, exports): the records are judged again by a fresh CalibrationHistory with the
// stored pre-mission calibration and options, which rebuilds the trend (the file keeps the
// records, not the fitted polynomials). Judging is deterministic, so the replay reproduces
// the stored verdicts; where it does not (a file written by another build), the caller is
// told which attempts differ.
#pragma once

#include <vector>

#include "pipeline/calibration_export.h"
#include "pipeline/calibration_history.h"
#include "pipeline/history_store.h"

namespace autocal {

// What box 10 reported for a stored attempt, as Judge takes it.
SelfCalibrationResult ResultOfRecord(const AttemptRecord& record);

// Judges the stored attempts again, in order. `differing`, when given, receives the ids of
// attempts whose replayed verdict is not the stored one. Throws Error when the stored
// pre-mission calibration or options are not valid (an empty file holds neither).
CalibrationHistory ReplayHistory(const StoredHistory& stored,
                                 std::vector<int>* differing = nullptr);

// An attempt as exported (calibration_export.h): its estimate and its stored verdict.
HistoryEntry ToHistoryEntry(const AttemptRecord& record);

}  // namespace autocal
