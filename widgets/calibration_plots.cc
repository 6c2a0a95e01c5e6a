#include "widgets/calibration_plots.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include <QAction>
#include <QCheckBox>
#include <QCursor>
#include <QFileDialog>
#include <QFileInfo>
#include <QGraphicsLayout>
#include <QGridLayout>
#include <QHBoxLayout>
#include <QLabel>
#include <QMessageBox>
#include <QMouseEvent>
#include <QPainter>
#include <QPixmap>
#include <QPushButton>
#include <QResizeEvent>
#include <QScrollArea>
#include <QSvgGenerator>
#include <QToolTip>
#include <QVBoxLayout>
#include <QWheelEvent>
#include <QtCharts/QLegend>

#include "widgets/plot_decimation.h"
#include "widgets/plot_ticks.h"

namespace autocal {
namespace {

constexpr int kMarkerSize = 8;
// A drag shorter than this (pixels) is a click: it seeks instead of panning.
constexpr int kDragThreshold = 4;
constexpr double kMinSpanSeconds = 0.05;
// Tall enough for the value axis's title and three labels (110 left one label and cut
// "rms (px)" short in the workbench's dock); the plots scroll below this.
constexpr int kMinChartHeight = 150;
// The no-update row: its marks' size, and their height above the chart's foot as a
// fraction of the value range shown.
constexpr int kNoUpdateMarkerSize = 7;
constexpr double kNoUpdateRowHeight = 0.04;

std::optional<MarkerClass> MarkerOf(Verdict verdict) {
  switch (verdict) {
    case Verdict::kAccepted:
      return MarkerClass::kAccepted;
    case Verdict::kRejected:
      return MarkerClass::kRejected;
    case Verdict::kAlarm:
    case Verdict::kNewRegime:
      return MarkerClass::kJump;
    case Verdict::kNoUpdate:
      break;
  }
  return std::nullopt;
}

QString ValueTitle(int channel) {
  const QString name = ChannelName(channel);
  return channel < kK1 || channel == kRmsChannel ? QStringLiteral("%1 (px)").arg(name) : name;
}

bool Estimated(const AttemptRecord& record, int channel) {
  return channel == kRmsChannel ||
         std::find(record.free_parameters.begin(), record.free_parameters.end(), channel) !=
             record.free_parameters.end();
}

// What a legend entry shows before its name.
enum class Sample { kDot, kSquare, kRing, kLine, kDashed, kDashDot };

// A legend entry: a sample of the marker or line, then its name.
QWidget* LegendEntry(const QString& text, const QColor& color, Sample shown) {
  QPixmap icon(18, 12);
  icon.fill(Qt::transparent);
  QPainter painter(&icon);
  painter.setRenderHint(QPainter::Antialiasing);
  switch (shown) {
    case Sample::kLine:
    case Sample::kDashed:
    case Sample::kDashDot:
      painter.setPen(QPen(color, 2.0,
                          shown == Sample::kLine     ? Qt::SolidLine
                          : shown == Sample::kDashed ? Qt::DashLine
                                                     : Qt::DashDotLine));
      painter.drawLine(0, 6, 18, 6);
      break;
    case Sample::kSquare:
      painter.setPen(Qt::NoPen);
      painter.setBrush(color);
      painter.drawRect(5, 2, kMarkerSize, kMarkerSize);
      break;
    case Sample::kDot:
    case Sample::kRing:
      painter.setPen(shown == Sample::kRing ? QPen(color, 2.0) : QPen(Qt::NoPen));
      painter.setBrush(shown == Sample::kRing ? QBrush(Qt::NoBrush) : QBrush(color));
      painter.drawEllipse(5, 2, kMarkerSize, kMarkerSize);
      break;
  }
  painter.end();
  auto* entry = new QWidget;
  auto* layout = new QHBoxLayout(entry);
  layout->setContentsMargins(0, 0, 8, 0);
  layout->setSpacing(3);
  auto* sample = new QLabel;
  sample->setPixmap(icon);
  layout->addWidget(sample);
  layout->addWidget(new QLabel(text));
  return entry;
}

// Smallest and largest value of `points` whose time is in [t0, t1].
void ExtendRange(const QVector<QPointF>& points, double t0, double t1, double* lo, double* hi) {
  for (const QPointF& p : points) {
    if (p.x() < t0 || p.x() > t1) continue;
    *lo = std::min(*lo, p.y());
    *hi = std::max(*hi, p.y());
  }
}

// Each chart's own margins; CalibrationPlots widens the left one to line up a column.
const QMargins kChartMargins(2, 4, 6, 2);

// Sets a range and its tick interval without passing through a state with a great many
// ticks (a wide range with a fine interval), which Qt Charts would lay out one by one.
// The format goes first: the space for the labels is laid out when the range changes.
void SetAxis(QValueAxis* axis, double min, double max, double tick) {
  axis->setLabelFormat(LabelFormat(tick));
  axis->setTickInterval(std::max(axis->tickInterval(), tick));
  axis->setRange(min, max);
  axis->setTickInterval(tick);
}

}  // namespace

QColor MarkerColor(MarkerClass marker) {
  switch (marker) {
    case MarkerClass::kAccepted:
      return {44, 160, 44};
    case MarkerClass::kRejected:
      return {214, 39, 40};
    case MarkerClass::kJump:
      return {255, 127, 14};
  }
  return {};
}

QColor TrendColor() { return {31, 119, 180}; }
QColor TruthColor() { return {120, 120, 120}; }
QColor AlarmColor() { return {148, 103, 189}; }
QColor CompareColor() { return {140, 86, 75}; }
QColor NoUpdateColor() { return {150, 150, 150}; }

CalibrationChart::CalibrationChart(int channel, QWidget* parent)
    : QChartView(parent), channel_(channel) {
  auto* chart = new QChart;
  chart->layout()->setContentsMargins(0, 0, 0, 0);
  chart->setMargins(kChartMargins);
  chart->setBackgroundRoundness(0);
  chart->legend()->hide();

  time_axis_ = new QValueAxis;
  // The interval must be set before the type: an interval of 0 would mean endless ticks.
  time_axis_->setTickInterval(1.0);
  time_axis_->setTickAnchor(0.0);
  time_axis_->setTickType(QValueAxis::TicksDynamic);
  value_axis_ = new QValueAxis;
  value_axis_->setTitleText(ValueTitle(channel));
  value_axis_->setTickInterval(1.0);
  value_axis_->setTickType(QValueAxis::TicksDynamic);
  chart->addAxis(time_axis_, Qt::AlignBottom);
  chart->addAxis(value_axis_, Qt::AlignLeft);

  auto add = [&](QAbstractSeries* series) {
    chart->addSeries(series);
    series->attachAxis(time_axis_);
    series->attachAxis(value_axis_);
  };
  // Added in drawing order: lines under the markers, the cursor on top.
  truth_ = new QLineSeries;
  truth_->setPen(QPen(TruthColor(), 2.0, Qt::DashLine));
  add(truth_);
  compare_trend_ = new QLineSeries;
  compare_trend_->setPen(QPen(CompareColor(), 2.0, Qt::DashDotLine));
  add(compare_trend_);
  trend_ = new QLineSeries;
  trend_->setPen(QPen(TrendColor(), 2.0));
  add(trend_);
  compare_markers_ = new QScatterSeries;
  compare_markers_->setMarkerShape(QScatterSeries::MarkerShapeCircle);
  compare_markers_->setMarkerSize(kMarkerSize + 2);
  compare_markers_->setColor(Qt::transparent);
  compare_markers_->setBorderColor(CompareColor());
  compare_markers_->setPen(QPen(CompareColor(), 2.0));
  add(compare_markers_);
  for (int m = 0; m < kNumMarkerClasses; ++m) {
    const auto marker = static_cast<MarkerClass>(m);
    auto* series = new QScatterSeries;
    series->setMarkerShape(marker == MarkerClass::kAccepted ? QScatterSeries::MarkerShapeCircle
                                                            : QScatterSeries::MarkerShapeRectangle);
    series->setMarkerSize(kMarkerSize);
    series->setColor(MarkerColor(marker));
    series->setBorderColor(MarkerColor(marker));
    markers_[m] = series;
    add(series);
  }
  no_updates_ = new QScatterSeries;
  no_updates_->setMarkerShape(QScatterSeries::MarkerShapeRectangle);
  no_updates_->setMarkerSize(kNoUpdateMarkerSize);
  no_updates_->setColor(NoUpdateColor());
  no_updates_->setBorderColor(NoUpdateColor().darker(130));
  add(no_updates_);
  cursor_ = new QLineSeries;
  cursor_->setPen(QPen(QColor(20, 20, 20), 1.5));
  add(cursor_);

  setChart(chart);
  setRenderHint(QPainter::Antialiasing);
  setMinimumSize(200, kMinChartHeight);
  setCursor(Qt::CrossCursor);
}

QPoint CalibrationChart::positionOf(double t_s, double value) const {
  const QPointF in_chart = chart()->mapToPosition(QPointF(t_s, value), trend_);
  return mapFromScene(chart()->mapToScene(in_chart));
}

double CalibrationChart::timeAt(const QPoint& pos) const {
  return chart()->mapToValue(chart()->mapFromScene(mapToScene(pos)), trend_).x();
}

void CalibrationChart::setAlarmCount(int count) {
  QChart* c = chart();
  for (QLineSeries* alarm : alarms_) {
    c->removeSeries(alarm);
    delete alarm;
  }
  alarms_.clear();
  if (count == 0) return;
  // The alarm lines go under the markers and the cursor, which are taken off and put back.
  std::vector<QAbstractSeries*> on_top(markers_.begin(), markers_.end());
  on_top.push_back(no_updates_);
  on_top.push_back(cursor_);
  for (QAbstractSeries* series : on_top) c->removeSeries(series);
  for (int i = 0; i < count; ++i) {
    auto* alarm = new QLineSeries;
    alarm->setPen(QPen(AlarmColor(), 1.5, Qt::DashLine));
    alarms_.push_back(alarm);
    on_top.insert(on_top.begin() + i, alarm);
  }
  for (QAbstractSeries* series : on_top) {
    c->addSeries(series);
    series->attachAxis(time_axis_);
    series->attachAxis(value_axis_);
  }
}

void CalibrationChart::mousePressEvent(QMouseEvent* event) {
  if (event->button() != Qt::LeftButton) {
    QChartView::mousePressEvent(event);
    return;
  }
  press_pos_ = last_pos_ = event->pos();
  dragging_ = false;
  event->accept();
}

void CalibrationChart::mouseMoveEvent(QMouseEvent* event) {
  if (!(event->buttons() & Qt::LeftButton)) {
    QChartView::mouseMoveEvent(event);  // Hover, for the markers' tooltips.
    return;
  }
  if (!dragging_ && (event->pos() - press_pos_).manhattanLength() < kDragThreshold) return;
  dragging_ = true;
  setCursor(Qt::ClosedHandCursor);
  emit panRequested(timeAt(last_pos_) - timeAt(event->pos()));
  last_pos_ = event->pos();
  event->accept();
}

void CalibrationChart::mouseReleaseEvent(QMouseEvent* event) {
  if (event->button() != Qt::LeftButton) {
    QChartView::mouseReleaseEvent(event);
    return;
  }
  if (!dragging_) emit seekRequested(timeAt(event->pos()));
  dragging_ = false;
  setCursor(Qt::CrossCursor);
  event->accept();
}

void CalibrationChart::resizeEvent(QResizeEvent* event) {
  QChartView::resizeEvent(event);
  emit resized();
}

void CalibrationChart::mouseDoubleClickEvent(QMouseEvent* event) {
  emit resetRequested();
  event->accept();
}

void CalibrationChart::wheelEvent(QWheelEvent* event) {
  const int steps = event->angleDelta().y() / 120;
  if (steps != 0) {
    emit zoomRequested(timeAt(event->position().toPoint()), std::pow(1.25, -steps));
  }
  event->accept();
}

CalibrationPlots::CalibrationPlots(QWidget* parent) : QWidget(parent) {
  grid_ = new QWidget;
  // Exports show the charts on white, whatever the window's palette.
  grid_->setAutoFillBackground(true);
  QPalette white = grid_->palette();
  white.setColor(QPalette::Window, Qt::white);
  white.setColor(QPalette::WindowText, Qt::black);
  grid_->setPalette(white);
  auto* grid = new QGridLayout(grid_);
  grid->setContentsMargins(4, 4, 4, 4);
  grid->setSpacing(2);

  title_ = new QLabel(tr("No calibration history open (File \u203a Open History\u2026)"));
  auto* legend = new QHBoxLayout;
  legend->setSpacing(0);
  legend->addWidget(title_);
  legend->addStretch(1);
  legend->addWidget(LegendEntry(tr("accepted"), MarkerColor(MarkerClass::kAccepted), Sample::kDot));
  legend->addWidget(
      LegendEntry(tr("rejected"), MarkerColor(MarkerClass::kRejected), Sample::kSquare));
  legend->addWidget(
      LegendEntry(tr("alarm / new regime"), MarkerColor(MarkerClass::kJump), Sample::kSquare));
  legend->addWidget(LegendEntry(tr("filtered (trend)"), TrendColor(), Sample::kLine));
  legend->addWidget(LegendEntry(tr("ground truth"), TruthColor(), Sample::kDashed));
  legend->addWidget(LegendEntry(tr("alarm"), AlarmColor(), Sample::kDashed));
  legend->addWidget(LegendEntry(tr("no update"), NoUpdateColor(), Sample::kSquare));
  auto* header = new QVBoxLayout;
  header->setSpacing(0);
  header->addLayout(legend);
  grid->addLayout(header, 0, 0, 1, 2);
  // The compared run, on a line of its own under the first: both runs named.
  auto* compare_row = new QWidget;
  auto* compare_legend = new QHBoxLayout(compare_row);
  compare_legend->setContentsMargins(0, 0, 0, 0);
  compare_legend->setSpacing(0);
  compare_legend_ = new QLabel;
  compare_legend->addWidget(compare_legend_);
  compare_legend->addStretch(1);
  compare_legend->addWidget(LegendEntry(tr("compared: accepted"), CompareColor(), Sample::kRing));
  compare_legend->addWidget(LegendEntry(tr("compared: filtered"), CompareColor(), Sample::kDashDot));
  compare_row->hide();
  header->addWidget(compare_row);

  for (int channel = 0; channel < kNumCalibrationChannels; ++channel) {
    auto* chart = new CalibrationChart(channel);
    charts_[channel] = chart;
    grid->addWidget(chart, 1 + channel / 2, channel % 2);
    grid->setRowStretch(1 + channel / 2, 1);
    connect(chart, &CalibrationChart::zoomRequested, this, &CalibrationPlots::zoom);
    connect(chart, &CalibrationChart::panRequested, this, &CalibrationPlots::pan);
    connect(chart, &CalibrationChart::seekRequested, this, &CalibrationPlots::seekRequested);
    connect(chart, &CalibrationChart::resetRequested, this, &CalibrationPlots::resetZoom);
    connect(chart, &CalibrationChart::resized, this, &CalibrationPlots::scheduleRedraw);
    connect(chart->chart(), &QChart::plotAreaChanged, this, &CalibrationPlots::alignPlotAreas);
    for (int m = 0; m < kNumMarkerClasses; ++m) {
      const auto marker = static_cast<MarkerClass>(m);
      connect(chart->markers(marker), &QScatterSeries::hovered, this,
              [this, channel, marker](const QPointF& point, bool state) {
                showTooltip(channel, marker, point, state);
              });
    }
    connect(chart->noUpdates(), &QScatterSeries::hovered, this,
            [this, channel](const QPointF& point, bool state) {
              showTooltipText(channel, describeAttempt(noUpdateAt(point.x()), channel), state);
            });
  }
  // The time axis is named under the bottom row only, to leave the rest to the curves.
  for (int channel = kNumCalibrationChannels - 2; channel < kNumCalibrationChannels; ++channel) {
    charts_[channel]->timeAxis()->setTitleText(tr("Time since start (s)"));
  }

  show_rejected_ = new QCheckBox(tr("Show rejected"));
  show_rejected_->setChecked(true);
  show_rejected_->setToolTip(
      tr("Rejected attempts can lie far off; hide them to scale the charts to the rest"));
  connect(show_rejected_, &QCheckBox::toggled, this, &CalibrationPlots::setShowRejected);
  auto* fit = new QPushButton(tr("Fit"));
  fit->setToolTip(tr("Show the whole history (or double-click a chart)"));
  connect(fit, &QPushButton::clicked, this, &CalibrationPlots::resetZoom);
  auto* export_button = new QPushButton(tr("Export\u2026"));
  export_button->setToolTip(tr("Save the charts as PNG or SVG"));
  connect(export_button, &QPushButton::clicked, this, &CalibrationPlots::exportDialog);
  compare_action_ = new QAction(tr("Compare With History\u2026"), this);
  compare_action_->setToolTip(
      tr("Overlay another run's history of the same recording (other settings)"));
  connect(compare_action_, &QAction::triggered, this, [this] {
    const QString path = QFileDialog::getOpenFileName(
        this, tr("Compare With History"), {}, tr("autocal histories (*.sqlite *.db);;All files (*)"));
    if (!path.isEmpty()) openCompare(path);
  });
  clear_compare_action_ = new QAction(tr("Clear Comparison"), this);
  clear_compare_action_->setEnabled(false);
  connect(clear_compare_action_, &QAction::triggered, this, [this] { setCompareSeries(nullptr); });
  connect(&compare_opener_, &HistoryOpener::opened, this,
          [this](const QString&, std::shared_ptr<const CalibrationSeries> series) {
            setCompareSeries(std::move(series));
          });
  connect(&compare_opener_, &HistoryOpener::updated, this,
          [this](const QString&, std::shared_ptr<const CalibrationSeries> series) {
            if (compare_) setCompareSeries(std::move(series));
          });
  connect(&compare_opener_, &HistoryOpener::failed, this, &CalibrationPlots::compareFailed);
  auto* compare_button = new QPushButton(tr("Compare\u2026"));
  compare_button->setToolTip(compare_action_->toolTip());
  connect(compare_button, &QPushButton::clicked, compare_action_, &QAction::trigger);
  auto* hint = new QLabel(tr("Wheel: zoom \u00b7 drag: pan \u00b7 click: go to time"));
  hint->setEnabled(false);

  auto* controls = new QHBoxLayout;
  controls->setContentsMargins(6, 2, 6, 2);
  controls->addWidget(hint);
  controls->addStretch(1);
  controls->addWidget(show_rejected_);
  controls->addWidget(compare_button);
  controls->addWidget(fit);
  controls->addWidget(export_button);

  // The charts keep a readable size and scroll when the dock is small, so that the video
  // keeps its room.
  grid_->setMinimumHeight(5 * kMinChartHeight + 30);
  auto* scroll = new QScrollArea;
  scroll->setWidget(grid_);
  scroll->setWidgetResizable(true);
  scroll->setFrameShape(QFrame::NoFrame);

  auto* layout = new QVBoxLayout(this);
  layout->setContentsMargins(0, 0, 0, 0);
  layout->setSpacing(0);
  layout->addLayout(controls);
  layout->addWidget(scroll, 1);

  redraw_timer_.setSingleShot(true);
  redraw_timer_.setInterval(0);
  connect(&redraw_timer_, &QTimer::timeout, this, &CalibrationPlots::redraw);
  redraw();
}

void CalibrationPlots::alignPlotAreas() {
  if (aligning_) return;
  aligning_ = true;
  for (int column = 0; column < 2; ++column) {
    // Where each chart's plot area would start with its own margin: the value labels'
    // widths differ from chart to chart ("417.2" against "-0.0123").
    std::vector<std::pair<QChart*, double>> natural;
    double widest = 0.0;
    for (int channel = column; channel < kNumCalibrationChannels; channel += 2) {
      QChart* chart = charts_[channel]->chart();
      chart->layout()->activate();  // The plot area as the margins set last lay it out.
      const double left =
          chart->plotArea().left() - (chart->margins().left() - kChartMargins.left());
      natural.emplace_back(chart, left);
      widest = std::max(widest, left);
    }
    for (const auto& [chart, left] : natural) {
      QMargins margins = chart->margins();
      const int wanted = kChartMargins.left() + static_cast<int>(std::lround(widest - left));
      if (margins.left() == wanted) continue;
      margins.setLeft(wanted);
      chart->setMargins(margins);
      chart->layout()->activate();
    }
  }
  aligning_ = false;
}

QSize CalibrationPlots::sizeHint() const { return {900, 300}; }

void CalibrationPlots::setSeries(std::shared_ptr<const CalibrationSeries> series) {
  const bool same_file = series_ && series && series_->path == series->path;
  const bool whole_in_view = std::pair(t0_, t1_) == fullRange();
  series_ = std::move(series);
  rebuild(same_file && !whole_in_view);
}

void CalibrationPlots::setCompareSeries(std::shared_ptr<const CalibrationSeries> compare) {
  const bool whole_in_view = std::pair(t0_, t1_) == fullRange();
  compare_ = std::move(compare);
  clear_compare_action_->setEnabled(compare_ != nullptr);
  compare_legend_->parentWidget()->setVisible(compare_ != nullptr);
  rebuild(!whole_in_view);
}

void CalibrationPlots::openCompare(const QString& path) { compare_opener_.open(path); }

void CalibrationPlots::setTimeOrigin(int64_t origin_ns) {
  origin_ns_ = origin_ns;
  origin_set_ = true;
  rebuild();
}

void CalibrationPlots::setGroundTruth(std::vector<std::pair<int64_t, CameraIntrinsics>> truth) {
  truth_ = std::move(truth);
  rebuild();
}

bool CalibrationPlots::showsRejected() const { return show_rejected_->isChecked(); }

double CalibrationPlots::toSeconds(int64_t t_ns) const {
  return static_cast<double>(t_ns - origin_ns_) * 1e-9;
}

void CalibrationPlots::rebuild(bool keep_view) {
  const std::vector<AttemptRecord> none;
  const std::vector<AttemptRecord>& attempts = series_ ? series_->stored.attempts : none;
  if (!origin_set_) {
    origin_ns_ = !attempts.empty()                                    ? attempts.front().t_ns
                 : compare_ && !compare_->stored.attempts.empty() ? compare_->stored.attempts.front().t_ns
                                                                  : 0;
  }

  for (auto& channel : points_) {
    for (Points& p : channel) p = {};
  }
  no_updates_ = {};
  for (const AttemptRecord& record : attempts) {
    const std::optional<MarkerClass> marker = MarkerOf(record.verdict);
    if (!marker) {
      no_updates_.t.push_back(toSeconds(record.t_ns));
      no_updates_.v.push_back(0.0);
      no_updates_.id.push_back(record.id);
      continue;
    }
    for (int channel = 0; channel < kNumCalibrationChannels; ++channel) {
      const double value = ChannelValue(record, channel);
      // A parameter the attempt held at its prior tells nothing: only estimates are marked.
      if (!std::isfinite(value) || !Estimated(record, channel)) continue;
      Points& p = points_[channel][static_cast<int>(*marker)];
      p.t.push_back(toSeconds(record.t_ns));
      p.v.push_back(value);
      p.id.push_back(record.id);
    }
  }
  for (int channel = 0; channel < kNumCalibrationChannels; ++channel) {
    compare_points_[channel] = {};
    compare_trend_[channel] = {};
    if (!compare_) continue;
    for (const AttemptRecord& record : compare_->stored.attempts) {
      const double value = ChannelValue(record, channel);
      // What the compared run took (accepted, or off the trend into a new regime).
      const std::optional<MarkerClass> marker = MarkerOf(record.verdict);
      if (!marker || *marker == MarkerClass::kRejected || !std::isfinite(value) ||
          !Estimated(record, channel)) {
        continue;
      }
      compare_points_[channel].t.push_back(toSeconds(record.t_ns));
      compare_points_[channel].v.push_back(value);
      compare_points_[channel].id.push_back(record.id);
    }
    if (channel == kRmsChannel) continue;
    for (const TrendSample& sample : compare_->trend) {
      compare_trend_[channel].t.push_back(toSeconds(sample.t_ns));
      compare_trend_[channel].v.push_back(sample.value[channel]);
    }
  }
  for (int channel = 0; channel < kNumIntrinsics; ++channel) {
    trend_[channel] = {};
    truth_lines_[channel] = {};
    if (series_) {
      for (const TrendSample& sample : series_->trend) {
        trend_[channel].t.push_back(toSeconds(sample.t_ns));
        trend_[channel].v.push_back(sample.value[channel]);
      }
    }
    for (const auto& [t_ns, intrinsics] : truth_) {
      truth_lines_[channel].t.push_back(toSeconds(t_ns));
      truth_lines_[channel].v.push_back(intrinsics.Packed()[channel]);
    }
  }
  alarm_t_.clear();
  if (series_) {
    for (const Alarm& alarm : series_->stored.alarms) alarm_t_.push_back(toSeconds(alarm.t_ns));
  }
  for (CalibrationChart* chart : charts_) chart->setAlarmCount(static_cast<int>(alarm_t_.size()));

  // "name: attempts N, accepted ..." for a history.
  const auto summary = [this](const CalibrationSeries& series) {
    const StoredHistory& stored = series.stored;
    auto count = [&](Verdict verdict) {
      return std::count_if(stored.attempts.begin(), stored.attempts.end(),
                           [verdict](const AttemptRecord& r) { return r.verdict == verdict; });
    };
    return tr("<b>%1</b>: attempts %2, accepted %3, rejected %4, alarms %5; RMS limit %6 px")
        .arg(QFileInfo(QString::fromStdString(series.path)).fileName().toHtmlEscaped())
        .arg(stored.attempts.size())
        .arg(count(Verdict::kAccepted))
        .arg(count(Verdict::kRejected))
        .arg(stored.alarms.size())
        .arg(stored.options.max_rms_px, 0, 'f', 2);
  };
  if (series_) title_->setText(summary(*series_));
  if (compare_) {
    compare_legend_->setText(tr("<span style='color:%1'>compared with</span> %2")
                                 .arg(CompareColor().name(), summary(*compare_)));
  }
  // Redrawn either way: resetting to a time range that has not changed draws nothing new
  // by itself, and a history followed while it grows stays within the recording's range.
  scheduleRedraw();
  if (!keep_view) resetZoom();
}

std::pair<double, double> CalibrationPlots::fullRange() const {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  auto extend = [&](const std::vector<double>& t) {
    if (t.empty()) return;
    lo = std::min(lo, t.front());
    hi = std::max(hi, t.back());
  };
  for (const auto& channel : points_) {
    for (const Points& p : channel) extend(p.t);
  }
  extend(trend_[0].t);
  extend(truth_lines_[0].t);
  for (const Points& p : compare_points_) extend(p.t);
  extend(no_updates_.t);
  extend(compare_trend_[0].t);
  extend(alarm_t_);
  if (!(lo <= hi)) return {0.0, 1.0};
  // Room for the markers at the ends, which would be cut in half at the edge.
  const double pad = std::max(0.02 * (hi - lo), 0.5);
  return {lo - pad, hi + pad};
}

void CalibrationPlots::resetZoom() {
  const auto [t0, t1] = fullRange();
  setVisibleRange(t0, t1);
}

void CalibrationPlots::setVisibleRange(double t0_s, double t1_s) {
  if (!(t1_s - t0_s >= kMinSpanSeconds)) {
    const double middle = 0.5 * (t0_s + t1_s);
    t0_s = middle - 0.5 * kMinSpanSeconds;
    t1_s = middle + 0.5 * kMinSpanSeconds;
  }
  if (t0_s == t0_ && t1_s == t1_) return;
  t0_ = t0_s;
  t1_ = t1_s;
  scheduleRedraw();
  emit visibleRangeChanged(t0_, t1_);
}

void CalibrationPlots::setCursorTime(double seconds) {
  cursor_s_ = seconds;
  if (!isVisible()) {
    redraw_when_shown_ = true;
  } else if (!redraw_timer_.isActive()) {
    moveCursor();  // A redraw under way draws the cursor where it now is.
  }
}

void CalibrationPlots::moveCursor() {
  for (CalibrationChart* chart : charts_) {
    const double lo = chart->valueAxis()->min(), hi = chart->valueAxis()->max();
    chart->cursor()->replace(QVector<QPointF>{{cursor_s_, lo}, {cursor_s_, hi}});
  }
}

void CalibrationPlots::showEvent(QShowEvent* event) {
  QWidget::showEvent(event);
  if (redraw_when_shown_) scheduleRedraw();
}

void CalibrationPlots::setShowRejected(bool show) {
  show_rejected_->setChecked(show);
  scheduleRedraw();
}

void CalibrationPlots::zoom(double t_s, double factor) {
  setVisibleRange(t_s - (t_s - t0_) * factor, t_s + (t1_ - t_s) * factor);
}

void CalibrationPlots::pan(double dt_s) { setVisibleRange(t0_ + dt_s, t1_ + dt_s); }

int CalibrationPlots::attemptAt(int channel, MarkerClass marker, const QPointF& point) const {
  // Drawn points are copies of the stored ones, so they compare equal.
  const Points& p = points_[channel][static_cast<int>(marker)];
  for (auto it = std::lower_bound(p.t.begin(), p.t.end(), point.x());
       it != p.t.end() && *it == point.x(); ++it) {
    const size_t i = static_cast<size_t>(it - p.t.begin());
    if (p.v[i] == point.y()) return p.id[i];
  }
  return -1;
}

int CalibrationPlots::noUpdateAt(double t_s) const {
  const auto it = std::lower_bound(no_updates_.t.begin(), no_updates_.t.end(), t_s);
  if (it == no_updates_.t.end() || *it != t_s) return -1;
  return no_updates_.id[static_cast<size_t>(it - no_updates_.t.begin())];
}

QString CalibrationPlots::describeAttempt(int id, int channel) const {
  if (!series_ || id < 0 || id >= static_cast<int>(series_->stored.attempts.size())) return {};
  const AttemptRecord& record = series_->stored.attempts[static_cast<size_t>(id)];
  if (!MarkerOf(record.verdict)) {  // No estimate to give.
    return tr("attempt %1 at %2 s: %3")
        .arg(record.id)
        .arg(toSeconds(record.t_ns), 0, 'f', 3)
        .arg(QString::fromStdString(record.reason));
  }
  return tr("attempt %1 at %2 s: %3\n%4 = %5\n%6")
      .arg(record.id)
      .arg(toSeconds(record.t_ns), 0, 'f', 3)
      .arg(QString::fromStdString(VerdictName(record.verdict)), ChannelName(channel))
      .arg(ChannelValue(record, channel), 0, 'g', 8)
      .arg(QString::fromStdString(record.reason));
}

void CalibrationPlots::showTooltip(int channel, MarkerClass marker, const QPointF& point,
                                   bool state) {
  showTooltipText(channel, describeAttempt(attemptAt(channel, marker, point), channel), state);
}

void CalibrationPlots::showTooltipText(int channel, const QString& text, bool state) {
  if (!state) {
    QToolTip::hideText();
    return;
  }
  if (!text.isEmpty()) QToolTip::showText(QCursor::pos(), text, charts_[channel]);
}

bool CalibrationPlots::exportImage(const QString& path, QString* error) {
  redrawNow();
  const QString suffix = QFileInfo(path).suffix().toLower();
  if (suffix == QLatin1String("png")) {
    if (grid_->grab().toImage().save(path, "PNG")) return true;
    *error = tr("cannot write %1").arg(path);
    return false;
  }
  if (suffix == QLatin1String("svg")) {
    QSvgGenerator svg;
    svg.setFileName(path);
    svg.setSize(grid_->size());
    svg.setViewBox(QRect(QPoint(0, 0), grid_->size()));
    svg.setTitle(tr("autocal calibration history"));
    QPainter painter;
    if (!painter.begin(&svg)) {
      *error = tr("cannot write %1").arg(path);
      return false;
    }
    grid_->render(&painter);
    painter.end();
    return true;
  }
  *error = tr("%1: unknown image type '%2' (use .png or .svg)").arg(path, suffix);
  return false;
}

void CalibrationPlots::exportDialog() {
  QString filter;
  QString path = QFileDialog::getSaveFileName(
      this, tr("Export Calibration Plots"), QStringLiteral("calibration.png"),
      tr("PNG image (*.png);;SVG drawing (*.svg)"), &filter);
  if (path.isEmpty()) return;
  if (QFileInfo(path).suffix().isEmpty()) {
    path += filter.contains(QLatin1String("svg")) ? QLatin1String(".svg") : QLatin1String(".png");
  }
  QString error;
  if (!exportImage(path, &error)) QMessageBox::warning(this, tr("Export failed"), error);
}

void CalibrationPlots::scheduleRedraw() {
  if (!isVisible()) {
    redraw_when_shown_ = true;
    return;
  }
  if (!redraw_timer_.isActive()) redraw_timer_.start();
}

void CalibrationPlots::redrawNow() {
  redraw_timer_.stop();
  redraw();
}

void CalibrationPlots::redraw() {
  redraw_when_shown_ = false;
  const double time_tick = NiceTickInterval(t1_ - t0_, 8);
  for (int channel = 0; channel < kNumCalibrationChannels; ++channel) {
    CalibrationChart& chart = *charts_[channel];
    SetAxis(chart.timeAxis(), t0_, t1_, time_tick);

    // Each pixel column keeps its extremes, so hours of history cost a few thousand points.
    const int columns = std::max(1, static_cast<int>(chart.chart()->plotArea().width()));
    auto decimate = [&](const std::vector<double>& t, const std::vector<double>& v) {
      return DecimateMinMax(t, v, VisibleRange(t, t0_, t1_), columns);
    };
    double lo = std::numeric_limits<double>::infinity();
    double hi = -lo;
    for (int m = 0; m < kNumMarkerClasses; ++m) {
      const Points& p = points_[channel][m];
      const bool shown = showsRejected() || static_cast<MarkerClass>(m) != MarkerClass::kRejected;
      const QVector<QPointF> points = shown ? decimate(p.t, p.v) : QVector<QPointF>();
      ExtendRange(points, t0_, t1_, &lo, &hi);
      chart.markers(static_cast<MarkerClass>(m))->replace(points);
    }
    const QVector<QPointF> trend = decimate(trend_[channel].t, trend_[channel].v);
    const QVector<QPointF> truth = decimate(truth_lines_[channel].t, truth_lines_[channel].v);
    ExtendRange(trend, t0_, t1_, &lo, &hi);
    ExtendRange(truth, t0_, t1_, &lo, &hi);
    chart.trend()->replace(trend);
    chart.truth()->replace(truth);
    const QVector<QPointF> compare_points =
        decimate(compare_points_[channel].t, compare_points_[channel].v);
    const QVector<QPointF> compare_trend =
        decimate(compare_trend_[channel].t, compare_trend_[channel].v);
    ExtendRange(compare_points, t0_, t1_, &lo, &hi);
    ExtendRange(compare_trend, t0_, t1_, &lo, &hi);
    chart.compareMarkers()->replace(compare_points);
    chart.compareTrend()->replace(compare_trend);

    if (!(lo <= hi)) {
      lo = -1.0;
      hi = 1.0;
    }
    // A flat series (a parameter held fixed, up to rounding) is shown flat in the middle of
    // a readable range: ticks finer than the values' rounding would never end.
    if (hi - lo <= 1e-6 * std::max(std::abs(lo), std::abs(hi)) + 1e-12) {
      const double middle = 0.5 * (lo + hi);
      const double half = std::max(0.01 * std::abs(middle), 1e-3);
      lo = middle - half;
      hi = middle + half;
    } else {
      const double pad = 0.08 * (hi - lo);
      lo -= pad;
      hi += pad;
    }
    // Labels about 30 px apart (Qt Charts elides them all when they crowd), and at least
    // three asked for, so that two or more fall inside the range.
    const int ticks = std::clamp(static_cast<int>(chart.chart()->plotArea().height()) / 30, 3, 5);
    double value_tick = NiceTickInterval(hi - lo, ticks);
    const auto labelled = [&](double tick) {
      return std::floor(hi / tick) - std::ceil(lo / tick) + 1.0;
    };
    for (int more = ticks + 1; labelled(value_tick) < 2.0 && more <= 4 * ticks; ++more) {
      value_tick = NiceTickInterval(hi - lo, more);
    }
    chart.valueAxis()->setTickAnchor(std::floor(lo / value_tick) * value_tick);
    SetAxis(chart.valueAxis(), lo, hi, value_tick);

    for (size_t i = 0; i < alarm_t_.size(); ++i) {
      chart.alarms()[i]->replace(QVector<QPointF>{{alarm_t_[i], lo}, {alarm_t_[i], hi}});
    }
    QVector<QPointF> no_updates = decimate(no_updates_.t, no_updates_.v);
    for (QPointF& point : no_updates) point.setY(lo + kNoUpdateRowHeight * (hi - lo));
    chart.noUpdates()->replace(no_updates);
  }
  moveCursor();  // Across each chart's new value range.
}

}  // namespace autocal
