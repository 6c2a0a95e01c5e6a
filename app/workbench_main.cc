// autocal-workbench: the Qt workbench. Parses the command line and opens the main window.
#include <cstdio>
#include <memory>

#include <QAction>
#include <QApplication>
#include <QCommandLineOption>
#include <QCommandLineParser>
#include <QImage>
#include <QPixmap>
#include <QStringList>
#include <QTimer>

#include "pipeline/self_calibration.h"
#include "pipeline/version.h"
#include "widgets/main_window.h"
#include "widgets/scene_view.h"

namespace {

struct Options {
  QCommandLineOption help;
  QCommandLineOption version;
  QCommandLineOption screenshot{
      QStringLiteral("screenshot"),
      QStringLiteral("Save a PNG of the main window to <file>: when --quit-after ends the run, "
                     "or else 1 s after the first frame is shown (then quit)."),
      QStringLiteral("file")};
  QCommandLineOption quit_after{QStringLiteral("quit-after"),
                                QStringLiteral("Quit after <ms> milliseconds."),
                                QStringLiteral("ms")};
  QCommandLineOption history{
      QStringLiteral("history"),
      QStringLiteral("Open a calibration history (the SQLite file autocal writes) in the "
                     "Calibration and History docks."),
      QStringLiteral("file")};
  QCommandLineOption prior{
      QStringLiteral("prior"),
      QStringLiteral("Pre-mission calibration every pipeline starts from and is judged "
                     "against (any format `autocal` writes; default: the source's own)."),
      QStringLiteral("file")};
  QCommandLineOption follow{
      QStringLiteral("follow"),
      QStringLiteral("Follow the pipeline: show each frame as boxes 1-10 finish it, with its "
                     "overlays, instead of playing at the recording's pace (how the built-in "
                     "simulated vest opens).")};
  QCommandLineOption overlays{
      QStringLiteral("overlays"),
      QStringLiteral("Overlay layers to show, comma-separated: lines, snakes, tracks, planes, "
                     "boards, gravity; 'all' or 'none' (default: as last time)."),
      QStringLiteral("layers")};
  QCommandLineOption view{QStringLiteral("view"),
                          QStringLiteral("The video as 'raw', 'rectified' or 'side-by-side' "
                                         "(default: as last time)."),
                          QStringLiteral("mode")};
};

Options Configure(QCommandLineParser* parser) {
  parser->setApplicationDescription(
      QStringLiteral(
          "Workbench of autocal: plays a camera + accelerometer recording with its plots.\n"
          "Without SOURCE it opens the built-in simulated vest (%1).")
          .arg(QString::fromLatin1(autocal::MainWindow::kDefaultSource)));
  Options options{parser->addHelpOption(), parser->addVersionOption()};
  parser->addOption(options.screenshot);
  parser->addOption(options.quit_after);
  parser->addOption(options.history);
  parser->addOption(options.prior);
  parser->addOption(options.follow);
  parser->addOption(options.overlays);
  parser->addOption(options.view);
  parser->addPositionalArgument(
      QStringLiteral("source"),
      QStringLiteral("Recording folder, video file with an accelerometer CSV, or sim:SPEC "
                     "(e.g. sim:corridor,lens=sonnar,seconds=20)."),
      QStringLiteral("[SOURCE]"));
  return options;
}

}  // namespace

int main(int argc, char** argv) {
  autocal::QuietSolverWarnings();
  QCoreApplication::setOrganizationName(QStringLiteral("autocal"));
  QCoreApplication::setApplicationName(QStringLiteral("autocal-workbench"));
  QCoreApplication::setApplicationVersion(QString::fromLatin1(autocal::kVersion));

  // --help and --version must work without a display, so they are answered before
  // QApplication connects to one. Anything else (Qt's own -platform, -style, ...) waits
  // for the full parse below.
  {
    QStringList arguments;
    for (int i = 0; i < argc; ++i) arguments << QString::fromLocal8Bit(argv[i]);
    QCommandLineParser parser;
    const Options options = Configure(&parser);
    if (parser.parse(arguments)) {
      if (parser.isSet(options.version)) {
        std::printf("autocal-workbench %s\n", autocal::kVersion);
        return 0;
      }
      if (parser.isSet(options.help)) {
        const QCoreApplication core(argc, argv);  // helpText() takes the program name from it.
        std::printf("%s", qUtf8Printable(parser.helpText()));
        return 0;
      }
    }
  }

  autocal::SceneView::SetDefaultSurfaceFormat();  // VTK's 3-D view, before the QApplication.
  autocal::SceneView::SetDefaultSurfaceFormat();  // The 3-D view's OpenGL, before the app.
  QApplication app(argc, argv);
  QCommandLineParser parser;
  const Options options = Configure(&parser);
  if (!parser.parse(QCoreApplication::arguments())) {
    std::fprintf(stderr, "autocal-workbench: %s\n", qUtf8Printable(parser.errorText()));
    return 2;
  }
  // The help with Qt's own options (-platform, -style, ...): process() prints it and exits.
  if (parser.isSet(QStringLiteral("help-all"))) parser.process(app);
  const QStringList positional = parser.positionalArguments();
  if (positional.size() > 1) {
    std::fprintf(stderr, "autocal-workbench: one SOURCE at most, got %lld\n",
                 static_cast<long long>(positional.size()));
    return 2;
  }
  int quit_after_ms = -1;
  if (parser.isSet(options.quit_after)) {
    bool ok = false;
    quit_after_ms = parser.value(options.quit_after).toInt(&ok);
    if (!ok || quit_after_ms < 0) {
      std::fprintf(stderr, "autocal-workbench: --quit-after wants milliseconds >= 0, got '%s'\n",
                   qUtf8Printable(parser.value(options.quit_after)));
      return 2;
    }
  }
  const QString screenshot = parser.value(options.screenshot);
  const bool unattended = quit_after_ms >= 0 || !screenshot.isEmpty();

  autocal::MainWindow window;
  if (parser.isSet(options.overlays)) {
    const QStringList wanted =
        parser.value(options.overlays).toLower().split(QLatin1Char(','), Qt::SkipEmptyParts);
    for (const QString& key : wanted) {
      bool known = key == QLatin1String("all") || key == QLatin1String("none");
      for (const autocal::OverlayLayer layer : autocal::kAllOverlayLayers) {
        known = known || key == autocal::OverlayLayerKey(layer);
      }
      if (!known) {
        std::fprintf(stderr, "autocal-workbench: unknown overlay layer '%s'\n",
                     qUtf8Printable(key));
        return 2;
      }
    }
    for (const autocal::OverlayLayer layer : autocal::kAllOverlayLayers) {
      window.overlayAction(layer)->setChecked(wanted.contains(QLatin1String("all")) ||
                                              wanted.contains(autocal::OverlayLayerKey(layer)));
    }
  }
  if (parser.isSet(options.view)) {
    const QString mode = parser.value(options.view);
    using Mode = autocal::VideoView::ViewMode;
    const Mode chosen = mode == QLatin1String("rectified")      ? Mode::kRectified
                        : mode == QLatin1String("side-by-side") ? Mode::kSideBySide
                                                                : Mode::kRaw;
    if (chosen == Mode::kRaw && mode != QLatin1String("raw")) {
      std::fprintf(stderr,
                   "autocal-workbench: --view wants raw, rectified or side-by-side, got '%s'\n",
                   qUtf8Printable(mode));
      return 2;
    }
    window.viewModeAction(chosen)->trigger();
  }
  window.show();

  bool screenshot_failed = false;
  auto finish = [&] {
    if (!screenshot.isEmpty()) {
      if (window.grab().toImage().save(screenshot, "PNG")) {
        std::fprintf(stderr, "autocal-workbench: screenshot saved to %s\n",
                     qUtf8Printable(screenshot));
      } else {
        std::fprintf(stderr, "autocal-workbench: cannot write the screenshot %s\n",
                     qUtf8Printable(screenshot));
        screenshot_failed = true;
      }
    }
    window.close();
    QCoreApplication::quit();  // Also when an error dialog is still open.
  };
  if (quit_after_ms >= 0) {
    QTimer::singleShot(quit_after_ms, &window, finish);
  } else if (!screenshot.isEmpty()) {
    // One second after the first frame (or after a failure to open), so the picture
    // shows the window settled.
    auto settle = [&] { QTimer::singleShot(1000, &window, finish); };
    QObject::connect(&window, &autocal::MainWindow::openFailed, &window, settle);
    auto first_frame = std::make_shared<QMetaObject::Connection>();
    *first_frame =
        QObject::connect(&window, &autocal::MainWindow::frameShown, &window, [first_frame, settle] {
          QObject::disconnect(*first_frame);
          settle();
        });
  }

  // The simulated vest shows what the pipeline finds on every frame from the start; at the
  // recording's pace a machine without a GPU draws frames the pipeline has not reached yet.
  if (parser.isSet(options.follow) || positional.isEmpty()) {
    window.followPipelineAction()->setChecked(true);
  }
  // Its error is on stderr (the log's path).
  if (parser.isSet(options.prior) && !window.setPremissionFile(parser.value(options.prior))) {
    return 2;
  }
  window.open(positional.isEmpty() ? QString::fromLatin1(autocal::MainWindow::kDefaultSource)
                                   : positional.front());
  bool history_failed = false;
  if (parser.isSet(options.history)) {
    QObject::connect(&window, &autocal::MainWindow::historyFailed, &window,
                     [&history_failed] { history_failed = true; });
    window.openHistory(parser.value(options.history));
  }
  const int status = app.exec();
  if (status != 0) return status;
  // Smoke tests and bootstrap runs rely on the exit status to tell that it worked.
  if (unattended && (screenshot_failed || history_failed || window.sequence() == nullptr)) {
    return 1;
  }
  return 0;
}
