// What GUI tests look for in a grabbed image: a colour drawn at a place, or how much of it.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include <QColor>
#include <QImage>
#include <QPointF>

namespace autocal {

// Colour distance: the largest difference over the channels.
inline int ColorDistance(const QColor& a, const QColor& b) {
  return std::max({std::abs(a.red() - b.red()), std::abs(a.green() - b.green()),
                   std::abs(a.blue() - b.blue())});
}

// Whether a pixel within `radius` of `at` is within `tolerance` of `color`.
inline bool DrawnNear(const QImage& image, QPointF at, const QColor& color, int radius = 2,
                      int tolerance = 30) {
  const QPoint centre(int(std::lround(at.x())), int(std::lround(at.y())));
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const QPoint p = centre + QPoint(dx, dy);
      if (image.rect().contains(p) && ColorDistance(image.pixelColor(p), color) <= tolerance) {
        return true;
      }
    }
  }
  return false;
}

// Pixels of `image` within `tolerance` of `color`.
inline int CountColor(const QImage& image, const QColor& color, int tolerance) {
  int count = 0;
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      count += ColorDistance(image.pixelColor(x, y), color) <= tolerance;
    }
  }
  return count;
}

}  // namespace autocal
