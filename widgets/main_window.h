// The workbench window: opens a recording and binds the views to one playback cursor.
// It wires and draws; opening, decoding and timing live in the non-widget controllers.
#pragma once

#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include <QElapsedTimer>
#include <QMainWindow>
#include <QString>
#include <QTimer>

#include "widgets/overlay_painter.h"
#include "widgets/video_view.h"

class QAction;
class QActionGroup;
class QComboBox;
class QDockWidget;
class QDoubleSpinBox;
class QLabel;
class QMenu;
class QPlainTextEdit;
class QSlider;
class QToolButton;

namespace autocal {

class AccelPlot;
class CalibrationPlots;
class DevicePanel;
class ElidedLabel;
struct CalibrationSeries;
class FrameLoader;
class HistoryOpener;
class HistoryTable;
class TimingTable;
class LiveSession;
struct FrameOverlays;
struct FrameSnapshot;
class PipelineController;
class PlaybackController;
class SceneView;
class ThresholdPanel;
class Sequence;
class SequenceOpener;
struct SessionInfo;

class MainWindow : public QMainWindow {
  Q_OBJECT

 public:
  // What the workbench opens when it is given nothing: the built-in simulated vest.
  static constexpr const char* kDefaultSource = "sim:office";

  explicit MainWindow(QWidget* parent = nullptr);
  ~MainWindow() override;

  PlaybackController* playback() const { return playback_; }
  // Runs boxes 1-10 over the open recording; other docks follow it through snapshotReady.
  PipelineController* pipelineController() const { return pipeline_; }
  VideoView* videoView() const { return video_; }
  AccelPlot* accelPlot() const { return plot_; }
  CalibrationPlots* calibrationPlots() const { return calibration_plots_; }
  HistoryTable* historyTable() const { return history_table_; }
  TimingTable* timingTable() const { return timing_table_; }
  ThresholdPanel* thresholdPanel() const { return threshold_panel_; }
  SceneView* sceneView() const { return scene_view_; }
  // The Devices dock's session: while it is connected the video view shows its frames.
  LiveSession* liveSession() const { return live_session_; }
  // The open recording (null until one opened) and what it was opened from.
  const Sequence* sequence() const { return sequence_.get(); }
  const QString& source() const { return source_; }
  // The pre-mission calibration file set by hand (empty: each source's own).
  const QString& premissionFile() const { return premission_file_; }
  // The action that switches an overlay layer, and the one that picks a view mode.
  QAction* overlayAction(OverlayLayer layer) const;
  QAction* viewModeAction(VideoView::ViewMode mode) const;
  // Playback › Follow the Pipeline: while checked, the video view shows each frame as the
  // pipeline finishes it (the newest one when the window is slower), with its overlays.
  QAction* followPipelineAction() const { return follow_action_; }
  // Frames put on screen per second by the video view, over the last second while playing,
  // following the pipeline or showing a live source (0 when paused).
  double displayFps() const { return display_fps_; }

 public slots:
  // Opens a folder, a video or "sim:SPEC" in the background, then plays it. On failure
  // the error is shown and logged, and the recording open before stays.
  void open(const QString& source);
  // Opens a calibration history file (SQLite, as `autocal run` writes) in the background and
  // shows it in the Calibration and History docks. On failure the history shown stays.
  void openHistory(const QString& path);
  // The pre-mission calibration every pipeline starts from and is judged against instead of
  // the source's own: a file in any format `autocal` reads; empty: each source's own. The
  // open recording's run starts again from it, and the Devices dock and the vest check
  // connect with it. False, with the reason logged and shown, when the file cannot be read
  // (what was set stays).
  bool setPremissionFile(const QString& path);

 signals:
  void opened(const QString& source);
  void openFailed(const QString& source, const QString& message);
  void historyOpened(const QString& path);
  void historyFailed(const QString& path, const QString& message);
  // A decoded frame reached the screen.
  void frameShown(int index);
  // Every frame the pipeline has done, in frame order (PipelineController::snapshotReady).
  void snapshotReady(std::shared_ptr<const autocal::FrameSnapshot> snapshot);

 protected:
  void closeEvent(QCloseEvent* event) override;
  void dragEnterEvent(QDragEnterEvent* event) override;
  void dropEvent(QDropEvent* event) override;

 private:
  void createActions();
  void createCentralArea();
  void createDocks();
  void createOverlayControls();
  // Docks and dialogs that follow the pipeline: thresholds, the 3-D view, the vest check.
  void createPipelineDocks();
  void createStatusBar();
  void connectControllers();
  void restoreSettings();

  void onOpened(const QString& source, std::shared_ptr<const Sequence> sequence);
  // The settings take the rolling shutter the recording's camera states, as `autocal run`
  // does; a readout the last recording set goes with it.
  void takeRecordingsShutter(const SessionInfo& session);
  void onFirstFrameSettled();
  void onOpenFailed(const QString& source, const QString& message);
  void onHistoryOpened(const QString& path, std::shared_ptr<const CalibrationSeries> series);
  void onHistoryFailed(const QString& path, const QString& message);
  void onHistoryUpdated(const QString& path, std::shared_ptr<const CalibrationSeries> series);
  // A history of an earlier pipeline run, still read or followed after a new run began.
  bool isReplacedRunHistory(const QString& path) const;
  // Plots and table go where the video would be at `seconds`, or there alone without video.
  void seekToTime(double seconds);
  void onFrameChanged(int index);
  void onPlayingChanged(bool playing);
  void onOverlaysChanged(const FrameOverlays& overlays);
  void onLayersToggled();
  void onViewModeChosen(QAction* action);
  void onPipelineProgress();
  // The live session's newest frame goes on screen with its overlays, and the plot shows
  // the live accelerometer.
  void onLiveFrame();
  // The open recording's accelerometer in the plot.
  void showRecordingAccel();
  // The live source's last minute of accelerometer in the plot, the newest sample at the
  // right, the cursor on the frame shown.
  void showLiveAccel(int64_t frame_t_ns);
  // Once a second: the display's frame rate, the pipeline's progress and its timing.
  void onRateTick();
  // The Timing dock: the live pipeline's while live, else the recording's run's.
  void showTiming();
  void openFolderDialog();
  void openVideoDialog();
  void openSimulationDialog();
  void openHistoryDialog();
  void openPremissionDialog();
  void showAbout();
  // A message box that does not block: the error's `detail` selectable for copying.
  void showErrorBox(const QString& title, const QString& text, const QString& detail);
  // The one logging path: the log dock and stderr.
  void log(const QString& message, bool is_error = false);
  QString dialogStartDir() const;

  PlaybackController* playback_;
  PipelineController* pipeline_;
  FrameLoader* loader_;
  SequenceOpener* opener_;
  HistoryOpener* history_opener_;
  std::shared_ptr<const Sequence> sequence_;
  QString source_;
  QString last_path_;
  QString premission_file_;

  VideoView* video_ = nullptr;
  AccelPlot* plot_ = nullptr;
  CalibrationPlots* calibration_plots_ = nullptr;
  HistoryTable* history_table_ = nullptr;
  TimingTable* timing_table_ = nullptr;
  ThresholdPanel* threshold_panel_ = nullptr;
  SceneView* scene_view_ = nullptr;
  LiveSession* live_session_ = nullptr;
  DevicePanel* device_panel_ = nullptr;
  QDockWidget* plot_dock_ = nullptr;
  QDockWidget* calibration_dock_ = nullptr;
  QPlainTextEdit* log_ = nullptr;
  QSlider* slider_ = nullptr;
  QLabel* position_label_ = nullptr;
  QComboBox* speed_box_ = nullptr;
  QDoubleSpinBox* window_box_ = nullptr;
  ElidedLabel* status_source_ = nullptr;
  QLabel* status_resolution_ = nullptr;
  QLabel* status_fps_ = nullptr;
  QLabel* status_position_ = nullptr;
  QLabel* status_found_ = nullptr;
  ElidedLabel* status_lens_ = nullptr;  // Box 2's verdict on the lens.
  QLabel* status_pipeline_ = nullptr;
  QLabel* status_display_ = nullptr;

  QMenu* view_menu_ = nullptr;
  QActionGroup* view_mode_group_ = nullptr;
  // A history opened by hand stays in the docks; else they follow the pipeline's run.
  bool history_opened_by_hand_ = false;
  // A recording opened, its first frame not on screen (nor found unreadable) yet: its run,
  // and its playback unless the user took charge meanwhile, wait for that picture.
  bool awaiting_first_frame_ = false;
  bool play_on_first_frame_ = false;
  double recording_readout_ms_ = 0.0;     // The readout the open recording states (0: none).
  std::shared_ptr<const FrameSnapshot> last_live_snapshot_;  // Forwarded last.
  // A live source is connected: the video shows its frames, not the recording's.
  bool live_ = false;
  QElapsedTimer live_plot_clock_;  // Since the plot last took the live accelerometer.
  static constexpr int kLivePlotIntervalMs = 66;
  QTimer rate_timer_;
  QElapsedTimer rate_clock_;
  uint64_t frames_painted_at_tick_ = 0;
  double display_fps_ = 0.0;
  // Frames painted and seconds played while the pipeline ran: the display's rate under load.
  uint64_t run_frames_painted_ = 0;
  double run_seconds_played_ = 0.0;

  QAction* play_action_ = nullptr;
  QAction* step_back_action_ = nullptr;
  QAction* step_forward_action_ = nullptr;
  QAction* start_action_ = nullptr;
  QAction* end_action_ = nullptr;
  QAction* follow_action_ = nullptr;
  QAction* own_premission_action_ = nullptr;  // Back to each source's own calibration.
  std::vector<std::pair<OverlayLayer, QAction*>> layer_actions_;
};

}  // namespace autocal
