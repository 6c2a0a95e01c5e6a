// How far an estimated calibration is from the truth, in the terms the acceptance tests
// are stated in: focal lengths in percent, principal point and distortion in pixels.
#pragma once

#include "pipeline/camera_model.h"

namespace autocal {

struct CalibrationError {
  double fx_percent = 0.0;  // 100 (estimate - truth) / truth, signed.
  double fy_percent = 0.0;
  double cx_px = 0.0;  // estimate - truth, signed.
  double cy_px = 0.0;
  // The estimated distortion (in pixels, carried to the true focal length) against the true
  // one, both on the true pinhole: the worst
  // distance between where they put the same ray, out to `radius_fraction` of the image
  // half-diagonal (MaxDistortionDifference).
  double distortion_px = 0.0;
};

CalibrationError CompareCalibration(const CameraIntrinsics& estimate,
                                    const CameraIntrinsics& truth,
                                    double radius_fraction = 0.9);

// Tolerances on each error (absolute values); the defaults are the calibration issue's.
struct CalibrationTolerance {
  double focal_percent = 0.5;
  double principal_px = 2.0;
  double distortion_px = 0.5;

  bool Admits(const CalibrationError& error) const;
};

}  // namespace autocal
