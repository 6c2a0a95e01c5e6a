// Box 9's anchored measurement on known zooms of a simulated frame: box 5's
// Lucas-Kanade tracks drift as the patch they follow grows, the anchored ones stay on the
// point they started on; the anchors carry over when the plane moves its reference, are
// taken again for a new window size, and a patch that no longer matches its anchor is not
// measured.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "devices/sim/lens.h"
#include "pipeline/anchored_tracks.h"
#include "pipeline/flow.h"
#include "tests/sim_test_util.h"

namespace autocal {
namespace {

// Frames are the middle 320x240 of a zoomed 640x480 office frame.
const cv::Rect kCrop(160, 120, 320, 240);
const cv::Point2d kCentre(159.5, 119.5);  // Of the zoom, in crop coordinates.
constexpr double kZoomPerFrame = 1.02;

double Zoom(int frame) { return std::pow(kZoomPerFrame, frame); }

cv::Mat Zoomed(int frame) {
  const cv::Point2f centre(float(kCrop.x + kCentre.x), float(kCrop.y + kCentre.y));
  const cv::Mat m = cv::getRotationMatrix2D(centre, 0.0, Zoom(frame));
  cv::Mat image;
  cv::warpAffine(test::OfficeGreen(), image, m, test::OfficeGreen().size(), cv::INTER_LINEAR,
                 cv::BORDER_REFLECT);
  return image(kCrop).clone();
}

// Frame `from` -> frame `to`, pixels (there is no lens distortion).
cv::Matx33d ZoomBetween(int from, int to) {
  const double s = Zoom(to) / Zoom(from);
  return {s, 0, kCentre.x * (1 - s), 0, s, kCentre.y * (1 - s), 0, 0, 1};
}

cv::Point2f Truth(cv::Point2f at_start, int from, int to) {
  const double s = Zoom(to) / Zoom(from);
  return {float(kCentre.x + s * (at_start.x - kCentre.x)),
          float(kCentre.y + s * (at_start.y - kCentre.y))};
}

CameraIntrinsics Pinhole() {
  CameraIntrinsics camera;
  camera.width = 320;
  camera.height = 240;
  camera.fx = camera.fy = 300;
  camera.cx = 159.5;
  camera.cy = 119.5;
  return camera;
}

int64_t FrameTime(int k) { return 1'000'000'000 + k * 33'333'333LL; }

// A plane followed from frame 0 whose tracks lie on a 20 px grid over the image.
DominantPlane GridPlane(int id) {
  DominantPlane plane;
  plane.id = id;
  plane.reference_t_ns = FrameTime(0);
  for (int y = 40; y <= 200; y += 20) {
    for (int x = 40; x <= 280; x += 20) {
      plane.track_ids.push_back(int(plane.points.size()));
      plane.points.emplace_back(float(x), float(y));
    }
  }
  return plane;
}

// Anchors taken on `plane`'s tracks in frame 0.
AnchoredTracks AnchoredAtStart(const AnchorOptions& options, const DominantPlane& plane) {
  AnchoredTracks anchors(options);
  anchors.Measure(plane, Zoomed(0), Pinhole());
  return anchors;
}

double Median(std::vector<double> values) {
  if (values.empty()) return std::nan("");
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

struct Errors {
  std::vector<double> tracked, anchored;
  size_t followed = 0;  // Tracks from frame 0 alive at the end.
};

// Tracks the zoom for `frames` frames with box 5, hands the tracks from frame 0 to the
// anchors every third frame as one plane, and compares both with where the zoom put
// each track's first point. From `rereference_at` on (if positive), the plane's
// homographies start from that frame, as after PlaneTracker moves a plane's reference.
Errors FollowZoom(int frames, int rereference_at) {
  FlowTracker tracker;
  AnchoredTracks anchors;
  std::map<int, cv::Point2f> start;
  Errors errors;
  for (int k = 0; k <= frames; ++k) {
    const cv::Mat frame = Zoomed(k);
    tracker.Update(FrameTime(k), frame);
    if (k == 0) {
      for (const Track& t : tracker.tracks()) start[t.id] = t.current();
    }
    if (k % 3 != 0) continue;
    DominantPlane plane;
    plane.id = 1;
    if (rereference_at > 0 && k >= rereference_at) {
      plane.reference_t_ns = FrameTime(rereference_at);
      plane.homography = ZoomBetween(rereference_at, k);
      plane.previous_reference_t_ns = FrameTime(0);
      plane.previous_to_reference = ZoomBetween(0, rereference_at);
    } else {
      plane.reference_t_ns = FrameTime(0);
      plane.homography = ZoomBetween(0, k);
    }
    for (const Track& t : tracker.tracks()) {
      if (!start.count(t.id)) continue;
      plane.track_ids.push_back(t.id);
      plane.points.push_back(t.current());
    }
    const auto measured = anchors.Measure(plane, frame, Pinhole());
    anchors.Keep({plane});
    if (k + 3 <= frames) continue;
    errors.followed = plane.track_ids.size();
    for (size_t i = 0; i < plane.track_ids.size(); ++i) {
      const cv::Point2f truth = Truth(start[plane.track_ids[i]], 0, k);
      errors.tracked.push_back(cv::norm(plane.points[i] - truth));
      if (measured[i]) errors.anchored.push_back(cv::norm(*measured[i] - truth));
    }
  }
  std::printf(
      "zoom %.2f: %zu tracks followed, %zu anchored; median error tracked %.3f px, "
      "anchored %.3f px\n",
      Zoom(frames), errors.followed, errors.anchored.size(), Median(errors.tracked),
      Median(errors.anchored));
  return errors;
}

TEST(AnchorOptions, DefaultsAreValidAndFaultsAreNamed) {
  std::string error;
  EXPECT_TRUE(AnchorOptions().Check(&error)) << error;
  auto fails_on = [](auto change, const std::string& field) {
    AnchorOptions options;
    change(&options);
    std::string message;
    EXPECT_FALSE(options.Check(&message)) << field;
    EXPECT_NE(message.find(field), std::string::npos) << message;
  };
  fails_on([](AnchorOptions* o) { o->window_px = 14; }, "window_px");
  fails_on([](AnchorOptions* o) { o->max_shift_px = 0; }, "max_shift_px");
  fails_on([](AnchorOptions* o) { o->off_plane_fraction = -1; }, "off_plane_fraction");
  fails_on([](AnchorOptions* o) { o->off_plane_ratio = 0.5; }, "off_plane_ratio");
  fails_on([](AnchorOptions* o) { o->min_correlation = 1; }, "min_correlation");
  fails_on([](AnchorOptions* o) { o->max_iterations = 0; }, "max_iterations");
  fails_on([](AnchorOptions* o) { o->epsilon_px = 0; }, "epsilon_px");
}

// 24 frames zooming 2% each (the image grows by 61%): what a walk toward a wall does to
// the patches box 5 follows.
TEST(AnchoredTracks, StayOnTheirPointWhereTheTrackerDrifts) {
  Errors errors = FollowZoom(24, 0);
  ASSERT_GT(errors.followed, 100u);
  EXPECT_GT(errors.anchored.size(), 0.9 * errors.followed) << "nearly every track measured";
  ASSERT_GT(Median(errors.tracked), 0.15) << "the tracker drifts (else nothing is tested)";
  EXPECT_LT(Median(errors.anchored), 0.05) << "median error, px";
  std::sort(errors.anchored.begin(), errors.anchored.end());
  EXPECT_LT(errors.anchored[errors.anchored.size() * 95 / 100], 0.15) << "95th percentile, px";
}

// The plane moves its reference to frame 12, by which the tracker has drifted: anchors
// taken at frame 0 carry over instead of being taken again where the tracker has them.
TEST(AnchoredTracks, CarryOverWhenThePlaneMovesItsReference) {
  const Errors errors = FollowZoom(24, 12);
  ASSERT_GT(errors.followed, 100u);
  EXPECT_GT(errors.anchored.size(), 0.9 * errors.followed);
  EXPECT_LT(Median(errors.anchored), 0.05) << "median error, px";
}

// A larger window needs a larger patch around each anchor: changing it (the workbench's
// threshold panel may, mid-run) takes the anchors again where the tracker has the tracks.
TEST(AnchoredTracks, ANewWindowSizeTakesTheAnchorsAgain) {
  DominantPlane plane;
  plane.id = 4;
  plane.reference_t_ns = FrameTime(0);
  plane.track_ids = {0, 1};
  plane.points = {cv::Point2f(100, 100), cv::Point2f(200, 150)};
  AnchoredTracks anchors;
  anchors.Measure(plane, Zoomed(0), Pinhole());
  const int k = 3;
  plane.homography = ZoomBetween(0, k);
  const cv::Point2f off(0.7f, -0.5f);  // The tracker's drift.
  plane.points = {Truth({100, 100}, 0, k) + off, Truth({200, 150}, 0, k) + off};
  AnchorOptions wider;
  wider.window_px = 21;
  anchors.set_options(wider);
  const auto retaken = anchors.Measure(plane, Zoomed(k), Pinhole());
  for (size_t i = 0; i < plane.points.size(); ++i) {
    ASSERT_TRUE(retaken[i]);
    EXPECT_EQ(*retaken[i], plane.points[i]) << "anchored afresh where the tracker has it";
  }
}

// Part of the view is covered by unrelated texture: the points under it are not
// measured, the others are, where the zoom put them.
TEST(AnchoredTracks, APatchThatNoLongerMatchesIsNotMeasured) {
  DominantPlane plane = GridPlane(3);
  const std::vector<cv::Point2f> at_start = plane.points;
  AnchoredTracks anchors;
  const auto first = anchors.Measure(plane, Zoomed(0), Pinhole());
  for (size_t i = 0; i < first.size(); ++i) {
    ASSERT_TRUE(first[i]);
    EXPECT_EQ(*first[i], at_start[i]) << "anchored where the tracker has it";
  }

  const int k = 6;
  cv::Mat frame = Zoomed(k);
  const cv::Rect occluder(170, 60, 120, 120);
  cv::Mat patch;
  cv::flip(test::OfficeGreen()(cv::Rect(20, 300, occluder.width, occluder.height)), patch, -1);
  patch.copyTo(frame(occluder));
  plane.homography = ZoomBetween(0, k);
  int covered = 0, covered_measured = 0, clear = 0;
  std::vector<double> clear_errors;
  for (size_t i = 0; i < at_start.size(); ++i) {
    // The tracker's position, half a pixel off the truth.
    plane.points[i] = Truth(at_start[i], 0, k) + cv::Point2f(0.5f, -0.3f);
  }
  const auto measured = anchors.Measure(plane, frame, Pinhole());
  const int margin = AnchorOptions().window_px / 2 + 4;
  const cv::Rect inside(occluder.x + margin, occluder.y + margin, occluder.width - 2 * margin,
                        occluder.height - 2 * margin);
  const cv::Rect around(occluder.x - margin, occluder.y - margin, occluder.width + 2 * margin,
                        occluder.height + 2 * margin);
  for (size_t i = 0; i < at_start.size(); ++i) {
    const cv::Point2f truth = Truth(at_start[i], 0, k);
    if (inside.contains(truth)) {
      ++covered;
      covered_measured += measured[i].has_value();
    } else if (!around.contains(truth) && truth.x > 12 && truth.y > 12 && truth.x < 307 &&
               truth.y < 227) {
      ++clear;
      if (measured[i]) clear_errors.push_back(cv::norm(*measured[i] - truth));
    }
  }
  ASSERT_GT(covered, 5);
  EXPECT_EQ(covered_measured, 0) << "of " << covered << " points under the occluder";
  EXPECT_GT(clear_errors.size(), 0.9 * clear) << "of " << clear << " points in the clear";
  // Points on a grid, not on corners: some lie along an edge, placed less well.
  EXPECT_LT(Median(clear_errors), 0.1) << "median error, px";
  EXPECT_LT(*std::max_element(clear_errors.begin(), clear_errors.end()), 0.5) << "px";
}

// Part of the view moves 2 px more than the plane's homography says, as something nearer
// or farther than the plane would (a facade's foot held by the ground's plane): its points
// match their anchors there but are not measured, being off the plane; with the check off
// they are, where they moved. The other points are measured where the zoom put them.
TEST(AnchoredTracks, PointsMovingOffThePlanesHomographyAreNotMeasured) {
  const std::vector<cv::Point2f> at_start = GridPlane(5).points;
  const int k = 6;
  const cv::Rect off_plane(150, 50, 120, 120);
  const cv::Point2f parallax(2.0f, 0.0f);
  cv::Mat frame = Zoomed(k);
  Zoomed(k)(off_plane - cv::Point(int(parallax.x), int(parallax.y))).copyTo(frame(off_plane));
  const int margin = AnchorOptions().window_px / 2 + 4;
  const cv::Rect inside(off_plane.x + margin, off_plane.y + margin,
                        off_plane.width - 2 * margin, off_plane.height - 2 * margin);
  const cv::Rect around(off_plane.x - margin, off_plane.y - margin,
                        off_plane.width + 2 * margin, off_plane.height + 2 * margin);

  for (const double off_plane_fraction : {AnchorOptions().off_plane_fraction, 0.0}) {
    AnchorOptions options;
    options.off_plane_fraction = off_plane_fraction;
    DominantPlane plane = GridPlane(5);
    AnchoredTracks anchors = AnchoredAtStart(options, plane);
    plane.homography = ZoomBetween(0, k);
    int moved = 0, clear = 0;
    std::vector<double> moved_errors, clear_errors;
    for (size_t i = 0; i < at_start.size(); ++i) {
      const cv::Point2f truth = Truth(at_start[i], 0, k);
      plane.points[i] = inside.contains(truth) ? truth + parallax : truth;
    }
    const auto measured = anchors.Measure(plane, frame, Pinhole());
    for (size_t i = 0; i < at_start.size(); ++i) {
      const cv::Point2f truth = Truth(at_start[i], 0, k);
      if (inside.contains(truth)) {
        ++moved;
        if (measured[i]) moved_errors.push_back(cv::norm(*measured[i] - (truth + parallax)));
      } else if (!around.contains(truth) && truth.x > 12 && truth.y > 12 && truth.x < 307 &&
                 truth.y < 227) {
        ++clear;
        if (measured[i]) clear_errors.push_back(cv::norm(*measured[i] - truth));
      }
    }
    ASSERT_GT(moved, 5);
    if (off_plane_fraction > 0) {
      EXPECT_EQ(moved_errors.size(), 0u) << "of " << moved << " points off the plane";
    } else {
      EXPECT_GT(moved_errors.size(), 0.9 * moved) << "of " << moved << " points, unchecked";
      EXPECT_LT(Median(moved_errors), 0.1) << "median error from where they moved, px";
    }
    EXPECT_GT(clear_errors.size(), 0.9 * clear) << "of " << clear << " points on the plane";
    EXPECT_LT(Median(clear_errors), 0.1) << "median error, px";
  }
}

// Box 6 follows a plane's homography on drifting tracks, so it may be off by more than a
// pixel over the whole plane: its points are then judged against the plane's median, and
// stay measured (against a fixed pixel limit, half of them would go).
TEST(AnchoredTracks, APlaneWhoseHomographyIsOffKeepsItsPoints) {
  const int k = 6;
  const cv::Matx33d homography_off = cv::Matx33d(1, 0, 1.5, 0, 1, 0, 0, 0, 1) * ZoomBetween(0, k);
  const auto measured_fraction = [&](double ratio) {
    AnchorOptions options;
    options.off_plane_ratio = ratio;
    DominantPlane plane = GridPlane(6);
    AnchoredTracks anchors = AnchoredAtStart(options, plane);
    plane.homography = homography_off;
    for (cv::Point2f& point : plane.points) point = Truth(point, 0, k);
    const auto measured = anchors.Measure(plane, Zoomed(k), Pinhole());
    return double(std::count_if(measured.begin(), measured.end(),
                                [](const auto& m) { return m.has_value(); })) /
           double(measured.size());
  };
  EXPECT_GT(measured_fraction(AnchorOptions().off_plane_ratio), 0.9);
  EXPECT_LT(measured_fraction(1.0), 0.7) << "against the median alone, about half go";
}

// A plane slides across the view of a 110 deg lens (the simulator's hologon: k1 -0.35,
// k2 0.12) at 320x240, from near the centre of the image to its edge, where the lens
// bends a window's pixels by up to 0.3 px off the linearization at its centre: with the
// anchor warped by that linearization, the points there were measured 0.26 px outward on
// average.
TEST(AnchoredTracks, StayOnTheirPointThroughAStronglyBendingLens) {
  const CameraIntrinsics wide = LensIntrinsics("hologon", 320, 240);
  // Frame k: the office frame in undistorted pixels, slid right by k * kSlide, through the lens.
  constexpr double kSlide = 50.0;
  const cv::Point2d texture_origin(320.0 - wide.cx, 240.0 - wide.cy);
  const auto frame = [&](int k) {
    cv::Mat map_x(240, 320, CV_32F), map_y(240, 320, CV_32F);
    for (int y = 0; y < 240; ++y) {
      for (int x = 0; x < 320; ++x) {
        const auto ideal = UndistortPixel(wide, Eigen::Vector2d(x, y));
        map_x.at<float>(y, x) = float(ideal->x() - k * kSlide + texture_origin.x);
        map_y.at<float>(y, x) = float(ideal->y() + texture_origin.y);
      }
    }
    cv::Mat image;
    cv::remap(test::OfficeGreen(), image, map_x, map_y, cv::INTER_CUBIC, cv::BORDER_REFLECT);
    return image;
  };
  const auto truth = [&](cv::Point2f at_start, int k) {
    const auto ideal = UndistortPixel(wide, Eigen::Vector2d(at_start.x, at_start.y));
    const Eigen::Vector2d raw = Project(
        wide, {(ideal->x() + k * kSlide - wide.cx) / wide.fx, (ideal->y() - wide.cy) / wide.fy, 1});
    return cv::Point2f(float(raw.x()), float(raw.y()));
  };

  DominantPlane plane;
  plane.id = 7;
  plane.reference_t_ns = FrameTime(0);
  for (int y = 40; y <= 200; y += 10) {
    for (int x = 40; x <= 200; x += 10) {
      plane.track_ids.push_back(int(plane.points.size()));
      plane.points.emplace_back(float(x), float(y));
    }
  }
  const std::vector<cv::Point2f> at_start = plane.points;
  AnchoredTracks anchors;
  anchors.Measure(plane, frame(0), wide);
  anchors.Keep({plane});
  const int k = 3;
  plane.homography = cv::Matx33d(1, 0, k * kSlide, 0, 1, 0, 0, 0, 1);
  for (size_t i = 0; i < at_start.size(); ++i) {
    plane.points[i] = truth(at_start[i], k) + cv::Point2f(0.4f, -0.3f);  // The tracker's.
  }
  const auto measured = anchors.Measure(plane, frame(k), wide);
  // Of the points past 60% of the half-diagonal: the error's length, and its component
  // away from the image centre.
  std::vector<double> errors, outward;
  size_t far_out = 0;
  for (size_t i = 0; i < at_start.size(); ++i) {
    const cv::Point2f expected = truth(at_start[i], k);
    const cv::Point2f from_centre(float(expected.x - wide.cx), float(expected.y - wide.cy));
    if (cv::norm(from_centre) < 0.6 * 200.0) continue;
    ++far_out;
    if (!measured[i]) continue;
    errors.push_back(cv::norm(*measured[i] - expected));
    outward.push_back((*measured[i] - expected).dot(from_centre) / cv::norm(from_centre));
  }
  ASSERT_GT(far_out, 40u) << "the plane reaches the edge of the image";
  const double mean_outward =
      std::accumulate(outward.begin(), outward.end(), 0.0) / double(outward.size());
  std::printf("%zu of %zu points far out measured: median error %.3f px, mean outward %+.3f px\n",
              errors.size(), far_out, Median(errors), mean_outward);
  EXPECT_GT(errors.size(), 0.8 * far_out) << "nearly every point measured";
  // The rest is the rendering's: the lens squeezes the texture there by a quarter.
  EXPECT_LT(Median(errors), 0.1) << "median error, px";
  EXPECT_LT(std::abs(mean_outward), 0.03) << "no lean outward or inward, px";
}

}  // namespace
}  // namespace autocal
