// OpenSequence (devices/sequence.h): tells the formats apart by what is on disk.
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

#include "devices/dataset_readers.h"
#include "devices/recording_reader.h"
#include "devices/sequence.h"
#include "devices/sim/simulator.h"
#include "pipeline/error.h"

namespace fs = std::filesystem;

namespace autocal {

std::unique_ptr<Sequence> OpenSequence(const std::string& path, const ReadOptions& options) {
  constexpr std::string_view kSimPrefix = "sim:";
  if (path.starts_with(kSimPrefix)) {
    return MakeSimulatedSequence(ParseScenarioSpec(path.substr(kSimPrefix.size())));
  }

  std::error_code ignored;
  if (fs::is_regular_file(path, ignored)) return OpenVideo(path, options);
  if (!fs::is_directory(path, ignored)) {
    throw Error(path, 0, "no such file or folder (and not sim:SCENARIO)");
  }
  if (FindEurocMav0(path)) return OpenEuroc(path, options);
  if (IsTumFolder(path)) return OpenTum(path, options);
  if (LooksLikeRecording(path)) return OpenRecording(path, options);
  throw Error(path, 0,
              "is not a recording folder of a known layout; looked for: a native recording "
              "(session.json, cam0/data.csv, accel0/data.csv), a EuRoC folder (mav0/cam0/ and "
              "mav0/imu0/, or cam0/ and imu0/ in mav0 itself), a TUM RGB-D folder (rgb.txt, "
              "accelerometer.txt); or give a video file with an accelerometer CSV beside it, or "
              "sim:SCENARIO");
}

}  // namespace autocal
