// The 3-D view (VTK): the camera's trajectory over the newest attempt's window, its frustum
// through the calibration in effect, the dominant planes box 10 placed with their virtual
// checkerboards (box 8), and gravity. It draws pipeline/scene_geometry.h's SceneGeometry
// and nothing else; VTK stays inside scene_view.cc.
//
// Wiring: call SceneView::SetDefaultSurfaceFormat() before the QApplication is made (VTK's
// OpenGL widget needs its surface format), then connect the pipeline controller's
// snapshotReady(std::shared_ptr<const autocal::FrameSnapshot>) to showSnapshot().
#pragma once

#include <memory>
#include <optional>

#include <QPointF>
#include <QWidget>

#include "pipeline/calibration_pipeline.h"
#include "pipeline/scene_geometry.h"

class QLabel;

namespace autocal {

// Colours of what is drawn, shared with the legend and the tests.
QColor SceneTrajectoryColor();
QColor SceneFrustumColor();
QColor SceneGravityColor();
QColor ScenePlaneColor(int plane_id);
QColor SceneDarkSquareColor();

class SceneView : public QWidget {
  Q_OBJECT

 public:
  // Before the QApplication: QSurfaceFormat::setDefaultFormat(VTK's).
  static void SetDefaultSurfaceFormat();

  explicit SceneView(QWidget* parent = nullptr);
  ~SceneView() override;

  // The newest scene: from a snapshot that carries a posed attempt, drawn with the
  // calibration in effect after it; other snapshots leave the scene as it is.
  void showSnapshot(std::shared_ptr<const FrameSnapshot> snapshot);
  // The same for an attempt no snapshot carries (the one judged after the last frame):
  // `camera` in effect after it, `gravity_cam` in the camera frame at the last frame, if
  // known.
  void showAttempt(std::shared_ptr<const AttemptOutcome> attempt, const CameraIntrinsics& camera,
                   const std::optional<Eigen::Vector3d>& gravity_cam);
  void clear();

  // What is drawn (nothing before the first posed attempt), and the attempt it is of.
  const std::optional<SceneGeometry>& scene() const { return scene_; }
  const std::shared_ptr<const AttemptOutcome>& attempt() const { return attempt_; }
  // Looks at the whole scene from behind and above the newest camera, gravity down.
  void resetCamera();
  // The rendered image, and where a world point lands in it (for tests; the view has been
  // shown).
  QImage grab3d();
  QPointF worldToImage(const Eigen::Vector3d& world) const;

 protected:
  void paintEvent(QPaintEvent* event) override;

 private:
  struct Vtk;
  // VTK's OpenGL widget is made when the view is first shown: once a window holds an
  // OpenGL widget, Qt composes the whole window through OpenGL, which costs every video
  // frame on a machine without a GPU.
  Vtk& vtk();
  void rebuild();

  std::unique_ptr<Vtk> vtk_;
  QLabel* caption_ = nullptr;
  std::optional<SceneGeometry> scene_;
  std::shared_ptr<const AttemptOutcome> attempt_;
};

}  // namespace autocal
