#include "widgets/vest_report.h"

#include <QFile>
#include <QFileInfo>
#include <QPageLayout>
#include <QPageSize>
#include <QPdfWriter>
#include <QTextDocument>

#include "pipeline/version.h"

namespace autocal {
namespace {

QString Number(double value, int decimals) { return QString::number(value, 'f', decimals); }

QString Signed(double value, int decimals) {
  return (value > 0 ? QStringLiteral("+") : QString()) + Number(value, decimals);
}

QString Escaped(const std::string& text) { return QString::fromStdString(text).toHtmlEscaped(); }

QString VerdictColour(VestVerdict verdict) {
  return verdict == VestVerdict::kPass   ? QStringLiteral("#1b7f2a")
         : verdict == VestVerdict::kFail ? QStringLiteral("#b00020")
                                         : QStringLiteral("#b26a00");
}

QString CalibrationRow(const QString& name, const CameraIntrinsics& c) {
  return QStringLiteral(
             "<tr><td>%1</td><td>%2x%3</td><td>%4</td><td>%5</td><td>%6</td>"
             "<td>%7</td><td>%8</td><td>%9</td><td>%10</td><td>%11</td><td>%12</td></tr>")
      .arg(name)
      .arg(c.width)
      .arg(c.height)
      .arg(Number(c.fx, 2), Number(c.fy, 2), Number(c.cx, 2), Number(c.cy, 2), Number(c.k1, 5),
           Number(c.k2, 5), Number(c.p1, 6), Number(c.p2, 6))
      .arg(Number(c.k3, 5));
}

}  // namespace

std::vector<VestReportRow> VestReportRows(const VestCheckResult& result) {
  std::vector<VestReportRow> rows;
  for (const VestCriterion& c : result.criteria) {
    VestReportRow row;
    row.parameter = QString::fromStdString(c.parameter);
    row.pass = c.pass;
    row.verdict = c.pass ? QStringLiteral("pass") : QStringLiteral("FAIL");
    const QString unit = QString::fromStdString(c.unit);
    if (c.parameter == "distortion") {
      // The distortion is compared as a displacement, not by its coefficients.
      row.premission = QStringLiteral("k1 %1, k2 %2")
                           .arg(Number(result.premission.k1, 4), Number(result.premission.k2, 4));
      row.measured = QStringLiteral("k1 %1, k2 %2")
                         .arg(Number(result.measured.k1, 4), Number(result.measured.k2, 4));
      row.difference = Number(c.difference, 2) + QStringLiteral(" px");
      row.tolerance = QStringLiteral("≤ ") + Number(c.tolerance, 2) + QStringLiteral(" px");
    } else {
      row.premission = Number(c.premission, 2) + QStringLiteral(" px");
      row.measured = Number(c.measured, 2) + QStringLiteral(" px");
      row.difference = Signed(c.difference, 2) + QLatin1Char(' ') + unit;
      row.tolerance = QStringLiteral("± ") + Number(c.tolerance, 2) + QLatin1Char(' ') + unit;
    }
    rows.push_back(row);
  }
  return rows;
}

QString VestVerdictAdvice(VestVerdict verdict) {
  switch (verdict) {
    case VestVerdict::kPass:
      return QStringLiteral("The camera matches its pre-mission calibration.");
    case VestVerdict::kFail:
      return QStringLiteral(
          "The camera no longer matches its pre-mission calibration: have "
          "the vest recalibrated (the measured calibration is below).");
    case VestVerdict::kInconclusive:
      return QStringLiteral(
          "Not enough was seen to judge: check again, following the "
          "guidance on the screen.");
  }
  return {};
}

QString VestReportHtml(const VestReport& report) {
  const VestCheckResult& r = report.result;
  const VestCheckOptions& o = report.options;
  QString html = QStringLiteral("<html><body style=\"font-family: sans-serif;\">");
  html += QStringLiteral("<h1>autocal vest check</h1>");
  html += QStringLiteral("<table cellpadding=\"2\">");
  const auto info = [&](const QString& name, const QString& value) {
    html += QStringLiteral("<tr><td><b>%1</b></td><td>%2</td></tr>").arg(name, value);
  };
  info(QStringLiteral("Date"), report.when.toString(QStringLiteral("yyyy-MM-dd HH:mm:ss t")));
  info(QStringLiteral("Source"), report.source.toHtmlEscaped());
  info(QStringLiteral("Devices"), report.devices.toHtmlEscaped());
  info(QStringLiteral("Walk"), QStringLiteral("%1 s, %2 frames (%3 s asked)")
                                   .arg(Number(r.seconds, 1))
                                   .arg(r.frames)
                                   .arg(Number(o.duration_s, 0)));
  info(QStringLiteral("Shutter"),
       r.readout_ms > 0
           ? QStringLiteral("rolling, rows read over %1 ms").arg(Number(r.readout_ms, 1))
           : QStringLiteral("global (readout 0 ms)"));
  if (r.unfit_s > 0.0) {
    info(QStringLiteral("Unfit images"),
         QStringLiteral("%1 s (fog, blur or noise: not counted)").arg(Number(r.unfit_s, 1)));
  }
  info(QStringLiteral("Software"), QStringLiteral("autocal %1").arg(QLatin1String(kVersion)));
  html += QStringLiteral("</table>");

  html += QStringLiteral("<h2 style=\"color: %1;\">Verdict: %2</h2>")
              .arg(VerdictColour(r.verdict), QString::fromStdString(VestVerdictName(r.verdict)));
  html += QStringLiteral("<p><b>%1</b></p>").arg(VestVerdictAdvice(r.verdict).toHtmlEscaped());
  if (r.reasons.empty()) {
    html += QStringLiteral(
        "<p>Every parameter is within its tolerance of the pre-mission "
        "calibration.</p>");
  } else {
    html += QStringLiteral("<ul>");
    for (const std::string& reason : r.reasons)
      html += QStringLiteral("<li>%1</li>").arg(Escaped(reason));
    html += QStringLiteral("</ul>");
  }

  const std::vector<VestReportRow> rows = VestReportRows(r);
  if (!rows.empty()) {
    html += QStringLiteral(
        "<h2>Parameters</h2><table border=\"1\" cellspacing=\"0\" "
        "cellpadding=\"4\"><tr><th>Parameter</th><th>Pre-mission</th>"
        "<th>Measured</th><th>Difference</th><th>Tolerance</th>"
        "<th>Verdict</th></tr>");
    for (const VestReportRow& row : rows) {
      html +=
          QStringLiteral(
              "<tr><td>%1</td><td>%2</td><td>%3</td><td>%4</td><td>%5</td>"
              "<td style=\"color: %6;\"><b>%7</b></td></tr>")
              .arg(row.parameter, row.premission, row.measured, row.difference, row.tolerance,
                   VerdictColour(row.pass ? VestVerdict::kPass : VestVerdict::kFail), row.verdict);
    }
    html += QStringLiteral("</table>");
  }

  html += QStringLiteral("<h2>Tolerances</h2><ul>");
  html += QStringLiteral("<li>fx, fy within %1% of the pre-mission value</li>")
              .arg(Number(o.tolerance.focal_percent, 2));
  html += QStringLiteral("<li>cx, cy within %1 px</li>").arg(Number(o.tolerance.principal_px, 1));
  html += QStringLiteral(
              "<li>distortion: the two lenses put the same ray within %1 px of each "
              "other, out to %2% of the image half-diagonal</li>")
              .arg(Number(o.tolerance.distortion_px, 1), Number(100 * o.radius_fraction, 0));
  html += QStringLiteral(
              "<li>a verdict needs %1 calibration updates accepted in the "
              "calibration's current regime, and no unconfirmed jump</li></ul>")
              .arg(o.min_accepted);

  html += QStringLiteral(
      "<h2>Calibrations</h2><table border=\"1\" cellspacing=\"0\" "
      "cellpadding=\"3\"><tr><th></th><th>size</th><th>fx</th><th>fy</th>"
      "<th>cx</th><th>cy</th><th>k1</th><th>k2</th><th>p1</th><th>p2</th>"
      "<th>k3</th></tr>");
  html += CalibrationRow(QStringLiteral("pre-mission"), r.premission);
  html += CalibrationRow(QStringLiteral("measured"), r.measured);
  html += QStringLiteral("</table>");

  html += QStringLiteral(
      "<h2>Motion covered</h2><table border=\"1\" cellspacing=\"0\" "
      "cellpadding=\"3\"><tr><th>What the calibration needs</th>"
      "<th>Covered</th><th></th></tr>");
  for (const VestNeedStatus& s : r.coverage) {
    html += QStringLiteral("<tr><td>%1</td><td>%2</td><td>%3</td></tr>")
                .arg(Escaped(s.name), Escaped(s.measured),
                     s.done       ? QStringLiteral("done")
                     : s.required ? QStringLiteral("missing")
                                  : QStringLiteral("not covered (helps, not needed)"));
  }
  html += QStringLiteral("</table>");

  html += QStringLiteral("<h2>Calibration updates</h2><p>%1 attempts:").arg(r.attempts);
  for (const auto& [verdict, count] : r.verdicts) {
    html += QStringLiteral(" %1 %2;").arg(count).arg(Escaped(VerdictName(verdict)));
  }
  html += QStringLiteral(" %1 accepted in the current regime.</p>").arg(r.accepted_in_regime);
  for (const std::string& alarm : r.alarms)
    html += QStringLiteral("<p>Alarm at %1</p>").arg(Escaped(alarm));
  html += QStringLiteral("</body></html>");
  return html;
}

bool WriteVestReportPdf(const VestReport& report, const QString& path, QString* error) {
  // QPdfWriter reports nothing when it cannot open its file: try it first.
  {
    QFile file(path);
    if (!file.open(QIODevice::WriteOnly)) {
      if (error) *error = QStringLiteral("%1: %2").arg(path, file.errorString());
      return false;
    }
  }
  {
    QPdfWriter writer(path);
    writer.setTitle(QStringLiteral("autocal vest check: %1")
                        .arg(QString::fromStdString(VestVerdictName(report.result.verdict))));
    writer.setCreator(QStringLiteral("autocal %1").arg(QLatin1String(kVersion)));
    writer.setPageSize(QPageSize(QPageSize::A4));
    writer.setPageMargins(QMarginsF(15, 15, 15, 15), QPageLayout::Millimeter);
    QTextDocument document;
    document.setHtml(VestReportHtml(report));
    document.print(&writer);
  }
  if (QFileInfo(path).size() == 0) {
    if (error) *error = QStringLiteral("%1: nothing was written").arg(path);
    return false;
  }
  return true;
}

}  // namespace autocal
