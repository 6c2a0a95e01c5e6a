#include "pipeline/calibration_error.h"

#include <cmath>

#include "pipeline/plumb_line.h"

namespace autocal {

CalibrationError CompareCalibration(const CameraIntrinsics& estimate,
                                    const CameraIntrinsics& truth, double radius_fraction) {
  CalibrationError error;
  error.fx_percent = 100.0 * (estimate.fx - truth.fx) / truth.fx;
  error.fy_percent = 100.0 * (estimate.fy - truth.fy) / truth.fy;
  error.cx_px = estimate.cx - truth.cx;
  error.cy_px = estimate.cy - truth.cy;
  // The estimate's distortion in pixels (what the plumb line and the tracks see), carried
  // to the true focal length, so that a focal error is not counted twice.
  const CameraIntrinsics lens = WithDistortionOf(truth, estimate);
  error.distortion_px = MaxDistortionDifference(lens, truth, radius_fraction);
  return error;
}

bool CalibrationTolerance::Admits(const CalibrationError& error) const {
  return std::abs(error.fx_percent) <= focal_percent &&
         std::abs(error.fy_percent) <= focal_percent &&
         std::abs(error.cx_px) <= principal_px && std::abs(error.cy_px) <= principal_px &&
         error.distortion_px <= distortion_px;
}

}  // namespace autocal
