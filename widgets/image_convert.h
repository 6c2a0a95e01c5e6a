// cv::Mat -> QImage for display.
#pragma once

#include <QImage>
#include <opencv2/core.hpp>

namespace autocal {

// Deep-copies an 8-bit frame (BGR, BGRA or grey, as OpenCV delivers them) into a QImage
// that owns its pixels, so the result outlives `frame` and can cross threads. QImage rows
// are 4-byte aligned, so rows are copied with QImage's bytesPerLine, not width * 3.
// Returns a null QImage for an empty or unsupported matrix.
QImage MatToQImage(const cv::Mat& frame);

}  // namespace autocal
