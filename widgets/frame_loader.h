// Decodes frames off the GUI thread so that playing and seeking never block the UI.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>

#include <QCache>
#include <QFutureWatcher>
#include <QImage>
#include <QObject>
#include <QString>

namespace autocal {

class Sequence;

class FrameLoader : public QObject {
  Q_OBJECT

 public:
  // Decoded frames kept for instant seeking back and forth: about 140 VGA frames.
  static constexpr int kCacheKiB = 128 << 10;

  explicit FrameLoader(QObject* parent = nullptr);
  ~FrameLoader() override;

  // Switches to another sequence (or none); forgets cached frames and requests in flight.
  void setSequence(std::shared_ptr<const Sequence> sequence);

 public slots:
  // Asks for frame `index`: frameReady follows, at once when the frame is cached. Only
  // one frame is decoded at a time; a request that has not started yet is replaced by
  // the next one, so fast seeking decodes only the frames still wanted.
  void request(int index);

 signals:
  void frameReady(int index, const QImage& image);
  void frameFailed(int index, const QString& message);

 private:
  struct Decoded {
    uint64_t generation = 0;
    int index = -1;
    QImage image;
    QString error;
  };

  void start(int index);
  void onDecoded();

  std::shared_ptr<const Sequence> sequence_;
  uint64_t generation_ = 0;  // Bumped by setSequence; stale results are dropped.
  QFutureWatcher<Decoded> watcher_;
  bool busy_ = false;
  bool in_flight_superseded_ = false;  // A newer request was answered from the cache.
  std::optional<int> pending_;
  QCache<int, QImage> cache_;  // Least recently used first out; cost in KiB.
};

}  // namespace autocal
