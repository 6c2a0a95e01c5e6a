#include "widgets/frame_loader.h"

#include <algorithm>
#include <exception>
#include <utility>

#include <QtConcurrent/QtConcurrentRun>

#include "devices/sequence.h"
#include "widgets/image_convert.h"

namespace autocal {
namespace {

int CostKiB(const QImage& image) {
  return static_cast<int>(std::max<qint64>(1, image.sizeInBytes() >> 10));
}

}  // namespace

FrameLoader::FrameLoader(QObject* parent) : QObject(parent) {
  cache_.setMaxCost(kCacheKiB);
  connect(&watcher_, &QFutureWatcher<Decoded>::finished, this, &FrameLoader::onDecoded);
}

// The decoding task holds its own reference to the sequence, so nothing it touches
// dies with the loader; waiting here only keeps shutdown orderly.
FrameLoader::~FrameLoader() { watcher_.waitForFinished(); }

void FrameLoader::setSequence(std::shared_ptr<const Sequence> sequence) {
  sequence_ = std::move(sequence);
  ++generation_;
  pending_.reset();
  cache_.clear();
}

void FrameLoader::request(int index) {
  if (!sequence_ || index < 0 || static_cast<size_t>(index) >= sequence_->frame_count()) return;
  if (const QImage* cached = cache_.object(index)) {
    pending_.reset();
    // The frame being decoded is older than this one: showing it afterwards would leave
    // the view on the wrong frame.
    if (busy_) in_flight_superseded_ = true;
    emit frameReady(index, *cached);
    return;
  }
  if (busy_) {
    pending_ = index;
    return;
  }
  start(index);
}

void FrameLoader::start(int index) {
  busy_ = true;
  in_flight_superseded_ = false;
  watcher_.setFuture(
      QtConcurrent::run([sequence = sequence_, generation = generation_, index]() -> Decoded {
        Decoded decoded{generation, index, {}, {}};
        try {
          decoded.image = MatToQImage(sequence->LoadFrame(static_cast<size_t>(index)));
          if (decoded.image.isNull()) {
            decoded.error = QStringLiteral("frame %1 is not an 8-bit image").arg(index);
          }
        } catch (const std::exception& e) {
          decoded.error = QString::fromStdString(e.what());
        }
        return decoded;
      }));
}

void FrameLoader::onDecoded() {
  busy_ = false;
  const Decoded decoded = watcher_.result();
  if (decoded.generation == generation_) {
    if (decoded.error.isEmpty()) {
      cache_.insert(decoded.index, new QImage(decoded.image), CostKiB(decoded.image));
      // Shown even when a newer request is pending: while scrubbing, each decoded frame
      // is the best picture there is until the wanted one arrives. Not when a newer one
      // was shown from the cache meanwhile.
      if (!in_flight_superseded_) emit frameReady(decoded.index, decoded.image);
    } else {
      emit frameFailed(decoded.index, decoded.error);
    }
  }
  if (pending_) {
    const int next = *pending_;
    pending_.reset();
    request(next);
  }
}

}  // namespace autocal
