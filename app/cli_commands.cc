#include "app/cli_commands.h"

#include <cstdio>
#include <optional>
#include <string>

#include <QCommandLineParser>
#include <QFileInfo>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "app/cli_util.h"
#include "devices/inspect.h"
#include "devices/recording_writer.h"
#include "devices/sequence.h"
#include "devices/sim/lens.h"
#include "devices/sim/simulator.h"
#include "pipeline/calibration_history.h"
#include "pipeline/calibration_io.h"
#include "pipeline/error.h"
#include "pipeline/lens_stage.h"
#include "pipeline/text_format.h"

namespace autocal::cli {

int Simulate(const QStringList& arguments) {
  const QString name = "simulate";
  QStringList lenses;
  for (const std::string& lens : LensNames()) lenses << QString::fromStdString(lens);
  QCommandLineParser parser;
  parser.setApplicationDescription(
      "Writes a simulated recording (frames, accelerometer, ground truth) from a scenario:\n"
      "a built-in one (see --list) or a scenario YAML file.");
  parser.addOptions({
      {"scenario", "Built-in scenario name or YAML file (default office).", "name|file", "office"},
      {"out", "Recording folder to create (must not exist or be empty).", "dir"},
      {"lens", "Lens: " + lenses.join(", ") + ".", "lens"},
      {"seconds", "Duration in seconds.", "s"},
      {"resolution", "Frame size, e.g. 640x480.", "WxH"},
      {"fps", "Frame rate.", "hz"},
      {"seed", "Random seed (textures, noise).", "n"},
      {"accel-rate", "Accelerometer rate in Hz (up to 1600).", "hz"},
      {"set", "Any other scenario field, e.g. --set noise_sigma=3 (repeatable).", "key=value"},
      {"list", "List the built-in scenarios and exit."},
  });
  if (const auto code = Parse(parser, name, arguments)) return *code;

  try {
    if (parser.isSet("list")) {
      for (const std::string& scenario_name : BuiltInScenarioNames()) {
        const Scenario scenario = LoadScenario(scenario_name);
        std::printf("%-10s %s\n", scenario_name.c_str(), scenario.description.c_str());
      }
      return 0;
    }
    if (!parser.isSet("out")) return UsageError(name, "--out is required", parser);
    Scenario scenario = LoadScenario(parser.value("scenario").toStdString());
    for (const char* key : {"lens", "seconds", "resolution", "fps", "seed"}) {
      if (parser.isSet(key)) {
        ApplyScenarioOverride(&scenario, key, parser.value(key).toStdString());
      }
    }
    if (parser.isSet("accel-rate")) {
      ApplyScenarioOverride(&scenario, "accel_rate", parser.value("accel-rate").toStdString());
    }
    for (const QString& assignment : parser.values("set")) {
      const int equals = assignment.indexOf('=');
      if (equals <= 0) return UsageError(name, "--set takes key=value, got " + assignment, parser);
      ApplyScenarioOverride(&scenario, assignment.left(equals).toStdString(),
                            assignment.mid(equals + 1).toStdString());
    }
    std::string why;
    if (!scenario.Check(&why)) throw Error("scenario " + scenario.name + ": " + why);

    const std::string out = parser.value("out").toStdString();
    const std::unique_ptr<Sequence> sequence = MakeSimulatedSequence(scenario);
    ProgressPrinter progress("simulate", "frames");
    WriteSequence(*sequence, out, std::ref(progress));
    std::printf("wrote %zu frames (%dx%d) and %zu accelerometer samples to %s in %.1f s\n",
                sequence->frame_count(), sequence->session().width, sequence->session().height,
                sequence->accel().size(), out.c_str(), progress.Elapsed());
    return 0;
  } catch (const Error& error) {
    std::fprintf(stderr, "autocal %s: %s\n", qPrintable(name), error.what());
    return 1;
  }
}

int Info(const QStringList& arguments) {
  const QString name = "info";
  QCommandLineParser parser;
  parser.setApplicationDescription(
      "Validates a recording and reports frame and accelerometer counts, rates, gaps and\n"
      "their time overlap. Reads native recordings, EuRoC and TUM RGB-D folders, a video\n"
      "with an accelerometer CSV beside it, and sim:SCENARIO. Exits 1 when the recording\n"
      "has errors.");
  parser.addPositionalArgument("recording", "Recording folder, video file or sim:SPEC.");
  parser.addOptions({
      {"json", "Print the report as JSON."},
      {"truncate-at-fault", "Read up to the first fault instead of refusing the recording."},
  });
  if (const auto code = Parse(parser, name, arguments)) return *code;
  if (parser.positionalArguments().size() != 1) {
    return UsageError(name, "expected one recording", parser);
  }
  try {
    ReadOptions options;
    options.truncate_at_fault = parser.isSet("truncate-at-fault");
    const auto sequence = OpenSequence(parser.positionalArguments().front().toStdString(), options);
    const SequenceReport report = InspectSequence(*sequence);
    std::printf("%s", (parser.isSet("json") ? ReportToJson(report) : FormatReport(report)).c_str());
    return HasErrors(report) ? 1 : 0;
  } catch (const Error& error) {
    std::fprintf(stderr, "autocal %s: %s\n", qPrintable(name), error.what());
    return 1;
  }
}

int Distortion(const QStringList& arguments) {
  const QString name = "distortion";
  QCommandLineParser parser;
  parser.setApplicationDescription(
      "Boxes 1-2 on still images: finds straight lines, follows them with Radon snakes\n"
      "along the edges the lens bends, and estimates the distortion that straightens them\n"
      "(plumb-line principle). Writes the estimate and the straightness residual (RMS\n"
      "distance of undistorted points to their lines) before and after.");
  parser.addPositionalArgument("images", "More image files (besides --images).", "[FILE...]");
  parser.addOptions({
      {"images", "Image files: a glob pattern such as 'shots/*.png' (repeatable).", "glob"},
      {"prior",
       "Calibration to start from (OpenCV YAML, autocal JSON, ROS camera_info, Kalibr "
       "camchain or COLMAP cameras.txt); its focal length is held.",
       "file"},
      {"fov",
       "Without --prior: horizontal field of view assumed for the focal length, "
       "in degrees (the pixel-space distortion does not depend on it).",
       "deg", "75"},
      {"summary", "Write a JSON summary here.", "file"},
      {"out", "Write the calibration with the estimated distortion here.", "file"},
      {"format",
       "Format of --out: opencv, json, ros, kalibr or colmap (default: .json is json, .txt "
       "colmap, anything else opencv).",
       "name"},
      {"k3", "Also estimate k3."},
      {"tangential", "Also estimate p1, p2."},
      {"centre", "Also estimate the distortion centre (principal point)."},
  });
  if (const auto code = Parse(parser, name, arguments)) return *code;

  std::vector<std::string> files;
  for (const QString& pattern : parser.values("images")) {
    std::vector<cv::String> matches;
    try {
      cv::glob(pattern.toStdString(), matches, false);
    } catch (const cv::Exception&) {
      matches.clear();  // OpenCV throws when the pattern's folder does not exist.
    }
    if (matches.empty()) return UsageError(name, "no file matches " + pattern, parser);
    files.insert(files.end(), matches.begin(), matches.end());
  }
  for (const QString& file : parser.positionalArguments()) files.push_back(file.toStdString());
  if (files.empty()) return UsageError(name, "no images given (--images GLOB)", parser);

  try {
    const cv::Mat first = cv::imread(files.front(), cv::IMREAD_COLOR);
    if (first.empty()) throw Error(files.front(), 0, "cannot decode as an image");
    CameraIntrinsics prior;
    std::string focal_source;
    if (parser.isSet("prior")) {
      prior = ReadCalibration(parser.value("prior").toStdString());
      focal_source = "prior " + parser.value("prior").toStdString();
      if (prior.width != first.cols || prior.height != first.rows) {
        throw Error(parser.value("prior").toStdString(), 0,
                    "calibration is for " + std::to_string(prior.width) + "x" +
                        std::to_string(prior.height) + " images, the images are " +
                        std::to_string(first.cols) + "x" + std::to_string(first.rows));
      }
    } else {
      bool ok = false;
      const double fov = parser.value("fov").toDouble(&ok);
      if (!ok || fov <= 1 || fov >= 179)
        return UsageError(name, "--fov takes degrees in (1, 179)", parser);
      prior = CameraIntrinsics::FromFieldOfView(first.cols, first.rows, fov);
      focal_source = "assumed from a " + parser.value("fov").toStdString() +
                     " degree field of view (no --prior)";
      std::fprintf(stderr, "autocal distortion: no --prior: focal length %s\n",
                   focal_source.c_str());
    }

    LensOptions options;
    options.plumb_line.estimate_k3 = parser.isSet("k3");
    options.plumb_line.estimate_tangential = parser.isSet("tangential");
    options.plumb_line.estimate_centre = parser.isSet("centre");
    options.pool_per_cell = 1000;  // Still images: keep every shape.
    LensStage stage(options);
    ProgressPrinter progress("distortion", "images");
    std::vector<cv::Mat> images = {first};
    progress(1, files.size());
    for (size_t i = 1; i < files.size(); ++i) {
      cv::Mat image = cv::imread(files[i], cv::IMREAD_COLOR);
      if (image.empty()) throw Error(files[i], 0, "cannot decode as an image");
      if (image.size() != first.size()) {
        throw Error(files[i], 0,
                    "image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                        ", the first was " + std::to_string(first.cols) + "x" +
                        std::to_string(first.rows));
      }
      images.push_back(std::move(image));
      progress(i + 1, files.size());
    }
    std::fprintf(stderr, "autocal distortion: lines and distortion in %zu images, up to %d rounds\n",
                 images.size(), options.still_rounds);
    const LensStage::StillsResult stills = stage.EstimateFromStills(images, prior);
    const PlumbLineResult& result = stills.distortion;
    size_t lines_found = 0, snakes = 0;
    for (const LensSnapshot& snapshot : stills.snapshots) {
      lines_found += snapshot.lines.size();
      snakes += snapshot.snakes.size();
    }
    const DistortionObservability& o = result.observability;
    std::printf("%s\n", result.message.c_str());
    std::printf("lines reach %.0f%% of the half-diagonal; points by radius (tenths):", 100 * o.covered_radius);
    for (int count : o.radial_points) std::printf(" %d", count);
    std::printf("\n");

    if (parser.isSet("summary")) {
      const CameraIntrinsics& e = result.estimate;
      std::string json = "{\n";
      json += "  \"images\": " + std::to_string(images.size()) + ",\n";
      json += "  \"rounds\": " + std::to_string(stills.rounds) + ",\n";
      json += "  \"lines_found\": " + std::to_string(lines_found) + ",\n";
      json += "  \"snakes\": " + std::to_string(snakes) + ",\n";
      json += "  \"usable\": " + std::string(result.usable ? "true" : "false") + ",\n";
      json += "  \"message\": " + JsonString(result.message) + ",\n";
      json += "  \"focal_length_source\": " + JsonString(focal_source) + ",\n";
      json += "  \"lines_used\": " + std::to_string(result.lines_used) + ",\n";
      json += "  \"lines_rejected\": " + std::to_string(result.lines_rejected) + ",\n";
      json += "  \"points_used\": " + std::to_string(result.points_used) + ",\n";
      json += "  \"rms_before_px\": " + JsonNumber(result.rms_before_px) + ",\n";
      json += "  \"rms_after_px\": " + JsonNumber(result.rms_after_px) + ",\n";
      json += "  \"observability\": " + ObservabilityJson(result.observability) + ",\n";
      json += "  \"estimate\": {\"image_width\": " + std::to_string(e.width) +
              ", \"image_height\": " + std::to_string(e.height);
      const auto packed = e.Packed();
      for (int i = 0; i < kNumIntrinsics; ++i) {
        json += ", " + JsonString(IntrinsicName(i)) + ": " + JsonNumber(packed[i]);
      }
      json += "}\n}\n";
      WriteTextFile(parser.value("summary").toStdString(), json);
    }
    if (!result.usable) return 1;
    if (parser.isSet("out")) {
      const std::string out = parser.value("out").toStdString();
      const QString suffix = QFileInfo(QString::fromStdString(out)).suffix();
      const std::string format = parser.isSet("format") ? parser.value("format").toStdString()
                                 : suffix == "json"     ? "json"
                                 : suffix == "txt"      ? "colmap"
                                                        : "opencv";
      WriteCalibration(out, result.estimate, CalibrationFormatFromName(format));
    }
    return 0;
  } catch (const Error& error) {
    std::fprintf(stderr, "autocal %s: %s\n", qPrintable(name), error.what());
    return 1;
  }
}

}  // namespace autocal::cli
