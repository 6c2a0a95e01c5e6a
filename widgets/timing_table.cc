#include "widgets/timing_table.h"

#include <array>
#include <utility>

#include <QHeaderView>
#include <QLabel>
#include <QTableWidget>
#include <QVBoxLayout>

namespace autocal {
namespace {

// Box order, with what each name stands for.
const std::array<std::pair<const char*, const char*>, 12> kRows = {{
    {"frame", "Frame: boxes 1-9 and the judgement, on the frame's own threads"},
    {"lines", "1  Lines and snakes"},
    {"distortion",
     "2  Distortion from the plumb lines (a worker, every 30 frames until one is accepted)"},
    {"rectify", "3  Green channel, equalized; image measures"},
    {"features", "4  Corners"},
    {"flow", "5  Optical flow"},
    {"planes", "6  Dominant planes"},
    {"refind", "6  Lost planes re-found by their keypoints"},
    {"inertial", "7  Accelerometer"},
    {"material", "9  Window and material"},
    {"calibration", "10  Calibration solve (a worker, per attempt)"},
    {"history", "8  Judgement and virtual boards (per attempt)"},
}};

}  // namespace

TimingTable::TimingTable(QWidget* parent)
    : QWidget(parent), caption_(new QLabel), table_(new QTableWidget(0, kNumColumns)) {
  caption_->setObjectName(QStringLiteral("timing_caption"));
  caption_->setWordWrap(true);
  table_->setObjectName(QStringLiteral("timing_table"));
  table_->setHorizontalHeaderLabels({tr("Box"), tr("Median ms"), tr("95% ms"), tr("Frames")});
  table_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  table_->setSelectionMode(QAbstractItemView::NoSelection);
  table_->verticalHeader()->hide();
  // One line a row, so that a short dock shows most of them.
  table_->verticalHeader()->setDefaultSectionSize(table_->fontMetrics().height() + 6);
  table_->horizontalHeader()->setSectionResizeMode(kBox, QHeaderView::Stretch);
  for (int column = kMedian; column < kNumColumns; ++column) {
    table_->horizontalHeader()->setSectionResizeMode(column, QHeaderView::ResizeToContents);
  }
  auto* layout = new QVBoxLayout(this);
  layout->setContentsMargins(4, 4, 4, 4);
  layout->addWidget(caption_);
  layout->addWidget(table_, 1);
  setStats({}, QString());
}

void TimingTable::setStats(const std::map<std::string, TimingStats>& stats, const QString& source) {
  const auto frame = stats.find("frame");
  caption_->setText(frame == stats.end()
                        ? tr("No frame processed yet.")
                        : tr("Time per frame over %1 frames of %2: median and 95th percentile, "
                             "wall clock. The boxes run on two threads and two workers, so the "
                             "frame rate is set by the busier thread, not by the sum.")
                              .arg(frame->second.count)
                              .arg(source));
  table_->setRowCount(0);
  for (const auto& [name, description] : kRows) {
    const auto found = stats.find(name);
    if (found == stats.end()) continue;
    const int row = table_->rowCount();
    table_->insertRow(row);
    auto* box = new QTableWidgetItem(tr(description));
    box->setData(Qt::UserRole, QString::fromLatin1(name));
    table_->setItem(row, kBox, box);
    const auto number = [](double value, int decimals) {
      auto* item = new QTableWidgetItem(QString::number(value, 'f', decimals));
      item->setTextAlignment(Qt::AlignRight | Qt::AlignVCenter);
      return item;
    };
    table_->setItem(row, kMedian, number(found->second.median_ms, 2));
    table_->setItem(row, kP95, number(found->second.p95_ms, 2));
    table_->setItem(row, kFrames, number(found->second.count, 0));
  }
}

}  // namespace autocal
