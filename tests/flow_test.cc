// Box 5 on known warps of a simulated frame: Lucas-Kanade tracks land where the warp puts
// them, keep their ids, die on an occluder by the forward-backward check, and new tracks
// fill the cells where tracks died.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "pipeline/flow.h"
#include "tests/sim_test_util.h"

namespace autocal {
namespace {

// Frames are the middle 320x240 of a warped 640x480 office frame, so the warp never
// shows the border.
const cv::Rect kCrop(160, 120, 320, 240);

// The source turned by `angle_deg` about the crop's centre and shifted by `shift`,
// cropped; `warp` is the map from frame-0 crop coordinates to this frame's.
cv::Mat Warped(double angle_deg, cv::Point2d shift, cv::Matx23d* warp) {
  const cv::Point2f centre(kCrop.x + kCrop.width / 2.0f, kCrop.y + kCrop.height / 2.0f);
  cv::Mat m = cv::getRotationMatrix2D(centre, angle_deg, 1.0);
  m.at<double>(0, 2) += shift.x;
  m.at<double>(1, 2) += shift.y;
  cv::Mat image;
  cv::warpAffine(test::OfficeGreen(), image, m, test::OfficeGreen().size(), cv::INTER_LINEAR,
                 cv::BORDER_REFLECT);
  // Crop coordinates: add the crop's corner, warp, take it away again.
  const cv::Matx23d source_warp(m);
  const cv::Vec2d corner(kCrop.x, kCrop.y);
  cv::Matx23d w = source_warp;
  const cv::Vec2d offset = source_warp.get_minor<2, 2>(0, 0) * corner - corner;
  w(0, 2) += offset[0];
  w(1, 2) += offset[1];
  *warp = w;
  return image(kCrop).clone();
}

cv::Point2f Apply(const cv::Matx23d& w, const cv::Point2f& p) {
  return {float(w(0, 0) * p.x + w(0, 1) * p.y + w(0, 2)),
          float(w(1, 0) * p.x + w(1, 1) * p.y + w(1, 2))};
}

int64_t FrameTime(int k) { return 1'000'000'000 + k * 33'333'333LL; }

TEST(FlowOptions, DefaultsAreValidAndFaultsAreNamed) {
  std::string error;
  EXPECT_TRUE(FlowOptions().Check(&error)) << error;
  auto fails_on = [](auto change, const std::string& field) {
    FlowOptions options;
    change(&options);
    std::string message;
    EXPECT_FALSE(options.Check(&message)) << field;
    EXPECT_NE(message.find(field), std::string::npos) << message;
  };
  fails_on([](FlowOptions* o) { o->window_px = 14; }, "window_px");
  fails_on([](FlowOptions* o) { o->pyramid_levels = -1; }, "pyramid_levels");
  fails_on([](FlowOptions* o) { o->retry_levels = 4; }, "retry_levels");
  fails_on([](FlowOptions* o) { o->max_iterations = 0; }, "max_iterations");
  fails_on([](FlowOptions* o) { o->epsilon_px = 0; }, "epsilon_px");
  fails_on([](FlowOptions* o) { o->min_eigen = -1; }, "min_eigen");
  fails_on([](FlowOptions* o) { o->max_fb_error_px = 0; }, "max_fb_error_px");
  fails_on([](FlowOptions* o) { o->border_px = -1; }, "border_px");
  fails_on([](FlowOptions* o) { o->target_tracks = 0; }, "target_tracks");
  fails_on([](FlowOptions* o) { o->history_frames = 1; }, "history_frames");
  fails_on([](FlowOptions* o) { o->features.max_per_cell = 0; }, "features.max_per_cell");
}

// Follows `frames` frames, each turned by `angle_deg` and shifted by `shift` more than
// the last, checking that every track's every remembered position is where its id's
// point went; returns the errors (px) of the tracks from frame 0 in the last frame.
std::vector<double> FollowWarps(double angle_deg, cv::Point2d shift, int frames) {
  FlowOptions options;
  options.history_frames = 8;
  FlowTracker tracker(options);
  std::vector<cv::Matx23d> warps;
  std::map<int, cv::Point2f> start;  // Track id -> position in frame 0.
  for (int k = 0; k <= frames; ++k) {
    cv::Matx23d warp;
    const cv::Mat frame = Warped(angle_deg * k, shift * k, &warp);
    warps.push_back(warp);
    tracker.Update(FrameTime(k), frame);
    if (k == 0) {
      EXPECT_GT(int(tracker.tracks().size()), 0.9 * options.target_tracks);
      for (const Track& t : tracker.tracks()) start[t.id] = t.current();
      continue;
    }
    for (const Track& t : tracker.tracks()) {
      if (!start.count(t.id)) continue;
      EXPECT_EQ(t.age, k);
      EXPECT_EQ(t.history.size(), std::min<size_t>(k + 1, options.history_frames));
      for (size_t h = 0; h < t.history.size(); ++h) {
        const int frame_index = k - int(t.history.size() - 1 - h);
        EXPECT_EQ(t.history[h].t_ns, FrameTime(frame_index));
        // Corners start min_distance_px (8 px) apart: an id that moved to another point
        // would be off by that much.
        const double error = cv::norm(t.history[h].pixel - Apply(warps[frame_index], start[t.id]));
        EXPECT_LT(error, 0.5 * options.features.min_distance_px)
            << "track " << t.id << " frame " << frame_index;
      }
    }
  }
  std::vector<double> errors;
  for (const Track& t : tracker.tracks()) {
    if (start.count(t.id))
      errors.push_back(cv::norm(t.current() - Apply(warps.back(), start[t.id])));
  }
  EXPECT_GT(errors.size(), 0.8 * options.target_tracks) << "tracks from frame 0 still alive";
  std::sort(errors.begin(), errors.end());
  std::printf(
      "after %d frames (%.2f deg, %.2f, %.2f px a frame): median %.3f px, 95%% %.3f px, "
      "worst %.3f px\n",
      frames, angle_deg, shift.x, shift.y, errors[errors.size() / 2],
      errors[errors.size() * 95 / 100], errors.back());
  return errors;
}

// Each frame resamples the source at another sub-pixel phase, which blurs it a little
// differently: a few hundredths of a pixel a frame is all the error there is.
TEST(FlowTracker, SubPixelShiftsAreFollowedClosely) {
  const std::vector<double> errors = FollowWarps(0.0, {1.37, -0.83}, 12);
  EXPECT_LT(errors[errors.size() / 2], 0.04) << "median error, px";
  EXPECT_LT(errors[errors.size() * 95 / 100], 0.2) << "95th percentile error, px";
}

// A turn deforms the patches, which a translation-only window follows with a small
// drift: the reason box 6 judges planes over a short baseline.
TEST(FlowTracker, ATurnIsFollowedWithLittleDrift) {
  const std::vector<double> errors = FollowWarps(0.4, {0.9, 0.5}, 12);
  EXPECT_LT(errors[errors.size() / 2], 0.2) << "median error, px";
  EXPECT_LT(errors[errors.size() * 95 / 100], 0.6) << "95th percentile error, px";
}

// An occluder appears: tracks under it must die, and it is the forward-backward check
// that kills them (Lucas-Kanade alone converges somewhere on the occluder's texture).
TEST(FlowTracker, ForwardBackwardCheckDropsTracksOnAnOccluder) {
  const cv::Rect occluder(100, 60, 120, 100);
  auto run = [&](double max_fb_error_px, int* under, int* survived_under, int* away,
                 int* survived_away, FlowTracker* tracker) {
    FlowOptions options;
    options.max_fb_error_px = max_fb_error_px;
    *tracker = FlowTracker(options);
    cv::Matx23d warp0, warp1;
    tracker->Update(FrameTime(0), Warped(0.0, {0, 0}, &warp0));
    std::map<int, cv::Point2f> start;
    for (const Track& t : tracker->tracks()) start[t.id] = t.current();
    cv::Mat frame = Warped(0.0, {1.6, 0.7}, &warp1);
    // Texture from elsewhere in the source, flipped: as textured as the scene, unrelated.
    cv::Mat patch;
    cv::flip(test::OfficeGreen()(cv::Rect(20, 300, occluder.width, occluder.height)), patch, -1);
    patch.copyTo(frame(occluder));
    tracker->Advance(FrameTime(1), frame);
    EXPECT_EQ(tracker->died(), int(start.size() - tracker->tracks().size()));
    // Under: the whole window on the occluder. Away: beyond the window's reach on the
    // level the lost tracks are searched again on.
    const int margin = options.window_px / 2 + 2;
    const int reach = options.window_px << options.retry_levels;
    const cv::Rect inside(occluder.x + margin, occluder.y + margin, occluder.width - 2 * margin,
                          occluder.height - 2 * margin);
    const cv::Rect around(occluder.x - reach, occluder.y - reach, occluder.width + 2 * reach,
                          occluder.height + 2 * reach);
    *under = *survived_under = *away = *survived_away = 0;
    for (const auto& [id, p] : start) {
      const cv::Point2f q = Apply(warp1, p);
      const bool alive = std::any_of(tracker->tracks().begin(), tracker->tracks().end(),
                                     [&](const Track& t) { return t.id == id; });
      if (inside.contains(q)) {
        ++*under;
        *survived_under += alive;
      } else if (!around.contains(q)) {
        ++*away;
        *survived_away += alive;
      }
    }
  };
  int under, survived_under, away, survived_away;
  FlowTracker tracker;
  run(FlowOptions().max_fb_error_px, &under, &survived_under, &away, &survived_away, &tracker);
  ASSERT_GT(under, 20);
  EXPECT_EQ(survived_under, 0) << "of " << under << " tracks under the occluder";
  EXPECT_GT(survived_away, 0.95 * away) << "tracks away from the occluder survive";

  // New tracks fill the occluder's cells, where the old ones died, and nowhere beyond
  // the target.
  const int before = static_cast<int>(tracker.tracks().size());
  int newest_old_id = 0;
  for (const Track& t : tracker.tracks()) newest_old_id = std::max(newest_old_id, t.id);
  const int started = tracker.Replenish();
  EXPECT_EQ(started, int(tracker.tracks().size()) - before);
  EXPECT_LE(int(tracker.tracks().size()), FlowOptions().target_tracks);
  int started_on_occluder = 0;
  for (const Track& t : tracker.tracks()) {
    if (t.id <= newest_old_id) continue;
    EXPECT_EQ(t.age, 0);
    EXPECT_EQ(t.history.size(), 1u);
    started_on_occluder += occluder.contains(t.current());
  }
  EXPECT_GT(started_on_occluder, 0.5 * started);

  // Without the check, many tracks under the occluder would live on.
  FlowTracker unchecked;
  run(1e6, &under, &survived_under, &away, &survived_away, &unchecked);
  EXPECT_GT(survived_under, under / 4) << "the occluder must fool Lucas-Kanade alone";
}

TEST(FlowTracker, HistoryLookUpAndRestartOnANewImageSize) {
  FlowOptions options;
  options.history_frames = 3;
  FlowTracker tracker(options);
  cv::Matx23d warp;
  for (int k = 0; k < 5; ++k) tracker.Update(FrameTime(k), Warped(0.0, {0.5 * k, 0.0}, &warp));
  const Track& t = tracker.tracks().front();
  ASSERT_EQ(t.history.size(), 3u);
  EXPECT_EQ(t.FramesAgo(0)->t_ns, FrameTime(4));
  EXPECT_EQ(t.FramesAgo(2)->t_ns, FrameTime(2));
  EXPECT_EQ(t.FramesAgo(3), nullptr);
  EXPECT_EQ(t.At(FrameTime(3)), t.FramesAgo(1));
  EXPECT_EQ(t.At(FrameTime(1)), nullptr);
  EXPECT_EQ(t.At(FrameTime(3) + 1), nullptr);

  const int oldest_id = t.id;
  tracker.Update(FrameTime(5), cv::Mat(100, 120, CV_8U, cv::Scalar(0)));
  EXPECT_TRUE(tracker.tracks().empty()) << "a blank frame of another size: nothing to track";
  tracker.Update(FrameTime(6), test::OfficeGreen()(cv::Rect(0, 0, 120, 100)).clone());
  ASSERT_FALSE(tracker.tracks().empty());
  EXPECT_GT(tracker.tracks().front().id, oldest_id) << "ids are never reused";
}

}  // namespace
}  // namespace autocal
