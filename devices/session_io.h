// session.json of a native recording (DESIGN.md section 4), read and written with
// cv::FileStorage. Numbers are written with 17 significant digits and read back exactly.
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "devices/sequence.h"

namespace autocal {

std::string SessionToJson(const SessionInfo& session);

// Parses session.json text; `source` names the file in errors. Throws Error for JSON that
// does not parse, a format_version other than SessionInfo::kFormatVersion, a missing or
// mistyped field, an invalid pre-mission calibration or a cam_from_accel that is not a
// rotation.
SessionInfo SessionFromJson(const std::string& json, const std::string& source);

SessionInfo ReadSessionFile(const std::string& path);
// Writes to a temporary name and renames, so that the file is never half written.
void WriteSessionFile(const std::string& path, const SessionInfo& session);

// Writes a text value into a JSON cv::FileStorage (an empty key inside a list). Unlike
// `fs << text`, text starting with '[' or '{' stays text. Throws Error for text that
// FileStorage cannot write so that it reads back: longer than 4096 bytes, or starting and
// ending with the same quote character.
void WriteJsonText(cv::FileStorage& fs, const std::string& key, const std::string& text);
// Writes {width, height, fx, fy, cx, cy, k1, k2, p1, p2, k3} under `key`.
void WriteJsonIntrinsics(cv::FileStorage& fs, const std::string& key, const CameraIntrinsics& c);

}  // namespace autocal
