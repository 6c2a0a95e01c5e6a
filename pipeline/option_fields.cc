#include "pipeline/option_fields.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <type_traits>

#include "pipeline/error.h"
#include "pipeline/self_calibration.h"
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
  } else if constexpr (std::is_integral_v<Value> || std::is_enum_v<Value>) {
    field.kind = OptionField::Kind::kInteger;  // An enum by its values' numbers.
  }
  field.get = [members...](const PipelineOptions& options) {
    if constexpr (std::is_enum_v<Value>) {
      return static_cast<double>(static_cast<int>((options .* ... .* members)));
    } else {
      return static_cast<double>((options .* ... .* members));
    }
  };
  field.set = [members...](PipelineOptions* options, double value) {
    if constexpr (std::is_same_v<Value, bool>) {
      ((*options) .* ... .* members) = value != 0.0;
    } else if constexpr (std::is_enum_v<Value>) {
      ((*options) .* ... .* members) = static_cast<Value>(static_cast<int>(value));
    } else {
      ((*options) .* ... .* members) = static_cast<Value>(value);
    }
  };
  return field;
}

std::vector<OptionField> MakeFields() {
  using P = PipelineOptions;
  using L = LensOptions;
  using Lines = LineDetectorOptions;
  using Snakes = SnakeOptions;
  using Plumb = PlumbLineOptions;
  using Rect = RectifyOptions;
  using M = MotionStageOptions;
  using Flow = FlowOptions;
  using Feat = FeatureOptions;
  using Planes = PlaneOptions;
  using I = InertialOptions;
  using Screen = AccelScreenOptions;
  using Rest = QuasiStaticOptions;
  using Class = MotionClassOptions;
  using Scale = ScaleOptions;
  using B = VirtualBoardOptions;
  using Mat = MaterialOptions;
  using Q = ImageQualityOptions;
  using Anc = AnchorOptions;
  using C = SelfCalibrationOptions;
  using A = AcceptanceOptions;
  return {
      // Boxes 1-3.
      Field<int>("lens.observe_every_frames", 1, 10000,
                 "a snake's shape joins the distortion pool this often (frames)", &P::lens,
                 &L::observe_every_frames),
      Field<double>("lens.min_observation_shift_px", 0, 1000,
                    "...if the snake moved this much since its last shape (px)", &P::lens,
                    &L::min_observation_shift_px),
      Field<int>("lens.pool_grid", 1, 100, "cells across the image that pooled shapes are kept in",
                 &P::lens, &L::pool_grid),
      Field<int>("lens.pool_per_cell", 1, 1000,
                 "newest snake shapes kept per image cell and orientation", &P::lens,
                 &L::pool_per_cell),
      Field<int>("lens.estimate_every_frames", 1, 10000,
                 "frames between two plumb-line distortion estimates", &P::lens,
                 &L::estimate_every_frames),
      Field<int>("lens.estimate_lag_frames", 0, 10000,
                 "frames after it is begun that box 2's estimate, made on its own thread, "
                 "takes effect",
                 &P::lens, &L::estimate_lag_frames),
      Field<int>("lens.estimate_per_cell", 1, 1000,
                 "box 2's estimate takes the newest this many shapes per cell and orientation",
                 &P::lens, &L::estimate_per_cell),
      Field<int>("lens.still_rounds", 1, 100,
                 "rounds of boxes 1-2 on still images, each through the distortion so far",
                 &P::lens, &L::still_rounds),
      Field<int>("lens.still_max_lines", 1, 100000, "lines a still image may give, at most",
                 &P::lens, &L::still_max_lines),
      Field<int>("lens.still_max_snakes", 1, 100000, "snakes a still image may give, at most",
                 &P::lens, &L::still_max_snakes),
      Field<double>("lens.lines.canny_low", 0, 1000,
                    "lower hysteresis threshold of the edge detector", &P::lens, &L::lines,
                    &Lines::canny_low),
      Field<double>("lens.lines.canny_high", 0, 1000,
                    "upper hysteresis threshold of the edge detector", &P::lens, &L::lines,
                    &Lines::canny_high),
      Field<double>("lens.lines.theta_resolution_deg", 0.01, 45,
                    "angular bin of the Radon transform (deg; refined after)", &P::lens, &L::lines,
                    &Lines::theta_resolution_deg),
      Field<double>("lens.lines.rho_resolution_px", 0.1, 100,
                    "distance bin of the Radon transform (px)", &P::lens, &L::lines,
                    &Lines::rho_resolution_px),
      Field<double>("lens.lines.min_length_px", 5, 2000, "shortest line segment reported (px)",
                    &P::lens, &L::lines, &Lines::min_length_px),
      Field<double>("lens.lines.max_gap_px", 0, 1000,
                    "longest run without edge pixels inside a segment (px)", &P::lens, &L::lines,
                    &Lines::max_gap_px),
      Field<double>("lens.lines.min_fill", 0, 1,
                    "fraction of a segment's length backed by edge pixels", &P::lens, &L::lines,
                    &Lines::min_fill),
      Field<double>("lens.lines.inlier_distance_px", 0.01, 100,
                    "edge pixels this close to a line belong to it (px)", &P::lens, &L::lines,
                    &Lines::inlier_distance_px),
      Field<double>("lens.lines.max_normal_angle_deg", 0, 90,
                    "an edge's gradient must be this close to the line's normal (deg)", &P::lens,
                    &L::lines, &Lines::max_normal_angle_deg),
      Field<int>("lens.lines.max_lines", 1, 10000, "at most this many segments per image", &P::lens,
                 &L::lines, &Lines::max_lines),
      Field<double>("lens.snakes.spacing_px", 1, 1000, "length of one edge between hinges (px)",
                    &P::lens, &L::snakes, &Snakes::spacing_px),
      Field<double>("lens.snakes.search_px", 0.1, 1000,
                    "how far a snake may move along its normals per frame (px)", &P::lens,
                    &L::snakes, &Snakes::search_px),
      Field<double>("lens.snakes.min_edge_strength", 0, 255,
                    "weakest edge a hinge locks on (grey levels per px)", &P::lens, &L::snakes,
                    &Snakes::min_edge_strength),
      Field<double>("lens.snakes.max_bend_change_deg", 0, 180,
                    "a hinge bending this much off the snake's median bend has jumped (deg)",
                    &P::lens, &L::snakes, &Snakes::max_bend_change_deg),
      Field<double>("lens.snakes.min_length_px", 1, 10000,
                    "snakes shorter than this are neither seeded nor kept (px)", &P::lens,
                    &L::snakes, &Snakes::min_length_px),
      Field<int>("lens.snakes.max_grow_per_frame", 0, 1000,
                 "hinges added at each end per frame, at most", &P::lens, &L::snakes,
                 &Snakes::max_grow_per_frame),
      Field<double>("lens.snakes.border_margin_px", 0, 1000,
                    "hinges stay this far inside the image (px)", &P::lens, &L::snakes,
                    &Snakes::border_margin_px),
      Field<double>("lens.snakes.seed_max_distance", 0, 10,
                    "lines seed snakes this close to the principal point (of the half-diagonal)",
                    &P::lens, &L::snakes, &Snakes::seed_max_distance),
      Field<bool>("lens.snakes.adaptive_bend", 0, 1,
                  "a noisy edge raises max_bend_change_deg to 3x its own bend scatter (still "
                  "images always)",
                  &P::lens, &L::snakes, &Snakes::adaptive_bend),
      Field<int>("lens.snakes.max_snakes", 0, 1000, "snakes tracked at once, at most", &P::lens,
                 &L::snakes, &Snakes::max_snakes),
      Field<bool>("lens.plumb_line.estimate_k3", 0, 1, "box 2 also estimates k3", &P::lens,
                  &L::plumb_line, &Plumb::estimate_k3),
      Field<bool>("lens.plumb_line.estimate_tangential", 0, 1, "box 2 also estimates p1, p2",
                  &P::lens, &L::plumb_line, &Plumb::estimate_tangential),
      Field<bool>("lens.plumb_line.estimate_centre", 0, 1,
                  "box 2 also estimates the distortion centre (the principal point)", &P::lens,
                  &L::plumb_line, &Plumb::estimate_centre),
      Field<double>("lens.plumb_line.loss_scale_px", 0.001, 100,
                    "Cauchy loss scale on point-to-line distances (px)", &P::lens, &L::plumb_line,
                    &Plumb::loss_scale_px),
      Field<double>("lens.plumb_line.outlier_factor", 1, 1000,
                    "lines with an RMS above this times the median are dropped", &P::lens,
                    &L::plumb_line, &Plumb::outlier_factor),
      Field<int>("lens.plumb_line.min_lines", 1, 100000,
                 "fewer pooled lines: distortion not observable", &P::lens, &L::plumb_line,
                 &Plumb::min_lines),
      Field<int>("lens.plumb_line.min_points_per_line", 2, 100000, "shorter polylines are ignored",
                 &P::lens, &L::plumb_line, &Plumb::min_points_per_line),
      Field<int>("lens.plumb_line.max_iterations", 1, 10000,
                 "Levenberg-Marquardt iterations per distortion solve", &P::lens, &L::plumb_line,
                 &Plumb::max_iterations),
      Field<double>("lens.plumb_line.min_covered_radius", 0, 1.5,
                    "box 2's lines must reach this far from the principal point (of the "
                    "half-diagonal), else not observable",
                    &P::lens, &L::plumb_line, &Plumb::min_covered_radius),
      Field<double>("lens.plumb_line.max_direction_share", 0.01, 1,
                    "largest share of box 2's line points within 20 deg of one direction, else "
                    "not observable",
                    &P::lens, &L::plumb_line, &Plumb::max_direction_share),
      Field<double>("lens.plumb_line.max_sigma_px", 0.001, 1000,
                    "largest 1-sigma of box 2's shift within the lines' reach (px), else not "
                    "observable",
                    &P::lens, &L::plumb_line, &Plumb::max_sigma_px),
      Field<double>("lens.plumb_line.min_straightening", 0, 0.99,
                    "an estimate that moves the lens must straighten the lines by this fraction, "
                    "else not observable",
                    &P::lens, &L::plumb_line, &Plumb::min_straightening),
      Field<bool>("lens.rectify.undistort", 0, 1, "box 3 removes the lens distortion", &P::lens,
                  &L::rectify, &Rect::undistort),
      Field<bool>("lens.rectify.green_channel", 0, 1,
                  "geometry from the green channel, not a grey mix", &P::lens, &L::rectify,
                  &Rect::green_channel),
      Field<Equalization>("lens.rectify.equalization", 0, 2,
                          "grey levels: 0 as they come, 1 equalized globally, 2 locally (CLAHE)",
                          &P::lens, &L::rectify, &Rect::equalization),
      Field<double>("lens.rectify.clahe_clip_limit", 0.01, 1000,
                    "contrast limit of local equalization", &P::lens, &L::rectify,
                    &Rect::clahe_clip_limit),
      Field<int>("lens.rectify.clahe_tiles", 1, 256,
                 "tiles across the image for local equalization", &P::lens, &L::rectify,
                 &Rect::clahe_tiles),
      // Boxes 4-6.
      Field<int>("motion.lost_planes_kept", 0, 1000,
                 "lost planes remembered so they get their id back when seen again (0: not)",
                 &P::motion, &M::lost_planes_kept),
      Field<int>("motion.refind_min_matches", 4, 100000, "homography inliers to re-find a plane",
                 &P::motion, &M::refind_min_matches),
      Field<DescriptorType>("motion.refind_descriptor", 0, 1,
                            "keypoints that re-find a plane: 0 ORB, 1 SIFT", &P::motion,
                            &M::refind_descriptor),
      Field<int>("motion.flow.window_px", 3, 101, "side of the Lucas-Kanade window (px, odd)",
                 &P::motion, &M::flow, &Flow::window_px),
      Field<int>("motion.flow.pyramid_levels", 0, 10, "pyramid levels above the full image",
                 &P::motion, &M::flow, &Flow::pyramid_levels),
      Field<int>("motion.flow.max_iterations", 1, 1000, "Lucas-Kanade iterations per level",
                 &P::motion, &M::flow, &Flow::max_iterations),
      Field<double>("motion.flow.epsilon_px", 1e-6, 10,
                    "...or until a step is shorter than this (px)", &P::motion, &M::flow,
                    &Flow::epsilon_px),
      Field<double>("motion.flow.min_eigen", 0, 1,
                    "windows flatter than this fail (OpenCV's minEigThreshold)", &P::motion,
                    &M::flow, &Flow::min_eigen),
      Field<double>("motion.flow.max_fb_error_px", 0.01, 100,
                    "tracked back, a point must land this close to its start (px)", &P::motion,
                    &M::flow, &Flow::max_fb_error_px),
      Field<bool>("motion.flow.predict", 0, 1, "start each search at the point's previous velocity",
                  &P::motion, &M::flow, &Flow::predict),
      Field<int>("motion.flow.retry_levels", -1, 10,
                 "lost tracks searched again with this many levels (-1: not)", &P::motion, &M::flow,
                 &Flow::retry_levels),
      Field<int>("motion.flow.border_px", 0, 1000, "tracks closer to the border are dropped (px)",
                 &P::motion, &M::flow, &Flow::border_px),
      Field<int>("motion.flow.target_tracks", 10, 5000,
                 "new corners fill empty cells up to this many tracks", &P::motion, &M::flow,
                 &Flow::target_tracks),
      Field<int>("motion.flow.history_frames", 2, 10000, "positions kept per track (frames)",
                 &P::motion, &M::flow, &Flow::history_frames),
      Field<int>("motion.flow.features.grid_columns", 1, 1000,
                 "cells across the image that new corners are spread over", &P::motion, &M::flow,
                 &Flow::features, &Feat::grid_columns),
      Field<int>("motion.flow.features.grid_rows", 1, 1000, "cells down the image", &P::motion,
                 &M::flow, &Flow::features, &Feat::grid_rows),
      Field<int>("motion.flow.features.max_per_cell", 1, 10000,
                 "tracked points per cell, existing ones counted", &P::motion, &M::flow,
                 &Flow::features, &Feat::max_per_cell),
      Field<int>("motion.flow.features.fast_threshold", 1, 255,
                 "FAST: grey-level contrast of the ring around a corner", &P::motion, &M::flow,
                 &Flow::features, &Feat::fast_threshold),
      Field<int>("motion.flow.features.min_fast_threshold", 1, 255,
                 "cells with no corner are searched again at this contrast", &P::motion, &M::flow,
                 &Flow::features, &Feat::min_fast_threshold),
      Field<double>("motion.flow.features.min_distance_px", 0, 1000,
                    "new corners keep this far from tracked points and each other (px)", &P::motion,
                    &M::flow, &Flow::features, &Feat::min_distance_px),
      Field<int>("motion.flow.features.border_px", 0, 1000,
                 "no corners this close to the border (px)", &P::motion, &M::flow, &Flow::features,
                 &Feat::border_px),
      Field<DescriptorType>("motion.flow.features.descriptor", 0, 1,
                            "keypoints of still shots: 0 ORB, 1 SIFT", &P::motion, &M::flow,
                            &Flow::features, &Feat::descriptor),
      Field<int>("motion.flow.features.max_keypoints", 1, 1000000,
                 "strongest scale-invariant keypoints kept per image", &P::motion, &M::flow,
                 &Flow::features, &Feat::max_keypoints),
      Field<double>("motion.flow.features.match_ratio", 0.01, 1,
                    "Lowe's test: best match closer than this times the second", &P::motion,
                    &M::flow, &Flow::features, &Feat::match_ratio),
      Field<int>("motion.planes.baseline_frames", 1, 1000,
                 "membership and new planes are judged on the flow over this many frames",
                 &P::motion, &M::planes, &Planes::baseline_frames),
      Field<int>("motion.planes.long_baseline_frames", 0, 1000,
                 "old tracks are judged over this longer baseline too (0: not)", &P::motion,
                 &M::planes, &Planes::long_baseline_frames),
      Field<int>("motion.planes.young_frames", 0, 1000,
                 "tracks this old are judged over their own life (0: not)", &P::motion, &M::planes,
                 &Planes::young_frames),
      Field<double>("motion.planes.inlier_threshold_px", 0.01, 100,
                    "transfer error over the baseline for a track to join a plane (px)", &P::motion,
                    &M::planes, &Planes::inlier_threshold_px),
      Field<double>("motion.planes.eject_threshold_px", 0.01, 100,
                    "a member whose error exceeds this leaves its plane (px)", &P::motion,
                    &M::planes, &Planes::eject_threshold_px),
      Field<double>("motion.planes.noise_scale", 0, 100,
                    "a noisy plane's thresholds grow with this times its median error (0: never)",
                    &P::motion, &M::planes, &Planes::noise_scale),
      Field<double>("motion.planes.max_noise_scale", 1, 100, "...by at most this factor",
                    &P::motion, &M::planes, &Planes::max_noise_scale),
      Field<double>("motion.planes.join_radius", 0, 10,
                    "a track joins a plane this close to one of its tracks (of the diagonal)",
                    &P::motion, &M::planes, &Planes::join_radius),
      Field<int>("motion.planes.ransac_iterations", 1, 1000000, "most RANSAC samples per fit",
                 &P::motion, &M::planes, &Planes::ransac_iterations),
      Field<int>("motion.planes.min_inliers", 4, 10000, "tracks a new plane needs", &P::motion,
                 &M::planes, &Planes::min_inliers),
      Field<double>("motion.planes.min_area_fraction", 0, 1,
                    "...and the image fraction their convex hull covers", &P::motion, &M::planes,
                    &Planes::min_area_fraction),
      Field<int>("motion.planes.min_tracks_to_keep", 1, 10000,
                 "a plane left with fewer live tracks is lost", &P::motion, &M::planes,
                 &Planes::min_tracks_to_keep),
      Field<double>("motion.planes.min_parallax_px", 0, 1000,
                    "image motion from translation needed before a new plane is fitted (px)",
                    &P::motion, &M::planes, &Planes::min_parallax_px),
      Field<int>("motion.planes.max_planes", 1, 100, "planes followed at once", &P::motion,
                 &M::planes, &Planes::max_planes),
      Field<int>("motion.planes.max_reference_frames", 1, 100000,
                 "a plane's reference frame moves up after this many frames", &P::motion,
                 &M::planes, &Planes::max_reference_frames),
      Field<double>("motion.planes.merge_fraction", 0, 1,
                    "two planes one homography fits this well are one", &P::motion, &M::planes,
                    &Planes::merge_fraction),
      Field<double>("motion.planes.min_spread", 0, 1,
                    "orientation decomposed only while tracks spread this much (of the diagonal)",
                    &P::motion, &M::planes, &Planes::min_spread),
      Field<int>("motion.planes.normal_votes", 1, 10000,
                 "frames of decomposition candidates voted over", &P::motion, &M::planes,
                 &Planes::normal_votes),
      Field<double>("motion.planes.normal_agreement_deg", 0, 180,
                    "candidates this close vote for each other (deg)", &P::motion, &M::planes,
                    &Planes::normal_agreement_deg),
      Field<double>("motion.planes.shot_inlier_threshold_px", 0.01, 1000,
                    "still shots: transfer error of matched keypoints (px)", &P::motion, &M::planes,
                    &Planes::shot_inlier_threshold_px),
      Field<bool>("motion.planes.shot_guided_matching", 0, 1,
                  "still shots: each plane's homography also matches keypoints that look alike",
                  &P::motion, &M::planes, &Planes::shot_guided_matching),
      // Box 7.
      Field<double>("inertial.velocity_horizon_s", 0, 3600,
                    "integrated velocity is forgotten this long after the last rest (s)",
                    &P::inertial, &I::velocity_horizon_s),
      Field<double>("inertial.history_s", 0.1, 3600,
                    "readings kept this far behind the newest frame (s)", &P::inertial,
                    &I::history_s),
      Field<bool>("inertial.learn_bias", 0, 1,
                  "learn the accelerometer's bias from scale windows and take it off", &P::inertial,
                  &I::learn_bias),
      Field<double>("inertial.max_bias_sigma_m_s2", 0, 100,
                    "a window's bias less certain than this is not fused (m/s^2)", &P::inertial,
                    &I::max_bias_sigma_m_s2),
      Field<double>("inertial.bias_gate_chi2", 0, 1e6,
                    "a window's bias this far (chi-square) from what was learned is not fused",
                    &P::inertial, &I::bias_gate_chi2),
      Field<double>("inertial.screen.range_m_s2", 0.1, 10000,
                    "the sensor's full scale: readings clip at +-range (m/s^2)", &P::inertial,
                    &I::screen, &Screen::range_m_s2),
      Field<double>("inertial.screen.saturation_margin_m_s2", 0, 100,
                    "an axis this close to full scale is saturated (m/s^2)", &P::inertial,
                    &I::screen, &Screen::saturation_margin_m_s2),
      Field<double>("inertial.screen.max_gap_s", 0.0001, 10,
                    "readings further apart than this leave a gap (s)", &P::inertial, &I::screen,
                    &Screen::max_gap_s),
      Field<double>("inertial.quasi_static.window_s", 0.001, 100,
                    "rest is tested on the readings within half of this (s)", &P::inertial,
                    &I::quasi_static, &Rest::window_s),
      Field<double>("inertial.quasi_static.max_norm_deviation_m_s2", 0, 100,
                    "at rest the mean force's size is this close to gravity (m/s^2)", &P::inertial,
                    &I::quasi_static, &Rest::max_norm_deviation_m_s2),
      Field<double>("inertial.quasi_static.max_variance_m2_s4", 0, 100,
                    "variance of the readings per axis at most this for rest ((m/s^2)^2)",
                    &P::inertial, &I::quasi_static, &Rest::max_variance_m2_s4),
      Field<int>("inertial.quasi_static.min_readings", 1, 100000,
                 "fewer readings in the window: not tested", &P::inertial, &I::quasi_static,
                 &Rest::min_readings),
      Field<double>("inertial.quasi_static.min_rest_s", 0, 100,
                    "gravity is measured once a rest lasts this long (s)", &P::inertial,
                    &I::quasi_static, &Rest::min_rest_s),
      Field<double>("inertial.quasi_static.rest_average_s", 0, 3600,
                    "...as the mean over this much of it (s)", &P::inertial, &I::quasi_static,
                    &Rest::rest_average_s),
      Field<double>("inertial.quasi_static.rest_max_turn_deg", 0, 180,
                    "...restarted when vision sees the camera turn more (deg)", &P::inertial,
                    &I::quasi_static, &Rest::rest_max_turn_deg),
      Field<double>("inertial.quasi_static.gravity_m_s2", 9, 10.5, "local gravity (m/s^2)",
                    &P::inertial, &I::quasi_static, &Rest::gravity_m_s2),
      Field<double>("inertial.quasi_static.bias_uncertainty_m_s2", 0, 100,
                    "unknown bias across gravity added to the tilt's sigma (m/s^2)", &P::inertial,
                    &I::quasi_static, &Rest::bias_uncertainty_m_s2),
      Field<double>("inertial.motion.still_max_rotation_deg_s", 0, 10000,
                    "vision turning faster is not still (deg/s)", &P::inertial, &I::motion,
                    &Class::still_max_rotation_deg_s),
      Field<double>("inertial.motion.rotate_min_deg_s", 0, 10000,
                    "turning faster without moving forward is a rotation (deg/s)", &P::inertial,
                    &I::motion, &Class::rotate_min_deg_s),
      Field<double>("inertial.motion.forward_max_angle_deg", 0, 90,
                    "translation this near the optical axis is forward, farther sidestep (deg)",
                    &P::inertial, &I::motion, &Class::forward_max_angle_deg),
      Field<double>("inertial.motion.min_horizontal_fraction", 0, 1,
                    "translation less horizontal than this is not classified", &P::inertial,
                    &I::motion, &Class::min_horizontal_fraction),
      Field<double>("inertial.motion.min_speed_m_s", 0, 100,
                    "accelerometer only: slower is not classified (m/s)", &P::inertial, &I::motion,
                    &Class::min_speed_m_s),
      Field<int>("inertial.scale.min_poses", 2, 100000, "fewer poses in the window: no scale",
                 &P::inertial, &I::scale, &Scale::min_poses),
      Field<bool>("inertial.scale.estimate_bias", 0, 1, "scale windows also estimate a bias",
                  &P::inertial, &I::scale, &Scale::estimate_bias),
      Field<bool>("inertial.scale.known_gravity_norm", 0, 1,
                  "hold gravity's size at gravity_m_s2, leaving its direction", &P::inertial,
                  &I::scale, &Scale::known_gravity_norm),
      Field<double>("inertial.scale.gravity_m_s2", 9, 10.5, "local gravity (m/s^2)", &P::inertial,
                    &I::scale, &Scale::gravity_m_s2),
      Field<int>("inertial.scale.gravity_iterations", 0, 100,
                 "Gauss-Newton steps on gravity's direction", &P::inertial, &I::scale,
                 &Scale::gravity_iterations),
      Field<double>("inertial.scale.accel_noise_density", 0, 10,
                    "the accelerometer's white noise ((m/s^2)/sqrt(Hz))", &P::inertial, &I::scale,
                    &Scale::accel_noise_density),
      Field<double>("inertial.scale.visual_rotation_sigma_deg", 0, 90,
                    "noise of vision's orientations per pose (deg)", &P::inertial, &I::scale,
                    &Scale::visual_rotation_sigma_deg),
      Field<double>("inertial.scale.max_relative_sigma", 0, 10,
                    "a scale less certain than this (relative, 1 sigma) is not used", &P::inertial,
                    &I::scale, &Scale::max_relative_sigma),
      // Box 8.
      Field<int>("board.squares_x", 1, 100, "squares of a virtual board along its first axis",
                 &P::board, &B::squares_x),
      Field<int>("board.squares_y", 1, 100, "squares of a virtual board along its second axis",
                 &P::board, &B::squares_y),
      Field<int>("board.samples_per_square", 1, 100,
                 "points per square side on the drawn lines (they bend)", &P::board,
                 &B::samples_per_square),
      Field<double>("board.outlier_factor", 1, 1e6,
                    "tracked points this many median distances from the plane's middle are "
                    "not covered",
                    &P::board, &B::outlier_factor),
      Field<int>("board.min_tracks_seen", 1, 10000,
                 "a board is drawn on frames that show this many of its plane's tracks", &P::board,
                 &B::min_tracks_seen),
      Field<double>("board.max_track_error", 1e-6, 1,
                    "...where its pose puts them this close (median, of the image diagonal)",
                    &P::board, &B::max_track_error),
      // Box 9.
      Field<double>("material.window_s", 0.1, 600, "views this far back make up a window (s)",
                    &P::material, &Mat::window_s),
      Field<int>("material.view_every_frames", 1, 1000, "one frame in this many is a view",
                 &P::material, &Mat::view_every_frames),
      Field<double>("material.attempt_every_s", 0.01, 3600, "box 10 is tried this often (s)",
                    &P::material, &Mat::attempt_every_s),
      Field<int>("material.max_points_per_plane", 6, 100000,
                 "tracks per plane handed to box 10, the longest seen first", &P::material,
                 &Mat::max_points_per_plane),
      Field<int>("material.min_views_per_point", 2, 1000, "tracks seen in fewer views are left out",
                 &P::material, &Mat::min_views_per_point),
      Field<int>("material.max_lines", 0, 100000, "straight-line shapes handed to box 10",
                 &P::material, &Mat::max_lines),
      Field<bool>("material.anchor.enabled", 0, 1,
                  "measure plane tracks against the patch each was first measured at, warped "
                  "by its plane (no tracker drift)",
                  &P::material, &Mat::anchor, &Anc::enabled),
      Field<int>("material.anchor.window_px", 5, 101, "side of the patch aligned (px, odd)",
                 &P::material, &Mat::anchor, &Anc::window_px),
      Field<double>("material.anchor.max_shift_px", 0.01, 100,
                    "an aligned track this far from the tracker's position is not measured (px)",
                    &P::material, &Mat::anchor, &Anc::max_shift_px),
      Field<double>("material.anchor.off_plane_fraction", 0, 1,
                    "...nor one off its plane: this far from where the plane's homography "
                    "carries its anchor (of the image diagonal; 0: any),",
                    &P::material, &Mat::anchor, &Anc::off_plane_fraction),
      Field<double>("material.anchor.off_plane_ratio", 1, 100,
                    "...and this many times the plane's median point", &P::material, &Mat::anchor,
                    &Anc::off_plane_ratio),
      Field<double>("material.anchor.min_correlation", -0.99, 0.99,
                    "...nor one correlating less with its warped anchor patch", &P::material,
                    &Mat::anchor, &Anc::min_correlation),
      Field<int>("material.anchor.max_iterations", 1, 1000, "Gauss-Newton steps per alignment",
                 &P::material, &Mat::anchor, &Anc::max_iterations),
      Field<double>("material.anchor.epsilon_px", 1e-6, 1,
                    "...or until a step is shorter than this (px)", &P::material, &Mat::anchor,
                    &Anc::epsilon_px),
      Field<bool>("material.quality.enabled", 0, 1,
                  "judge each frame's image quality (fog, noise) before measuring from it",
                  &P::material, &Mat::quality, &Q::enabled),
      Field<double>("material.quality.baseline_s", 0.1, 3600,
                    "good frames this far back make the usual quality (s)", &P::material,
                    &Mat::quality, &Q::baseline_s),
      Field<int>("material.quality.min_baseline_frames", 1, 100000,
                 "fewer good frames: nothing is judged yet", &P::material, &Mat::quality,
                 &Q::min_baseline_frames),
      Field<double>("material.quality.max_blur_increase", 0.001, 1,
                    "blur above the recent usual by more than this makes a frame unfit",
                    &P::material, &Mat::quality, &Q::max_blur_increase),
      Field<double>("material.quality.fog_blur_increase", 0.001, 1,
                    "fog sign: blur up by this much (two fog signs make a frame unfit)",
                    &P::material, &Mat::quality, &Q::fog_blur_increase),
      Field<double>("material.quality.fog_contrast_ratio", 0.01, 1,
                    "fog sign: contrast below this fraction of the usual", &P::material,
                    &Mat::quality, &Q::fog_contrast_ratio),
      Field<double>("material.quality.fog_noise_ratio", 0.01, 1,
                    "fog sign: noise below this fraction of the usual", &P::material, &Mat::quality,
                    &Q::fog_noise_ratio),
      Field<double>("material.quality.min_contrast_ratio", 0.01, 1,
                    "contrast below this fraction of the usual makes a frame unfit", &P::material,
                    &Mat::quality, &Q::min_contrast_ratio),
      Field<double>("material.quality.max_noise_ratio", 1, 1000,
                    "noise above this many times the usual makes a frame unfit", &P::material,
                    &Mat::quality, &Q::max_noise_ratio),
      Field<double>("material.quality.min_noise_increase_grey", 0, 255,
                    "...and up by at least this many grey levels", &P::material, &Mat::quality,
                    &Q::min_noise_increase_grey),
      Field<double>("material.quality.motion_blur_speed_px", 0.01, 10000,
                    "image moving this fast (px a frame): blur is the exposure's, not a fault",
                    &P::material, &Mat::quality, &Q::motion_blur_speed_px),
      Field<double>("material.quality.accept_as_usual_s", 0.1, 3600,
                    "an unfit look lasting longer becomes the usual (s)", &P::material,
                    &Mat::quality, &Q::accept_as_usual_s),
      // Box 10.
      Field<bool>("calibration.estimate_principal_point", 0, 1, "cx, cy free", &P::calibration,
                  &C::estimate_principal_point),
      Field<bool>("calibration.estimate_distortion", 0, 1, "k1, k2 free", &P::calibration,
                  &C::estimate_distortion),
      Field<bool>("calibration.estimate_k3", 0, 1, "k3 free too", &P::calibration, &C::estimate_k3),
      Field<bool>("calibration.estimate_tangential", 0, 1, "p1, p2 free too", &P::calibration,
                  &C::estimate_tangential),
      Field<double>("calibration.loss_px", 0.01, 100,
                    "Cauchy loss scale on reprojection errors (px)", &P::calibration, &C::loss_px),
      Field<double>("calibration.prior_focal_fraction", 1e-6, 10,
                    "prior sigma of fx, fy as a fraction of them", &P::calibration,
                    &C::prior_focal_fraction),
      Field<double>("calibration.prior_principal_px", 1e-6, 10000, "prior sigma of cx, cy (px)",
                    &P::calibration, &C::prior_principal_px),
      Field<double>("calibration.prior_distortion", 1e-9, 100,
                    "prior sigma of each distortion coefficient", &P::calibration,
                    &C::prior_distortion),
      Field<double>("calibration.prior_track_noise_px", 1e-4, 100,
                    "the plane tracks' noise the prior is weighed against (px)", &P::calibration,
                    &C::prior_track_noise_px),
      Field<int>("calibration.min_frames", 3, 100000, "fewer views with a pose: no update",
                 &P::calibration, &C::min_frames),
      Field<int>("calibration.min_points_per_plane", 6, 100000,
                 "planes with fewer tracked points are left out", &P::calibration,
                 &C::min_points_per_plane),
      Field<double>("calibration.min_rotation_deg", 0, 180,
                    "views must differ by this much in orientation (deg)", &P::calibration,
                    &C::min_rotation_deg),
      Field<double>("calibration.barely_moved_px", 0, 10000,
                    "a window whose image moved less than this (px) makes no update because "
                    "the camera barely moved, and says so",
                    &P::calibration, &C::barely_moved_px),
      Field<double>("calibration.max_focal_sigma", 1e-6, 1,
                    "no update when sigma(fx) / fx exceeds this", &P::calibration,
                    &C::max_focal_sigma),
      Field<int>("calibration.max_iterations", 1, 10000, "Levenberg-Marquardt iterations",
                 &P::calibration, &C::max_iterations),
      Field<int>("calibration.warm_first_pass_iterations", 1, 10000,
                 "from the previous attempt's solution, the first pass (before the worst "
                 "points are left out) stops after this many iterations at most",
                 &P::calibration, &C::warm_first_pass_iterations),
      Field<bool>("calibration.warm_start", 0, 1,
                  "start from the previous attempt's solution on the views it shares",
                  &P::calibration, &C::warm_start),
      Field<double>("calibration.warm_start_max_median_px", 1e-3, 1000,
                    "a warm start whose plane points reproject with a median error above "
                    "this (px) is dropped for a cold one",
                    &P::calibration, &C::warm_start_max_median_px),
      Field<double>("calibration.max_point_rms_ratio", 0, 1000,
                    "a point reprojecting this many times worse than the median point, or a "
                    "line this many times less straight than the median line, is left out and "
                    "the solve goes on (0: none)",
                    &P::calibration, &C::max_point_rms_ratio),
      Field<double>("calibration.function_tolerance", 1e-12, 0.1,
                    "converged when an iteration lowers the cost by less than this fraction",
                    &P::calibration, &C::function_tolerance),
      Field<double>("calibration.still_intrinsics_px", 0, 100,
                    "the last pass also ends once two iterations in a row each move the "
                    "calibration's image by less than this (px; 0: only by the cost)",
                    &P::calibration, &C::still_intrinsics_px),
      Field<double>("calibration.readout_ms", 0, kMaxReadoutMs,
                    "the camera's rolling shutter reads its rows top to bottom over this time "
                    "(ms; 0: a global shutter; a recording that states it sets it)",
                    &P::calibration, &C::readout_ms),
      // The history.
      Field<double>("acceptance.max_rms_px", 0.001, 100,
                    "attempts with a larger reprojection RMS are rejected (px)", &P::acceptance,
                    &A::max_rms_px),
      Field<double>("acceptance.max_sigma", 0.1, 1000,
                    "an attempt fits the trend within this many sigma", &P::acceptance,
                    &A::max_sigma),
      Field<double>("acceptance.focal_floor_fraction", 0, 1,
                    "least sigma of an attempt's fx, fy, as a fraction of them", &P::acceptance,
                    &A::focal_floor_fraction),
      Field<double>("acceptance.principal_floor_px", 0, 1000,
                    "least sigma of an attempt's cx, cy (px)", &P::acceptance,
                    &A::principal_floor_px),
      Field<double>("acceptance.distortion_floor_px", 0, 1000,
                    "least sigma of the displacement an attempt's distortion causes (px)",
                    &P::acceptance, &A::distortion_floor_px),
      Field<double>("acceptance.distortion_radius_fraction", 0.01, 1,
                    "distortion compared by its displacement at this fraction of the half-diagonal",
                    &P::acceptance, &A::distortion_radius_fraction),
      Field<double>("acceptance.window_s", 0.1, kUnbounded,
                    "the trend fits the accepted attempts this far back (s)", &P::acceptance,
                    &A::window_s),
      Field<int>("acceptance.max_order", 0, 2, "highest order of the trend", &P::acceptance,
                 &A::max_order),
      Field<int>("acceptance.min_points_linear", 2, 100000,
                 "fewer accepted attempts in the window: a constant trend", &P::acceptance,
                 &A::min_points_linear),
      Field<int>("acceptance.min_points_quadratic", 3, 100000,
                 "fewer accepted attempts in the window: at most a linear trend", &P::acceptance,
                 &A::min_points_quadratic),
      Field<double>("acceptance.order_evidence_chi2", 0, 1e6,
                    "a higher trend order must lower some parameter's chi-square this much",
                    &P::acceptance, &A::order_evidence_chi2),
      Field<double>("acceptance.max_extrapolation_s", 0, kUnbounded,
                    "the trend is held this long after its newest attempt (s)", &P::acceptance,
                    &A::max_extrapolation_s),
      Field<double>("acceptance.attempt_window_s", 0, kUnbounded,
                    "attempts closer than this share views, in the output's covariance (s; a "
                    "run takes material.window_s, this serves a history judged on its own)",
                    &P::acceptance, &A::attempt_window_s),
      Field<int>("acceptance.alarm_after", 1, 100,
                 "consistent attempts off the trend that raise a jump alarm", &P::acceptance,
                 &A::alarm_after),
      Field<int>("acceptance.confirm_after", 1, 100,
                 "consistent attempts off the trend that start a new regime", &P::acceptance,
                 &A::confirm_after),
  };
}

std::string Trim(const std::string& text) {
  const size_t first = text.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  return text.substr(first, text.find_last_not_of(" \t\r") - first + 1);
}

std::string ValueText(const OptionField& field, const PipelineOptions& options) {
  const double value = field.get(options);
  if (field.kind == OptionField::Kind::kFlag) return value != 0 ? "true" : "false";
  return ShortestDecimal(value);
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
    text << field.name << " = " << ValueText(field, options) << "\n";
  }
  return text.str();
}

std::vector<std::pair<std::string, std::string>> ChangedPipelineOptions(
    const PipelineOptions& options) {
  const PipelineOptions defaults;
  std::vector<std::pair<std::string, std::string>> changed;
  for (const OptionField& field : PipelineOptionFields()) {
    if (field.get(options) != field.get(defaults)) {
      changed.emplace_back(field.name, ValueText(field, options));
    }
  }
  return changed;
}

}  // namespace autocal
