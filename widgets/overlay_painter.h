// Draws a frame's overlay layers (pipeline/overlay_geometry.h) over the video, each layer on
// its own switch. Colours (docs/workbench.md): lines yellow; snakes cyan with hinges from
// green (straight) to red (bent 2 deg or more); tracks and planes in the plane's colour
// (tracks on no plane grey); boards white; gravity and horizon magenta.
#pragma once

#include <QColor>
#include <QFlags>
#include <QString>
#include <QTransform>

#include "pipeline/overlay_geometry.h"

class QPainter;

namespace autocal {

enum class OverlayLayer {
  kLines = 1 << 0,    // Box 1: Radon lines.
  kSnakes = 1 << 1,   // Box 1: Radon snakes, hinges coloured by bend.
  kTracks = 1 << 2,   // Box 5: tracks and their flow since the previous frame.
  kPlanes = 1 << 3,   // Box 6: dominant planes' outlines and ids.
  kBoards = 1 << 4,   // Box 8: virtual checkerboards.
  kGravity = 1 << 5,  // Box 7: gravity and the horizon.
};
Q_DECLARE_FLAGS(OverlayLayers, OverlayLayer)
Q_DECLARE_OPERATORS_FOR_FLAGS(OverlayLayers)

inline constexpr OverlayLayer kAllOverlayLayers[] = {OverlayLayer::kLines,  OverlayLayer::kSnakes,
                                                     OverlayLayer::kTracks, OverlayLayer::kPlanes,
                                                     OverlayLayer::kBoards, OverlayLayer::kGravity};

// The layers on until a user chooses: what the pipeline found at a glance (planes, the
// boards that show whether the calibration sticks, gravity). Lines, snakes and tracks are
// dense and for engineers.
inline const OverlayLayers kDefaultOverlayLayers =
    OverlayLayers(OverlayLayer::kPlanes) | OverlayLayer::kBoards | OverlayLayer::kGravity;

// "Lines", "Snakes", ...: the layer's name in menus.
QString OverlayLayerName(OverlayLayer layer);
// "lines", "snakes", ...: its key in settings and file names.
QString OverlayLayerKey(OverlayLayer layer);
// A hinge's colour for its bend angle.
QColor BendColor(double bend_deg);
// A plane's colour, by its id.
QColor PlaneColor(int plane_id);

// Draws the layers of `overlay` whose bit is set; `image_to_widget` maps the overlay's
// pixels (centres at integers) to the painter's coordinates. Marks and pens keep their size
// on screen whatever the scale.
void PaintOverlay(QPainter* painter, const QTransform& image_to_widget,
                  const OverlayGeometry& overlay, OverlayLayers layers);

}  // namespace autocal
