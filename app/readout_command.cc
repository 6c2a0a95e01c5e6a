// `autocal readout`: a recording's rolling-shutter readout, measured by running it once per
// candidate readout (devices/readout_sweep.h).
#include <cstdio>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <QCommandLineParser>

#include "app/cli_commands.h"
#include "app/cli_util.h"
#include "devices/in_memory_sequence.h"
#include "devices/offline_runner.h"
#include "devices/readout_sweep.h"
#include "devices/sequence.h"
#include "pipeline/calibration_io.h"
#include "pipeline/error.h"
#include "pipeline/text_format.h"

namespace autocal::cli {
namespace {

std::string EstimateJson(const ReadoutEstimate& estimate, double stated_ms) {
  std::string json =
      "{\n  \"readout_ms\": " + (estimate.readout_ms ? JsonNumber(*estimate.readout_ms) : "null") +
      ",\n  \"why\": " + JsonString(estimate.why) + ",\n  \"nearly_as_well_ms\": [" +
      JsonNumber(estimate.nearly_as_well_from_ms) + ", " +
      JsonNumber(estimate.nearly_as_well_to_ms) + "]" +
      ",\n  \"stated_ms\": " + JsonNumber(stated_ms) + ",\n  \"trials\": [";
  for (size_t k = 0; k < estimate.trials.size(); ++k) {
    const ReadoutTrial& t = estimate.trials[k];
    json += std::string(k ? "," : "") + "\n    {\"readout_ms\": " + JsonNumber(t.readout_ms) +
            ", \"attempts\": " + std::to_string(t.attempts) +
            ", \"solved\": " + std::to_string(t.solved) +
            ", \"accepted\": " + std::to_string(t.accepted) +
            ", \"median_rms_px\": " + JsonNumber(t.median_rms_px) + "}";
  }
  return json + "\n  ]\n}\n";
}

}  // namespace

int Readout(const QStringList& arguments) {
  const QString name = QStringLiteral("readout");
  QCommandLineParser parser;
  parser.setApplicationDescription(
      "Measures the rolling-shutter readout of a recording's camera (the time its rows take to "
      "be read, top to bottom): runs the recording through boxes 1-10 once per candidate "
      "readout, from 0 to --max-ms every --step-ms, and takes the one whose calibration "
      "attempts fit their tracks best (median reprojection RMS), refined between its "
      "neighbours. The camera must turn and move as on a walk; a run per candidate takes as "
      "long as `autocal run` does.");
  parser.addOptions({
      {"input", "Recording: native folder, EuRoC or TUM folder, video with CSV, sim:SCENARIO.",
       "source"},
      {"prior",
       "Calibration to start from (any format `autocal` writes); default: the recording's "
       "pre-mission calibration.",
       "file"},
      {"max-ms", "Largest readout tried (ms; default 40).", "ms", "40"},
      {"step-ms", "Between the readouts tried (ms; default 5).", "ms", "5"},
      {"json", "Write the trials and the estimate as JSON here.", "file.json"},
  });
  AddPipelineSettingsOptions(parser);
  if (const auto code = Parse(parser, name, arguments)) return *code;
  if (const auto malformed = MalformedSetting(parser)) return UsageError(name, *malformed, parser);
  if (!parser.isSet("input")) return UsageError(name, "--input is required", parser);
  bool max_ok = false, step_ok = false;
  const double max_ms = parser.value("max-ms").toDouble(&max_ok);
  const double step_ms = parser.value("step-ms").toDouble(&step_ok);
  if (!max_ok || !(max_ms > 0 && max_ms <= 1000)) {
    return UsageError(name, "--max-ms takes milliseconds in (0, 1000]", parser);
  }
  if (!step_ok || !(step_ms > 0) || max_ms / step_ms > 100) {
    return UsageError(name, "--step-ms takes positive milliseconds, at most 100 steps to --max-ms",
                      parser);
  }
  try {
    std::unique_ptr<Sequence> sequence = OpenSequence(parser.value("input").toStdString());
    // Each trial reads every frame: read once, where they fit.
    constexpr double kMaxInMemoryMb = 2048;
    if (const double mb = InMemorySequence::MegabytesOf(*sequence); mb <= kMaxInMemoryMb) {
      std::fprintf(stderr, "autocal readout: reading the %zu frames into memory (%.0f MB)...\n",
                   sequence->frame_count(), mb);
      sequence = std::make_unique<InMemorySequence>(std::move(sequence));
    }
    RunSettings settings;
    settings.pipeline = PipelineOptionsFrom(parser, RecordingDefaults(sequence->session()));
    if (parser.isSet("prior")) {
      settings.prior = ReadCalibration(parser.value("prior").toStdString());
    }
    std::vector<double> candidates;
    for (int k = 0; k * step_ms <= max_ms + 1e-9; ++k) candidates.push_back(k * step_ms);
    std::fprintf(stderr, "autocal readout: %s, %zu readouts from 0 to %g ms\n",
                 sequence->Describe().c_str(), candidates.size(), candidates.back());
    ProgressPrinter printer("readout", "frames");
    const size_t frames = sequence->frame_count();
    const ReadoutEstimate estimate = MeasureReadout(
        *sequence, settings, candidates, [&](size_t k, size_t n, size_t frame, size_t) {
          printer(k * frames + frame, n * frames,
                  QStringLiteral("trying %1 ms").arg(candidates[k]));
        });
    std::printf("readout ms  attempts  solved  accepted  median RMS px\n");
    for (const ReadoutTrial& t : estimate.trials) {
      std::printf("%10g  %8d  %6d  %8d  %13.4f\n", t.readout_ms, t.attempts, t.solved, t.accepted,
                  t.median_rms_px);
    }
    const double stated = sequence->session().readout_ms;
    if (parser.isSet("json")) {
      WriteTextFile(parser.value("json").toStdString(), EstimateJson(estimate, stated));
    }
    if (stated > 0) std::printf("stated by the recording: %g ms\n", stated);
    if (!estimate.readout_ms) {
      std::fprintf(stderr, "autocal readout: not measured: %s\n", estimate.why.c_str());
      return 1;
    }
    std::printf("readout %.1f ms: %s; within %g%% of that fit from %g to %g ms\n",
                *estimate.readout_ms, estimate.why.c_str(), 100 * ReadoutEstimate::kNearlyAsWell,
                estimate.nearly_as_well_from_ms, estimate.nearly_as_well_to_ms);
    std::printf("use it: --set calibration.readout_ms=%.1f\n", *estimate.readout_ms);
    return 0;
  } catch (const Error& e) {
    std::fprintf(stderr, "autocal readout: %s\n", e.what());
    return 1;
  }
}

}  // namespace autocal::cli
