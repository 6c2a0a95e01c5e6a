// The vest check's report (docs/vest_check.md): when and on what it ran, the software
// version, the pre-mission and measured calibrations, the tolerances, each parameter's
// verdict with its reason, and the motion the walk covered. Laid out once as HTML, and
// printed from that to a PDF (QTextDocument on a QPdfWriter; needs a QGuiApplication).
#pragma once

#include <vector>

#include <QDateTime>
#include <QString>

#include "pipeline/vest_check.h"

namespace autocal {

struct VestReport {
  QDateTime when;
  QString source;   // FrameSource::Describe().
  QString devices;  // Camera and accelerometer ids.
  VestCheckOptions options;
  VestCheckResult result;
};

// One row of the result table, as shown on screen and printed.
struct VestReportRow {
  QString parameter, premission, measured, difference, tolerance, verdict;
  bool pass = false;
};
std::vector<VestReportRow> VestReportRows(const VestCheckResult& result);

// What the technician does next, one sentence per verdict.
QString VestVerdictAdvice(VestVerdict verdict);

QString VestReportHtml(const VestReport& report);

// False, with `error` saying why, when the file cannot be written.
bool WriteVestReportPdf(const VestReport& report, const QString& path, QString* error);

}  // namespace autocal
