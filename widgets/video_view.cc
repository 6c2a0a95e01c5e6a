#include "widgets/video_view.h"

#include <QFont>
#include <QPainter>

namespace autocal {

VideoView::VideoView(QWidget* parent) : QWidget(parent) {
  setAttribute(Qt::WA_OpaquePaintEvent);
  setFocusPolicy(Qt::StrongFocus);
  setSizePolicy(QSizePolicy::Expanding, QSizePolicy::Expanding);
}

QSize VideoView::sizeHint() const { return {640, 480}; }

QSize VideoView::minimumSizeHint() const { return {320, 180}; }

QRectF VideoView::imageRect() const {
  if (image_.isNull()) return {};
  const QSizeF scaled = QSizeF(image_.size()).scaled(QSizeF(size()), Qt::KeepAspectRatio);
  return {QPointF((width() - scaled.width()) / 2.0, (height() - scaled.height()) / 2.0), scaled};
}

QTransform VideoView::imageToWidget() const {
  const QRectF target = imageRect();
  if (target.isEmpty()) return {};
  return QTransform::fromTranslate(target.left(), target.top())
      .scale(target.width() / image_.width(), target.height() / image_.height())
      .translate(0.5, 0.5);
}

void VideoView::setFrame(int index, const QImage& image) {
  frame_index_ = index;
  image_ = image;
  pixmap_ = QPixmap::fromImage(image);
  message_.clear();
  update();
}

void VideoView::showMessage(const QString& message) {
  frame_index_ = -1;
  image_ = {};
  pixmap_ = {};
  message_ = message;
  update();
}

void VideoView::paintEvent(QPaintEvent* /*event*/) {
  QPainter painter(this);
  painter.fillRect(rect(), QColor(24, 24, 24));
  if (!pixmap_.isNull()) {
    painter.setRenderHint(QPainter::SmoothPixmapTransform);
    painter.drawPixmap(imageRect(), pixmap_, QRectF(pixmap_.rect()));
    return;
  }
  if (!message_.isEmpty()) {
    painter.setPen(QColor(220, 220, 220));
    QFont font = painter.font();
    font.setPointSizeF(font.pointSizeF() * 1.4);
    painter.setFont(font);
    painter.drawText(rect().adjusted(24, 24, -24, -24), Qt::AlignCenter | Qt::TextWordWrap,
                     message_);
  }
}

}  // namespace autocal
