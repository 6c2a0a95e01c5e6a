#include "widgets/vest_check_dialog.h"

#include <cmath>

#include <QDateTime>
#include <QDoubleSpinBox>
#include <QFileDialog>
#include <QFormLayout>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QLineEdit>
#include <QListWidget>
#include <QMessageBox>
#include <QProgressBar>
#include <QPushButton>
#include <QStackedWidget>
#include <QTableWidget>
#include <QVBoxLayout>

#include "widgets/calibration_file_field.h"
#include "widgets/vest_check_controller.h"
#include "widgets/vest_report.h"

namespace autocal {
namespace {

QLabel* BigLabel(int point_size, QWidget* parent) {
  auto* label = new QLabel(parent);
  QFont font = label->font();
  font.setPointSize(point_size);
  font.setBold(true);
  label->setFont(font);
  label->setAlignment(Qt::AlignCenter);
  label->setWordWrap(true);
  return label;
}

QString MinutesSeconds(double seconds) {
  const int s = std::max(0, int(std::lround(seconds)));
  return QStringLiteral("%1:%2").arg(s / 60).arg(s % 60, 2, 10, QLatin1Char('0'));
}

QDoubleSpinBox* Spin(double value, double max, int decimals, const QString& suffix,
                     QWidget* parent) {
  auto* spin = new QDoubleSpinBox(parent);
  spin->setRange(std::pow(10.0, -decimals), max);
  spin->setDecimals(decimals);
  spin->setValue(value);
  spin->setSuffix(suffix);
  return spin;
}

}  // namespace

VestCheckDialog::VestCheckDialog(const QString& input, const QString& accel, QWidget* parent)
    : QDialog(parent) {
  setWindowTitle(tr("Vest Check"));
  resize(760, 620);
  pages_ = new QStackedWidget(this);
  auto* layout = new QVBoxLayout(this);
  layout->addWidget(pages_);
  const VestCheckOptions defaults;

  // Connect.
  auto* connect_page = new QWidget(pages_);
  auto* connect_layout = new QVBoxLayout(connect_page);
  auto* intro = new QLabel(
      tr("<h2>Vest check</h2><p>Plug in the vest's camera and accelerometer, then press "
         "<b>Start</b> and walk for the time below, following what the screen asks. The "
         "check ends in PASS or FAIL against the pre-mission calibration, with the reasons, "
         "and a report you can save as PDF.</p>"),
      connect_page);
  intro->setWordWrap(true);
  connect_layout->addWidget(intro);
  auto* form = new QFormLayout;
  input_ = new QLineEdit(input, connect_page);
  input_->setToolTip(
      tr("camera:0 for the vest's camera, sim:office for the simulated vest, "
         "or a recording folder"));
  accel_ = new QLineEdit(accel, connect_page);
  accel_->setPlaceholderText(tr("the source's own"));
  accel_->setToolTip(tr("usb for the vest's USB accelerometer; empty: the source's own"));
  premission_ = new CalibrationFileField(connect_page);
  duration_ = Spin(defaults.duration_s, 600, 0, tr(" s"), connect_page);
  // A live camera states no readout: the technician gives the datasheet's, or what
  // `autocal readout` measured on a walk recorded with this vest.
  readout_ = Spin(0, 1000, 1, tr(" ms"), connect_page);
  readout_->setMinimum(-1);
  readout_->setSpecialValueText(tr("as the source states"));
  readout_->setValue(-1);
  readout_->setToolTip(
      tr("The camera's rolling-shutter readout: the time its rows take to read, top to "
         "bottom (0: a global shutter). A recording may state it; a live camera does not."));
  focal_tol_ = Spin(defaults.tolerance.focal_percent, 20, 2, tr(" %"), connect_page);
  principal_tol_ = Spin(defaults.tolerance.principal_px, 100, 1, tr(" px"), connect_page);
  distortion_tol_ = Spin(defaults.tolerance.distortion_px, 100, 1, tr(" px"), connect_page);
  form->addRow(tr("Camera:"), input_);
  form->addRow(tr("Accelerometer:"), accel_);
  form->addRow(tr("Pre-mission calibration:"), premission_);
  form->addRow(tr("Walk for:"), duration_);
  form->addRow(tr("Rolling-shutter readout:"), readout_);
  form->addRow(tr("Focal length within:"), focal_tol_);
  form->addRow(tr("Principal point within:"), principal_tol_);
  form->addRow(tr("Distortion within:"), distortion_tol_);
  connect_layout->addLayout(form);
  connect_error_ = new QLabel(connect_page);
  connect_error_->setObjectName(QStringLiteral("connectError"));
  connect_error_->setWordWrap(true);
  connect_error_->setStyleSheet(QStringLiteral("color: #b00020;"));
  connect_layout->addWidget(connect_error_);
  connect_layout->addStretch();
  auto* start = new QPushButton(tr("Start"), connect_page);
  start->setDefault(true);
  connect(start, &QPushButton::clicked, this, &VestCheckDialog::startCheck);
  auto* connect_buttons = new QHBoxLayout;
  connect_buttons->addStretch();
  connect_buttons->addWidget(start);
  connect_layout->addLayout(connect_buttons);
  pages_->addWidget(connect_page);

  // Walk.
  auto* walk_page = new QWidget(pages_);
  auto* walk_layout = new QVBoxLayout(walk_page);
  source_label_ = new QLabel(walk_page);
  source_label_->setWordWrap(true);
  walk_layout->addWidget(source_label_);
  guidance_ = BigLabel(22, walk_page);
  guidance_->setObjectName(QStringLiteral("guidance"));
  guidance_->setMinimumHeight(90);
  walk_layout->addWidget(guidance_);
  progress_ = new QProgressBar(walk_page);
  progress_->setRange(0, 100);
  progress_->setFormat(tr("%p% of what the calibration needs"));
  walk_layout->addWidget(progress_);
  auto* walk_middle = new QHBoxLayout;
  checklist_ = new QListWidget(walk_page);
  checklist_->setSelectionMode(QAbstractItemView::NoSelection);
  checklist_->setFocusPolicy(Qt::NoFocus);
  checklist_->setWordWrap(true);
  checklist_->setHorizontalScrollBarPolicy(Qt::ScrollBarAlwaysOff);
  QFont list_font = checklist_->font();
  list_font.setPointSize(list_font.pointSize() + 2);
  checklist_->setFont(list_font);
  walk_middle->addWidget(checklist_, 3);
  thumbnail_ = new QLabel(walk_page);
  thumbnail_->setFixedSize(240, 180);
  thumbnail_->setAlignment(Qt::AlignCenter);
  thumbnail_->setStyleSheet(QStringLiteral("background: black;"));
  walk_middle->addWidget(thumbnail_, 0, Qt::AlignTop);
  walk_layout->addLayout(walk_middle);
  elapsed_ = BigLabel(14, walk_page);
  walk_layout->addWidget(elapsed_);
  auto* walk_buttons = new QHBoxLayout;
  auto* cancel = new QPushButton(tr("Cancel"), walk_page);
  connect(cancel, &QPushButton::clicked, this, &VestCheckDialog::BackToConnect);
  finish_now_ = new QPushButton(tr("Finish Now"), walk_page);
  finish_now_->setToolTip(tr("End the walk and judge what was seen so far"));
  connect(finish_now_, &QPushButton::clicked, this, [this] {
    if (controller_) controller_->finishNow();
  });
  walk_buttons->addWidget(cancel);
  walk_buttons->addStretch();
  walk_buttons->addWidget(finish_now_);
  walk_layout->addLayout(walk_buttons);
  pages_->addWidget(walk_page);

  // Result.
  auto* result_page = new QWidget(pages_);
  auto* result_layout = new QVBoxLayout(result_page);
  verdict_ = BigLabel(40, result_page);
  verdict_->setObjectName(QStringLiteral("verdict"));
  result_layout->addWidget(verdict_);
  summary_ = new QLabel(result_page);
  summary_->setObjectName(QStringLiteral("summary"));
  summary_->setWordWrap(true);
  summary_->setAlignment(Qt::AlignCenter);
  result_layout->addWidget(summary_);
  reasons_ = new QLabel(result_page);
  reasons_->setObjectName(QStringLiteral("reasons"));
  reasons_->setWordWrap(true);
  reasons_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  result_layout->addWidget(reasons_);
  table_ = new QTableWidget(0, 6, result_page);
  table_->setHorizontalHeaderLabels({tr("Parameter"), tr("Pre-mission"), tr("Measured"),
                                     tr("Difference"), tr("Tolerance"), tr("Verdict")});
  table_->verticalHeader()->hide();
  table_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  table_->horizontalHeader()->setSectionResizeMode(QHeaderView::ResizeToContents);
  table_->horizontalHeader()->setStretchLastSection(true);
  result_layout->addWidget(table_, 1);
  // Takes the table's room when it is hidden (inconclusive), so the text stays on top.
  result_layout->addStretch(0);
  auto* result_buttons = new QHBoxLayout;
  auto* again = new QPushButton(tr("Check Again"), result_page);
  connect(again, &QPushButton::clicked, this, &VestCheckDialog::BackToConnect);
  auto* save = new QPushButton(tr("Save Report…"), result_page);
  connect(save, &QPushButton::clicked, this, [this] {
    const QString name =
        QStringLiteral("vest-check-%1.pdf")
            .arg(QDateTime::currentDateTime().toString(QStringLiteral("yyyyMMdd-HHmm")));
    const QString path =
        QFileDialog::getSaveFileName(this, tr("Save Report"), name, tr("PDF (*.pdf)"));
    if (!path.isEmpty()) saveReport(path);
  });
  auto* close = new QPushButton(tr("Close"), result_page);
  connect(close, &QPushButton::clicked, this, &QDialog::accept);
  result_buttons->addWidget(again);
  result_buttons->addStretch();
  result_buttons->addWidget(save);
  result_buttons->addWidget(close);
  result_layout->addLayout(result_buttons);
  pages_->addWidget(result_page);
}

VestCheckDialog::~VestCheckDialog() = default;

QLineEdit* VestCheckDialog::premissionEdit() const { return premission_->edit(); }

VestCheckDialog::Page VestCheckDialog::page() const { return Page(pages_->currentIndex()); }

void VestCheckDialog::startCheck() {
  connect_error_->clear();
  std::optional<CameraIntrinsics> premission;
  QString error;
  if (!premission_->read(&premission, &error)) {
    connect_error_->setText(error);
    return;
  }
  VestCheckOptions options;
  options.duration_s = duration_->value();
  options.tolerance.focal_percent = focal_tol_->value();
  options.tolerance.principal_px = principal_tol_->value();
  options.tolerance.distortion_px = distortion_tol_->value();
  options_ = options;
  const std::optional<double> readout_ms =
      readout_->value() < 0 ? std::nullopt : std::optional<double>(readout_->value());
  controller_ = std::make_unique<VestCheckController>(input_->text(), accel_->text(), premission,
                                                      readout_ms, options);
  connect(controller_.get(), &VestCheckController::connected, this,
          [this](const QString& description) {
            source_label_->setText(tr("Source: %1").arg(description));
          });
  connect(controller_.get(), &VestCheckController::progressed, this,
          &VestCheckDialog::ShowProgress);
  connect(controller_.get(), &VestCheckController::finished, this, &VestCheckDialog::ShowResult);
  connect(controller_.get(), &VestCheckController::failed, this, &VestCheckDialog::ShowFailure);
  result_.reset();
  source_label_->setText(tr("Connecting to %1…").arg(input_->text()));
  checklist_->clear();
  thumbnail_->clear();
  finish_now_->setEnabled(true);
  pages_->setCurrentIndex(int(Page::kWalk));
  ShowProgress();
  controller_->start();
}

void VestCheckDialog::ShowProgress() {
  if (!controller_) return;
  const VestCheckProgress p = controller_->progress();
  guidance_->setText(p.guidance);
  progress_->setValue(int(std::lround(100 * p.progress)));
  elapsed_->setText(tr("%1 of %2").arg(MinutesSeconds(p.elapsed_s), MinutesSeconds(p.duration_s)));
  if (checklist_->count() != int(p.coverage.size())) {
    checklist_->clear();
    for (size_t i = 0; i < p.coverage.size(); ++i) checklist_->addItem(QString());
  }
  for (size_t i = 0; i < p.coverage.size(); ++i) {
    const VestNeedStatus& s = p.coverage[i];
    QListWidgetItem* item = checklist_->item(int(i));
    item->setText(QStringLiteral("%1  %2 — %3%4")
                      .arg(s.done ? QStringLiteral("✔") : QStringLiteral("✘"),
                           QString::fromStdString(s.name), QString::fromStdString(s.measured),
                           s.required ? QString() : tr(" (helps)")));
    item->setForeground(s.done       ? QColor(0x1b, 0x7f, 0x2a)
                        : s.required ? QColor(0xb0, 0x00, 0x20)
                                     : QColor(0x70, 0x70, 0x70));
  }
  if (!p.frame.isNull()) {
    thumbnail_->setPixmap(QPixmap::fromImage(
        p.frame.scaled(thumbnail_->size(), Qt::KeepAspectRatio, Qt::SmoothTransformation)));
  }
}

void VestCheckDialog::ShowResult(const VestCheckResult& result) {
  result_ = result;
  source_description_ = controller_->sourceDescription();
  device_ids_ = controller_->deviceIds();
  const char* colour = result.verdict == VestVerdict::kPass   ? "#1b7f2a"
                       : result.verdict == VestVerdict::kFail ? "#b00020"
                                                              : "#b26a00";
  verdict_->setText(QString::fromStdString(VestVerdictName(result.verdict)));
  verdict_->setStyleSheet(QStringLiteral("color: %1;").arg(QLatin1String(colour)));
  summary_->setText(QStringLiteral("<b>%1</b><br>").arg(VestVerdictAdvice(result.verdict)) +
                    tr("%1 s walked on %2; %3 calibration updates of %4 accepted%5")
                        .arg(QString::number(result.seconds, 'f', 1), source_description_)
                        .arg(result.accepted_in_regime)
                        .arg(result.attempts)
                        .arg(result.unfit_s > 0.0
                                 ? tr("; images unfit for %1 s").arg(result.unfit_s, 0, 'f', 1)
                                 : QString())
                        .toHtmlEscaped());
  QStringList reasons;
  for (const std::string& reason : result.reasons) {
    reasons << QStringLiteral("• ") + QString::fromStdString(reason).toHtmlEscaped();
  }
  reasons_->setText(reasons.isEmpty()
                        ? tr("Every parameter is within its tolerance of the pre-mission "
                             "calibration.")
                        : reasons.join(QStringLiteral("<br>")));
  const std::vector<VestReportRow> rows = VestReportRows(result);
  table_->setRowCount(int(rows.size()));
  for (size_t r = 0; r < rows.size(); ++r) {
    const QStringList cells = {rows[r].parameter,  rows[r].premission, rows[r].measured,
                               rows[r].difference, rows[r].tolerance,  rows[r].verdict};
    for (int c = 0; c < cells.size(); ++c) {
      auto* item = new QTableWidgetItem(cells[c]);
      if (c == 5)
        item->setForeground(rows[r].pass ? QColor(0x1b, 0x7f, 0x2a) : QColor(0xb0, 0x00, 0x20));
      table_->setItem(int(r), c, item);
    }
  }
  table_->setVisible(!rows.empty());
  pages_->setCurrentIndex(int(Page::kResult));
  emit checkFinished();
}

void VestCheckDialog::ShowFailure(const QString& message) {
  // Called from the controller's own signal: deleted once that returns.
  controller_.release()->deleteLater();
  pages_->setCurrentIndex(int(Page::kConnect));
  connect_error_->setText(tr("The check could not run: %1").arg(message));
}

void VestCheckDialog::BackToConnect() {
  controller_.reset();
  pages_->setCurrentIndex(int(Page::kConnect));
}

VestReport VestCheckDialog::report() const {
  VestReport report;
  report.when = QDateTime::currentDateTime();
  report.source = source_description_;
  report.devices = device_ids_;
  report.options = options_;
  if (result_) report.result = *result_;
  return report;
}

bool VestCheckDialog::saveReport(const QString& path, bool quiet) {
  if (!result_) return false;
  QString error;
  if (WriteVestReportPdf(report(), path, &error)) return true;
  if (!quiet) QMessageBox::warning(this, tr("Save Report"), error);
  return false;
}

}  // namespace autocal
