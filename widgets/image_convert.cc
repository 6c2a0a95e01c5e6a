#include "widgets/image_convert.h"

#include <opencv2/imgproc.hpp>

namespace autocal {

QImage MatToQImage(const cv::Mat& frame) {
  if (frame.empty() || frame.depth() != CV_8U) return {};
  QImage::Format format;
  int conversion;
  switch (frame.channels()) {
    case 1:
      format = QImage::Format_Grayscale8;
      conversion = -1;
      break;
    case 3:
      format = QImage::Format_RGB888;
      conversion = cv::COLOR_BGR2RGB;
      break;
    case 4:
      format = QImage::Format_RGBA8888;  // Byte order R, G, B, A on every platform.
      conversion = cv::COLOR_BGRA2RGBA;
      break;
    default:
      return {};
  }
  QImage image(frame.cols, frame.rows, format);
  if (image.isNull()) return {};
  // A view of the QImage's own buffer with its stride: OpenCV writes straight into it.
  cv::Mat target(frame.rows, frame.cols, frame.type(), image.bits(),
                 static_cast<size_t>(image.bytesPerLine()));
  if (conversion >= 0) {
    cv::cvtColor(frame, target, conversion);
  } else {
    frame.copyTo(target);
  }
  return image;
}

}  // namespace autocal
