// Calibration files: read and write a camera's intrinsics in the field names of the
// ecosystem that reads them. OpenCV's FileStorage does the parsing and printing.
#pragma once

#include <string>
#include <vector>

#include "pipeline/camera_model.h"

namespace autocal {

enum class CalibrationFormat {
  kOpenCv,  // OpenCV FileStorage YAML: camera_matrix, distortion_coefficients, image size.
  kJson,    // autocal's JSON: one field per parameter.
};

// "opencv" or "json"; throws Error listing the names it knows.
CalibrationFormat CalibrationFormatFromName(const std::string& name);
std::vector<std::string> CalibrationFormatNames();

// Reads any format above, recognized by its fields. Throws Error naming the file and the
// missing or malformed field.
CameraIntrinsics ReadCalibration(const std::string& path);

// Writes (replacing) the file. Throws Error when it cannot.
void WriteCalibration(const std::string& path, const CameraIntrinsics& camera,
                      CalibrationFormat format);

}  // namespace autocal
