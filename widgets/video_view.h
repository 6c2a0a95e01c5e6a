// Draws the current video frame, scaled to fit with its aspect ratio kept: raw, box 3's
// rectified image, or both side by side, with the pipeline's overlay layers over each.
#pragma once

#include <cstdint>

#include <QImage>
#include <QPixmap>
#include <QRectF>
#include <QString>
#include <QTransform>
#include <QWidget>

#include "widgets/overlay_painter.h"
#include "widgets/pipeline_controller.h"

namespace autocal {

class VideoView : public QWidget {
  Q_OBJECT

 public:
  enum class ViewMode { kRaw, kRectified, kSideBySide };
  enum class Pane { kRaw, kRectified };

  explicit VideoView(QWidget* parent = nullptr);

  // Index of the frame on screen, -1 when none.
  int frameIndex() const { return frame_index_; }
  const QImage& image() const { return image_; }
  // Box 3's image of the frame on screen (null until it came).
  const QImage& rectifiedImage() const { return rectified_; }
  ViewMode viewMode() const { return view_mode_; }
  OverlayLayers layers() const { return layers_; }
  const FrameOverlays& overlays() const { return overlays_; }
  // Whether `pane` is on screen in the current view mode.
  bool showsPane(Pane pane) const;
  // Where the frame lies in widget coordinates in `pane` (empty when it is not shown).
  // Without a pane: the first pane shown (the raw one, but in the rectified view).
  QRectF imageRect() const;
  QRectF imageRect(Pane pane) const;
  // Frame pixel coordinates, pixel centres at integers (DESIGN.md section 2), -> widget
  // coordinates in the pane; overlays draw through this.
  QTransform imageToWidget() const;
  QTransform imageToWidget(Pane pane) const;

  // Paint events so far, and of them the ones that put a frame on screen other than the one
  // painted before: the redraw rate the eye sees is the second per second.
  uint64_t paintCount() const { return paint_count_; }
  uint64_t framesPainted() const { return frames_painted_; }

  // With layers on, what the view says over a frame box 9's image-quality gate found unfit
  // ("Unfit to measure from: fogged (blur ...)"); empty for a fit frame.
  QString unfitNote() const;
  // The colour of the unfit frame's border and banner.
  static QColor UnfitColor();

  QSize sizeHint() const override;
  QSize minimumSizeHint() const override;

 public slots:
  void setFrame(int index, const QImage& image);
  // Forgets the frame and shows `message` instead ("Opening ...", "No recording").
  void showMessage(const QString& message);
  void setViewMode(autocal::VideoView::ViewMode mode);
  void setLayers(autocal::OverlayLayers layers);
  // The overlays of frame `overlays.index`; ignored for another frame than the one shown.
  void setOverlays(const autocal::FrameOverlays& overlays);
  void setRectifiedImage(int index, const QImage& image);

 protected:
  void paintEvent(QPaintEvent* event) override;

 private:
  // The area `pane` takes in the widget, before fitting the image into it.
  QRectF paneArea(Pane pane) const;
  void paintPane(QPainter* painter, Pane pane);
  // With layers on, what the view says over a frame the pipeline has no findings for.
  QString pipelineNote() const;
  // A note in a dark box at the top left of the frame, wrapped to its width.
  void paintNote(QPainter* painter, const QString& note, const QColor& background);

  int frame_index_ = -1;
  QImage image_;
  QPixmap pixmap_;  // image_ converted once, so repaints only scale.
  QImage rectified_;
  QPixmap rectified_pixmap_;
  QString message_;
  ViewMode view_mode_ = ViewMode::kRaw;
  OverlayLayers layers_;
  FrameOverlays overlays_;
  uint64_t paint_count_ = 0;
  uint64_t frames_painted_ = 0;
  int last_painted_index_ = -1;
};

}  // namespace autocal
