// Opens recordings off the GUI thread: reading a long recording's index or building a
// simulated scene takes a moment, and the window stays responsive meanwhile.
#pragma once

#include <memory>

#include <QFutureWatcher>
#include <QObject>
#include <QString>

namespace autocal {

class Sequence;

class SequenceOpener : public QObject {
  Q_OBJECT

 public:
  explicit SequenceOpener(QObject* parent = nullptr);
  ~SequenceOpener() override;

  // Starts opening `source` (a path or "sim:SPEC", as OpenSequence takes it). A newer
  // call supersedes one still running: only the newest source reports back.
  void open(const QString& source);

 signals:
  void opened(const QString& source, std::shared_ptr<const autocal::Sequence> sequence);
  // `message` is the full error text (autocal::Error names the file and line).
  void failed(const QString& source, const QString& message);

 private:
  struct Result {
    QString source;
    std::shared_ptr<const Sequence> sequence;
    QString error;
  };

  void onFinished();

  QFutureWatcher<Result> watcher_;
};

}  // namespace autocal
