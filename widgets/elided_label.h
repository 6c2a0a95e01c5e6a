// A one-line label that ends its text with "…" where the text does not fit, rather than
// cutting it off mid-word; its whole text stays text() (and goes in a tooltip by choice).
#pragma once

#include <QLabel>
#include <QString>

namespace autocal {

class ElidedLabel : public QLabel {
  Q_OBJECT

 public:
  explicit ElidedLabel(QWidget* parent = nullptr);

  // What is drawn at the label's present width.
  QString shownText() const;
  // Any width down to nothing: the text is elided instead.
  QSize minimumSizeHint() const override;

 protected:
  void paintEvent(QPaintEvent* event) override;
};

}  // namespace autocal
