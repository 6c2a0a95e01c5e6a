// The pieces around boxes 1-10 that `autocal run` is made of: the window of material
// (box 9), where each solve starts, the option fields and settings files, the error
// against the truth, and the run's summary JSON read back with OpenCV's own JSON reader.
#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "devices/offline_runner.h"
#include "devices/sim/simulator.h"
#include "pipeline/calibration_error.h"
#include "pipeline/calibration_pipeline.h"
#include "pipeline/error.h"
#include "pipeline/history_store.h"
#include "pipeline/material_window.h"
#include "pipeline/option_fields.h"
#include "pipeline/plumb_line.h"
#include "pipeline/text_format.h"
#include "test_util.h"

namespace autocal {
namespace {

// A frame whose plane 7 holds tracks `first`..`last` at pixels (track, frame).
MotionSnapshot Frame(int64_t t_ns, int first, int last) {
  MotionSnapshot motion;
  motion.t_ns = t_ns;
  DominantPlane plane;
  plane.id = 7;
  for (int track = first; track <= last; ++track) {
    plane.track_ids.push_back(track);
    plane.points.emplace_back(float(track), float(t_ns / 1000000));
  }
  motion.planes.push_back(plane);
  return motion;
}

InertialSnapshot AtRest(GravitySource source) {
  InertialSnapshot inertial;
  inertial.gravity_source = source;
  inertial.gravity_cam = Eigen::Vector3d(0.0, 9.81, 0.0);
  inertial.gravity_sigma_deg = 0.3;
  return inertial;
}

TEST(MaterialWindow, TakesEveryNthFrameOverTheWindow) {
  MaterialOptions options;
  options.view_every_frames = 3;
  options.window_s = 1.0;
  MaterialWindow window(options);
  int views = 0;
  for (int i = 0; i < 90; ++i) {  // 3 s at 30 Hz.
    views += window.Add(Frame(int64_t(i) * 33333333, 0, 20), AtRest(GravitySource::kNone),
                        cv::Mat(), {});
  }
  EXPECT_EQ(views, 30);
  const std::vector<int64_t> times = window.view_times();
  // Views 100 ms apart, the newest at frame 87, the oldest at most 1 s before it.
  ASSERT_EQ(times.size(), 11u);
  EXPECT_EQ(times.back(), 87 * int64_t(33333333));
  EXPECT_EQ(times.front(), 57 * int64_t(33333333));
  EXPECT_NEAR(window.span_s(), 1.0, 1e-6);
  // Box 10 times each view by them (a rolling shutter's rows).
  EXPECT_EQ(window.Assemble({}).frame_t_ns, times);
}

TEST(MaterialWindow, HandsOnTheRealTrackPixelsOfTheLongestSeenTracks) {
  MaterialOptions options;
  options.view_every_frames = 1;
  options.max_points_per_plane = 10;
  options.min_views_per_point = 3;
  options.anchor.enabled = false;  // The pixels as box 5 measured them.
  MaterialWindow window(options);
  // Tracks 0-19 seen in all 6 frames; 20-29 only in the last two; 30-39 in the last four.
  for (int i = 0; i < 6; ++i) {
    MotionSnapshot frame = Frame(int64_t(i) * 1000000, 0, 19);
    const MotionSnapshot late = Frame(int64_t(i) * 1000000, i >= 4 ? 20 : 30, i >= 2 ? 39 : 29);
    for (size_t k = 0; k < late.planes[0].track_ids.size(); ++k) {
      if (late.planes[0].track_ids[k] < 20) continue;
      if (late.planes[0].track_ids[k] < 30 && i < 4) continue;
      frame.planes[0].track_ids.push_back(late.planes[0].track_ids[k]);
      frame.planes[0].points.push_back(late.planes[0].points[k]);
    }
    window.Add(frame, AtRest(GravitySource::kNone), cv::Mat(), {});
  }
  const CalibrationMaterial material = window.Assemble({});
  EXPECT_EQ(material.frame_count, 6);
  ASSERT_EQ(material.planes.size(), 1u);
  EXPECT_EQ(material.planes[0].id, 7);
  std::set<int> points;
  for (const PlaneObservation& o : material.planes[0].observations) {
    points.insert(o.point);
    // The pixel is the track's own, as box 5 measured it (x = track id, y = frame in ms).
    EXPECT_EQ(o.pixel.x(), double(o.point));
    EXPECT_EQ(o.pixel.y(), double(o.frame));
  }
  EXPECT_EQ(points.size(), 10u) << "at most max_points_per_plane";
  for (int p : points) EXPECT_LT(p, 20) << "the tracks seen in every view come first";
  EXPECT_EQ(material.planes[0].observations.size(), 60u);
}

TEST(MaterialWindow, GravityOnlyWhereMeasuredAtRest) {
  MaterialOptions options;
  options.view_every_frames = 1;
  MaterialWindow window(options);
  window.Add(Frame(0, 0, 20), AtRest(GravitySource::kMeasured), cv::Mat(), {});
  window.Add(Frame(1000000, 0, 20), AtRest(GravitySource::kPropagated), cv::Mat(), {});
  window.Add(Frame(2000000, 0, 20), AtRest(GravitySource::kMeasured), cv::Mat(), {});
  const CalibrationMaterial material = window.Assemble({});
  ASSERT_EQ(material.gravity.size(), 2u);
  EXPECT_EQ(material.gravity[0].frame, 0);
  EXPECT_EQ(material.gravity[1].frame, 2);
  EXPECT_NEAR(material.gravity[0].down_cam.norm(), 1.0, 1e-12);
  EXPECT_EQ(material.gravity[0].sigma_deg, 0.3);
}

TEST(MaterialWindow, ThinsLinesEvenlyOverThePool) {
  MaterialOptions options;
  options.max_lines = 4;
  MaterialWindow window(options);
  window.Add(Frame(0, 0, 20), AtRest(GravitySource::kNone), cv::Mat(), {});
  std::vector<LineObservation> lines(10);
  for (int i = 0; i < 10; ++i) lines[i].points = {Eigen::Vector2d(i, 0)};
  const CalibrationMaterial material = window.Assemble(lines);
  ASSERT_EQ(material.lines.size(), 4u);
  EXPECT_EQ(material.lines[0].points[0].x(), 0.0);
  EXPECT_EQ(material.lines[1].points[0].x(), 2.0);
  EXPECT_EQ(material.lines[2].points[0].x(), 5.0);
  EXPECT_EQ(material.lines[3].points[0].x(), 7.0);
}

// What the tests below ask of one walk through the pipeline in its two halves, box 10
// solved on the spot where `autocal run` gives it a thread.
struct PipelineWalk {
  struct Job {
    size_t frame = 0;
    bool after_an_attempt = false;   // The history held attempts when it was handed out.
    std::optional<double> start_fx;  // Where its solve started, if from an earlier solve.
    bool taken = false;              // Accepted, or the start of a new regime.
    bool with_distortion = false;    // The distortion was estimated.
    double fx = 0.0;
  };
  size_t frames = 0;
  std::vector<Job> jobs;
  std::vector<size_t> box2_estimates;  // Frames on which one of box 2's estimates landed.
};

// The office through the sonnar lens from the wrong start, 6 s at 320x240.
const PipelineWalk& WrongStartWalk() {
  static const PipelineWalk kWalk = [] {
    const std::unique_ptr<Sequence> sequence =
        MakeSimulatedSequence(ParseScenarioSpec("office,lens=sonnar,resolution=320x240,seconds=6"));
    AccelCalibration accel;
    accel.cam_from_accel = sequence->session().cam_from_accel;
    const PipelineOptions options;
    CalibrationPipeline pipeline(test::WrongStart(*sequence->session().premission_calibration),
                                 accel, options);
    // The accelerometer half a quasi-static window ahead of the frames, as the runtime has it.
    const auto lead_ns = int64_t(0.5 * options.inertial.quasi_static.window_s * 1e9);
    const std::vector<AccelSample>& samples = sequence->accel();
    size_t fed = 0;
    PipelineWalk walk;
    walk.frames = sequence->frame_count();
    for (size_t i = 0; i < sequence->frame_count(); ++i) {
      const int64_t t_ns = sequence->frame_time_ns(i);
      std::vector<SpecificForceSample> batch;
      for (; fed < samples.size() && samples[fed].t_ns <= t_ns + lead_ns; ++fed) {
        batch.push_back({samples[fed].t_ns, samples[fed].specific_force});
      }
      pipeline.AddAccel(batch);
      std::optional<CalibrationJob> job;
      const FrameSnapshot snapshot = pipeline.ProcessFrame(t_ns, sequence->LoadFrame(i), &job);
      if (snapshot.timing.distortion_ms > 0) walk.box2_estimates.push_back(i);
      if (!job) continue;
      PipelineWalk::Job done;
      done.frame = i;
      done.after_an_attempt = !pipeline.history().attempts().empty();
      if (job->material.start) done.start_fx = job->material.start->intrinsics.fx;
      const SelfCalibrationResult result =
          SelfCalibrate(job->material, job->prior, options.calibration);
      const AttemptRecord& record = pipeline.Judge(*job, result)->record;
      done.taken = record.verdict == Verdict::kAccepted || record.verdict == Verdict::kNewRegime;
      done.with_distortion = std::ranges::count(record.free_parameters, int(kK1)) > 0;
      done.fx = result.estimate.fx;
      walk.jobs.push_back(done);
    }
    return walk;
  }();
  return kWalk;
}

// The attempts that confirm a jump must each reach it on their own: a solve the history
// rejected does not seed the next, or one wrong minimum is carried from window to window
// (outdoor sonnar seed 4 at 320x240: the ground alone, fx 137 px for 213 three times in a
// row, and a false alarm). From the wrong start the first attempts are rejected
// and start afresh; once a regime takes one, each starts from the last one taken.
TEST(CalibrationPipeline, OnlyASolveTheHistoryTookSeedsTheNext) {
  std::optional<double> taken_fx;  // Of the last solve the history took.
  int before_any_taken = 0, after_taken = 0;
  for (const PipelineWalk::Job& job : WrongStartWalk().jobs) {
    if (job.after_an_attempt) (taken_fx ? after_taken : before_any_taken) += 1;
    EXPECT_EQ(job.start_fx, taken_fx) << "the job on frame " << job.frame;
    if (job.taken) taken_fx = job.fx;
  }
  // Not vacuous: attempts came both before anything was taken and after.
  EXPECT_GE(before_any_taken, 2);
  EXPECT_GE(after_taken, 2);
}

// Box 2's estimates steer boxes 1-6 only until the history holds a distortion (box 10's,
// from the whole pool): it begins none after that, and the one under way still lands.
TEST(CalibrationPipeline, Box2StopsEstimatingOnceTheHistoryHoldsADistortion) {
  const PipelineWalk& walk = WrongStartWalk();
  const auto first_taken = std::ranges::find_if(
      walk.jobs, [](const PipelineWalk::Job& job) { return job.taken && job.with_distortion; });
  ASSERT_NE(first_taken, walk.jobs.end()) << "the history never took a distortion";
  const size_t taken_at = first_taken->frame;
  const LensOptions lens;
  ASSERT_GT(walk.frames, taken_at + 2 * size_t(lens.estimate_every_frames))
      << "too short a walk after the distortion was taken to show that box 2 stopped";
  ASSERT_FALSE(walk.box2_estimates.empty());
  EXPECT_LT(walk.box2_estimates.front(), taken_at) << "box 2 estimated nothing before";
  // An estimate begun on that frame or before lands within the lag; none is begun after.
  EXPECT_LE(walk.box2_estimates.back(), taken_at + size_t(lens.estimate_lag_frames))
      << walk.box2_estimates.size() << " estimates, the last on frame "
      << walk.box2_estimates.back() << "; the history took a distortion on frame " << taken_at;
}

TEST(OptionFields, EveryFieldReadsBackWhatWasSetAndTheDefaultsAreInRange) {
  const PipelineOptions defaults;
  for (const OptionField& field : PipelineOptionFields()) {
    const double value = field.get(defaults);
    EXPECT_GE(value, field.min) << field.name;
    EXPECT_LE(value, field.max) << field.name;
    EXPECT_FALSE(field.help.empty()) << field.name;
    // The top of the range (a changed value for every field), set by name.
    PipelineOptions changed;
    const double target = field.kind == OptionField::Kind::kFlag ? 1.0 - value
                          : field.max > 1e6                        ? value + 1.0
                                                                   : field.max;
    SetPipelineOption(&changed, field.name, ShortestDecimal(target));
    EXPECT_EQ(field.get(changed), target) << field.name;
    // Only that field changed.
    for (const OptionField& other : PipelineOptionFields()) {
      if (other.name != field.name) {
        EXPECT_EQ(other.get(changed), other.get(defaults)) << other.name;
      }
    }
  }
}

TEST(OptionFields, RefusesUnknownNamesWrongKindsAndValuesOutOfRange) {
  PipelineOptions options;
  try {
    SetPipelineOption(&options, "material.windw_s", "3");
    FAIL() << "unknown name accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("material.window_s"), std::string::npos)
        << "lists the names of the group: " << e.what();
  }
  EXPECT_THROW(SetPipelineOption(&options, "material.window_s", "3s"), Error);
  EXPECT_THROW(SetPipelineOption(&options, "material.window_s", "-1"), Error);
  EXPECT_THROW(SetPipelineOption(&options, "material.view_every_frames", "2.5"), Error);
  EXPECT_THROW(SetPipelineOption(&options, "calibration.estimate_k3", "maybe"), Error);
  SetPipelineOption(&options, "calibration.estimate_k3", "true");
  EXPECT_TRUE(options.calibration.estimate_k3);
}

TEST(OptionFields, SettingsFilesRoundTripAndNameTheFaultyLine) {
  const test::TempDir dir;
  PipelineOptions options;
  options.material.window_s = 2.75;
  options.calibration.estimate_tangential = true;
  options.acceptance.alarm_after = 3;
  test::WriteTextFile(dir / "a.settings", PipelineSettingsText(options));
  const PipelineOptions read = ReadPipelineSettings(dir / "a.settings");
  for (const OptionField& field : PipelineOptionFields()) {
    EXPECT_EQ(field.get(read), field.get(options)) << field.name;
  }

  test::WriteTextFile(dir / "b.settings", "# comment\nmaterial.window_s = 3\n\nmaterial.max_lines 4\n");
  try {
    ReadPipelineSettings(dir / "b.settings");
    FAIL() << "a line without '=' accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.line(), 4);
    EXPECT_EQ(e.file(), dir / "b.settings");
  }
  // Fields valid one by one but not together: Check() has the last word.
  test::WriteTextFile(dir / "c.settings", "acceptance.alarm_after = 5\nacceptance.confirm_after = 3\n");
  try {
    ReadPipelineSettings(dir / "c.settings");
    FAIL() << "an alarm after 5 attempts confirmed after 3 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("confirm_after"), std::string::npos) << e.what();
  }
}

TEST(CalibrationError, WorkedByHand) {
  const CameraIntrinsics truth = test::SonnarLikeCamera();
  // The true distortion in pixels, at focal lengths 1% too long.
  CameraIntrinsics estimate = ScaleDistortionToFocal(truth, 1.01 * truth.fx, 1.01 * truth.fy);
  estimate.cx += 1.5;
  estimate.cy -= 2.5;
  const CalibrationError e = CompareCalibration(estimate, truth);
  EXPECT_NEAR(e.fx_percent, 1.0, 1e-9);
  EXPECT_NEAR(e.fy_percent, 1.0, 1e-9);
  EXPECT_NEAR(e.cx_px, 1.5, 1e-9);
  EXPECT_NEAR(e.cy_px, -2.5, 1e-9);
  EXPECT_LT(e.distortion_px, 1e-6) << "the same distortion in pixels is no distortion error";
  // The same normalized coefficients at the longer focal length are another distortion in
  // pixels: carried to the true focal length, k1 and k2 grow by 1.01^2 and 1.01^4, which
  // moves a ray at x by f x (0.0201 k1 x^2 + 0.0406 k2 x^4), largest near x = 0.96 (inside
  // 90% of the half-diagonal): 427 * 0.96 * (-0.00556 + 0.00345) = -0.87 px.
  CameraIntrinsics unscaled = truth;
  unscaled.fx *= 1.01;
  unscaled.fy *= 1.01;
  EXPECT_NEAR(CompareCalibration(unscaled, truth).distortion_px, 0.87, 0.03);
  const CalibrationTolerance tolerance;
  EXPECT_FALSE(tolerance.Admits(e));
  // No distortion at all on a k1 = -0.3 lens: tens of pixels at 90% of the half-diagonal.
  CameraIntrinsics pinhole = truth;
  pinhole.k1 = pinhole.k2 = 0.0;
  EXPECT_GT(CompareCalibration(pinhole, truth).distortion_px, 20.0);
  EXPECT_TRUE(tolerance.Admits(CompareCalibration(truth, truth)));
}

TEST(RunSummary, JsonReadsBackWithOpenCv) {
  const test::TempDir dir;
  const std::unique_ptr<Sequence> sequence =
      MakeSimulatedSequence(ParseScenarioSpec("static,seconds=2,resolution=320x240"));
  RunSettings settings;
  settings.history_path = dir / "h.sqlite";
  int calls = 0;
  const RunReport report = RunSequence(*sequence, settings, [&](const RunProgress& progress) {
    ++calls;
    EXPECT_EQ(progress.frames, sequence->frame_count());
    EXPECT_EQ(progress.frame, size_t(calls));
  });
  EXPECT_EQ(size_t(calls), sequence->frame_count());
  WriteSummary(dir / "summary.json", report);

  cv::FileStorage json(dir / "summary.json", cv::FileStorage::READ | cv::FileStorage::FORMAT_JSON);
  ASSERT_TRUE(json.isOpened());
  EXPECT_EQ(int(json["frames"]), int(sequence->frame_count()));
  EXPECT_NEAR(double(json["seconds"]), report.seconds, 1e-9);
  EXPECT_GT(double(json["fps"]), 0.0);
  const CameraIntrinsics& premission = *sequence->session().premission_calibration;
  EXPECT_NEAR(double(json["final"]["fx"]), premission.fx, 1e-6);
  EXPECT_NEAR(double(json["final"]["k1"]), premission.k1, 1e-9);
  EXPECT_EQ(int(json["updates"]["attempted"]), report.attempts);
  EXPECT_EQ(int(json["updates"]["accepted"]), 0);
  EXPECT_TRUE(json["alarms"].isSeq());
  for (const char* box :
       {"lines", "rectify", "features", "flow", "planes", "refind", "inertial", "frame"}) {
    EXPECT_GT(double(json["timing_ms"][box]["median"]), 0.0) << box;
    EXPECT_GE(double(json["timing_ms"][box]["p95"]), double(json["timing_ms"][box]["median"]));
  }
  ASSERT_TRUE(report.truth);
  EXPECT_NEAR(double(json["error"]["final"]["fx_percent"]), report.truth->final.fx_percent, 1e-12);
}

// A run killed before its first attempt leaves a history file that already holds the
// calibration it started from and the options its attempts are judged with: the file is
// read as a kill would leave it, while the first frame is in hand.
TEST(RunSummary, TheHistoryFileHoldsTheStartBeforeTheFirstFrame) {
  const test::TempDir dir;
  const std::unique_ptr<Sequence> sequence =
      MakeSimulatedSequence(ParseScenarioSpec("office,seconds=1,resolution=320x240"));
  RunSettings settings;
  settings.history_path = dir / "h.sqlite";
  settings.prior = test::WrongStart(*sequence->session().premission_calibration);
  std::optional<StoredHistory> at_first_frame;
  const RunReport report = RunSequence(*sequence, settings, [&](const RunProgress& progress) {
    if (progress.frame == 1) at_first_frame = HistoryStore(settings.history_path).Load();
  });
  ASSERT_TRUE(at_first_frame);
  EXPECT_TRUE(at_first_frame->premission == *settings.prior);
  EXPECT_TRUE(at_first_frame->attempts.empty());
  // The options as the run judges with them (box 9's window length included).
  const StoredHistory at_end = HistoryStore(settings.history_path).Load();
  EXPECT_EQ(at_first_frame->options.attempt_window_s, at_end.options.attempt_window_s);
  EXPECT_EQ(at_first_frame->options.attempt_window_s, settings.pipeline.material.window_s);
  EXPECT_EQ(at_end.attempts.size(), size_t(report.attempts));
}

TEST(RunSummary, RefusesACalibrationForAnotherImageSize) {
  const std::unique_ptr<Sequence> sequence =
      MakeSimulatedSequence(ParseScenarioSpec("static,seconds=1,resolution=320x240"));
  RunSettings settings;
  settings.prior = test::SonnarLikeCamera();  // 640x480.
  try {
    RunSequence(*sequence, settings);
    FAIL() << "a 640x480 calibration accepted for 320x240 frames";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("640x480"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace autocal
