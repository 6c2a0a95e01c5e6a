// The accelerometer's three axes against time, in a window that follows the time cursor.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include <QElapsedTimer>
#include <QTimer>
#include <QtCharts/QChart>
#include <QtCharts/QChartView>
#include <QtCharts/QLineSeries>
#include <QtCharts/QValueAxis>

namespace autocal {

#if QT_VERSION < QT_VERSION_CHECK(6, 0, 0)
// Qt 5 keeps Qt Charts in a namespace of its own; Qt 6 does not.
using QtCharts::QChart;
using QtCharts::QChartView;
using QtCharts::QLineSeries;
using QtCharts::QValueAxis;
#endif

struct AccelSample;

class AccelPlot : public QChartView {
  Q_OBJECT

 public:
  static constexpr double kMinWindowSeconds = 0.5;
  static constexpr double kMaxWindowSeconds = 600.0;

  explicit AccelPlot(QWidget* parent = nullptr);

  // Copies the samples; times are drawn in seconds since `start_ns`, and the window
  // never scrolls past [0, duration_s].
  void setSamples(const std::vector<AccelSample>& samples, int64_t start_ns, double duration_s);

  QSize sizeHint() const override;
  // The window asked for; the span shown is the recording's when that is shorter.
  double windowSeconds() const { return window_s_; }
  double durationSeconds() const { return duration_s_; }
  // Where the cursor line is drawn now (it catches up with setCursorTime on the next
  // redraw).
  double drawnCursorTime() const;
  // The time span on screen.
  double visibleStart() const;
  double visibleEnd() const;

 public slots:
  void setCursorTime(double seconds);
  void setWindowSeconds(double seconds);

 signals:
  // The user clicked or dragged on the plot at this time.
  void seekRequested(double seconds);
  void windowSecondsChanged(double seconds);

 protected:
  void mousePressEvent(QMouseEvent* event) override;
  void mouseMoveEvent(QMouseEvent* event) override;
  void wheelEvent(QWheelEvent* event) override;
  void resizeEvent(QResizeEvent* event) override;
  void showEvent(QShowEvent* event) override;

 private:
  // Redraws follow the cursor at most this often: a chart's redraw costs the GUI thread
  // more than a video frame, and the video comes first.
  static constexpr int kMinRedrawIntervalMs = 66;

  void seekTo(const QPoint& pos);
  // Redraws are coalesced: many cursor moves between two frames cost one redraw; none is
  // made while the plot is hidden (it redraws when shown).
  void scheduleRedraw();
  void redraw();

  // The time span and pixel columns the curves were last drawn for.
  struct DrawnSpan {
    double t0, t1;
    int columns;
    bool operator==(const DrawnSpan&) const = default;
  };

  std::vector<double> t_;  // Seconds since the start.
  std::array<std::vector<double>, 3> values_;
  double duration_s_ = 0.0;
  double cursor_s_ = 0.0;
  double window_s_ = 10.0;
  double y_min_ = -1.0, y_max_ = 1.0;

  QValueAxis* time_axis_;
  QValueAxis* value_axis_;
  std::array<QLineSeries*, 3> series_;
  QLineSeries* cursor_;
  QTimer redraw_timer_;
  QElapsedTimer since_redraw_;
  bool redraw_when_shown_ = false;
  std::optional<DrawnSpan> drawn_;
};

}  // namespace autocal
