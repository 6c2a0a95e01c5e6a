// Draws the current video frame, scaled to fit with its aspect ratio kept.
#pragma once

#include <QImage>
#include <QPixmap>
#include <QRectF>
#include <QString>
#include <QTransform>
#include <QWidget>

namespace autocal {

class VideoView : public QWidget {
  Q_OBJECT

 public:
  explicit VideoView(QWidget* parent = nullptr);

  // Index of the frame on screen, -1 when none.
  int frameIndex() const { return frame_index_; }
  const QImage& image() const { return image_; }
  // Where the frame lies in widget coordinates (empty when there is none).
  QRectF imageRect() const;
  // Frame pixel coordinates, pixel centres at integers (DESIGN.md section 2), -> widget
  // coordinates; overlays draw through this.
  QTransform imageToWidget() const;

  QSize sizeHint() const override;
  QSize minimumSizeHint() const override;

 public slots:
  void setFrame(int index, const QImage& image);
  // Forgets the frame and shows `message` instead ("Opening ...", "No recording").
  void showMessage(const QString& message);

 protected:
  void paintEvent(QPaintEvent* event) override;

 private:
  int frame_index_ = -1;
  QImage image_;
  QPixmap pixmap_;  // image_ converted once, so repaints only scale.
  QString message_;
};

}  // namespace autocal
