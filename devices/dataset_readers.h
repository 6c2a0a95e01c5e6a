// Readers for recordings made by others (DESIGN.md section 4, docs/recordings.md): EuRoC/ASL
// folders, TUM RGB-D folders, and a video file with an accelerometer CSV beside it.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "devices/sequence.h"

namespace autocal {

// The mav0 folder of `dir` when `dir` is a EuRoC folder (mav0/ itself, holding cam0/ and
// imu0/, or its parent); nothing otherwise.
std::optional<std::filesystem::path> FindEurocMav0(const std::filesystem::path& dir);

// Reads mav0/cam0/data.csv and data/*.png, the accelerometer columns of mav0/imu0/data.csv,
// and, where present, mav0/cam0/sensor.yaml (resolution, pinhole radial-tangential
// intrinsics as pre-mission calibration, and with mav0/imu0/sensor.yaml the camera <-
// accelerometer rotation from both T_BS). `dir` is the mav0 folder or its parent.
std::unique_ptr<Sequence> OpenEuroc(const std::string& dir, const ReadOptions& options = {});

// True when `dir` holds rgb.txt or accelerometer.txt.
bool IsTumFolder(const std::filesystem::path& dir);

// Reads rgb.txt and accelerometer.txt (timestamps in decimal seconds, converted to ns
// exactly), and session.json where present (pre-mission calibration and so on).
std::unique_ptr<Sequence> OpenTum(const std::string& dir, const ReadOptions& options = {});

// Reads a video file (anything cv::VideoCapture opens) with, beside it, the accelerometer
// CSV (<base>.csv, or accel.csv; the native accel0 layout) and optionally the frame
// timestamps <base>.timestamps.csv (`#timestamp [ns]` per frame). Without timestamps the
// frames are timed by the container's frame rate from the first accelerometer sample.
std::unique_ptr<Sequence> OpenVideo(const std::string& path, const ReadOptions& options = {});

}  // namespace autocal
