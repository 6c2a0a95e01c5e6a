// `autocal record` and `autocal devices`: live sources on the command line.
#include <unistd.h>

#include <cstdio>
#include <optional>
#include <string>

#include <QCommandLineParser>

#include "app/cli_commands.h"
#include "app/cli_util.h"
#include "devices/device_list.h"
#include "devices/recorder.h"
#include "devices/source.h"
#include "pipeline/error.h"

namespace autocal::cli {
namespace {

int Fail(const QString& name, const std::string& message) {
  std::fprintf(stderr, "autocal %s: %s\n", qPrintable(name), message.c_str());
  return 1;
}

// One progress line: what is safely on disk, and what was lost on the way.
void PrintProgress(const RecorderProgress& p, bool live, bool tty, size_t* events_shown) {
  for (; *events_shown < p.events.size(); ++*events_shown) {
    std::fprintf(stderr, "%srecord: %s\n", tty ? "\r\033[K" : "",
                 FormatSourceEvent(p.events[*events_shown]).c_str());
  }
  std::fprintf(stderr, "%srecord: %.1f s, %llu frames, %llu accelerometer samples written",
               tty ? "\r\033[K" : "", p.elapsed_s,
               static_cast<unsigned long long>(p.frames_written),
               static_cast<unsigned long long>(p.accel_written));
  if (live) {
    std::fprintf(stderr, " (camera %.1f Hz, accelerometer %.0f Hz)", p.source.camera_rate_hz,
                 p.source.accel_rate_hz);
  }
  const unsigned long long dropped = p.frames_dropped + p.source.frames_dropped;
  if (dropped > 0 || p.source.accel_dropped > 0) {
    std::fprintf(stderr, "; dropped %llu frames, %llu samples", dropped,
                 static_cast<unsigned long long>(p.source.accel_dropped));
  }
  std::fprintf(stderr, tty ? "" : "\n");
}

}  // namespace

int Record(const QStringList& arguments) {
  const QString name = "record";
  QCommandLineParser parser;
  parser.setApplicationDescription(
      "Records a source into a native recording folder while it runs: a live camera with a\n"
      "USB accelerometer, or a recording, dataset, video + CSV, image folder or simulator\n"
      "scenario. Every row is flushed as it is written: a killed recording is readable up\n"
      "to its last second. Ctrl-C stops it cleanly. See docs/devices.md.");
  parser.addOptions({
      {"input",
       "camera:N, camera:/dev/videoN (with ,size=WxH ,fps=F ,format=MJPG), sim:SCENARIO, a "
       "recording, dataset, video or image folder.",
       "source"},
      {"accel",
       "Accelerometer: usb, usb:VID:PID, usb:mapping=FILE, a CSV file, or none (default: the "
       "input's own).",
       "spec"},
      {"seconds", "Seconds to record (default: until the source ends or Ctrl-C).", "s"},
      {"out", "Recording folder to create (must not exist or be empty).", "dir"},
      {"readout-ms",
       "The camera's rolling-shutter readout to state in the recording (ms; 0: a global "
       "shutter; `autocal readout` measures it). Default: the source's own (none for a "
       "camera).",
       "ms"},
  });
  if (const auto code = Parse(parser, name, arguments)) return *code;
  if (!parser.isSet("input")) return UsageError(name, "--input is required", parser);
  if (!parser.isSet("out")) return UsageError(name, "--out is required", parser);
  RecorderOptions options;
  if (parser.isSet("seconds")) {
    bool ok = false;
    options.seconds = parser.value("seconds").toDouble(&ok);
    if (!ok || !(options.seconds > 0)) {
      return UsageError(name, "--seconds takes a positive number", parser);
    }
  }

  QString bad_readout;
  options.readout_ms = ReadoutMsOption(parser, &bad_readout);
  if (!bad_readout.isEmpty()) return UsageError(name, bad_readout, parser);

  try {
    const std::string out = parser.value("out").toStdString();
    const std::unique_ptr<FrameSource> source =
        OpenSource(parser.value("input").toStdString(), parser.value("accel").toStdString());
    const bool live = source->live();
    source->Start();  // Before anything else is said: a missing device is the news.
    if (live && !parser.isSet("accel")) {
      std::fprintf(stderr,
                   "autocal record: no --accel: recording the camera alone (--accel usb adds "
                   "a USB accelerometer)\n");
    }
    const StopRequest& stop = CatchStopSignals();  // The recording's files complete.
    const bool tty = isatty(STDERR_FILENO);
    size_t events_shown = 0;
    const RecorderProgress result = autocal::Record(
        *source, out, options,
        [&](const RecorderProgress& p) { PrintProgress(p, live, tty, &events_shown); },
        &stop.requested);
    if (tty) std::fprintf(stderr, "\n");
    std::printf("recorded %llu frames and %llu accelerometer samples over %.2f s from %s to %s\n",
                static_cast<unsigned long long>(result.frames_written),
                static_cast<unsigned long long>(result.accel_written), result.recorded_s,
                source->Describe().c_str(), out.c_str());
    for (const TimeGap& gap : result.source.camera_gaps) {
      std::printf("camera gap: %.3f s without frames\n", gap.seconds());
    }
    const unsigned long long dropped = result.frames_dropped + result.source.frames_dropped;
    if (dropped > 0 || result.source.accel_dropped > 0 || result.items_refused > 0) {
      std::printf(
          "lost: %llu frames and %llu samples dropped (consumer too slow), %llu items "
          "refused (time not increasing)\n",
          dropped, static_cast<unsigned long long>(result.source.accel_dropped),
          static_cast<unsigned long long>(result.items_refused));
    }
    if (result.frames_written == 0) return Fail(name, "no frame was recorded");
    return 0;
  } catch (const Error& error) {
    return Fail(name, error.what());
  }
}

int Devices(const QStringList& arguments) {
  const QString name = "devices";
  QCommandLineParser parser;
  parser.setApplicationDescription(
      "Lists the cameras (V4L2 /dev/video* nodes with their formats, sizes and rates) and\n"
      "looks for a USB accelerometer. Exits 1 when neither a camera nor an accelerometer\n"
      "is found.");
  if (const auto code = Parse(parser, name, arguments)) return *code;

  const DeviceListing listing = ListDevices();
  std::printf("%s", listing.Text().c_str());
  return listing.AnyDevice() ? 0 : 1;
}

}  // namespace autocal::cli
