// The workbench's board layer over a real run of boxes 1-10 on the simulated office walk
// (the recording gui_overlay_test shows): on every frame, each board drawn lies on the
// plane it was attached to, by the simulator's plane labels. Box 10 places some of a
// plane's tracks far off (one at 400 times the patch's size) and poses some views wrongly;
// boards over those points, or at those poses, were drawn as a fan above the horizon and
// across the wrong wall. The plane's extent is its labels with nothing else in the scene:
// a board spans the outline of its plane's tracks, which can reach around a cabinet in
// front of the wall, and the wall behind the cabinet is still the wall.
#include <algorithm>
#include <cstdio>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include <gtest/gtest.h>

#include "devices/runtime.h"
#include "devices/sim/renderer.h"
#include "devices/sim/scene.h"
#include "devices/sim/simulator.h"
#include "pipeline/overlay_geometry.h"
#include "tests/sim_test_util.h"

namespace autocal {
namespace {

struct PipelineRun {
  Scenario scenario;
  std::unique_ptr<Sequence> sequence;
  std::vector<std::shared_ptr<const FrameSnapshot>> frames;
};

PipelineRun RunPipeline(const std::string& spec) {
  PipelineRun run{ParseScenarioSpec(spec), nullptr, {}};
  run.sequence = MakeSimulatedSequence(run.scenario);
  AccelCalibration accel;
  accel.cam_from_accel = run.sequence->session().cam_from_accel;
  std::mutex mutex;
  Runtime runtime(*run.sequence->session().premission_calibration, accel, {}, {},
                  [&](const std::shared_ptr<const FrameSnapshot>& snapshot) {
                    std::lock_guard lock(mutex);
                    run.frames.push_back(snapshot);
                  });
  PushSequence(*run.sequence, &runtime);
  return run;
}

// The true plane under most of `board`'s tracks seen in `frame`; 0 when none is seen.
int TruePlaneOf(const VirtualBoard& board, const FrameSnapshot& frame, const cv::Mat& labels) {
  std::map<int, int> votes;
  for (const Track& track : frame.motion.tracks) {
    const bool tracked = std::any_of(board.tracked.begin(), board.tracked.end(),
                                     [&](const auto& entry) { return entry.first == track.id; });
    const cv::Point pixel(cvRound(track.current().x), cvRound(track.current().y));
    if (tracked && cv::Rect(0, 0, labels.cols, labels.rows).contains(pixel)) {
      ++votes[labels.at<uint16_t>(pixel)];
    }
  }
  const auto most = std::max_element(votes.begin(), votes.end(), [](const auto& a, const auto& b) {
    return a.second < b.second;
  });
  return most == votes.end() ? 0 : most->first;
}

// Renders one plane of a scene as if nothing else were in it.
class LonePlane {
 public:
  LonePlane(const Scene& scene, int id) {
    auto alone = std::make_shared<Scene>(scene);
    alone->planes = {scene.planes.at(static_cast<size_t>(id - 1))};
    renderer_ = std::make_unique<Renderer>(std::move(alone));
  }
  cv::Mat Labels(const GroundTruthFrame& truth) const {
    return renderer_->RenderLabels(truth.intrinsics,
                                   test::Pose(truth.world_from_cam_rotation.toRotationMatrix(),
                                              truth.world_from_cam_translation));
  }

 private:
  std::unique_ptr<Renderer> renderer_;
};

TEST(BoardOverlayWalk, EveryBoardDrawnLiesOnItsPlane) {
  const PipelineRun run = RunPipeline("office,seconds=3,resolution=320x240");
  ASSERT_EQ(run.frames.size(), run.sequence->frame_count());
  const std::shared_ptr<const Scene> scene = BuildScene(run.scenario);
  std::map<int, LonePlane> lone_planes;
  // As the workbench shows a finished run: every attempt is in, the newest first.
  std::vector<std::shared_ptr<const AttemptOutcome>> attempts;
  for (const auto& frame : run.frames) {
    if (frame->attempt) attempts.push_back(frame->attempt);
  }
  const VirtualBoardOptions options;
  // A point is on its plane when the plane is seen within this many pixels of it: the
  // board's outline runs through tracked points, which sit up to a patch from an edge.
  constexpr int kNearPx = 3;
  int frames_with_boards = 0, points = 0, on_plane = 0;
  for (const auto& frame : run.frames) {
    const std::vector<PlacedBoard> placed = PlaceNewestBoards(attempts, frame->t_ns);
    const OverlayGeometry overlay = MakeOverlayGeometry(*frame, placed, options, OverlaySpace::kRaw);
    if (overlay.boards.empty()) continue;
    ++frames_with_boards;
    const cv::Mat labels = *run.sequence->LoadPlaneLabels(frame->index);
    for (const OverlayGeometry::Board& drawn : overlay.boards) {
      const auto board = std::find_if(placed.begin(), placed.end(), [&](const PlacedBoard& p) {
        return p.board.plane_id == drawn.plane_id;
      });
      ASSERT_NE(board, placed.end());
      const int truth = TruePlaneOf(board->board, *frame, labels);
      ASSERT_GT(truth, 0) << "frame " << frame->index << ": the board's tracks are seen";
      const cv::Mat extent =
          lone_planes.try_emplace(truth, *scene, truth)
              .first->second.Labels(run.sequence->ground_truth()->at(frame->index));
      int frame_points = 0, frame_on_plane = 0;
      for (const Polyline& line : drawn.lines) {
        for (const Eigen::Vector2d& p : line) {
          const cv::Point pixel(cvRound(p.x()), cvRound(p.y()));
          if (!cv::Rect(0, 0, labels.cols, labels.rows).contains(pixel)) continue;
          const cv::Rect near =
              cv::Rect(pixel.x - kNearPx, pixel.y - kNearPx, 2 * kNearPx + 1, 2 * kNearPx + 1) &
              cv::Rect(0, 0, labels.cols, labels.rows);
          ++frame_points;
          frame_on_plane += cv::countNonZero(extent(near) == truth) > 0 ? 1 : 0;
        }
      }
      EXPECT_GE(frame_on_plane, 0.95 * frame_points)
          << "frame " << frame->index << ", board on plane " << drawn.plane_id << ": "
          << frame_on_plane << " of " << frame_points << " points on the true plane " << truth;
      points += frame_points;
      on_plane += frame_on_plane;
    }
  }
  std::printf("boards on %d of %zu frames; %d of %d board points on their true plane\n",
              frames_with_boards, run.frames.size(), on_plane, points);
  // Not vacuous: the boards are drawn through most of the attempts' windows.
  EXPECT_GE(frames_with_boards, 40);
  EXPECT_GE(on_plane, 0.99 * points);
}

}  // namespace
}  // namespace autocal
