// Where GUI tests save their screenshots: $AUTOCAL_SCREENSHOT_DIR (ctest sets it to
// build/screenshots), else the temporary folder.
#pragma once

#include <QDir>
#include <QString>

namespace autocal {

inline QString ScreenshotPath(const QString& name) {
  const QString dir = qEnvironmentVariable("AUTOCAL_SCREENSHOT_DIR", QDir::tempPath());
  QDir().mkpath(dir);
  return QDir(dir).filePath(name);
}

}  // namespace autocal
