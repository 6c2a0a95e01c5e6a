#include "widgets/overlay_painter.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <tuple>
#include <utility>

#include <QFontMetricsF>
#include <QImage>
#include <QObject>
#include <QPainter>
#include <QPainterPath>
#include <QPolygonF>

namespace autocal {
namespace {

// Bend at which a hinge is drawn fully red: a lens bends a 12 px edge by well under this.
constexpr double kFullBendDeg = 2.0;

const QColor kLineColor(255, 214, 0);
const QColor kSnakeColor(0, 220, 255);
const QColor kOffPlaneColor(190, 190, 190);
const QColor kBoardColor(255, 255, 255);
const QColor kGravityColor(255, 64, 255);

QPointF Map(const QTransform& to_widget, const Eigen::Vector2d& p) {
  return to_widget.map(QPointF(p.x(), p.y()));
}

QPolygonF MapPolyline(const QTransform& to_widget, const Polyline& points) {
  QPolygonF mapped;
  mapped.reserve(static_cast<int>(points.size()));
  for (const Eigen::Vector2d& p : points) mapped << Map(to_widget, p);
  return mapped;
}

QPen Pen(const QColor& color, double width, Qt::PenStyle style = Qt::SolidLine) {
  QPen pen(color, width, style, Qt::RoundCap, Qt::BevelJoin);
  pen.setCosmetic(true);
  return pen;
}

// A dark halo under a line keeps it visible on bright and dark texture alike.
void DrawPolyline(QPainter* painter, const QPolygonF& line, const QColor& color, double width,
                  Qt::PenStyle style = Qt::SolidLine) {
  painter->setPen(Pen(QColor(0, 0, 0, 140), width + 2.0, style));
  painter->drawPolyline(line);
  painter->setPen(Pen(color, width, style));
  painter->drawPolyline(line);
}

// A dot with a dark rim, drawn once for each colour, size and pixel ratio and then copied:
// drawn as antialiased ellipses, 300 tracks' and the hinges' dots cost the GUI thread more
// than the frame under them. Hinge colours come from 8-bit hues, some 500 of them.
const QImage& Dot(const QColor& fill, double radius, qreal pixel_ratio) {
  thread_local std::map<std::tuple<QRgb, int, int>, QImage> dots;
  const auto key = std::make_tuple(fill.rgba(), static_cast<int>(std::lround(radius * 8.0)),
                                   static_cast<int>(std::lround(pixel_ratio * 8.0)));
  if (const auto found = dots.find(key); found != dots.end()) return found->second;
  if (dots.size() >= 2048) dots.clear();
  const double side = 2.0 * std::ceil(radius + 1.0);  // The rim's half pixel outside, rounded.
  const int pixels = static_cast<int>(std::ceil(side * pixel_ratio));
  QImage image(pixels, pixels, QImage::Format_ARGB32_Premultiplied);
  image.setDevicePixelRatio(pixel_ratio);
  image.fill(Qt::transparent);
  QPainter painter(&image);
  painter.setRenderHint(QPainter::Antialiasing);
  painter.setPen(Pen(QColor(0, 0, 0, 160), 1.0));
  painter.setBrush(fill);
  painter.drawEllipse(QPointF(side / 2.0, side / 2.0), radius, radius);
  return dots.emplace(key, std::move(image)).first->second;
}

void DrawDot(QPainter* painter, const QPointF& centre, const QColor& fill, double radius) {
  const qreal pixel_ratio = painter->device()->devicePixelRatioF();
  const QImage& dot = Dot(fill, radius, pixel_ratio);
  const double half = 0.5 * dot.width() / pixel_ratio;
  // At whole pixels the dot is copied, not resampled; half a pixel off is not seen.
  painter->drawImage(QPointF(std::round(centre.x() - half), std::round(centre.y() - half)), dot);
}

void DrawLabel(QPainter* painter, const QPointF& centre, const QString& text, const QColor& color) {
  const QFontMetricsF metrics(painter->font());
  QRectF box = metrics.boundingRect(text).adjusted(-4, -1, 4, 1);
  box.moveCenter(centre);
  painter->setPen(Pen(color, 1.5));
  painter->setBrush(QColor(0, 0, 0, 170));
  painter->drawRoundedRect(box, 3, 3);
  painter->setPen(color);
  painter->drawText(box, Qt::AlignCenter, text);
}

void DrawArrow(QPainter* painter, const QPointF& from, const QPointF& to, const QColor& color) {
  const QLineF shaft(from, to);
  DrawPolyline(painter, QPolygonF() << from << to, color, 3.0);
  if (shaft.length() < 1.0) return;
  const double head = std::min(14.0, 0.4 * shaft.length());
  const double angle = std::atan2(-shaft.dy(), shaft.dx());
  const QPointF left = to - QPointF(std::cos(angle - std::numbers::pi / 7) * head,
                                    -std::sin(angle - std::numbers::pi / 7) * head);
  const QPointF right = to - QPointF(std::cos(angle + std::numbers::pi / 7) * head,
                                     -std::sin(angle + std::numbers::pi / 7) * head);
  painter->setPen(Pen(QColor(0, 0, 0, 140), 1.0));
  painter->setBrush(color);
  painter->drawPolygon(QPolygonF() << to << left << right);
}

}  // namespace

QString OverlayLayerName(OverlayLayer layer) {
  switch (layer) {
    case OverlayLayer::kLines:
      return QObject::tr("Lines");
    case OverlayLayer::kSnakes:
      return QObject::tr("Snakes");
    case OverlayLayer::kTracks:
      return QObject::tr("Tracks");
    case OverlayLayer::kPlanes:
      return QObject::tr("Planes");
    case OverlayLayer::kBoards:
      return QObject::tr("Boards");
    case OverlayLayer::kGravity:
      return QObject::tr("Gravity");
  }
  return {};
}

QString OverlayLayerKey(OverlayLayer layer) { return OverlayLayerName(layer).toLower(); }

QColor BendColor(double bend_deg) {
  const double t = std::clamp(std::abs(bend_deg) / kFullBendDeg, 0.0, 1.0);
  return QColor::fromHsvF((1.0 - t) / 3.0, 1.0, 1.0);  // Hue 120 deg (green) to 0 (red).
}

QColor PlaneColor(int plane_id) {
  static const QColor kPalette[] = {{66, 133, 244}, {52, 168, 83}, {251, 140, 0},  {171, 71, 188},
                                    {0, 172, 193},  {233, 30, 99}, {124, 179, 66}, {141, 110, 99}};
  return kPalette[static_cast<size_t>(std::abs(plane_id)) % std::size(kPalette)];
}

void PaintOverlay(QPainter* painter, const QTransform& to_widget, const OverlayGeometry& overlay,
                  OverlayLayers layers) {
  painter->save();
  painter->setRenderHint(QPainter::Antialiasing);

  if (layers & OverlayLayer::kPlanes) {
    for (const OverlayGeometry::PlaneOutline& plane : overlay.planes) {
      QColor fill = PlaneColor(plane.id);
      fill.setAlpha(45);
      const QPolygonF hull = MapPolyline(to_widget, plane.hull);
      // The fill's edge is under the outline: filling without antialiasing is not seen, and
      // it is the cheap way to fill a third of the frame.
      painter->setRenderHint(QPainter::Antialiasing, false);
      painter->setPen(Qt::NoPen);
      painter->setBrush(fill);
      painter->drawPolygon(hull);
      painter->setRenderHint(QPainter::Antialiasing);
      painter->setPen(Pen(PlaneColor(plane.id), 2.0));
      painter->setBrush(Qt::NoBrush);
      painter->drawPolygon(hull);
    }
  }
  if (layers & OverlayLayer::kBoards) {
    for (const OverlayGeometry::Board& board : overlay.boards) {
      for (const Polyline& line : board.lines) {
        DrawPolyline(painter, MapPolyline(to_widget, line), kBoardColor, 1.2);
      }
    }
  }
  if (layers & OverlayLayer::kLines) {
    for (const Polyline& line : overlay.lines) {
      DrawPolyline(painter, MapPolyline(to_widget, line), kLineColor, 1.5);
    }
  }
  if (layers & OverlayLayer::kSnakes) {
    for (const OverlayGeometry::Snake& snake : overlay.snakes) {
      DrawPolyline(painter, MapPolyline(to_widget, snake.vertices), kSnakeColor, 1.5);
      for (size_t i = 1; i + 1 < snake.vertices.size(); ++i) {
        DrawDot(painter, Map(to_widget, snake.vertices[i]), BendColor(snake.bend_deg[i]), 3.0);
      }
    }
  }
  if (layers & OverlayLayer::kTracks) {
    for (const OverlayGeometry::TrackMark& track : overlay.tracks) {
      const QColor color = track.plane_id ? PlaneColor(track.plane_id) : kOffPlaneColor;
      const QPointF now = Map(to_widget, track.now);
      if (track.previous) {
        painter->setPen(Pen(color, 1.0));
        painter->drawLine(Map(to_widget, *track.previous), now);
      }
      DrawDot(painter, now, color, 2.5);
    }
  }
  if (layers & OverlayLayer::kGravity && overlay.gravity) {
    for (const Polyline& piece : overlay.gravity->horizon) {
      DrawPolyline(painter, MapPolyline(to_widget, piece), kGravityColor, 2.0, Qt::DashLine);
    }
    DrawArrow(painter, Map(to_widget, overlay.gravity->from), Map(to_widget, overlay.gravity->to),
              kGravityColor);
  }
  // Ids last, over everything they label.
  if (layers & OverlayLayer::kPlanes) {
    for (const OverlayGeometry::PlaneOutline& plane : overlay.planes) {
      DrawLabel(painter, Map(to_widget, plane.centre), QObject::tr("plane %1").arg(plane.id),
                PlaneColor(plane.id).lighter(130));
    }
  }
  painter->restore();
}

}  // namespace autocal
