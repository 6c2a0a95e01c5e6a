// Calibration files: read and write one camera's intrinsics in the field names and
// conventions of the ecosystem that reads them (docs/formats.md). Histories are in
// calibration_export.h.
#pragma once

#include <string>
#include <vector>

#include "pipeline/camera_model.h"

namespace autocal {

enum class CalibrationFormat {
  kOpenCv,  // OpenCV FileStorage YAML: camera_matrix, distortion_coefficients, image size.
  kJson,    // autocal's JSON: one field per parameter.
  kRos,     // ROS camera_info YAML (camera_calibration_parsers), plumb_bob.
  kKalibr,  // Kalibr camchain YAML, one camera, pinhole + radtan (no k3).
  kColmap,  // COLMAP cameras.txt, OPENCV (FULL_OPENCV when k3 != 0), centres at +0.5.
};

// "opencv", "json", "ros", "kalibr" or "colmap"; throws Error listing the names it knows.
CalibrationFormat CalibrationFormatFromName(const std::string& name);
std::vector<std::string> CalibrationFormatNames();

// Reads any format above (and OpenCV's XML and JSON), recognized by its content, not its
// name; `format`, when given, receives the one found. Throws Error naming the file, the
// line where there is one, and what was expected. Coefficients the model cannot hold
// (skew, k4 and beyond) are refused when nonzero, never dropped.
CameraIntrinsics ReadCalibration(const std::string& path, CalibrationFormat* format = nullptr);

// Writes (replacing) the file. Throws Error for an invalid calibration, one the format
// cannot express (Kalibr and k3 != 0), or when the file cannot be written.
void WriteCalibration(const std::string& path, const CameraIntrinsics& camera,
                      CalibrationFormat format);

}  // namespace autocal
