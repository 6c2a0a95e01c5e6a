// The 3-D view in a real window under Xvfb (Mesa), on real snapshots: the runtime runs
// boxes 1-10 over a short simulated office walk at 320x240, and the view is fed every
// snapshot. The rendered framebuffer is saved (scene_view.png) and checked where the
// scene's pieces project: the frustum's edges, the trajectory, the planes' colour, gravity.
#include <cmath>
#include <memory>
#include <vector>

#include <QApplication>
#include <QImage>
#include <QOpenGLWidget>
#include <QtTest>

#include "devices/runtime.h"
#include "devices/sim/simulator.h"
#include "widgets/scene_view.h"
#include "pixels.h"
#include "screenshot.h"

namespace autocal {
namespace {

int CountColor(const QImage& image, const QColor& color) {
  return autocal::CountColor(image, color, 12);
}

}  // namespace

class SceneViewTest : public QObject {
  Q_OBJECT

 private slots:
  void initTestCase();
  void drawsTheNewestAttemptsScene();
  void drawsWhatCameBeforeItWasShown();

 private:
  std::vector<std::shared_ptr<const FrameSnapshot>> snapshots_;
  std::vector<GroundTruthFrame> truth_;  // Per frame.
};

void SceneViewTest::initTestCase() {
  const std::unique_ptr<Sequence> sequence = MakeSimulatedSequence(
      ParseScenarioSpec("office,lens=tessar,resolution=320x240,seconds=4"));
  AccelCalibration accel;
  accel.cam_from_accel = sequence->session().cam_from_accel;
  Runtime runtime(*sequence->session().premission_calibration, accel, {}, {},
                  [this](const std::shared_ptr<const FrameSnapshot>& snapshot) {
                    snapshots_.push_back(snapshot);
                  });
  PushSequence(*sequence, &runtime);
  QCOMPARE(snapshots_.size(), sequence->frame_count());
  truth_ = sequence->ground_truth()->front().t_ns == snapshots_.front()->t_ns
               ? *sequence->ground_truth()
               : std::vector<GroundTruthFrame>{};
  QCOMPARE(truth_.size(), snapshots_.size());
}

void SceneViewTest::drawsTheNewestAttemptsScene() {
  SceneView view;
  view.resize(800, 640);
  view.show();
  QVERIFY(QTest::qWaitForWindowExposed(&view));
  QVERIFY(!view.scene());

  // Fed as the workbench feeds it: every snapshot, most without an attempt.
  std::shared_ptr<const FrameSnapshot> newest;
  for (const auto& snapshot : snapshots_) {
    view.showSnapshot(snapshot);
    if (snapshot->attempt && !snapshot->attempt->cam_from_world.empty() &&
        !snapshot->attempt->boards.empty()) {
      newest = snapshot;
    }
  }
  QVERIFY2(newest, "the walk gives at least one posed attempt with a board");
  QVERIFY(view.scene());
  const SceneGeometry& scene = *view.scene();
  // The walk never stands still long enough for box 7 to measure gravity: the newest
  // attempt's frame is given the simulator's true gravity, as a still moment would.
  {
    auto with_gravity = std::make_shared<FrameSnapshot>(*newest);
    const GroundTruthFrame& truth = truth_[size_t(newest->index)];
    QCOMPARE(truth.t_ns, newest->t_ns);
    with_gravity->inertial.gravity_cam =
        truth.world_from_cam_rotation.conjugate() * Eigen::Vector3d(0.0, 0.0, -9.81);
    newest = with_gravity;
    view.showSnapshot(newest);
  }
  const std::optional<SceneGeometry> expected = MakeSceneGeometry(
      *newest->attempt, newest->calibration.calibration, newest->inertial.gravity_cam);
  QVERIFY(expected);
  QCOMPARE(scene.trajectory.size(), expected->trajectory.size());
  QVERIFY(scene.trajectory.back().isApprox(expected->trajectory.back()));
  QVERIFY(scene.trajectory.size() >= 5);
  QVERIFY(!scene.boards.empty());

  view.resetCamera();
  QTest::qWait(50);
  const QImage image = view.grab3d();
  QVERIFY(!image.isNull());
  QVERIFY(image.save(ScreenshotPath("scene_view.png")));

  // The trajectory between its views.
  int on_trajectory = 0;
  for (size_t i = 0; i + 1 < scene.trajectory.size(); ++i) {
    const Eigen::Vector3d mid = (scene.trajectory[i] + scene.trajectory[i + 1]) / 2.0;
    on_trajectory += DrawnNear(image, view.worldToImage(mid), SceneTrajectoryColor());
  }
  QVERIFY2(on_trajectory * 2 >= int(scene.trajectory.size()) - 1, qPrintable(QString::number(on_trajectory)));
  // Each plane's colour, and its board's dark squares.
  for (const SceneBoard& board : scene.boards) {
    QVERIFY2(CountColor(image, ScenePlaneColor(board.plane_id)) > 200,
             qPrintable(QString::number(board.plane_id)));
  }
  // The boards' dark squares where they project (a plane in front may hide some).
  int squares = 0, seen = 0;
  for (const SceneBoard& board : scene.boards) {
    for (const auto& square : board.dark) {
      const Eigen::Vector3d centre = (square[0] + square[1] + square[2] + square[3]) / 4.0;
      const QPointF at = view.worldToImage(centre);
      ++squares;
      seen += DrawnNear(image, at, SceneDarkSquareColor(), 1);
    }
  }
  QVERIFY2(seen * 2 > squares, qPrintable(QString("%1 of %2").arg(seen).arg(squares)));

  // The camera's own glyphs on the same attempt without its boards: seen from above and
  // behind the camera, a board the camera looks along can stand in front of them.
  auto bare_attempt = std::make_shared<AttemptOutcome>(*newest->attempt);
  bare_attempt->boards.clear();
  auto bare = std::make_shared<FrameSnapshot>(*newest);
  bare->attempt = bare_attempt;
  view.showSnapshot(bare);
  QVERIFY(view.scene() && view.scene()->boards.empty());
  const SceneGeometry& glyphs = *view.scene();
  view.resetCamera();
  QTest::qWait(50);
  const QImage camera_image = view.grab3d();
  QVERIFY(camera_image.save(ScreenshotPath("scene_view_camera.png")));
  // The frustum's four edges and its far rectangle, at their midpoints.
  const auto& f = glyphs.frustum;
  for (int k = 1; k <= 4; ++k) {
    const Eigen::Vector3d edge = (f[0] + f[size_t(k)]) / 2.0;
    QVERIFY2(DrawnNear(camera_image, view.worldToImage(edge), SceneFrustumColor()),
             qPrintable(QString::number(k)));
    const Eigen::Vector3d side = (f[size_t(k)] + f[size_t(k % 4 + 1)]) / 2.0;
    QVERIFY2(DrawnNear(camera_image, view.worldToImage(side), SceneFrustumColor()),
             qPrintable(QString::number(k)));
  }
  // Gravity: the arrow from the camera, pointing down the screen (the view's up is up).
  QVERIFY(glyphs.gravity);
  const Eigen::Vector3d mid = f[0] + 0.5 * glyphs.gravity_length * *glyphs.gravity;
  QVERIFY(DrawnNear(camera_image, view.worldToImage(mid), SceneGravityColor()));
  const Eigen::Vector3d tip = f[0] + glyphs.gravity_length * *glyphs.gravity;
  QVERIFY(view.worldToImage(tip).y() > view.worldToImage(f[0]).y() + 10);
  // It ends where it is drawn to: nothing of it past the tip.
  const Eigen::Vector3d beyond = f[0] + 1.3 * glyphs.gravity_length * *glyphs.gravity;
  QVERIFY(!DrawnNear(camera_image, view.worldToImage(beyond), SceneGravityColor()));

  view.clear();
  QVERIFY(!view.scene());
  QCOMPARE(CountColor(view.grab3d(), SceneFrustumColor()), 0);
}

void SceneViewTest::drawsWhatCameBeforeItWasShown() {
  // Until it is painted the view holds no OpenGL widget; what it was fed meanwhile is
  // drawn once it is shown.
  SceneView view;
  view.resize(800, 640);
  for (const auto& snapshot : snapshots_) view.showSnapshot(snapshot);
  QVERIFY(view.scene());
  QVERIFY(view.findChildren<QOpenGLWidget*>().isEmpty());
  view.show();
  QVERIFY(QTest::qWaitForWindowExposed(&view));
  QTRY_COMPARE(view.findChildren<QOpenGLWidget*>().size(), 1);
  QOpenGLWidget* drawn = view.findChildren<QOpenGLWidget*>().front();
  QTRY_VERIFY(CountColor(drawn->grabFramebuffer(), SceneTrajectoryColor()) > 50);
  QTRY_VERIFY(CountColor(drawn->grabFramebuffer(), SceneFrustumColor()) > 50);
}

}  // namespace autocal

int main(int argc, char** argv) {
  autocal::SceneView::SetDefaultSurfaceFormat();  // Before the application, as VTK needs.
  QApplication app(argc, argv);
  autocal::SceneViewTest test;
  return QTest::qExec(&test, argc, argv);
}

#include "scene_view_test.moc"
