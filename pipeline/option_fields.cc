#include "pipeline/option_fields.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <type_traits>

#include "pipeline/error.h"
#include "pipeline/text_format.h"

namespace autocal {
namespace {

constexpr double kUnbounded = std::numeric_limits<double>::max();

// A field reached through a chain of member pointers from PipelineOptions.
template <typename Value, typename... Members>
OptionField Field(std::string name, double min, double max, std::string help,
                  Members... members) {
  OptionField field;
  field.name = std::move(name);
  field.help = std::move(help);
  field.min = min;
  field.max = max;
  if constexpr (std::is_same_v<Value, bool>) {
    field.kind = OptionField::Kind::kFlag;
    field.min = 0;
    field.max = 1;
  } else if constexpr (std::is_integral_v<Value>) {
    field.kind = OptionField::Kind::kInteger;
  }
  field.get = [members...](const PipelineOptions& options) {
    return static_cast<double>((options .* ... .* members));
  };
  field.set = [members...](PipelineOptions* options, double value) {
    if constexpr (std::is_same_v<Value, bool>) {
      ((*options) .* ... .* members) = value != 0.0;
    } else {
      ((*options) .* ... .* members) = static_cast<Value>(value);
    }
  };
  return field;
}

std::vector<OptionField> MakeFields() {
  using P = PipelineOptions;
  return {
      // Boxes 1-3.
      Field<double>("lens.lines.min_length_px", 5, 2000, "shortest line segment reported (px)",
                    &P::lens, &LensOptions::lines, &LineDetectorOptions::min_length_px),
      Field<int>("lens.estimate_every_frames", 1, 10000,
                 "frames between two plumb-line distortion estimates", &P::lens,
                 &LensOptions::estimate_every_frames),
      Field<int>("lens.pool_per_cell", 1, 1000,
                 "newest snake shapes kept per image cell and orientation", &P::lens,
                 &LensOptions::pool_per_cell),
      Field<int>("lens.plumb_line.min_lines", 1, 100000, "fewer pooled lines give no estimate",
                 &P::lens, &LensOptions::plumb_line, &PlumbLineOptions::min_lines),
      Field<bool>("lens.plumb_line.estimate_k3", 0, 1, "box 2 also estimates k3", &P::lens,
                  &LensOptions::plumb_line, &PlumbLineOptions::estimate_k3),
      // Boxes 4-6.
      Field<int>("motion.flow.target_tracks", 10, 5000,
                 "new corners fill empty cells up to this many tracks", &P::motion,
                 &MotionStageOptions::flow, &FlowOptions::target_tracks),
      Field<double>("motion.flow.max_fb_error_px", 0.01, 100,
                    "tracked back, a point must land this close to its start (px)", &P::motion,
                    &MotionStageOptions::flow, &FlowOptions::max_fb_error_px),
      Field<double>("motion.planes.inlier_threshold_px", 0.01, 100,
                    "transfer error over the baseline for a track to join a plane (px)",
                    &P::motion, &MotionStageOptions::planes, &PlaneOptions::inlier_threshold_px),
      Field<int>("motion.planes.min_inliers", 4, 10000, "tracks a new plane needs", &P::motion,
                 &MotionStageOptions::planes, &PlaneOptions::min_inliers),
      Field<double>("motion.planes.min_parallax_px", 0, 1000,
                    "image motion from translation needed before a new plane is fitted (px)",
                    &P::motion, &MotionStageOptions::planes, &PlaneOptions::min_parallax_px),
      // Box 7.
      Field<double>("inertial.quasi_static.max_variance_m2_s4", 0, 100,
                    "variance of the readings per axis at most this for rest ((m/s^2)^2)",
                    &P::inertial, &InertialOptions::quasi_static,
                    &QuasiStaticOptions::max_variance_m2_s4),
      // Box 8.
      Field<int>("board.squares_x", 1, 100, "squares of a virtual board along its first axis",
                 &P::board, &VirtualBoardOptions::squares_x),
      Field<int>("board.squares_y", 1, 100, "squares of a virtual board along its second axis",
                 &P::board, &VirtualBoardOptions::squares_y),
      // Box 9.
      Field<double>("material.window_s", 0.1, 600, "views this far back make up a window (s)",
                    &P::material, &MaterialOptions::window_s),
      Field<int>("material.view_every_frames", 1, 1000, "one frame in this many is a view",
                 &P::material, &MaterialOptions::view_every_frames),
      Field<double>("material.attempt_every_s", 0.01, 3600, "box 10 is tried this often (s)",
                    &P::material, &MaterialOptions::attempt_every_s),
      Field<int>("material.max_points_per_plane", 6, 100000,
                 "tracks per plane handed to box 10, the longest seen first", &P::material,
                 &MaterialOptions::max_points_per_plane),
      Field<int>("material.min_views_per_point", 2, 1000, "tracks seen in fewer views are left out",
                 &P::material, &MaterialOptions::min_views_per_point),
      Field<int>("material.max_lines", 0, 100000, "straight-line shapes handed to box 10",
                 &P::material, &MaterialOptions::max_lines),
      Field<bool>("material.quality.enabled", 0, 1,
                  "judge each frame's image quality (fog, noise) before measuring from it",
                  &P::material, &MaterialOptions::quality, &ImageQualityOptions::enabled),
      Field<double>("material.quality.max_blur_increase", 0.001, 1,
                    "blur above the recent usual by more than this makes a frame unfit",
                    &P::material, &MaterialOptions::quality, &ImageQualityOptions::max_blur_increase),
      Field<double>("material.quality.fog_blur_increase", 0.001, 1,
                    "fog sign: blur up by this much (two fog signs make a frame unfit)", &P::material,
                    &MaterialOptions::quality, &ImageQualityOptions::fog_blur_increase),
      Field<double>("material.quality.fog_contrast_ratio", 0.01, 1,
                    "fog sign: contrast below this fraction of the usual", &P::material,
                    &MaterialOptions::quality, &ImageQualityOptions::fog_contrast_ratio),
      Field<double>("material.quality.min_contrast_ratio", 0.01, 1,
                    "contrast below this fraction of the usual makes a frame unfit", &P::material,
                    &MaterialOptions::quality, &ImageQualityOptions::min_contrast_ratio),
      Field<double>("material.quality.max_noise_ratio", 1, 1000,
                    "noise above this many times the usual makes a frame unfit", &P::material,
                    &MaterialOptions::quality, &ImageQualityOptions::max_noise_ratio),
      Field<double>("material.quality.accept_as_usual_s", 0.1, 3600,
                    "an unfit look lasting longer becomes the usual (s)", &P::material,
                    &MaterialOptions::quality, &ImageQualityOptions::accept_as_usual_s),
      // Box 10.
      Field<bool>("calibration.estimate_principal_point", 0, 1, "cx, cy free", &P::calibration,
                  &SelfCalibrationOptions::estimate_principal_point),
      Field<bool>("calibration.estimate_distortion", 0, 1, "k1, k2 free", &P::calibration,
                  &SelfCalibrationOptions::estimate_distortion),
      Field<bool>("calibration.estimate_k3", 0, 1, "k3 free too", &P::calibration,
                  &SelfCalibrationOptions::estimate_k3),
      Field<bool>("calibration.estimate_tangential", 0, 1, "p1, p2 free too", &P::calibration,
                  &SelfCalibrationOptions::estimate_tangential),
      Field<double>("calibration.loss_px", 0.01, 100, "Cauchy loss scale on reprojection errors (px)",
                    &P::calibration, &SelfCalibrationOptions::loss_px),
      Field<double>("calibration.prior_focal_fraction", 1e-6, 10,
                    "prior sigma of fx, fy as a fraction of them", &P::calibration,
                    &SelfCalibrationOptions::prior_focal_fraction),
      Field<double>("calibration.prior_principal_px", 1e-6, 10000, "prior sigma of cx, cy (px)",
                    &P::calibration, &SelfCalibrationOptions::prior_principal_px),
      Field<double>("calibration.prior_distortion", 1e-9, 100,
                    "prior sigma of each distortion coefficient", &P::calibration,
                    &SelfCalibrationOptions::prior_distortion),
      Field<int>("calibration.min_frames", 3, 100000, "fewer views with a pose: no update",
                 &P::calibration, &SelfCalibrationOptions::min_frames),
      Field<int>("calibration.min_points_per_plane", 6, 100000,
                 "planes with fewer tracked points are left out", &P::calibration,
                 &SelfCalibrationOptions::min_points_per_plane),
      Field<double>("calibration.min_rotation_deg", 0, 180,
                    "views must differ by this much in orientation (deg)", &P::calibration,
                    &SelfCalibrationOptions::min_rotation_deg),
      Field<double>("calibration.max_focal_sigma", 1e-6, 1,
                    "no update when sigma(fx) / fx exceeds this", &P::calibration,
                    &SelfCalibrationOptions::max_focal_sigma),
      Field<int>("calibration.max_iterations", 1, 10000, "Levenberg-Marquardt iterations",
                 &P::calibration, &SelfCalibrationOptions::max_iterations),
      // The history.
      Field<double>("acceptance.max_rms_px", 0.001, 100,
                    "attempts with a larger reprojection RMS are rejected (px)", &P::acceptance,
                    &AcceptanceOptions::max_rms_px),
      Field<double>("acceptance.max_sigma", 0.1, 1000,
                    "an attempt fits the trend within this many sigma", &P::acceptance,
                    &AcceptanceOptions::max_sigma),
      Field<double>("acceptance.focal_floor_fraction", 0, 1,
                    "least sigma of an attempt's fx, fy, as a fraction of them", &P::acceptance,
                    &AcceptanceOptions::focal_floor_fraction),
      Field<double>("acceptance.principal_floor_px", 0, 1000,
                    "least sigma of an attempt's cx, cy (px)", &P::acceptance,
                    &AcceptanceOptions::principal_floor_px),
      Field<double>("acceptance.distortion_floor_px", 0, 1000,
                    "least sigma of the displacement an attempt's distortion causes (px)",
                    &P::acceptance, &AcceptanceOptions::distortion_floor_px),
      Field<double>("acceptance.window_s", 0.1, kUnbounded,
                    "the trend fits the accepted attempts this far back (s)", &P::acceptance,
                    &AcceptanceOptions::window_s),
      Field<int>("acceptance.max_order", 0, 2, "highest order of the trend", &P::acceptance,
                 &AcceptanceOptions::max_order),
      Field<int>("acceptance.min_points_linear", 2, 100000,
                 "fewer accepted attempts in the window: a constant trend", &P::acceptance,
                 &AcceptanceOptions::min_points_linear),
      Field<int>("acceptance.min_points_quadratic", 3, 100000,
                 "fewer accepted attempts in the window: at most a linear trend", &P::acceptance,
                 &AcceptanceOptions::min_points_quadratic),
      Field<double>("acceptance.order_evidence_chi2", 0, 1e6,
                    "a higher trend order must lower some parameter's chi-square this much",
                    &P::acceptance, &AcceptanceOptions::order_evidence_chi2),
      Field<double>("acceptance.max_extrapolation_s", 0, kUnbounded,
                    "the trend is held this long after its newest attempt (s)", &P::acceptance,
                    &AcceptanceOptions::max_extrapolation_s),
      Field<int>("acceptance.alarm_after", 1, 100,
                 "consistent attempts off the trend that raise a jump alarm", &P::acceptance,
                 &AcceptanceOptions::alarm_after),
      Field<int>("acceptance.confirm_after", 1, 100,
                 "consistent attempts off the trend that start a new regime", &P::acceptance,
                 &AcceptanceOptions::confirm_after),
  };
}

std::string Trim(const std::string& text) {
  const size_t first = text.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  return text.substr(first, text.find_last_not_of(" \t\r") - first + 1);
}

}  // namespace

const std::vector<OptionField>& PipelineOptionFields() {
  static const std::vector<OptionField> fields = MakeFields();
  return fields;
}

void SetPipelineOption(PipelineOptions* options, const std::string& name,
                       const std::string& value) {
  const std::vector<OptionField>& fields = PipelineOptionFields();
  const auto field = std::find_if(fields.begin(), fields.end(),
                                  [&](const OptionField& f) { return f.name == name; });
  if (field == fields.end()) {
    std::string known;
    const std::string group = name.substr(0, name.find('.'));
    for (const OptionField& f : fields) {
      if (f.name.compare(0, group.size(), group) == 0) known += (known.empty() ? "" : ", ") + f.name;
    }
    throw Error("unknown option '" + name + "'" +
                (known.empty() ? "; groups: lens, motion, inertial, board, material, "
                                 "calibration, acceptance"
                               : "; in its group: " + known));
  }
  double number = 0.0;
  if (field->kind == OptionField::Kind::kFlag && (value == "true" || value == "false")) {
    number = value == "true" ? 1.0 : 0.0;
  } else {
    size_t used = 0;
    try {
      number = std::stod(value, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != value.size() || !std::isfinite(number)) {
      throw Error("option " + name + " takes a number, got '" + value + "'");
    }
  }
  if (field->kind != OptionField::Kind::kReal && number != std::floor(number)) {
    throw Error("option " + name + " takes a whole number, got '" + value + "'");
  }
  if (number < field->min || number > field->max) {
    throw Error("option " + name + " must be in [" + ShortestDecimal(field->min) + ", " +
                (field->max == kUnbounded ? "inf" : ShortestDecimal(field->max)) + "], got " +
                value);
  }
  field->set(options, number);
}

PipelineOptions ReadPipelineSettings(const std::string& path, const PipelineOptions& base) {
  std::ifstream in(path);
  if (!in) throw Error(path, 0, "cannot be opened for reading");
  PipelineOptions options = base;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const std::string text = Trim(line.substr(0, line.find('#')));
    if (text.empty()) continue;
    const size_t equals = text.find('=');
    if (equals == std::string::npos) {
      throw Error(path, number, "expected 'name = value', got '" + text + "'");
    }
    try {
      SetPipelineOption(&options, Trim(text.substr(0, equals)), Trim(text.substr(equals + 1)));
    } catch (const Error& error) {
      throw Error(path, number, error.what());
    }
  }
  std::string why;
  if (!options.Check(&why)) throw Error(path, 0, "options do not fit together: " + why);
  return options;
}

std::string PipelineSettingsText(const PipelineOptions& options) {
  std::ostringstream text;
  text << "# autocal pipeline settings: name = value (see `autocal run --help`).\n";
  std::string group;
  for (const OptionField& field : PipelineOptionFields()) {
    const std::string field_group = field.name.substr(0, field.name.find('.'));
    if (field_group != group) text << "\n";
    group = field_group;
    text << "# " << field.help << "\n";
    const double value = field.get(options);
    text << field.name << " = "
         << (field.kind == OptionField::Kind::kFlag ? (value != 0 ? "true" : "false")
                                                    : ShortestDecimal(value))
         << "\n";
  }
  return text.str();
}

}  // namespace autocal
