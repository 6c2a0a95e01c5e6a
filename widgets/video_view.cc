#include "widgets/video_view.h"

#include <QFont>
#include <QFontMetricsF>
#include <QPainter>
#include <QRegularExpression>

namespace autocal {
namespace {

constexpr double kPaneGap = 4.0;  // Between the panes side by side, px.
constexpr double kUnfitBorderPx = 4.0;

}  // namespace

VideoView::VideoView(QWidget* parent) : QWidget(parent) {
  setAttribute(Qt::WA_OpaquePaintEvent);
  setFocusPolicy(Qt::StrongFocus);
  setSizePolicy(QSizePolicy::Expanding, QSizePolicy::Expanding);
}

QSize VideoView::sizeHint() const { return {640, 480}; }

QSize VideoView::minimumSizeHint() const { return {320, 180}; }

bool VideoView::showsPane(Pane pane) const {
  switch (view_mode_) {
    case ViewMode::kRaw:
      return pane == Pane::kRaw;
    case ViewMode::kRectified:
      return pane == Pane::kRectified;
    case ViewMode::kSideBySide:
      return true;
  }
  return false;
}

QRectF VideoView::paneArea(Pane pane) const {
  if (view_mode_ != ViewMode::kSideBySide) return QRectF(rect());
  const double half = (width() - kPaneGap) / 2.0;
  return pane == Pane::kRaw ? QRectF(0, 0, half, height())
                            : QRectF(half + kPaneGap, 0, half, height());
}

QRectF VideoView::imageRect() const {
  return imageRect(view_mode_ == ViewMode::kRectified ? Pane::kRectified : Pane::kRaw);
}

QRectF VideoView::imageRect(Pane pane) const {
  if (image_.isNull() || !showsPane(pane)) return {};
  const QRectF area = paneArea(pane);
  const QSizeF scaled = QSizeF(image_.size()).scaled(area.size(), Qt::KeepAspectRatio);
  return {QPointF(area.left() + (area.width() - scaled.width()) / 2.0,
                  area.top() + (area.height() - scaled.height()) / 2.0),
          scaled};
}

QTransform VideoView::imageToWidget() const {
  return imageToWidget(view_mode_ == ViewMode::kRectified ? Pane::kRectified : Pane::kRaw);
}

QTransform VideoView::imageToWidget(Pane pane) const {
  const QRectF target = imageRect(pane);
  if (target.isEmpty()) return {};
  return QTransform::fromTranslate(target.left(), target.top())
      .scale(target.width() / image_.width(), target.height() / image_.height())
      .translate(0.5, 0.5);
}

void VideoView::setFrame(int index, const QImage& image) {
  if (index != frame_index_) {
    rectified_ = {};
    rectified_pixmap_ = {};
  }
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
  rectified_ = {};
  rectified_pixmap_ = {};
  overlays_ = {};
  message_ = message;
  update();
}

void VideoView::setViewMode(ViewMode mode) {
  view_mode_ = mode;
  update();
}

void VideoView::setLayers(OverlayLayers layers) {
  layers_ = layers;
  update();
}

void VideoView::setOverlays(const FrameOverlays& overlays) {
  overlays_ = overlays;
  if (overlays.index == frame_index_) update();
}

void VideoView::setRectifiedImage(int index, const QImage& image) {
  if (index != frame_index_) return;
  rectified_ = image;
  rectified_pixmap_ = QPixmap::fromImage(image);
  if (showsPane(Pane::kRectified)) update();
}

QString VideoView::pipelineNote() const {
  if (!layers_ || frame_index_ < 0 || overlays_.index != frame_index_ || overlays_.snapshot) {
    return {};
  }
  if (overlays_.live) return tr("The pipeline is not running on the live source (see Devices)");
  if (!overlays_.running && overlays_.pipeline_frames_done == 0) {
    return tr("The pipeline is not running on this recording");
  }
  if (overlays_.pipeline_frames_done <= frame_index_) {
    return tr("Pipeline at frame %1; this is frame %2")
        .arg(overlays_.pipeline_frames_done)
        .arg(frame_index_);
  }
  return tr("Frame %1's findings are no longer kept (the %2 frames nearest the one on screen are)")
      .arg(frame_index_)
      .arg(PipelineController::kMaxStoredSnapshots);
}

QColor VideoView::UnfitColor() { return {230, 110, 0}; }

QString VideoView::unfitNote() const {
  if (!layers_ || frame_index_ < 0 || overlays_.index != frame_index_ || !overlays_.snapshot ||
      overlays_.snapshot->degraded.empty()) {
    return {};
  }
  QString why = QString::fromStdString(overlays_.snapshot->degraded);
  why.remove(QRegularExpression(QStringLiteral("^image degraded: ")));
  return tr("Unfit to measure from: %1").arg(why);
}

void VideoView::paintNote(QPainter* painter, const QString& note, const QColor& background) {
  const QRectF image = imageRect();
  const QRectF room = image.adjusted(10, 10, -10, -10);
  const QFontMetricsF metrics(painter->font());
  const QRectF text = metrics.boundingRect(room, Qt::AlignLeft | Qt::AlignTop | Qt::TextWordWrap,
                                           note);
  const QRectF box = text.adjusted(-6, -3, 6, 3);
  painter->fillRect(box, background);
  painter->setPen(QColor(245, 245, 245));
  painter->drawText(text, Qt::AlignLeft | Qt::AlignTop | Qt::TextWordWrap, note);
}

void VideoView::paintPane(QPainter* painter, Pane pane) {
  const QPixmap& pixmap = pane == Pane::kRaw ? pixmap_ : rectified_pixmap_;
  const QRectF target = imageRect(pane);
  if (pixmap.isNull()) {
    painter->setPen(QColor(200, 200, 200));
    painter->drawText(target, Qt::AlignCenter | Qt::TextWordWrap,
                      tr("Rectified image: waiting for the pipeline"));
    return;
  }
  painter->drawPixmap(target, pixmap, QRectF(pixmap.rect()));
  const std::shared_ptr<const OverlayGeometry>& overlay =
      pane == Pane::kRaw ? overlays_.raw : overlays_.rectified;
  if (layers_ && overlay && overlays_.index == frame_index_) {
    painter->save();
    painter->setClipRect(target);
    PaintOverlay(painter, imageToWidget(pane), *overlay, layers_);
    painter->restore();
  }
  // Side by side, which is which: at the pane's foot, over the overlay.
  if (view_mode_ == ViewMode::kSideBySide) {
    const QString caption = pane == Pane::kRaw ? tr("Raw") : tr("Rectified (box 3)");
    const QFontMetricsF metrics(painter->font());
    const QRectF box = metrics.boundingRect(caption)
                           .translated(target.bottomLeft() + QPointF(10, -10 - metrics.descent()))
                           .adjusted(-6, -3, 6, 3);
    painter->fillRect(box, QColor(0, 0, 0, 170));
    painter->setPen(QColor(235, 235, 235));
    painter->drawText(box, Qt::AlignCenter, caption);
  }
}

void VideoView::paintEvent(QPaintEvent* /*event*/) {
  ++paint_count_;
  if (frame_index_ != last_painted_index_) {
    last_painted_index_ = frame_index_;
    if (frame_index_ >= 0) ++frames_painted_;
  }
  QPainter painter(this);
  painter.fillRect(rect(), QColor(24, 24, 24));
  if (!pixmap_.isNull()) {
    painter.setRenderHint(QPainter::SmoothPixmapTransform);
    for (const Pane pane : {Pane::kRaw, Pane::kRectified}) {
      if (showsPane(pane)) paintPane(&painter, pane);
    }
    const QString note = pipelineNote();
    if (!note.isEmpty()) paintNote(&painter, note, QColor(0, 0, 0, 170));
    const QString unfit = unfitNote();
    if (!unfit.isEmpty()) {
      // A border round every pane shown, so that an unfit stretch is seen while playing.
      painter.setPen(QPen(UnfitColor(), kUnfitBorderPx, Qt::SolidLine, Qt::SquareCap,
                          Qt::MiterJoin));
      painter.setBrush(Qt::NoBrush);
      for (const Pane pane : {Pane::kRaw, Pane::kRectified}) {
        if (!showsPane(pane)) continue;
        const double inset = kUnfitBorderPx / 2.0;
        painter.drawRect(imageRect(pane).adjusted(inset, inset, -inset, -inset));
      }
      QColor banner = UnfitColor().darker(140);
      banner.setAlpha(225);
      paintNote(&painter, unfit, banner);
    }
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
