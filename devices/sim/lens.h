// The simulated lenses and how the true intrinsics and image effects change over time.
#pragma once

#include <string>
#include <vector>

#include "devices/sim/scenario.h"
#include "pipeline/camera_model.h"

namespace autocal {

// "tessar", "sonnar", "hologon", "telephoto".
std::vector<std::string> LensNames();

// The named lens at the given image size. Its parameters scale with the resolution (fx
// proportional to the width): fx is chosen so that the left and right image edges see
// +-half the horizontal field of view through the distortion; the principal point is a
// few pixels off the image centre and fy is 0.2% longer than fx, so that swapped fields
// show. Throws Error for an unknown lens.
CameraIntrinsics LensIntrinsics(const std::string& lens, int width, int height);

// Horizontal field of view of the named lens in degrees. Throws Error for an unknown lens.
double LensFieldOfViewDeg(const std::string& lens);

// The true intrinsics `t_s` seconds after the first frame: the lens with every intrinsics
// event of the scenario applied. A pure function of its arguments.
CameraIntrinsics IntrinsicsAt(const Scenario& scenario, double t_s);

// Image effects in force at one moment: the scenario's image options plus the
// disturbances active then.
struct FrameEffects {
  double noise_sigma = 0.0;        // Gaussian noise, grey levels.
  double vignetting = 0.0;         // 0: none; 1: full cos^4 falloff.
  double chromatic_px = 0.0;       // Lateral colour shift at the image corner, pixels.
  double fog_blur_sigma_px = 0.0;  // Gaussian blur; 0: none.
  double fog_contrast = 1.0;       // Contrast factor toward the fog's grey; 1: none.
};

FrameEffects EffectsAt(const Scenario& scenario, double t_s);

}  // namespace autocal
