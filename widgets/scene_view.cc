#include "widgets/scene_view.h"

#include <array>
#include <vector>

#include <QLabel>
#include <QPaintEvent>
#include <QSurfaceFormat>
#include <QTimer>
#include <QVBoxLayout>

#include <QVTKOpenGLNativeWidget.h>
#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkConeSource.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkInteractorStyleTrackballCamera.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>

namespace autocal {

QColor SceneTrajectoryColor() { return QColor(20, 60, 200); }
QColor SceneFrustumColor() { return QColor(0, 0, 0); }
QColor SceneGravityColor() { return QColor(0, 150, 40); }
QColor SceneDarkSquareColor() { return QColor(45, 45, 45); }
QColor ScenePlaneColor(int plane_id) {
  static const std::array<QColor, 6> palette = {QColor(240, 150, 40), QColor(200, 60, 160),
                                                QColor(40, 180, 190), QColor(220, 200, 40),
                                                QColor(140, 100, 220), QColor(230, 90, 80)};
  return palette[size_t(plane_id < 0 ? -plane_id : plane_id) % palette.size()];
}

namespace {

void SetColor(vtkActor* actor, const QColor& color) {
  actor->GetProperty()->SetColor(color.redF(), color.greenF(), color.blueF());
}

vtkSmartPointer<vtkActor> ActorOf(vtkPolyData* data) {
  vtkNew<vtkPolyDataMapper> mapper;
  mapper->SetInputData(data);
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(mapper);
  return actor;
}

vtkSmartPointer<vtkActor> Polylines(const std::vector<std::vector<Eigen::Vector3d>>& lines,
                                    const QColor& color, double width) {
  vtkNew<vtkPoints> points;
  vtkNew<vtkCellArray> cells;
  for (const std::vector<Eigen::Vector3d>& line : lines) {
    cells->InsertNextCell(vtkIdType(line.size()));
    for (const Eigen::Vector3d& p : line) cells->InsertCellPoint(points->InsertNextPoint(p.data()));
  }
  vtkNew<vtkPolyData> data;
  data->SetPoints(points);
  data->SetLines(cells);
  auto actor = ActorOf(data);
  SetColor(actor, color);
  actor->GetProperty()->SetLineWidth(float(width));
  actor->GetProperty()->LightingOff();
  return actor;
}

vtkSmartPointer<vtkActor> Polygons(const std::vector<ScenePolygon>& polygons, const QColor& color) {
  vtkNew<vtkPoints> points;
  vtkNew<vtkCellArray> cells;
  for (const ScenePolygon& polygon : polygons) {
    cells->InsertNextCell(static_cast<vtkIdType>(polygon.size()));
    for (const Eigen::Vector3d& p : polygon) {
      cells->InsertCellPoint(points->InsertNextPoint(p.data()));
    }
  }
  vtkNew<vtkPolyData> data;
  data->SetPoints(points);
  data->SetPolys(cells);
  auto actor = ActorOf(data);
  SetColor(actor, color);
  actor->GetProperty()->LightingOff();  // Flat colours, whichever way the plane faces.
  return actor;
}

QString Swatch(const QColor& color, const QString& text) {
  return QStringLiteral("<span style='color:%1'>&#9632; %2</span>").arg(color.name(), text);
}

}  // namespace

struct SceneView::Vtk {
  QVTKOpenGLNativeWidget* widget = nullptr;
  vtkNew<vtkGenericOpenGLRenderWindow> window;
  vtkNew<vtkRenderer> renderer;
};

void SceneView::SetDefaultSurfaceFormat() {
  QSurfaceFormat::setDefaultFormat(QVTKOpenGLNativeWidget::defaultFormat());
}

SceneView::SceneView(QWidget* parent) : QWidget(parent) {
  auto* layout = new QVBoxLayout(this);
  layout->setContentsMargins(0, 0, 0, 0);
  caption_ = new QLabel(this);
  caption_->setWordWrap(true);
  layout->addWidget(caption_);
  clear();
}

SceneView::~SceneView() = default;

SceneView::Vtk& SceneView::vtk() {
  if (vtk_) return *vtk_;
  vtk_ = std::make_unique<Vtk>();
  vtk_->widget = new QVTKOpenGLNativeWidget(this);
  vtk_->widget->setRenderWindow(vtk_->window);
  vtk_->window->AddRenderer(vtk_->renderer);
  // Left drag turns the scene about its centre, the wheel zooms, the middle button pans.
  vtkNew<vtkInteractorStyleTrackballCamera> style;
  vtk_->window->GetInteractor()->SetInteractorStyle(style);
  vtk_->renderer->SetBackground(0.96, 0.96, 0.96);
  static_cast<QVBoxLayout*>(layout())->insertWidget(0, vtk_->widget, 1);
  rebuild();
  resetCamera();
  return *vtk_;
}

void SceneView::paintEvent(QPaintEvent* event) {
  QWidget::paintEvent(event);
  // Painted means on screen: a dock tabbed behind another is shown but never painted.
  // The widget is made outside the paint.
  if (!vtk_) QTimer::singleShot(0, this, [this] { vtk(); });
}

void SceneView::clear() {
  scene_.reset();
  attempt_.reset();
  if (vtk_) rebuild();
  caption_->setText(tr("No attempt with camera poses yet: the scene is box 10's newest "
                       "attempt, drawn once one is judged."));
}

void SceneView::showSnapshot(std::shared_ptr<const FrameSnapshot> snapshot) {
  if (!snapshot || !snapshot->attempt) return;
  showAttempt(snapshot->attempt, snapshot->calibration.calibration, snapshot->inertial.gravity_cam);
}

void SceneView::showAttempt(std::shared_ptr<const AttemptOutcome> attempt,
                            const CameraIntrinsics& camera,
                            const std::optional<Eigen::Vector3d>& gravity_cam) {
  if (!attempt) return;
  std::optional<SceneGeometry> scene = MakeSceneGeometry(*attempt, camera, gravity_cam);
  if (!scene) return;
  const bool first = !scene_;
  scene_ = std::move(scene);
  attempt_ = std::move(attempt);
  const AttemptRecord& record = attempt_->record;
  caption_->setText(
      tr("Attempt %1 (%2): %3 posed views, %4 planes. %5 %6 %7 %8 %9")
          .arg(record.id)
          .arg(QString::fromStdString(VerdictName(record.verdict)))
          .arg(scene_->trajectory.size())
          .arg(scene_->boards.size())
          .arg(Swatch(SceneTrajectoryColor(), tr("trajectory")),
               Swatch(SceneFrustumColor(), tr("camera")),
               Swatch(SceneGravityColor(),
                      scene_->gravity ? tr("gravity") : tr("gravity (not known)")),
               Swatch(ScenePlaneColor(scene_->boards.empty() ? 0 : scene_->boards[0].plane_id),
                      tr("planes")),
               Swatch(SceneDarkSquareColor(), tr("virtual boards"))));
  if (!vtk_) return;  // Drawn when first shown.
  rebuild();
  if (first) resetCamera();
  vtk_->window->Render();
}

void SceneView::rebuild() {
  vtkRenderer* renderer = vtk_->renderer;
  renderer->RemoveAllViewProps();
  if (!scene_) {
    vtk_->window->Render();
    return;
  }
  const SceneGeometry& s = *scene_;
  renderer->AddActor(Polylines({s.trajectory}, SceneTrajectoryColor(), 3.0));
  const auto& f = s.frustum;
  renderer->AddActor(Polylines({{f[0], f[1]}, {f[0], f[2]}, {f[0], f[3]}, {f[0], f[4]},
                                {f[1], f[2], f[3], f[4], f[1]}},
                               SceneFrustumColor(), 2.0));
  for (const SceneBoard& board : s.boards) {
    // The plane in its colour (its border and the light squares), the dark squares apart:
    // no two polygons in one place to fight over the depth.
    std::vector<ScenePolygon> plane = board.border;
    plane.insert(plane.end(), board.light.begin(), board.light.end());
    renderer->AddActor(Polygons(plane, ScenePlaneColor(board.plane_id)));
    renderer->AddActor(Polygons(board.dark, SceneDarkSquareColor()));
  }
  if (s.gravity) {
    const double length = s.gravity_length;
    const Eigen::Vector3d start = f[0];
    const Eigen::Vector3d tip = start + length * *s.gravity;
    renderer->AddActor(Polylines({{start, tip}}, SceneGravityColor(), 4.0));
    vtkNew<vtkConeSource> cone;
    const Eigen::Vector3d centre = tip - 0.1 * length * *s.gravity;
    cone->SetCenter(centre.x(), centre.y(), centre.z());
    cone->SetDirection(s.gravity->x(), s.gravity->y(), s.gravity->z());
    cone->SetHeight(0.2 * length);
    cone->SetRadius(0.06 * length);
    cone->SetResolution(16);
    vtkNew<vtkPolyDataMapper> mapper;
    mapper->SetInputConnection(cone->GetOutputPort());
    vtkNew<vtkActor> arrow;
    arrow->SetMapper(mapper);
    SetColor(arrow, SceneGravityColor());
    renderer->AddActor(arrow);
  }
}

void SceneView::resetCamera() {
  if (!scene_ || !vtk_) return;
  const Eigen::Isometry3d& camera = scene_->world_from_camera;
  const Eigen::Vector3d forward = camera.linear().col(2);
  // Image "down" is the camera's +y; gravity, when known, is down in the world.
  const Eigen::Vector3d down = scene_->gravity.value_or(camera.linear().col(1));
  const Eigen::Vector3d look = (forward + 0.8 * down).normalized();
  double bounds[6];
  vtk_->renderer->ComputeVisiblePropBounds(bounds);
  const Eigen::Vector3d focus((bounds[0] + bounds[1]) / 2, (bounds[2] + bounds[3]) / 2,
                              (bounds[4] + bounds[5]) / 2);
  vtkCamera* view = vtk_->renderer->GetActiveCamera();
  view->SetFocalPoint(focus.x(), focus.y(), focus.z());
  const Eigen::Vector3d position = focus - look;
  view->SetPosition(position.x(), position.y(), position.z());
  view->SetViewUp(-down.x(), -down.y(), -down.z());
  // Keeps the direction and fits the distance to the bounding sphere, so everything is in
  // view (zooming in past it cut the frustum off when the trajectory set the sphere).
  vtk_->renderer->ResetCamera();
  vtk_->window->Render();
}

QImage SceneView::grab3d() {
  vtk().window->Render();
  return vtk_->widget->grabFramebuffer();
}

QPointF SceneView::worldToImage(const Eigen::Vector3d& world) const {
  if (!vtk_) return {};
  vtkRenderer* renderer = vtk_->renderer;
  renderer->SetWorldPoint(world.x(), world.y(), world.z(), 1.0);
  renderer->WorldToDisplay();
  double display[3];
  renderer->GetDisplayPoint(display);
  // VTK's display runs up from the bottom in device pixels; the image runs down.
  const double ratio = vtk_->widget->devicePixelRatioF();
  return QPointF(display[0] / ratio, vtk_->widget->height() - display[1] / ratio);
}

}  // namespace autocal
