// Runtime::SetOptions: options changed during an offline run apply from the next frame
// pushed, in both halves, and not before; invalid options are refused with the reason and
// leave the options in effect. A short 320x240 simulated walk.
#include <algorithm>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "devices/runtime.h"
#include "devices/sim/simulator.h"
#include "pipeline/error.h"

namespace autocal {
namespace {

struct FrameCounts {
  size_t tracks = 0;
  int tracks_started = 0;
  size_t lines = 0;
  double shortest_line_px = 0.0;
};

// Runs the walk offline; before frame `change_at` is pushed, `change` (if any) is set.
std::vector<FrameCounts> RunWalk(const Sequence& sequence, size_t change_at,
                             const PipelineOptions* change) {
  AccelCalibration accel;
  accel.cam_from_accel = sequence.session().cam_from_accel;
  std::vector<FrameCounts> counts;
  Runtime runtime(*sequence.session().premission_calibration, accel, {}, {},
                  [&](const std::shared_ptr<const FrameSnapshot>& snapshot) {
                    FrameCounts frame;
                    frame.tracks = snapshot->motion.tracks.size();
                    frame.tracks_started = snapshot->motion.tracks_started;
                    frame.lines = snapshot->lens.lines.size();
                    frame.shortest_line_px = 1e9;
                    for (const LineSegment& line : snapshot->lens.lines) {
                      frame.shortest_line_px = std::min(frame.shortest_line_px, line.Length());
                    }
                    counts.push_back(frame);
                  });
  const std::vector<AccelSample>& samples = sequence.accel();
  size_t fed = 0;
  for (size_t i = 0; i < sequence.frame_count(); ++i) {
    const int64_t t_ns = sequence.frame_time_ns(i);
    const size_t first = fed;
    while (fed < samples.size() && samples[fed].t_ns <= t_ns + runtime.accel_lead_ns()) ++fed;
    runtime.PushAccel(std::span(samples).subspan(first, fed - first));
    if (change && i == change_at) {
      runtime.SetOptions(*change);
      EXPECT_EQ(runtime.options().motion.flow.target_tracks, change->motion.flow.target_tracks);
    }
    runtime.PushFrame(t_ns, sequence.LoadFrame(i));
  }
  runtime.Finish();
  return counts;
}

TEST(RuntimeOptions, ChangesApplyFromTheNextFramePushedAndNotBefore) {
  const std::unique_ptr<Sequence> sequence = MakeSimulatedSequence(
      ParseScenarioSpec("office,lens=tessar,resolution=320x240,seconds=2"));
  const size_t change_at = 20;
  ASSERT_GT(sequence->frame_count(), change_at + 20);
  PipelineOptions changed;
  changed.motion.flow.target_tracks = 10;     // Box 5: default 300.
  changed.lens.lines.min_length_px = 100.0;  // Box 1: default 40.

  const std::vector<FrameCounts> before = RunWalk(*sequence, change_at, nullptr);
  const std::vector<FrameCounts> after = RunWalk(*sequence, change_at, &changed);
  ASSERT_EQ(before.size(), sequence->frame_count());
  ASSERT_EQ(after.size(), sequence->frame_count());

  for (size_t i = 0; i < change_at; ++i) {
    EXPECT_EQ(after[i].tracks, before[i].tracks) << "frame " << i << " is before the change";
    EXPECT_EQ(after[i].lines, before[i].lines) << "frame " << i << " is before the change";
  }
  bool short_lines_before = false, many_new_tracks_before = false;
  for (size_t i = change_at; i < after.size(); ++i) {
    // Box 5 adds corners only up to the new target; box 1 reports no shorter line.
    if (after[i].tracks_started > 0) {
      EXPECT_LE(after[i].tracks, 10u) << "frame " << i;
    }
    EXPECT_GE(after[i].shortest_line_px, 100.0) << "frame " << i;
    EXPECT_LE(after[i].lines, before[i].lines) << "frame " << i;
    short_lines_before |= before[i].shortest_line_px < 100.0;
    many_new_tracks_before |= before[i].tracks_started > 0 && before[i].tracks > 10;
  }
  EXPECT_TRUE(short_lines_before) << "without the change, shorter lines are found";
  EXPECT_TRUE(many_new_tracks_before) << "without the change, tracks grow past 10";
  EXPECT_LT(after.back().tracks, before.back().tracks / 4);
}

TEST(RuntimeOptions, InvalidOptionsAreRefusedWithTheReason) {
  Runtime runtime(CameraIntrinsics{320, 240, 300, 300, 160, 120}, {}, {}, {});
  PipelineOptions bad;
  bad.motion.flow.target_tracks = 0;
  try {
    runtime.SetOptions(bad);
    ADD_FAILURE() << "target_tracks 0 accepted";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("target_tracks"), std::string::npos) << error.what();
  }
  EXPECT_EQ(runtime.options().motion.flow.target_tracks, PipelineOptions{}.motion.flow.target_tracks)
      << "the options in effect are kept";

  PipelineOptions acceptance;
  acceptance.acceptance.max_rms_px *= 2;
  try {
    runtime.SetOptions(acceptance);
    ADD_FAILURE() << "an acceptance threshold changed during the run";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("acceptance.max_rms_px"), std::string::npos)
        << error.what();
  }
  EXPECT_EQ(runtime.options().acceptance.max_rms_px, PipelineOptions{}.acceptance.max_rms_px);
  runtime.Finish();
}

}  // namespace
}  // namespace autocal
