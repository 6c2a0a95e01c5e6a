#include "widgets/accel_plot.h"

#include <algorithm>
#include <cmath>

#include <QGraphicsLayout>
#include <QMouseEvent>
#include <QPen>
#include <QWheelEvent>
#include <QtCharts/QLegend>
#include <QtCharts/QLegendMarker>

#include "devices/sequence.h"
#include "widgets/plot_decimation.h"
#include "widgets/plot_ticks.h"

namespace autocal {
AccelPlot::AccelPlot(QWidget* parent) : QChartView(parent) {
  auto* chart = new QChart;
  // Space goes to the curves: no padding around the chart, the legend beside it.
  chart->layout()->setContentsMargins(0, 0, 0, 0);
  chart->setMargins(QMargins(4, 6, 4, 2));
  chart->setBackgroundRoundness(0);
  chart->legend()->setAlignment(Qt::AlignRight);

  time_axis_ = new QValueAxis;
  time_axis_->setTitleText(tr("Time since start (s)"));
  // Dynamic ticks on round numbers; the interval must be set before the type, as an
  // interval of 0 would mean endless ticks.
  time_axis_->setTickInterval(1.0);
  time_axis_->setTickAnchor(0.0);
  time_axis_->setTickType(QValueAxis::TicksDynamic);
  value_axis_ = new QValueAxis;
  value_axis_->setTitleText(tr("Acceleration (m/s\u00b2)"));
  value_axis_->setTickInterval(1.0);
  value_axis_->setTickAnchor(0.0);
  value_axis_->setTickType(QValueAxis::TicksDynamic);
  chart->addAxis(time_axis_, Qt::AlignBottom);
  chart->addAxis(value_axis_, Qt::AlignLeft);

  // The usual axis colours: x red, y green, z blue.
  const std::array<QColor, 3> colors = {QColor(214, 39, 40), QColor(44, 160, 44),
                                        QColor(31, 119, 180)};
  const std::array<QString, 3> names = {tr("a_x"), tr("a_y"), tr("a_z")};
  for (size_t axis = 0; axis < 3; ++axis) {
    series_[axis] = new QLineSeries;
    series_[axis]->setName(names[axis]);
    series_[axis]->setPen(QPen(colors[axis], 1.0));
    chart->addSeries(series_[axis]);
    series_[axis]->attachAxis(time_axis_);
    series_[axis]->attachAxis(value_axis_);
  }
  cursor_ = new QLineSeries;
  cursor_->setPen(QPen(QColor(20, 20, 20), 2.0));
  chart->addSeries(cursor_);
  cursor_->attachAxis(time_axis_);
  cursor_->attachAxis(value_axis_);
  for (auto* marker : chart->legend()->markers(cursor_)) marker->setVisible(false);

  setChart(chart);
  setRenderHint(QPainter::Antialiasing);
  setMinimumHeight(160);
  setCursor(Qt::CrossCursor);

  redraw_timer_.setSingleShot(true);
  redraw_timer_.setInterval(0);
  connect(&redraw_timer_, &QTimer::timeout, this, &AccelPlot::redraw);
  redraw();
}

void AccelPlot::setSamples(const std::vector<AccelSample>& samples, int64_t start_ns,
                           double duration_s) {
  t_.clear();
  t_.reserve(samples.size());
  for (auto& v : values_) {
    v.clear();
    v.reserve(samples.size());
  }
  for (const AccelSample& sample : samples) {
    t_.push_back(static_cast<double>(sample.t_ns - start_ns) * 1e-9);
    for (int axis = 0; axis < 3; ++axis) values_[axis].push_back(sample.specific_force[axis]);
  }
  duration_s_ = std::max(duration_s, t_.empty() ? 0.0 : t_.back());
  cursor_s_ = 0.0;

  // One value range for the whole recording, so the axis holds still during playback.
  y_min_ = -1.0;
  y_max_ = 1.0;
  if (!t_.empty()) {
    y_min_ = y_max_ = values_[0].front();
    for (const auto& v : values_) {
      const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
      y_min_ = std::min(y_min_, *lo);
      y_max_ = std::max(y_max_, *hi);
    }
    const double pad = std::max(0.5, 0.05 * (y_max_ - y_min_));
    y_min_ -= pad;
    y_max_ += pad;
  }
  value_axis_->setRange(y_min_, y_max_);
  const double value_tick = NiceTickInterval(y_max_ - y_min_, 6);
  value_axis_->setTickInterval(value_tick);
  value_axis_->setLabelFormat(LabelFormat(value_tick));
  chart()->setTitle(t_.empty() ? tr("No accelerometer data in this recording") : QString());
  drawn_.reset();
  redraw();
}

QSize AccelPlot::sizeHint() const { return {800, 230}; }

double AccelPlot::drawnCursorTime() const {
  return cursor_->count() > 0 ? cursor_->at(0).x() : 0.0;
}

double AccelPlot::visibleStart() const { return time_axis_->min(); }

double AccelPlot::visibleEnd() const { return time_axis_->max(); }

void AccelPlot::setCursorTime(double seconds) {
  cursor_s_ = seconds;
  scheduleRedraw();
}

void AccelPlot::setWindowSeconds(double seconds) {
  seconds = std::clamp(seconds, kMinWindowSeconds, kMaxWindowSeconds);
  if (seconds == window_s_) return;
  window_s_ = seconds;
  scheduleRedraw();
  emit windowSecondsChanged(window_s_);
}

void AccelPlot::mousePressEvent(QMouseEvent* event) {
  if (event->button() == Qt::LeftButton) {
    seekTo(event->pos());
    event->accept();
    return;
  }
  QChartView::mousePressEvent(event);
}

void AccelPlot::mouseMoveEvent(QMouseEvent* event) {
  if (event->buttons() & Qt::LeftButton) {
    seekTo(event->pos());
    event->accept();
    return;
  }
  QChartView::mouseMoveEvent(event);
}

void AccelPlot::wheelEvent(QWheelEvent* event) {
  const int steps = event->angleDelta().y() / 120;
  if (steps != 0) setWindowSeconds(window_s_ * std::pow(1.25, -steps));
  event->accept();
}

void AccelPlot::resizeEvent(QResizeEvent* event) {
  QChartView::resizeEvent(event);
  scheduleRedraw();  // The number of pixel columns, hence the decimation, changed.
}

void AccelPlot::seekTo(const QPoint& pos) {
  const QPointF in_chart = chart()->mapFromScene(mapToScene(pos));
  const QRectF area = chart()->plotArea();
  if (area.isEmpty()) return;
  // Clicks left or right of the plot area go to the window's edges.
  const double x = std::clamp(in_chart.x(), area.left(), area.right());
  const double t = time_axis_->min() +
                   (x - area.left()) / area.width() * (time_axis_->max() - time_axis_->min());
  emit seekRequested(t);
}

void AccelPlot::showEvent(QShowEvent* event) {
  QChartView::showEvent(event);
  if (redraw_when_shown_) scheduleRedraw();
}

void AccelPlot::scheduleRedraw() {
  if (!isVisible()) {
    redraw_when_shown_ = true;
    return;
  }
  if (redraw_timer_.isActive()) return;
  const qint64 since = since_redraw_.isValid() ? since_redraw_.elapsed() : kMinRedrawIntervalMs;
  redraw_timer_.start(static_cast<int>(std::max<qint64>(0, kMinRedrawIntervalMs - since)));
}

void AccelPlot::redraw() {
  since_redraw_.start();
  redraw_when_shown_ = false;
  // A window centred on the cursor, held inside the recording near its ends; a recording
  // shorter than the window is shown whole, not in a corner of an empty plot.
  const double span = duration_s_ > 0.0 ? std::min(window_s_, duration_s_) : window_s_;
  const double t0 = std::clamp(cursor_s_ - span / 2.0, 0.0, std::max(0.0, duration_s_ - span));
  const double t1 = t0 + span;
  const int columns = std::max(1, static_cast<int>(chart()->plotArea().width()));
  // While the window holds still (a recording shorter than it, or the cursor near an end)
  // only the cursor moves: the curves are not replaced, so not drawn again.
  const DrawnSpan drawn{t0, t1, columns};
  if (drawn != drawn_) {
    drawn_ = drawn;
    time_axis_->setRange(t0, t1);
    const double time_tick = NiceTickInterval(span, 10);
    time_axis_->setTickInterval(time_tick);
    time_axis_->setLabelFormat(LabelFormat(time_tick));
    const SampleRange range = VisibleRange(t_, t0, t1);
    for (size_t axis = 0; axis < 3; ++axis) {
      series_[axis]->replace(DecimateMinMax(t_, values_[axis], range, columns));
    }
  }
  cursor_->replace(QVector<QPointF>{{cursor_s_, y_min_}, {cursor_s_, y_max_}});
}

}  // namespace autocal
