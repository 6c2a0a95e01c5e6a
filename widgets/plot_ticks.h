// Axis ticks on round numbers, shared by the workbench's plots.
#pragma once

#include <QString>

namespace autocal {

// A tick interval of 1, 2 or 5 times a power of ten giving about `ticks` ticks over `span`.
double NiceTickInterval(double span, int ticks);

// A printf format with just enough decimals for ticks `tick` apart.
QString LabelFormat(double tick);

}  // namespace autocal
