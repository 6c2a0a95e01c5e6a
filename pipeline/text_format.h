// Text files: numbers and strings as they are written (the shortest decimal that reads back
// as the same double, JSON's number and string syntax), and files replaced whole.
#pragma once

#include <string>

namespace autocal {

// The shortest decimal that reads back as the same double ("0.1", "1e-05", "427").
std::string ShortestDecimal(double value);

// A JSON number; NaN and infinity, which JSON cannot hold, as null (as JavaScript's
// JSON.stringify writes them).
std::string JsonNumber(double value);

// Writes `contents` to a temporary file beside `path` and renames it into place, so that a
// killed process leaves either the old file or the whole new one. Throws Error naming the
// file when it cannot be written.
void WriteTextFile(const std::string& path, const std::string& contents);

// A JSON string literal, quoted and escaped; UTF-8 passes through.
std::string JsonString(const std::string& text);

}  // namespace autocal
