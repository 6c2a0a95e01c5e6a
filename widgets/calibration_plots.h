// The calibration over time: one chart per intrinsic and one for the reprojection error,
// each with the attempts (accepted, rejected, off the trend) as markers, the filtered
// calibration (the trend) as a line, alarms as vertical lines and, when given, the ground
// truth. All charts share one time range (zoom, pan) and one time cursor.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include <QTimer>
#include <QWidget>
#include <QtCharts/QChartView>
#include <QtCharts/QLineSeries>
#include <QtCharts/QScatterSeries>
#include <QtCharts/QValueAxis>

#include "pipeline/camera_model.h"
#include "widgets/calibration_series.h"

class QAction;
class QCheckBox;
class QLabel;

namespace autocal {

#if QT_VERSION < QT_VERSION_CHECK(6, 0, 0)
// Qt 5 keeps Qt Charts in a namespace of its own; Qt 6 does not.
using QtCharts::QAbstractSeries;
using QtCharts::QChart;
using QtCharts::QChartView;
using QtCharts::QLineSeries;
using QtCharts::QScatterSeries;
using QtCharts::QValueAxis;
#endif

// How an attempt is marked: accepted, rejected, or off the trend in a way that raised an
// alarm or started a new regime. "No update" attempts have no estimate to draw: each chart
// marks them apart, in a row along its foot (CalibrationChart::noUpdates).
enum class MarkerClass { kAccepted, kRejected, kJump };
inline constexpr int kNumMarkerClasses = 3;

// Marker and line colours, shared with the legend and the tests.
QColor MarkerColor(MarkerClass marker);
QColor TrendColor();
QColor TruthColor();
QColor AlarmColor();
QColor NoUpdateColor();
// The compared run: its trend dash-dotted, the attempts it took as hollow circles.
QColor CompareColor();

// One channel's chart. Mouse input is turned into requests in time; CalibrationPlots
// carries them out for every chart at once.
class CalibrationChart : public QChartView {
  Q_OBJECT

 public:
  CalibrationChart(int channel, QWidget* parent = nullptr);

  int channel() const { return channel_; }
  QScatterSeries* markers(MarkerClass marker) const { return markers_[static_cast<int>(marker)]; }
  QLineSeries* trend() const { return trend_; }
  QLineSeries* truth() const { return truth_; }
  QLineSeries* cursor() const { return cursor_; }
  // The attempts that made no update (unfit images, too little motion, ...), at their times
  // along the foot of the chart, whatever the value axis shows.
  QScatterSeries* noUpdates() const { return no_updates_; }
  // The compared run's trend and the attempts it took (accepted, alarm, new regime).
  QLineSeries* compareTrend() const { return compare_trend_; }
  QScatterSeries* compareMarkers() const { return compare_markers_; }
  QValueAxis* timeAxis() const { return time_axis_; }
  QValueAxis* valueAxis() const { return value_axis_; }
  // Alarm lines, one series each.
  const std::vector<QLineSeries*>& alarms() const { return alarms_; }
  // Where (time, value) is drawn, in this view's pixels.
  QPoint positionOf(double t_s, double value) const;

 signals:
  void zoomRequested(double t_s, double factor);  // Around t_s; factor < 1 zooms in.
  void panRequested(double dt_s);
  void seekRequested(double t_s);
  void resetRequested();
  // The plot area changed size: the decimation depends on its width.
  void resized();

 protected:
  void resizeEvent(QResizeEvent* event) override;
  void mousePressEvent(QMouseEvent* event) override;
  void mouseMoveEvent(QMouseEvent* event) override;
  void mouseReleaseEvent(QMouseEvent* event) override;
  void mouseDoubleClickEvent(QMouseEvent* event) override;
  void wheelEvent(QWheelEvent* event) override;

 private:
  friend class CalibrationPlots;

  double timeAt(const QPoint& pos) const;
  void setAlarmCount(int count);

  int channel_;
  QValueAxis* time_axis_;
  QValueAxis* value_axis_;
  std::array<QScatterSeries*, kNumMarkerClasses> markers_;
  QScatterSeries* no_updates_;
  QLineSeries* trend_;
  QLineSeries* truth_;
  QLineSeries* cursor_;
  QLineSeries* compare_trend_;
  QScatterSeries* compare_markers_;
  std::vector<QLineSeries*> alarms_;
  QPoint press_pos_, last_pos_;  // Where the left button went down, and was last seen.
  bool dragging_ = false;        // Moved far enough since the press to be a pan.
};

class CalibrationPlots : public QWidget {
  Q_OBJECT

 public:
  explicit CalibrationPlots(QWidget* parent = nullptr);

  // Shows `series` (null: nothing) over its whole time span. A newer read of the file
  // shown keeps the view when it was zoomed in, and shows the whole of it otherwise.
  void setSeries(std::shared_ptr<const CalibrationSeries> series);
  const CalibrationSeries* series() const { return series_.get(); }
  // Times are drawn in seconds since `origin_ns` (the recording's start, so that the cursor
  // matches the video's; without a recording, the first attempt).
  void setTimeOrigin(int64_t origin_ns);
  int64_t timeOrigin() const { return origin_ns_; }
  // The true intrinsics over time, drawn as a line; empty: none.
  void setGroundTruth(std::vector<std::pair<int64_t, CameraIntrinsics>> truth);

  // Compare runs: a second history of the same recording (another run's settings), drawn
  // over the first on the same time axis in a style of its own (CompareColor) and named in
  // the legend beside the first. Null: no comparison.
  void setCompareSeries(std::shared_ptr<const CalibrationSeries> compare);
  const CalibrationSeries* compareSeries() const { return compare_.get(); }
  // Reads a history file off the GUI thread and compares with it; a failure is reported
  // by compareFailed and leaves the comparison as it was.
  void openCompare(const QString& path);
  // For the main window's File menu: "Compare With History…" (asks for a file, then
  // openCompare) and "Clear Comparison".
  QAction* compareAction() const { return compare_action_; }
  QAction* clearCompareAction() const { return clear_compare_action_; }

  QSize sizeHint() const override;
  CalibrationChart* chart(int channel) const { return charts_[channel]; }
  double visibleStart() const { return t0_; }
  double visibleEnd() const { return t1_; }
  double cursorTime() const { return cursor_s_; }
  bool showsRejected() const;
  // The tooltip text for an attempt: time, verdict, reason, value.
  QString describeAttempt(int id, int channel) const;
  // The attempt drawn at `point` (time, value) of `marker` in `channel`; -1 when none.
  int attemptAt(int channel, MarkerClass marker, const QPointF& point) const;
  // The no-update attempt drawn at time `t_s`; -1 when none.
  int noUpdateAt(double t_s) const;

  // Saves the charts and the legend as PNG or SVG, by the file's suffix. On failure returns
  // false with the reason in `error`.
  bool exportImage(const QString& path, QString* error);

  // Redraws now instead of at the next turn of the event loop.
  void redrawNow();

 public slots:
  void setCursorTime(double seconds);
  void setVisibleRange(double t0_s, double t1_s);
  // The whole history (and the cursor) in view.
  void resetZoom();
  void setShowRejected(bool show);

 signals:
  void seekRequested(double seconds);
  void visibleRangeChanged(double t0_s, double t1_s);
  // `message` names the file.
  void compareFailed(const QString& path, const QString& message);

 private:
  // Per channel and marker class: the attempts' times (s since the origin) and values, and
  // their ids for tooltips, in time order.
  struct Points {
    std::vector<double> t, v;
    std::vector<int> id;
  };
  struct Line {
    std::vector<double> t, v;
  };

  // Reshapes the series and truth for drawing; shows everything unless `keep_view`.
  void rebuild(bool keep_view = false);
  void showEvent(QShowEvent* event) override;
  void exportDialog();
  void zoom(double t_s, double factor);
  void pan(double dt_s);
  void showTooltip(int channel, MarkerClass marker, const QPointF& point, bool state);
  void showTooltipText(int channel, const QString& text, bool state);
  // Coalesced to one redraw per turn of the event loop; none while the plots are hidden
  // (a tab behind another), which redraw when shown.
  void scheduleRedraw();
  void redraw();
  // Moves the cursor alone: while a recording plays it moves with every frame.
  void moveCursor();
  // The charts of a column share one time axis: their plot areas are made to start at one
  // x, so that a time (the cursor, an alarm) is one vertical line down the column.
  void alignPlotAreas();
  double toSeconds(int64_t t_ns) const;
  // The time span of everything there is to draw.
  std::pair<double, double> fullRange() const;

  std::shared_ptr<const CalibrationSeries> series_;
  std::vector<std::pair<int64_t, CameraIntrinsics>> truth_;
  int64_t origin_ns_ = 0;
  bool origin_set_ = false;
  std::array<std::array<Points, kNumMarkerClasses>, kNumCalibrationChannels> points_;
  Points no_updates_;  // Values unused: the row sits at each chart's foot.
  std::array<Line, kNumCalibrationChannels> trend_;
  std::array<Line, kNumCalibrationChannels> truth_lines_;
  std::array<Points, kNumCalibrationChannels> compare_points_;
  std::array<Line, kNumCalibrationChannels> compare_trend_;
  std::shared_ptr<const CalibrationSeries> compare_;
  HistoryOpener compare_opener_;
  QAction* compare_action_;
  QAction* clear_compare_action_;
  QLabel* compare_legend_;
  std::vector<double> alarm_t_;
  double t0_ = 0.0, t1_ = 1.0;
  double cursor_s_ = 0.0;

  QWidget* grid_;
  QLabel* title_;
  QCheckBox* show_rejected_;
  std::array<CalibrationChart*, kNumCalibrationChannels> charts_;
  QTimer redraw_timer_;
  bool redraw_when_shown_ = false;
  bool aligning_ = false;  // Margins set by alignPlotAreas move the plot areas again.
};

}  // namespace autocal
