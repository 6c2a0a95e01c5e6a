#include "widgets/sequence_opener.h"

#include <exception>

#include <QFile>
#include <QtConcurrent/QtConcurrentRun>

#include "devices/sequence.h"

namespace autocal {

SequenceOpener::SequenceOpener(QObject* parent) : QObject(parent) {
  connect(&watcher_, &QFutureWatcher<Result>::finished, this, &SequenceOpener::onFinished);
}

SequenceOpener::~SequenceOpener() { watcher_.waitForFinished(); }

void SequenceOpener::open(const QString& source) {
  watcher_.setFuture(QtConcurrent::run([source]() -> Result {
    Result result{source, nullptr, {}};
    try {
      result.sequence = OpenSequence(QFile::encodeName(source).toStdString());
      if (!result.sequence) result.error = QStringLiteral("%1: nothing to open").arg(source);
    } catch (const std::exception& e) {
      result.error = QString::fromStdString(e.what());
    }
    return result;
  }));
}

void SequenceOpener::onFinished() {
  const Result result = watcher_.result();
  if (result.sequence) {
    emit opened(result.source, result.sequence);
  } else {
    emit failed(result.source, result.error);
  }
}

}  // namespace autocal
