#include "widgets/plot_ticks.h"

#include <algorithm>
#include <cmath>

namespace autocal {

double NiceTickInterval(double span, int ticks) {
  const double raw = span / std::max(ticks, 1);
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  for (double step : {1.0, 2.0, 5.0}) {
    if (raw <= step * power) return step * power;
  }
  return 10.0 * power;
}

QString LabelFormat(double tick) {
  const int decimals = std::max(0, -static_cast<int>(std::floor(std::log10(tick) + 1e-9)));
  return QStringLiteral("%.%1f").arg(decimals);
}

}  // namespace autocal
