#include "widgets/main_window.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <utility>
#include <vector>

#include <QAction>
#include <QActionGroup>
#include <QApplication>
#include <QCloseEvent>
#include <QComboBox>
#include <QDateTime>
#include <QDockWidget>
#include <QDoubleSpinBox>
#include <QDragEnterEvent>
#include <QDropEvent>
#include <QFileDialog>
#include <QFileInfo>
#include <QHBoxLayout>
#include <QInputDialog>
#include <QLabel>
#include <QMenuBar>
#include <QMessageBox>
#include <QMimeData>
#include <QPlainTextEdit>
#include <QPushButton>
#include <QScreen>
#include <QSettings>
#include <QSignalBlocker>
#include <QSlider>
#include <QStatusBar>
#include <QStyle>
#include <QToolBar>
#include <QToolButton>
#include <QUrl>
#include <QVBoxLayout>

#include "devices/sequence.h"
#include "pipeline/version.h"
#include "widgets/accel_plot.h"
#include "widgets/calibration_file_field.h"
#include "widgets/calibration_plots.h"
#include "widgets/calibration_series.h"
#include "widgets/device_panel.h"
#include "widgets/elided_label.h"
#include "widgets/frame_loader.h"
#include "widgets/history_table.h"
#include "widgets/image_convert.h"
#include "widgets/live_session.h"
#include "widgets/pipeline_controller.h"
#include "widgets/playback_controller.h"
#include "widgets/scene_view.h"
#include "widgets/sequence_opener.h"
#include "widgets/threshold_panel.h"
#include "widgets/timing_table.h"
#include "widgets/vest_check_dialog.h"
#include "widgets/video_view.h"

namespace autocal {
namespace {

// QSettings keys.
constexpr char kGeometryKey[] = "window/geometry";
constexpr char kStateKey[] = "window/state";
constexpr char kSpeedKey[] = "playback/speed";
constexpr char kPlotWindowKey[] = "plot/window_seconds";
constexpr char kLastPathKey[] = "files/last_path";
constexpr char kOverlayKeyPrefix[] = "overlays/";  // + the layer's key: on or off.
constexpr char kViewModeKey[] = "overlays/view";   // raw, rectified or side_by_side.
// Bumped when the docks change, so an old saved layout is not applied to a new one.
constexpr int kStateVersion = 2;

constexpr double kSpeeds[] = {0.25, 0.5, 1.0, 2.0, 4.0};

QString FormatSeconds(double seconds) { return QStringLiteral("%1 s").arg(seconds, 0, 'f', 3); }

struct ViewModeEntry {
  VideoView::ViewMode mode;
  const char* key;
  const char* name;        // In the menu.
  const char* short_name;  // On the toolbar.
};
constexpr ViewModeEntry kViewModes[] = {
    {VideoView::ViewMode::kRaw, "raw", QT_TR_NOOP("&Raw Video"), QT_TR_NOOP("Raw")},
    {VideoView::ViewMode::kRectified, "rectified", QT_TR_NOOP("Re&ctified Video (Box 3)"),
     QT_TR_NOOP("Rectified")},
    {VideoView::ViewMode::kSideBySide, "side_by_side",
     QT_TR_NOOP("Raw and Rectified &Side by Side"), QT_TR_NOOP("Side by side")},
};

// A label whose text changes with every frame is given a fixed size that fits `widest`: a
// label that may change size makes the whole window lay itself out again at each change,
// which costs the GUI thread more than the frame's drawing.
void FixSize(QLabel* label, const QString& widest) {
  const QFontMetrics metrics = label->fontMetrics();
  label->setFixedSize(metrics.horizontalAdvance(widest) + 2 * label->margin() + 4,
                      label->sizeHint().height());
}

QToolButton* TransportButton(QAction* action) {
  auto* button = new QToolButton;
  button->setDefaultAction(action);
  button->setAutoRaise(true);
  button->setIconSize(QSize(24, 24));
  // Keys belong to the window's shortcuts: a focused button would eat the space bar.
  button->setFocusPolicy(Qt::NoFocus);
  return button;
}

}  // namespace

MainWindow::MainWindow(QWidget* parent)
    : QMainWindow(parent),
      playback_(new PlaybackController(this)),
      pipeline_(new PipelineController(this)),
      loader_(new FrameLoader(this)),
      opener_(new SequenceOpener(this)),
      history_opener_(new HistoryOpener(this)) {
  setWindowTitle(tr("autocal workbench"));
  setAcceptDrops(true);
  createActions();
  createCentralArea();
  createDocks();
  createOverlayControls();
  createPipelineDocks();
  createStatusBar();
  connectControllers();
  restoreSettings();
  video_->showMessage(tr("No recording open.\nFile \u203a Open Recording Folder\u2026"));
  video_->setFocus();
}

MainWindow::~MainWindow() = default;

void MainWindow::createActions() {
  QMenu* file = menuBar()->addMenu(tr("&File"));
  QAction* open_folder =
      file->addAction(style()->standardIcon(QStyle::SP_DirOpenIcon),
                      tr("Open Recording &Folder\u2026"), this, &MainWindow::openFolderDialog);
  open_folder->setShortcut(QKeySequence::Open);
  file->addAction(tr("Open &Video\u2026"), this, &MainWindow::openVideoDialog);
  file->addAction(tr("Open &Simulation\u2026"), this, &MainWindow::openSimulationDialog);
  file->addAction(tr("Open Simulated &Vest (%1)").arg(QString::fromLatin1(kDefaultSource)), this,
                  [this] { open(QString::fromLatin1(kDefaultSource)); });
  file->addSeparator();
  QAction* open_history =
      file->addAction(tr("Open &History…"), this, &MainWindow::openHistoryDialog);
  open_history->setShortcut(Qt::CTRL | Qt::SHIFT | Qt::Key_O);
  file->addSeparator();
  file->addAction(tr("Pre-mission &Calibration…"), this, &MainWindow::openPremissionDialog);
  own_premission_action_ = file->addAction(tr("Each Source's &Own Pre-mission Calibration"), this,
                                           [this] { setPremissionFile(QString()); });
  own_premission_action_->setEnabled(false);
  file->addSeparator();
  QAction* quit = file->addAction(tr("&Quit"), this, &QWidget::close);
  quit->setShortcut(QKeySequence::Quit);

  QMenu* play = menuBar()->addMenu(tr("&Playback"));
  play_action_ = play->addAction(style()->standardIcon(QStyle::SP_MediaPlay), tr("&Play"),
                                 playback_, &PlaybackController::togglePlaying);
  play_action_->setShortcut(Qt::Key_Space);
  step_back_action_ =
      play->addAction(style()->standardIcon(QStyle::SP_MediaSeekBackward),
                      tr("Step &Back One Frame"), playback_, &PlaybackController::stepBackward);
  step_back_action_->setShortcut(Qt::Key_Left);
  step_forward_action_ =
      play->addAction(style()->standardIcon(QStyle::SP_MediaSeekForward),
                      tr("Step &Forward One Frame"), playback_, &PlaybackController::stepForward);
  step_forward_action_->setShortcut(Qt::Key_Right);
  start_action_ = play->addAction(style()->standardIcon(QStyle::SP_MediaSkipBackward),
                                  tr("Go to &Start"), playback_, &PlaybackController::seekToStart);
  start_action_->setShortcut(Qt::Key_Home);
  end_action_ = play->addAction(style()->standardIcon(QStyle::SP_MediaSkipForward),
                                tr("Go to &End"), playback_, &PlaybackController::seekToEnd);
  end_action_->setShortcut(Qt::Key_End);
  play->addSeparator();
  follow_action_ = play->addAction(tr("F&ollow the Pipeline"));
  follow_action_->setIconText(tr("Follow"));
  follow_action_->setCheckable(true);
  follow_action_->setShortcut(QKeySequence(QStringLiteral("Ctrl+Shift+F")));
  // Playing at the recording's pace and following the pipeline exclude each other.
  connect(follow_action_, &QAction::toggled, this, [this](bool on) {
    if (!on) return;
    play_on_first_frame_ = false;
    playback_->pause();
    if (pipeline_->framesDone() > 0 && !live_) playback_->seekToIndex(pipeline_->framesDone() - 1);
  });
  connect(playback_, &PlaybackController::playingChanged, this, [this](bool playing) {
    play_on_first_frame_ = false;  // Played or paused by hand before the first picture.
    if (playing) follow_action_->setChecked(false);
  });
  for (QAction* action : {play_action_, step_back_action_, step_forward_action_, start_action_,
                          end_action_, follow_action_}) {
    action->setToolTip(QStringLiteral("%1 (%2)").arg(action->text().remove(QLatin1Char('&')),
                                                     action->shortcut().toString()));
  }
}

void MainWindow::createCentralArea() {
  video_ = new VideoView;

  slider_ = new QSlider(Qt::Horizontal);
  slider_->setFocusPolicy(Qt::NoFocus);
  slider_->setToolTip(tr("Drag to seek"));
  position_label_ = new QLabel;
  FixSize(position_label_, QStringLiteral("00000.000 s / 00000.000 s   frame 000000 of 000000"));

  speed_box_ = new QComboBox;
  speed_box_->setObjectName(QStringLiteral("speed"));
  speed_box_->setFocusPolicy(Qt::ClickFocus);
  speed_box_->setToolTip(tr("Playback speed"));
  for (double speed : kSpeeds) {
    speed_box_->addItem(QStringLiteral("%1\u00d7").arg(speed), speed);
  }
  speed_box_->setCurrentIndex(speed_box_->findData(playback_->speed()));

  window_box_ = new QDoubleSpinBox;
  window_box_->setObjectName(QStringLiteral("plot_window"));
  window_box_->setFocusPolicy(Qt::ClickFocus);
  window_box_->setRange(AccelPlot::kMinWindowSeconds, AccelPlot::kMaxWindowSeconds);
  window_box_->setDecimals(1);
  window_box_->setSuffix(tr(" s"));
  window_box_->setToolTip(
      tr("Time span the accelerometer plot shows (mouse wheel on the plot zooms)"));

  auto* transport = new QHBoxLayout;
  transport->setContentsMargins(6, 2, 6, 2);
  transport->setSpacing(6);
  for (QAction* action :
       {start_action_, step_back_action_, play_action_, step_forward_action_, end_action_}) {
    transport->addWidget(TransportButton(action));
  }
  transport->addWidget(slider_, 1);
  transport->addSpacing(8);
  transport->addWidget(position_label_);
  transport->addSpacing(12);
  transport->addWidget(new QLabel(tr("Speed")));
  transport->addWidget(speed_box_);
  auto* follow = new QToolButton;
  follow->setDefaultAction(follow_action_);
  follow->setFocusPolicy(Qt::NoFocus);
  transport->addWidget(follow);
  transport->addSpacing(12);
  transport->addWidget(new QLabel(tr("Plot window")));
  transport->addWidget(window_box_);

  auto* central = new QWidget;
  auto* layout = new QVBoxLayout(central);
  layout->setContentsMargins(0, 0, 0, 0);
  layout->setSpacing(0);
  layout->addWidget(video_, 1);
  layout->addLayout(transport);
  setCentralWidget(central);
}

void MainWindow::createDocks() {
  plot_ = new AccelPlot;
  plot_dock_ = new QDockWidget(tr("Accelerometer"), this);
  plot_dock_->setObjectName(QStringLiteral("accelerometer_dock"));
  plot_dock_->setWidget(plot_);
  addDockWidget(Qt::BottomDockWidgetArea, plot_dock_);
  // The other bottom docks are tabs beside the accelerometer's.
  const auto add_tab = [this](const QString& title, const QString& name, QWidget* widget) {
    auto* dock = new QDockWidget(title, this);
    dock->setObjectName(name);
    dock->setWidget(widget);
    addDockWidget(Qt::BottomDockWidgetArea, dock);
    tabifyDockWidget(plot_dock_, dock);
    return dock;
  };

  log_ = new QPlainTextEdit;
  log_->setObjectName(QStringLiteral("log"));
  log_->setReadOnly(true);
  log_->setMaximumBlockCount(5000);
  QDockWidget* log_dock = add_tab(tr("Log"), QStringLiteral("log_dock"), log_);
  calibration_plots_ = new CalibrationPlots;
  calibration_dock_ =
      add_tab(tr("Calibration"), QStringLiteral("calibration_dock"), calibration_plots_);
  history_table_ = new HistoryTable;
  QDockWidget* history_dock =
      add_tab(tr("History"), QStringLiteral("history_dock"), history_table_);
  timing_table_ = new TimingTable;
  QDockWidget* timing_dock = add_tab(tr("Timing"), QStringLiteral("timing_dock"), timing_table_);
  plot_dock_->raise();

  view_menu_ = menuBar()->addMenu(tr("&View"));
  view_menu_->addAction(plot_dock_->toggleViewAction());
  view_menu_->addAction(calibration_dock_->toggleViewAction());
  view_menu_->addAction(history_dock->toggleViewAction());
  view_menu_->addAction(timing_dock->toggleViewAction());
  view_menu_->addAction(log_dock->toggleViewAction());
}

void MainWindow::createOverlayControls() {
  auto* toolbar = new QToolBar(tr("Overlays"), this);
  toolbar->setObjectName(QStringLiteral("overlay_toolbar"));
  toolbar->setToolButtonStyle(Qt::ToolButtonTextOnly);
  toolbar->setFocusPolicy(Qt::NoFocus);
  addToolBar(Qt::TopToolBarArea, toolbar);
  toolbar->addWidget(new QLabel(tr(" Overlays: ")));

  view_menu_->addSeparator();
  QMenu* overlays = view_menu_->addMenu(tr("&Overlays"));
  const QSettings settings;
  const QString tips[] = {
      tr("Box 1: straight lines the Radon transform found (yellow)"),
      tr("Box 1: Radon snakes (cyan); hinges green when straight, red when bent 2° or more"),
      tr("Box 5: tracked points and their motion since the previous frame, in their plane's "
         "colour (grey: on no plane)"),
      tr("Box 6: dominant planes, outlined and numbered"),
      tr("Box 8: virtual checkerboards on the planes, through the current calibration (white): "
         "they stick to the texture when the calibration is right"),
      tr("Box 7: gravity (arrow from the principal point) and the horizon (dashed), magenta")};
  for (size_t i = 0; i < std::size(kAllOverlayLayers); ++i) {
    const OverlayLayer layer = kAllOverlayLayers[i];
    QAction* action = overlays->addAction(OverlayLayerName(layer));
    action->setObjectName(QStringLiteral("overlay_") + OverlayLayerKey(layer));
    action->setCheckable(true);
    action->setChecked(settings
                           .value(kOverlayKeyPrefix + OverlayLayerKey(layer),
                                  kDefaultOverlayLayers.testFlag(layer))
                           .toBool());
    action->setToolTip(tips[i]);
    action->setShortcut(QKeySequence(QStringLiteral("Alt+%1").arg(i + 1)));
    connect(action, &QAction::toggled, this, &MainWindow::onLayersToggled);
    toolbar->addAction(action);
    layer_actions_.emplace_back(layer, action);
  }
  overlays->addSeparator();
  toolbar->addSeparator();
  view_mode_group_ = new QActionGroup(this);
  const QString saved_mode = settings.value(kViewModeKey, QStringLiteral("raw")).toString();
  for (const ViewModeEntry& entry : kViewModes) {
    QAction* action = overlays->addAction(MainWindow::tr(entry.name));
    action->setIconText(MainWindow::tr(entry.short_name));
    action->setObjectName(QStringLiteral("view_") + QLatin1String(entry.key));
    action->setCheckable(true);
    action->setData(static_cast<int>(entry.mode));
    action->setChecked(saved_mode == QLatin1String(entry.key));
    view_mode_group_->addAction(action);
    toolbar->addAction(action);
  }
  if (!view_mode_group_->checkedAction()) view_mode_group_->actions().front()->setChecked(true);
  // Box 2's verdict on the lens takes the room the layers leave, elided to it (the whole
  // message in its tooltip); a lens the lines do not determine is said in red.
  status_lens_ = new ElidedLabel;
  status_lens_->setObjectName(QStringLiteral("status_lens"));
  status_lens_->setMinimumWidth(0);
  status_lens_->setAlignment(Qt::AlignRight | Qt::AlignVCenter);
  status_lens_->setSizePolicy(QSizePolicy::Expanding, QSizePolicy::Preferred);
  status_lens_->setContentsMargins(8, 0, 16, 0);  // Apart from the layers and what was found.
  toolbar->addWidget(status_lens_);
  // What the pipeline found in the frame on screen, beside the layers that draw it; a fixed
  // size, so that its text changing every frame does not lay the window out again.
  status_found_ = new QLabel;
  status_found_->setObjectName(QStringLiteral("status_found"));
  status_found_->setToolTip(tr("What the pipeline found in the frame on screen"));
  FixSize(status_found_, tr("%1 lines, %2 snakes, %3 tracks, %4 planes, %5 boards")
                             .arg(999)
                             .arg(999)
                             .arg(9999)
                             .arg(99)
                             .arg(99));
  toolbar->addWidget(status_found_);
  connect(view_mode_group_, &QActionGroup::triggered, this, &MainWindow::onViewModeChosen);
  view_menu_->addAction(toolbar->toggleViewAction());

  onLayersToggled();
  onViewModeChosen(view_mode_group_->checkedAction());
}

void MainWindow::createPipelineDocks() {
  threshold_panel_ = new ThresholdPanel;
  threshold_panel_->setOptions(pipeline_->options());
  auto* threshold_dock = new QDockWidget(tr("Thresholds"), this);
  threshold_dock->setObjectName(QStringLiteral("threshold_dock"));
  threshold_dock->setWidget(threshold_panel_);
  addDockWidget(Qt::RightDockWidgetArea, threshold_dock);
  threshold_dock->hide();  // For engineers tuning: View › Thresholds.
  connect(threshold_panel_, &ThresholdPanel::optionsChanged, pipeline_,
          &PipelineController::setOptions);
  connect(pipeline_, &PipelineController::optionsRefused, threshold_panel_,
          &ThresholdPanel::showError);

  scene_view_ = new SceneView;
  auto* scene_dock = new QDockWidget(tr("3-D View"), this);
  scene_dock->setObjectName(QStringLiteral("scene_dock"));
  scene_dock->setWidget(scene_view_);
  addDockWidget(Qt::BottomDockWidgetArea, scene_dock);
  tabifyDockWidget(calibration_dock_, scene_dock);
  plot_dock_->raise();  // Tabifying brought the new tab to the front.
  connect(this, &MainWindow::snapshotReady, scene_view_, &SceneView::showSnapshot);
  connect(pipeline_, &PipelineController::attemptAfterLastFrame, scene_view_,
          &SceneView::showAttempt);
  connect(pipeline_, &PipelineController::started, scene_view_, &SceneView::clear);

  view_menu_->insertAction(view_menu_->actions().at(4), scene_dock->toggleViewAction());
  view_menu_->insertAction(view_menu_->actions().at(5), threshold_dock->toggleViewAction());

  auto* session = new LiveSession(this);  // A child: closing the window ends a recording cleanly.
  live_session_ = session;
  auto* devices_dock = new QDockWidget(tr("Devices"), this);
  devices_dock->setObjectName(QStringLiteral("devices_dock"));
  device_panel_ = new DevicePanel(session);
  devices_dock->setWidget(device_panel_);
  addDockWidget(Qt::RightDockWidgetArea, devices_dock);
  devices_dock->hide();  // View › Devices.
  view_menu_->insertAction(view_menu_->actions().at(6), devices_dock->toggleViewAction());
  connect(session, &LiveSession::connected, this, [this](const QString& description) {
    play_on_first_frame_ = false;
    playback_->pause();
    live_ = true;
    log(tr("Live: %1").arg(description));
    // Two pipelines would halve the live one's frames on a small machine.
    if (pipeline_->isRunning()) {
      pipeline_->stop();
      log(tr("The pipeline's run over the recording stopped: the live source has the machine"));
    }
  });
  connect(session, &LiveSession::frameReady, this, &MainWindow::onLiveFrame);
  connect(session, &LiveSession::connectFailed, this,
          [this](const QString& message) { log(tr("Could not connect: %1").arg(message), true); });
  connect(session, &LiveSession::deviceEvent, this, [this](const QString& text) { log(text); });
  connect(session, &LiveSession::disconnected, this, [this] {
    log(tr("Live source ended"));
    live_ = false;
    pipeline_->endLive();
    // The recording comes back where it was; without one the last live frame and the
    // live accelerometer stay.
    if (playback_->frameCount() > 0) {
      loader_->request(playback_->frameIndex());
      showRecordingAccel();
      plot_->setCursorTime(playback_->currentTime());
    }
  });
  // The live pipeline's newest snapshot goes where the recording's go (the 3-D view).
  connect(session, &LiveSession::statusChanged, this, [this, session] {
    std::shared_ptr<const FrameSnapshot> snapshot = session->latestSnapshot();
    if (snapshot && snapshot != last_live_snapshot_) {
      last_live_snapshot_ = snapshot;
      emit snapshotReady(std::move(snapshot));
    }
  });
  connect(session, &LiveSession::recordingFailed, this,
          [this](const QString& message) { log(tr("Recording failed: %1").arg(message), true); });
  connect(session, &LiveSession::recordingStopped, this,
          [this](const QString& dir, const QString& summary) {
            log(tr("Recorded %1: %2").arg(dir, summary));
            auto* box = new QMessageBox(QMessageBox::Information, tr("Recording complete"),
                                        tr("Recorded %1").arg(dir), QMessageBox::Close, this);
            box->setInformativeText(summary);
            QPushButton* open_it = box->addButton(tr("Open It"), QMessageBox::AcceptRole);
            box->setAttribute(Qt::WA_DeleteOnClose);
            connect(box, &QMessageBox::buttonClicked, this,
                    [this, dir, open_it](QAbstractButton* button) {
                      if (button == open_it) open(dir);
                    });
            box->open();
          });

  QMenu* tools = menuBar()->addMenu(tr("&Tools"));
  tools->addAction(tr("&Vest Check\u2026"), this, [this] {
    // Its own runtime on its own source; playback pauses so the two do not share the CPU.
    playback_->pause();
    VestCheckDialog dialog(QStringLiteral("sim:office"), QString(), this);
    dialog.premissionEdit()->setText(premission_file_);
    dialog.exec();
  });

  QMenu* help = menuBar()->addMenu(tr("&Help"));
  help->addAction(tr("&About"), this, &MainWindow::showAbout);
}

QAction* MainWindow::overlayAction(OverlayLayer layer) const {
  for (const auto& [each, action] : layer_actions_) {
    if (each == layer) return action;
  }
  return nullptr;
}

QAction* MainWindow::viewModeAction(VideoView::ViewMode mode) const {
  for (QAction* action : view_mode_group_->actions()) {
    if (action->data().toInt() == static_cast<int>(mode)) return action;
  }
  return nullptr;
}

void MainWindow::onLayersToggled() {
  OverlayLayers layers;
  QSettings settings;
  for (const auto& [layer, action] : layer_actions_) {
    if (action->isChecked()) layers |= layer;
    settings.setValue(kOverlayKeyPrefix + OverlayLayerKey(layer), action->isChecked());
  }
  video_->setLayers(layers);
}

void MainWindow::onViewModeChosen(QAction* action) {
  const auto mode = static_cast<VideoView::ViewMode>(action->data().toInt());
  video_->setViewMode(mode);
  pipeline_->setRectifiedWanted(mode != VideoView::ViewMode::kRaw);
  for (const ViewModeEntry& entry : kViewModes) {
    if (entry.mode == mode) QSettings().setValue(kViewModeKey, QLatin1String(entry.key));
  }
}

void MainWindow::createStatusBar() {
  status_source_ = new ElidedLabel;
  status_resolution_ = new QLabel;
  status_fps_ = new QLabel;
  status_position_ = new QLabel;
  status_pipeline_ = new QLabel;
  status_pipeline_->setObjectName(QStringLiteral("status_pipeline"));
  status_pipeline_->setToolTip(
      tr("Frames boxes 1-10 have processed, and how many per second of wall-clock time"));
  status_display_ = new QLabel;
  status_display_->setObjectName(QStringLiteral("status_display"));
  status_display_->setToolTip(tr("Frames the video view put on screen in the last second"));
  FixSize(status_position_, QStringLiteral("frame 000000 of 000000  00000.000 s"));
  FixSize(status_pipeline_, tr("pipeline done %1 / %2 frames, %3 fps")
                                .arg(99999)
                                .arg(99999)
                                .arg(QStringLiteral("999.9")));
  FixSize(status_display_, tr("display %1 fps").arg(QStringLiteral("999.9")));
  // The source has the room the rest leaves (what was found is above the video, with the
  // layers), elided to it, and its whole text as a tooltip.
  status_source_->setObjectName(QStringLiteral("status_source"));
  status_source_->setMinimumWidth(0);
  statusBar()->addWidget(status_source_, 1);
  statusBar()->addPermanentWidget(status_pipeline_);
  statusBar()->addPermanentWidget(status_display_);
  statusBar()->addPermanentWidget(status_resolution_);
  statusBar()->addPermanentWidget(status_fps_);
  statusBar()->addPermanentWidget(status_position_);
}

void MainWindow::connectControllers() {
  connect(opener_, &SequenceOpener::opened, this, &MainWindow::onOpened);
  connect(opener_, &SequenceOpener::failed, this, &MainWindow::onOpenFailed);
  connect(history_opener_, &HistoryOpener::opened, this, &MainWindow::onHistoryOpened);
  connect(history_opener_, &HistoryOpener::failed, this, &MainWindow::onHistoryFailed);
  connect(history_opener_, &HistoryOpener::updated, this, &MainWindow::onHistoryUpdated);

  connect(playback_, &PlaybackController::frameChanged, loader_, &FrameLoader::request);
  connect(playback_, &PlaybackController::frameChanged, this, &MainWindow::onFrameChanged);
  connect(playback_, &PlaybackController::timeChanged, plot_, &AccelPlot::setCursorTime);
  connect(playback_, &PlaybackController::timeChanged, calibration_plots_,
          &CalibrationPlots::setCursorTime);
  connect(playback_, &PlaybackController::playingChanged, this, &MainWindow::onPlayingChanged);
  connect(playback_, &PlaybackController::speedChanged, this, [this](double speed) {
    const QSignalBlocker blocker(speed_box_);
    speed_box_->setCurrentIndex(speed_box_->findData(speed));
    QSettings().setValue(kSpeedKey, speed);
  });
  connect(speed_box_, QOverload<int>::of(&QComboBox::currentIndexChanged), this,
          [this](int index) { playback_->setSpeed(speed_box_->itemData(index).toDouble()); });

  connect(loader_, &FrameLoader::frameReady, this, [this](int index, const QImage& image) {
    if (live_) return;  // The live source's frames are on screen.
    video_->setFrame(index, image);
    if (awaiting_first_frame_) onFirstFrameSettled();
    pipeline_->setCurrentFrame(index, image);
    emit frameShown(index);
  });

  connect(pipeline_, &PipelineController::overlaysChanged, this, &MainWindow::onOverlaysChanged);
  connect(pipeline_, &PipelineController::rectifiedReady, video_, &VideoView::setRectifiedImage);
  connect(pipeline_, &PipelineController::snapshotReady, this, &MainWindow::snapshotReady);
  // Following: each finished frame is asked for; the loader decodes only the newest asked.
  connect(pipeline_, &PipelineController::snapshotReady, this,
          [this](const std::shared_ptr<const FrameSnapshot>& snapshot) {
            if (follow_action_->isChecked() && !live_) {
              playback_->seekToIndex(static_cast<int>(snapshot->index));
            }
          });
  connect(pipeline_, &PipelineController::started, this, [this](int frames) {
    run_frames_painted_ = 0;
    run_seconds_played_ = 0.0;
    if (!history_opened_by_hand_) {  // The previous run's history is not this recording's.
      calibration_plots_->setSeries(nullptr);
      history_table_->setSeries(nullptr);
    }
    log(tr("Pipeline started on %n frame(s), as fast as it can, from the first frame", nullptr,
           frames));
    onPipelineProgress();
  });
  connect(pipeline_, &PipelineController::historyStarted, this, [this](const QString& path) {
    // The run's attempts go to the plots unless a history file was opened by hand.
    if (!history_opened_by_hand_) history_opener_->open(path);
  });
  connect(pipeline_, &PipelineController::finished, this, [this](int frames, double seconds) {
    onPipelineProgress();
    showTiming();
    QString display;
    if (run_seconds_played_ > 1.0) {
      display = tr("; the video view showed %1 frames per second while it ran and playback "
                   "played or followed it")
                    .arg(static_cast<double>(run_frames_painted_) / run_seconds_played_, 0, 'f', 1);
    }
    log(tr("Pipeline done: %1 frames in %2 s (%3 fps)%4")
            .arg(QString::number(frames), QString::number(seconds, 'f', 1),
                 QString::number(pipeline_->framesPerSecond(), 'f', 1), display));
  });
  connect(pipeline_, &PipelineController::failed, this, [this](const QString& message) {
    onPipelineProgress();
    log(tr("Pipeline not running: %1").arg(message), true);
  });
  connect(&rate_timer_, &QTimer::timeout, this, &MainWindow::onRateTick);
  rate_timer_.start(1000);
  rate_clock_.start();
  connect(loader_, &FrameLoader::frameFailed, this, [this](int index, const QString& message) {
    log(tr("Frame %1 could not be read: %2").arg(index).arg(message), true);
    if (awaiting_first_frame_) onFirstFrameSettled();
  });

  connect(slider_, &QSlider::valueChanged, playback_, &PlaybackController::seekToIndex);
  connect(plot_, &AccelPlot::seekRequested, playback_, &PlaybackController::seekToTime);
  connect(calibration_plots_, &CalibrationPlots::seekRequested, this, &MainWindow::seekToTime);
  connect(history_table_, &HistoryTable::seekRequested, this, &MainWindow::seekToTime);
  connect(plot_, &AccelPlot::windowSecondsChanged, this, [this](double seconds) {
    const QSignalBlocker blocker(window_box_);
    window_box_->setValue(seconds);
    QSettings().setValue(kPlotWindowKey, seconds);
  });
  connect(window_box_, QOverload<double>::of(&QDoubleSpinBox::valueChanged), plot_,
          &AccelPlot::setWindowSeconds);
  // Hand the keys back to the window's shortcuts once a value is entered.
  connect(window_box_, &QDoubleSpinBox::editingFinished, video_, [this] { video_->setFocus(); });
  connect(speed_box_, QOverload<int>::of(&QComboBox::activated), video_,
          [this] { video_->setFocus(); });
}

void MainWindow::restoreSettings() {
  const QSettings settings;
  // The nearest speed the speed box offers, whatever the file says.
  const double saved_speed = settings.value(kSpeedKey, 1.0).toDouble();
  playback_->setSpeed(
      *std::min_element(std::begin(kSpeeds), std::end(kSpeeds), [saved_speed](double a, double b) {
        return std::abs(a - saved_speed) < std::abs(b - saved_speed);
      }));
  plot_->setWindowSeconds(settings.value(kPlotWindowKey, 10.0).toDouble());
  window_box_->setValue(plot_->windowSeconds());
  last_path_ = settings.value(kLastPathKey).toString();
  if (!restoreGeometry(settings.value(kGeometryKey).toByteArray())) {
    const QRect screen = QGuiApplication::primaryScreen()->availableGeometry();
    resize(screen.size() * 0.9);
    move(screen.center() - rect().center());
  }
  restoreState(settings.value(kStateKey).toByteArray(), kStateVersion);
}

void MainWindow::open(const QString& source) {
  log(tr("Opening %1 \u2026").arg(source));
  statusBar()->showMessage(tr("Opening %1 \u2026").arg(source));
  if (!sequence_) video_->showMessage(tr("Opening %1 \u2026").arg(source));
  opener_->open(source);
}

void MainWindow::onOpened(const QString& source, std::shared_ptr<const Sequence> sequence) {
  sequence_ = std::move(sequence);
  source_ = source;
  if (!source.startsWith(QLatin1String("sim:"))) {
    last_path_ = source;
    QSettings().setValue(kLastPathKey, last_path_);
  }

  const Sequence& seq = *sequence_;
  const size_t count = seq.frame_count();
  std::vector<int64_t> times(count);
  for (size_t i = 0; i < count; ++i) times[i] = seq.frame_time_ns(i);
  const int64_t start_ns = RecordingStartNs(seq);
  const int64_t span_ns = count > 1 ? times.back() - times.front() : 0;
  const double fps =
      span_ns > 0 ? static_cast<double>(count - 1) * 1e9 / static_cast<double>(span_ns) : 0.0;

  const QString description = QString::fromStdString(seq.Describe());
  setWindowTitle(tr("%1 \u2014 autocal workbench").arg(description));
  status_source_->setText(description);
  status_source_->setToolTip(description);
  status_resolution_->setText(
      tr("%1 \u00d7 %2 px").arg(seq.session().width).arg(seq.session().height));
  status_fps_->setText(tr("%1 fps").arg(fps, 0, 'f', 2));
  statusBar()->clearMessage();

  loader_->setSequence(sequence_);
  // The history's times are on the recording's clock: both count from its start.
  calibration_plots_->setTimeOrigin(start_ns);
  history_table_->setTimeOrigin(start_ns);
  std::vector<std::pair<int64_t, CameraIntrinsics>> truth;
  if (const std::vector<GroundTruthFrame>* frames = seq.ground_truth()) {
    truth.reserve(frames->size());
    for (const GroundTruthFrame& frame : *frames) truth.emplace_back(frame.t_ns, frame.intrinsics);
  }
  calibration_plots_->setGroundTruth(std::move(truth));
  video_->showMessage(tr("Loading frame \u2026"));
  showRecordingAccel();
  {
    const QSignalBlocker blocker(slider_);
    slider_->setRange(0, std::max(0, static_cast<int>(count) - 1));
    slider_->setPageStep(std::max(1, static_cast<int>(fps)));
  }
  playback_->setTimeline(std::move(times), start_ns);

  // One arg() call: a '%' in the description must not be taken for a placeholder.
  log(tr("Opened %1: %2 frames at %3 fps, %4 \u00d7 %5 px, %6 accelerometer samples")
          .arg(description, QString::number(count), QString::number(fps, 'f', 2),
               QString::number(seq.session().width), QString::number(seq.session().height),
               QString::number(seq.accel().size())));
  for (const std::string& warning : seq.warnings()) {
    log(tr("Warning: %1").arg(QString::fromStdString(warning)), true);
  }
  if (count == 0) video_->showMessage(tr("%1 has no frames.").arg(description));
  takeRecordingsShutter(seq.session());
  // The run and the playback start once the first frame is on screen: the picture comes
  // first, and a slow first decode (the simulator builds its scene then) skips no frames.
  pipeline_->start(nullptr);
  awaiting_first_frame_ = true;
  play_on_first_frame_ = !follow_action_->isChecked();  // Following, it goes with the run.
  emit opened(source);
}

void MainWindow::onFirstFrameSettled() {
  awaiting_first_frame_ = false;
  pipeline_->start(sequence_);
  if (play_on_first_frame_) {
    play_on_first_frame_ = false;
    playback_->play();
  }
}

void MainWindow::takeRecordingsShutter(const SessionInfo& session) {
  PipelineOptions options = pipeline_->options();
  double& readout = options.calibration.readout_ms;
  const double in_effect = readout, stated = session.readout_ms;
  if (stated > 0) {
    readout = stated;
  } else if (recording_readout_ms_ > 0 && readout == recording_readout_ms_) {
    readout = 0.0;
  }
  recording_readout_ms_ = stated;
  if (stated > 0) {
    log(tr("The camera has a rolling shutter (rows read over %1 ms): undone "
           "(calibration.readout_ms).")
            .arg(stated));
  }
  if (readout == in_effect) return;
  if (stated == 0) log(tr("A global shutter, or not known: calibration.readout_ms back to 0."));
  threshold_panel_->setOptions(options);
  pipeline_->setOptions(options);
}

void MainWindow::onOpenFailed(const QString& source, const QString& message) {
  log(tr("Could not open %1: %2").arg(source, message), true);
  statusBar()->showMessage(tr("Could not open: %1").arg(message), 30000);
  if (!sequence_) {
    video_->showMessage(tr("No recording open.\nFile \u203a Open Recording Folder\u2026"));
  }
  showErrorBox(tr("Could not open recording"), tr("Could not open %1").arg(source), message);
  emit openFailed(source, message);
}

void MainWindow::openHistory(const QString& path) {
  history_opened_by_hand_ = true;
  log(tr("Opening history %1 \u2026").arg(path));
  statusBar()->showMessage(tr("Opening history %1 \u2026").arg(path));
  history_opener_->open(path);
}

bool MainWindow::isReplacedRunHistory(const QString& path) const {
  return !history_opened_by_hand_ && path != pipeline_->historyPath();
}

void MainWindow::onHistoryOpened(const QString& path,
                                 std::shared_ptr<const CalibrationSeries> series) {
  if (isReplacedRunHistory(path)) return;
  statusBar()->clearMessage();
  const StoredHistory& stored = series->stored;
  log(tr("Opened history %1: %2 attempts, %3 alarms, %4 regimes")
          .arg(path, QString::number(stored.attempts.size()), QString::number(stored.alarms.size()),
               QString::number(stored.regimes.size())));
  if (!series->differing.empty()) {
    log(tr("Warning: judged again, %1 attempts get another verdict than the file records (a "
           "file from another version?); the plots' trend is the replayed one")
            .arg(series->differing.size()),
        true);
  }
  calibration_plots_->setSeries(series);
  history_table_->setSeries(std::move(series));
  if (path != pipeline_->historyPath()) {  // The run's own comes up without taking the dock.
    calibration_dock_->show();
    calibration_dock_->raise();
  }
  emit historyOpened(path);
}

void MainWindow::onHistoryFailed(const QString& path, const QString& message) {
  log(tr("Could not open history %1: %2").arg(path, message), true);
  statusBar()->showMessage(tr("Could not open history: %1").arg(message), 30000);
  auto* box = new QMessageBox(QMessageBox::Critical, tr("Could not open history"),
                              tr("Could not open %1").arg(path), QMessageBox::Ok, this);
  box->setInformativeText(message);
  box->setTextInteractionFlags(Qt::TextSelectableByMouse);
  box->setAttribute(Qt::WA_DeleteOnClose);
  box->open();
  emit historyFailed(path, message);
}

void MainWindow::onHistoryUpdated(const QString& path,
                                  std::shared_ptr<const CalibrationSeries> series) {
  if (isReplacedRunHistory(path)) return;
  const CalibrationSeries* shown = calibration_plots_->series();
  const size_t before = shown ? shown->stored.attempts.size() : 0;
  const size_t now = series->stored.attempts.size();
  if (now != before) {
    log(tr("History %1 grew: %2 attempts (%3 new)")
            .arg(path, QString::number(now),
                 QString::number(static_cast<long long>(now) - static_cast<long long>(before))));
  }
  calibration_plots_->setSeries(series);
  history_table_->setSeries(std::move(series));
}

void MainWindow::seekToTime(double seconds) {
  if (playback_->frameCount() > 0) {
    playback_->seekToTime(seconds);
  } else {
    calibration_plots_->setCursorTime(seconds);
  }
}

void MainWindow::onFrameChanged(int index) {
  const int count = playback_->frameCount();
  if (!slider_->isSliderDown()) {
    const QSignalBlocker blocker(slider_);
    slider_->setValue(index);
  }
  const double duration = playback_->frameTime(count - 1);
  const QString time = QStringLiteral("%1 / %2").arg(FormatSeconds(playback_->currentTime()),
                                                     FormatSeconds(duration));
  // Indices from 0, as in the recording's files and the command-line tool.
  const QString frame = tr("frame %1 of %2").arg(index).arg(count);
  position_label_->setText(QStringLiteral("%1   %2").arg(time, frame));
  status_position_->setText(
      QStringLiteral("%1  %2").arg(frame, FormatSeconds(playback_->currentTime())));
}

void MainWindow::onPlayingChanged(bool playing) {
  play_action_->setIcon(
      style()->standardIcon(playing ? QStyle::SP_MediaPause : QStyle::SP_MediaPlay));
  play_action_->setText(playing ? tr("&Pause") : tr("&Play"));
  play_action_->setToolTip(playing ? tr("Pause (Space)") : tr("Play (Space)"));
}

void MainWindow::onOverlaysChanged(const FrameOverlays& overlays) {
  video_->setOverlays(overlays);
  onPipelineProgress();
  if (!overlays.raw) {
    status_found_->clear();
    status_lens_->clear();
    status_lens_->setToolTip({});
    return;
  }
  const OverlayGeometry& found = *overlays.raw;
  const QString verdict = QString::fromStdString(found.lens_verdict);
  if (verdict != status_lens_->text()) {
    status_lens_->setText(verdict);
    status_lens_->setToolTip(QString::fromStdString(found.lens_detail));
    status_lens_->setStyleSheet(found.lens_observable || verdict.isEmpty()
                                    ? QString()
                                    : QStringLiteral("color: #c62828; font-weight: bold"));
  }
  status_found_->setText(tr("%1 lines, %2 snakes, %3 tracks, %4 planes, %5 boards")
                             .arg(found.lines.size())
                             .arg(found.snakes.size())
                             .arg(found.tracks.size())
                             .arg(found.planes.size())
                             .arg(found.boards.size()));
}

void MainWindow::onPipelineProgress() {
  const int done = pipeline_->framesDone();
  const int total = pipeline_->frameCount();
  if (total == 0) {
    status_pipeline_->clear();
    return;
  }
  if (!pipeline_->isRunning() && done == 0) {
    status_pipeline_->setText(tr("pipeline not running"));
    return;
  }
  const QString fps = QString::number(pipeline_->framesPerSecond(), 'f', 1);
  status_pipeline_->setText(
      pipeline_->isRunning()
          ? tr("pipeline %1 / %2 frames, %3 fps").arg(done).arg(total).arg(fps)
          : tr("pipeline done %1 / %2 frames, %3 fps").arg(done).arg(total).arg(fps));
}

void MainWindow::onLiveFrame() {
  const LiveSession::LiveFrame frame = live_session_->latestFrame();
  if (!live_) return;  // A frame announced before the session ended.
  const QImage image = MatToQImage(frame.image);
  if (image.isNull()) return;
  const int index = static_cast<int>(frame.number);
  video_->setFrame(index, image);
  pipeline_->setLiveFrame(index, image, frame.snapshot, frame.boards_attempt);
  status_position_->setText(tr("live frame %1").arg(index));
  // No more often than the plot redraws.
  if (!live_plot_clock_.isValid() || live_plot_clock_.elapsed() >= kLivePlotIntervalMs) {
    live_plot_clock_.start();
    showLiveAccel(frame.t_ns);
  }
  emit frameShown(index);
}

void MainWindow::showLiveAccel(int64_t frame_t_ns) {
  const LiveSession::AccelHistory accel = live_session_->recentAccel();
  const int64_t end_ns =
      accel.samples.empty() ? frame_t_ns : std::max(frame_t_ns, accel.samples.back().t_ns);
  plot_->setSamples(accel.samples, accel.start_ns,
                    static_cast<double>(end_ns - accel.start_ns) * 1e-9);
  plot_->setCursorTime(static_cast<double>(frame_t_ns - accel.start_ns) * 1e-9);
}

void MainWindow::showRecordingAccel() {
  const Sequence& seq = *sequence_;
  const int64_t start_ns = RecordingStartNs(seq);
  int64_t end_ns = seq.frame_count() > 0 ? seq.frame_time_ns(seq.frame_count() - 1) : start_ns;
  if (!seq.accel().empty()) end_ns = std::max(end_ns, seq.accel().back().t_ns);
  plot_->setSamples(seq.accel(), start_ns, static_cast<double>(end_ns - start_ns) * 1e-9);
}

void MainWindow::showTiming() {
  if (live_) {
    timing_table_->setStats(live_session_->timingStats(), tr("the live source"));
  } else {
    timing_table_->setStats(pipeline_->timingStats(), tr("the recording"));
  }
}

void MainWindow::onRateTick() {
  showTiming();
  const double seconds = rate_clock_.restart() * 1e-3;
  const uint64_t painted = video_->framesPainted();
  const uint64_t frames = painted - frames_painted_at_tick_;
  frames_painted_at_tick_ = painted;
  const bool moving = playback_->isPlaying() || live_ ||
                     (follow_action_->isChecked() && pipeline_->isRunning());
  if (!moving || seconds <= 0.0) {
    display_fps_ = 0.0;
    status_display_->clear();
    return;
  }
  display_fps_ = static_cast<double>(frames) / seconds;
  status_display_->setText(tr("display %1 fps").arg(display_fps_, 0, 'f', 1));
  if (pipeline_->isRunning()) {
    run_frames_painted_ += frames;
    run_seconds_played_ += seconds;
  }
  onPipelineProgress();
}

void MainWindow::openFolderDialog() {
  const QString dir =
      QFileDialog::getExistingDirectory(this, tr("Open Recording Folder"), dialogStartDir());
  if (!dir.isEmpty()) open(dir);
}

void MainWindow::openVideoDialog() {
  const QString file =
      QFileDialog::getOpenFileName(this, tr("Open Video"), dialogStartDir(),
                                   tr("Videos (*.mp4 *.avi *.mkv *.mov *.webm);;All files (*)"));
  if (!file.isEmpty()) open(file);
}

void MainWindow::openSimulationDialog() {
  bool ok = false;
  const QString spec = QInputDialog::getText(
      this, tr("Open Simulation"),
      tr("Scenario and settings, e.g. office,lens=sonnar,seconds=20,resolution=640x480"),
      QLineEdit::Normal, QStringLiteral("office"), &ok);
  if (ok && !spec.trimmed().isEmpty()) open(QStringLiteral("sim:") + spec.trimmed());
}

void MainWindow::openHistoryDialog() {
  const QString file = QFileDialog::getOpenFileName(
      this, tr("Open Calibration History"), dialogStartDir(),
      tr("Calibration histories (*.sqlite *.sqlite3 *.db);;All files (*)"));
  if (!file.isEmpty()) openHistory(file);
}

void MainWindow::showErrorBox(const QString& title, const QString& text, const QString& detail) {
  // Not exec(): a modal loop here would stall playback and whoever called.
  auto* box = new QMessageBox(QMessageBox::Critical, title, text, QMessageBox::Ok, this);
  box->setInformativeText(detail);
  box->setTextInteractionFlags(Qt::TextSelectableByMouse);
  box->setAttribute(Qt::WA_DeleteOnClose);
  box->open();
}

void MainWindow::openPremissionDialog() {
  const QString file = QFileDialog::getOpenFileName(
      this, tr("Pre-mission Calibration"),
      premission_file_.isEmpty() ? dialogStartDir() : premission_file_,
      tr("Calibrations (*.yaml *.yml *.json *.xml *.txt);;All files (*)"));
  if (!file.isEmpty()) setPremissionFile(file);
}

bool MainWindow::setPremissionFile(const QString& path) {
  std::optional<CameraIntrinsics> premission;
  QString message;
  if (!ReadCalibrationFile(path, &premission, &message)) {
    log(tr("Pre-mission calibration not changed: %1").arg(message), true);
    statusBar()->showMessage(tr("Could not read the calibration: %1").arg(message), 30000);
    showErrorBox(tr("Could not read the calibration"), tr("Could not read %1").arg(path), message);
    return false;
  }
  premission_file_ = path;
  own_premission_action_->setEnabled(premission.has_value());
  device_panel_->premissionField()->setPath(path);
  pipeline_->setPremission(premission);
  if (premission) {
    log(tr("Pre-mission calibration from %1: %2x%3, fx %4 fy %5 cx %6 cy %7 px")
            .arg(path)
            .arg(premission->width)
            .arg(premission->height)
            .arg(premission->fx, 0, 'f', 1)
            .arg(premission->fy, 0, 'f', 1)
            .arg(premission->cx, 0, 'f', 1)
            .arg(premission->cy, 0, 'f', 1));
  } else {
    log(tr("Pre-mission calibration: each source's own"));
  }
  // The run so far started from the other calibration.
  if (sequence_ && !awaiting_first_frame_) pipeline_->start(sequence_);
  return true;
}

void MainWindow::showAbout() {
  QMessageBox::about(this, tr("About autocal workbench"),
                     tr("<b>autocal workbench</b> %1<p>Keeps a camera and accelerometer rig "
                        "calibrated while it is in use.</p>")
                         .arg(QString::fromLatin1(kVersion)));
}

void MainWindow::log(const QString& message, bool is_error) {
  const QString time = QDateTime::currentDateTime().toString(QStringLiteral("HH:mm:ss"));
  const QString html = message.toHtmlEscaped().replace(QLatin1Char('\n'), QLatin1String("<br>"));
  log_->appendHtml(
      is_error ? QStringLiteral("<span style=\"color:#b00020\">%1 %2</span>").arg(time, html)
               : QStringLiteral("%1 %2").arg(time, html));
  if (is_error) {
    qWarning("%s", qUtf8Printable(message));
  } else {
    qInfo("%s", qUtf8Printable(message));
  }
}

QString MainWindow::dialogStartDir() const {
  return last_path_.isEmpty() ? QString() : QFileInfo(last_path_).absolutePath();
}

void MainWindow::closeEvent(QCloseEvent* event) {
  QSettings settings;
  settings.setValue(kGeometryKey, saveGeometry());
  settings.setValue(kStateKey, saveState(kStateVersion));
  playback_->pause();
  pipeline_->stop();
  QMainWindow::closeEvent(event);
}

void MainWindow::dragEnterEvent(QDragEnterEvent* event) {
  const QList<QUrl> urls = event->mimeData()->urls();
  if (urls.size() == 1 && urls.front().isLocalFile()) event->acceptProposedAction();
}

void MainWindow::dropEvent(QDropEvent* event) {
  const QString path = event->mimeData()->urls().front().toLocalFile();
  const QString suffix = QFileInfo(path).suffix().toLower();
  if (suffix == QLatin1String("sqlite") || suffix == QLatin1String("sqlite3") ||
      suffix == QLatin1String("db")) {
    openHistory(path);
  } else {
    open(path);
  }
  event->acceptProposedAction();
}

}  // namespace autocal
