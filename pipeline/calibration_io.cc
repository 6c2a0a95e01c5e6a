#include "pipeline/calibration_io.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string_view>
#include <utility>

#include <opencv2/core.hpp>

#include "pipeline/error.h"
#include "pipeline/text_format.h"

namespace autocal {
namespace {

struct NamedFormat {
  CalibrationFormat format;
  const char* name;
};
constexpr NamedFormat kFormats[] = {{CalibrationFormat::kOpenCv, "opencv"},
                                    {CalibrationFormat::kJson, "json"},
                                    {CalibrationFormat::kRos, "ros"},
                                    {CalibrationFormat::kKalibr, "kalibr"},
                                    {CalibrationFormat::kColmap, "colmap"}};

// ---- Text -------------------------------------------------------------------------------

std::string ReadText(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw Error(path, 0, "no such calibration file");
  std::ifstream in(path, std::ios::binary);
  if (!in.is_open()) throw Error(path, 0, "cannot open for reading");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw Error(path, 0, "cannot read");
  return text.str();
}

// The whole text is composed before the file is opened, so a refusal leaves no file behind.
void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  out.close();
  if (!out) throw Error(path, 0, "cannot write");
}

std::vector<std::string_view> SplitLines(std::string_view text) {
  std::vector<std::string_view> lines;
  while (!text.empty()) {
    const size_t end = text.find('\n');
    std::string_view line = text.substr(0, end);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    lines.push_back(line);
    if (end == std::string_view::npos) break;
    text.remove_prefix(end + 1);
  }
  return lines;
}

std::string_view Trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

bool IsDigit(char c) { return c >= '0' && c <= '9'; }

// Index of the first line that is neither blank nor a comment, or the line count.
size_t FirstContentLine(const std::vector<std::string_view>& lines) {
  size_t i = 0;
  while (i < lines.size() && (Trim(lines[i]).empty() || Trim(lines[i]).front() == '#')) ++i;
  return i;
}

std::string Joined(const std::vector<std::string>& words, const char* separator) {
  std::string joined;
  for (const std::string& w : words) joined += (joined.empty() ? "" : separator) + w;
  return joined;
}

// 1-based line of the first `key:` (YAML), `"key":` (JSON) or `<key>` (XML), or 0:
// cv::FileStorage keeps no line numbers, but errors should still point somewhere.
int LineOfKey(const std::string& text, std::string_view key) {
  const std::string yaml = std::string(key) + ":";
  const std::string json = "\"" + std::string(key) + "\"";
  const std::string xml = "<" + std::string(key);
  const std::vector<std::string_view> lines = SplitLines(text);
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string_view s = Trim(lines[i]);
    const size_t quoted = s.find(json);
    if (s.starts_with(yaml) ||
        (quoted != std::string_view::npos &&
         Trim(s.substr(quoted + json.size())).starts_with(':')) ||
        (s.starts_with(xml) && s.size() > xml.size() &&
         (s[xml.size()] == '>' || s[xml.size()] == ' '))) {
      return static_cast<int>(i) + 1;
    }
  }
  return 0;
}

// ---- Numbers ----------------------------------------------------------------------------

// ShortestDecimal() with a '.' in the mantissa: YAML 1.1 readers (PyYAML, under Kalibr and ROS's
// Python tools) take "1e-05" for a string and "427" for an integer.
std::string YamlNumber(double value) {
  std::string s = ShortestDecimal(value);
  if (s.find('.') == std::string::npos) s.insert(std::min(s.find('e'), s.size()), ".0");
  return s;
}

// A whole token as a number; a leading '+' is allowed (std::from_chars refuses it).
template <typename T>
std::optional<T> ParseNumber(std::string_view s) {
  if (s.size() > 1 && s.front() == '+' && s[1] != '-') s.remove_prefix(1);
  T value{};
  const auto result = std::from_chars(s.data(), s.data() + s.size(), value);
  if (result.ec != std::errc() || result.ptr != s.data() + s.size()) return std::nullopt;
  return value;
}

// Unsigned decimal digit strings.
bool LessThan(const std::string& a, const std::string& b) {
  return a.size() != b.size() ? a.size() < b.size() : a < b;
}

std::string Sum(std::string a, const std::string& b) {
  if (a.size() < b.size()) a.insert(0, b.size() - a.size(), '0');
  int carry = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const size_t ia = a.size() - 1 - i;
    const int d = (a[ia] - '0') + carry + (i < b.size() ? b[b.size() - 1 - i] - '0' : 0);
    a[ia] = static_cast<char>('0' + d % 10);
    carry = d / 10;
  }
  return carry ? "1" + a : a;
}

// a - b for a >= b.
std::string Difference(std::string a, const std::string& b) {
  int borrow = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const size_t ia = a.size() - 1 - i;
    int d = (a[ia] - '0') - borrow - (i < b.size() ? b[b.size() - 1 - i] - '0' : 0);
    borrow = d < 0;
    a[ia] = static_cast<char>('0' + d + 10 * borrow);
  }
  return a;
}

// `number` + 0.5 (or - 0.5 when !up), worked in decimal so that nothing is rounded. COLMAP
// puts pixel centres half a pixel away from OpenCV; done in binary, the shift can lose the last
// bit when it crosses a power of two (511.8 + 0.5), and cx would not read back exactly.
// Returns nothing for a token that is not a plain decimal number.
std::optional<std::string> ShiftedByHalf(std::string_view number, bool up) {
  size_t i = 0;
  const bool negative = !number.empty() && number[0] == '-';
  if (!number.empty() && (number[0] == '-' || number[0] == '+')) ++i;
  std::string digits;
  int scale = 0;  // The value is digits / 10^scale.
  bool point = false;
  for (; i < number.size(); ++i) {
    if (IsDigit(number[i])) {
      digits += number[i];
      scale += point;
    } else if (number[i] == '.' && !point) {
      point = true;
    } else {
      break;
    }
  }
  if (digits.empty()) return std::nullopt;
  digits.erase(0, digits.find_first_not_of('0'));  // The magnitude comparison below needs it.
  if (i < number.size()) {
    if (number[i] != 'e' && number[i] != 'E') return std::nullopt;
    const std::optional<int> exponent = ParseNumber<int>(number.substr(i + 1));
    if (!exponent || std::abs(*exponent) > 400) return std::nullopt;  // Beyond any double.
    scale -= *exponent;
  }
  if (scale < 1) {
    digits.append(1 - scale, '0');
    scale = 1;
  }
  const std::string half = "5" + std::string(scale - 1, '0');
  std::string magnitude;
  bool result_negative = negative;
  if (negative != up) {
    magnitude = Sum(digits, half);
  } else if (!LessThan(digits, half)) {
    magnitude = Difference(digits, half);
  } else {
    magnitude = Difference(half, digits);
    result_negative = !up;
  }
  if (magnitude.size() <= static_cast<size_t>(scale)) {
    magnitude.insert(0, scale + 1 - magnitude.size(), '0');
  }
  std::string integer = magnitude.substr(0, magnitude.size() - scale);
  std::string fraction = magnitude.substr(integer.size());
  integer.erase(0, std::min(integer.find_first_not_of('0'), integer.size() - 1));
  fraction.erase(fraction.find_last_not_of('0') + 1);
  const bool zero = integer == "0" && fraction.empty();
  return (result_negative && !zero ? "-" : "") + integer + (fraction.empty() ? "" : "." + fraction);
}

// ---- cv::FileStorage documents: OpenCV (YAML, XML, JSON), autocal JSON, ROS ------------------

// A file parsed by cv::FileStorage, with its text kept so that errors can name a line.
class Document {
 public:
  Document(const std::string& path, const std::string& text) : path_(path), text_(text) {
    // FileStorage insists on the %YAML directive that ROS files lack; one in front of the
    // text costs a line, taken back from the line numbers of its parse errors.
    const std::string_view start = Trim(text);
    const bool bare_yaml =
        !(start.substr(0, 5) == "%YAML" || start.substr(0, 1) == "{" || start.substr(0, 1) == "<");
    try {
      storage_.open(bare_yaml ? "%YAML:1.0\n" + text : text,
                    cv::FileStorage::READ | cv::FileStorage::MEMORY);
    } catch (const cv::Exception& e) {
      throw ParseError(e, bare_yaml ? 1 : 0);
    }
    if (!storage_.isOpened()) throw Error(path_, 0, "cannot parse as YAML, XML or JSON");
  }

  cv::FileNode operator[](const char* key) const { return storage_[key]; }

  // An error at the line of `key` (0 when it is missing).
  Error At(std::string_view key, const std::string& what) const {
    return Error(path_, LineOfKey(text_, key), what);
  }

  int Integer(const char* key) const {
    const cv::FileNode node = storage_[key];
    if (node.empty())
      throw At(key, std::string("missing field '") + key + "': expected an integer");
    if (!node.isInt()) throw At(key, std::string("expected an integer in field '") + key + "'");
    return static_cast<int>(node);
  }

  double Number(const char* key) const {
    const cv::FileNode node = storage_[key];
    if (node.empty()) throw At(key, std::string("missing field '") + key + "': expected a number");
    if (!node.isInt() && !node.isReal()) {
      throw At(key, std::string("expected a number in field '") + key + "'");
    }
    return static_cast<double>(node);
  }

  // A matrix as {rows, cols, data}: OpenCV's !!opencv-matrix (in YAML, XML or JSON) and
  // ROS's matrices share this layout. Row-major data.
  std::vector<double> Matrix(const char* key, int* rows, int* cols) const {
    const cv::FileNode node = storage_[key];
    const std::string layout = std::string("'") + key + "' as a matrix {rows, cols, data}";
    if (node.empty()) throw At(key, "missing field: expected " + layout);
    if (!node.isMap() || !node["rows"].isInt() || !node["cols"].isInt() || !node["data"].isSeq()) {
      throw At(key, "expected " + layout);
    }
    *rows = static_cast<int>(node["rows"]);
    *cols = static_cast<int>(node["cols"]);
    std::vector<double> data;
    for (const cv::FileNode& element : node["data"]) {
      if (!element.isInt() && !element.isReal())
        throw At(key, "expected numbers in the data of " + layout);
      data.push_back(static_cast<double>(element));
    }
    if (*rows < 0 || *cols < 0 || data.size() != static_cast<size_t>(*rows) * *cols) {
      throw At(key, std::string("'") + key + "' is " + std::to_string(*rows) + "x" +
                        std::to_string(*cols) + " but its data has " + std::to_string(data.size()) +
                        " numbers");
    }
    return data;
  }

 private:
  // OpenCV puts "(LINE): WHAT" at the end of the function field of its parse errors.
  Error ParseError(const cv::Exception& e, int lines_added) const {
    const std::string& where = e.func;
    size_t close = where.rfind("): ");
    while (close != std::string::npos) {
      size_t open = close;
      while (open > 0 && IsDigit(where[open - 1])) --open;
      if (open > 0 && open < close && where[open - 1] == '(') {
        const int line = std::stoi(where.substr(open, close - open)) - lines_added;
        return Error(path_, std::max(line, 0),
                     "not valid YAML, XML or JSON: " + where.substr(close + 3));
      }
      close = close == 0 ? std::string::npos : where.rfind("): ", close - 1);
    }
    return Error(path_, 0, "not valid YAML, XML or JSON: " + e.err);
  }

  const std::string& path_;
  const std::string& text_;
  cv::FileStorage storage_;
};

// OpenCV and ROS: camera_matrix and distortion_coefficients as matrices, the image size,
// and for ROS the distortion model's name.
CameraIntrinsics FromMatrices(const Document& doc, CalibrationFormat* format) {
  CameraIntrinsics camera;
  camera.width = doc.Integer("image_width");
  camera.height = doc.Integer("image_height");

  int rows = 0, cols = 0;
  const std::vector<double> k = doc.Matrix("camera_matrix", &rows, &cols);
  if (rows != 3 || cols != 3) {
    throw doc.At("camera_matrix", "expected a 3x3 'camera_matrix', found " + std::to_string(rows) +
                                      "x" + std::to_string(cols));
  }
  if (k[1] != 0 || k[3] != 0 || k[6] != 0 || k[7] != 0 || k[8] != 1) {
    throw doc.At("camera_matrix",
                 "expected 'camera_matrix' [fx 0 cx; 0 fy cy; 0 0 1] (the model has no skew)");
  }
  camera.fx = k[0];
  camera.cx = k[2];
  camera.fy = k[4];
  camera.cy = k[5];

  // ROS names its model; OpenCV's count of coefficients says which they are.
  const cv::FileNode model = doc["distortion_model"];
  const bool ros = !model.empty() || doc["camera_matrix"]["dt"].empty();
  std::vector<size_t> counts = {4, 5, 8, 12, 14};
  if (ros) {
    if (model.empty()) {
      throw doc.At(
          "distortion_model",
          "missing field 'distortion_model': expected plumb_bob in a ROS camera_info file");
    }
    const std::string name = model.isString() ? static_cast<std::string>(model) : "";
    if (name == "plumb_bob") {
      counts = {5};
    } else if (name == "rational_polynomial") {
      counts = {8};
    } else {
      throw doc.At("distortion_model",
                   "expected 'distortion_model' plumb_bob (or rational_polynomial with k4 = k5 = "
                   "k6 = 0), found '" +
                       name + "'");
    }
  }
  const std::vector<double> d = doc.Matrix("distortion_coefficients", &rows, &cols);
  if ((rows != 1 && cols != 1) ||
      std::find(counts.begin(), counts.end(), d.size()) == counts.end()) {
    std::string expected;
    for (size_t n : counts) expected += (expected.empty() ? "" : " or ") + std::to_string(n);
    throw doc.At("distortion_coefficients",
                 "expected " + expected +
                     " 'distortion_coefficients' in one row (k1 k2 p1 p2 k3 ...), found " +
                     std::to_string(rows) + "x" + std::to_string(cols));
  }
  for (size_t i = 5; i < d.size(); ++i) {
    if (d[i] != 0) {
      throw doc.At("distortion_coefficients",
                   "distortion coefficient " + std::to_string(i + 1) + " is " + ShortestDecimal(d[i]) +
                       ": the model stops at k3 (k1 k2 p1 p2 k3); rational and thin-prism "
                       "terms cannot be expressed");
    }
  }
  camera.k1 = d[0];
  camera.k2 = d[1];
  camera.p1 = d[2];
  camera.p2 = d[3];
  camera.k3 = d.size() > 4 ? d[4] : 0.0;
  *format = ros ? CalibrationFormat::kRos : CalibrationFormat::kOpenCv;
  return camera;
}

CameraIntrinsics FromAutocalJson(const Document& doc) {
  CameraIntrinsics camera;
  camera.width = doc.Integer("image_width");
  camera.height = doc.Integer("image_height");
  double* fields[] = {&camera.fx, &camera.fy, &camera.cx, &camera.cy, &camera.k1,
                      &camera.k2, &camera.p1, &camera.p2, &camera.k3};
  const char* names[] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"};
  for (int i = 0; i < kNumIntrinsics; ++i) *fields[i] = doc.Number(names[i]);
  return camera;
}

CameraIntrinsics ReadWithFileStorage(const std::string& path, const std::string& text,
                                     CalibrationFormat* format) {
  const Document doc(path, text);
  if (!doc["camera_matrix"].empty()) return FromMatrices(doc, format);
  if (!doc["fx"].empty()) {
    *format = CalibrationFormat::kJson;
    return FromAutocalJson(doc);
  }
  throw Error(path, 0,
              "expected a calibration: OpenCV (camera_matrix, distortion_coefficients), ROS "
              "camera_info (camera_matrix, distortion_model), autocal JSON (fx, fy, cx, cy, "
              "k1, k2, p1, p2, k3), a Kalibr camchain (cam0:) or COLMAP cameras.txt");
}

// ---- Kalibr ------------------------------------------------------------------------------

// cv::FileStorage cannot parse Kalibr's files (PyYAML puts the rows of T_cam_imu at their
// key's indentation), so the camchain is read line by line: "camN:" opens a camera, its
// "key: value" lines follow, a flow list may wrap over several lines.
struct KalibrField {
  std::string value;
  int line = 0;
};

// The name and value of "name: value", or nothing.
std::optional<std::pair<std::string, std::string>> SplitKey(std::string_view s) {
  const size_t colon = s.find(':');
  if (colon == std::string_view::npos || colon == 0) return std::nullopt;
  if (colon + 1 < s.size() && s[colon + 1] != ' ') return std::nullopt;
  return std::make_pair(std::string(Trim(s.substr(0, colon))),
                        std::string(Trim(s.substr(colon + 1))));
}

std::string_view WithoutComment(std::string_view line) {
  for (size_t i = 0; i < line.size(); ++i) {
    if (line[i] == '#' && (i == 0 || line[i - 1] == ' ')) return line.substr(0, i);
  }
  return line;
}

bool IsKalibrCamera(std::string_view line) {
  if (line.substr(0, 3) != "cam" || line.size() < 5 || line.back() != ':') return false;
  const std::string_view number = line.substr(3, line.size() - 4);
  return std::all_of(number.begin(), number.end(), IsDigit);
}

std::string Unquoted(std::string value) {
  if (value.size() >= 2 && (value.front() == '\'' || value.front() == '"') &&
      value.back() == value.front()) {
    return value.substr(1, value.size() - 2);
  }
  return value;
}

std::vector<double> KalibrList(const std::string& path, const std::string& key,
                               const KalibrField& field, size_t count) {
  const std::string expected =
      "expected '" + key + "' as a list of " + std::to_string(count) + " numbers [a, b, ...]";
  std::string_view s = Trim(field.value);
  if (s.size() < 2 || s.front() != '[' || s.back() != ']') throw Error(path, field.line, expected);
  s = Trim(s.substr(1, s.size() - 2));
  std::vector<double> values;
  while (!s.empty()) {
    const size_t comma = std::min(s.find(','), s.size());
    const std::optional<double> value = ParseNumber<double>(Trim(s.substr(0, comma)));
    if (!value) throw Error(path, field.line, expected + ", found '" + field.value + "'");
    values.push_back(*value);
    s.remove_prefix(std::min(comma + 1, s.size()));
  }
  if (values.size() != count) {
    throw Error(path, field.line, expected + ", found " + std::to_string(values.size()));
  }
  return values;
}

CameraIntrinsics ReadKalibr(const std::string& path, const std::string& text) {
  const std::vector<std::string_view> lines = SplitLines(text);
  std::vector<std::pair<std::string, int>> cameras;
  std::map<std::string, KalibrField> fields;  // Of the first camera.
  size_t key_indent = 0;
  bool in_first_camera = false;
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string_view content = WithoutComment(lines[i]);
    const std::string_view trimmed = Trim(content);
    if (trimmed.empty()) continue;
    const int line = static_cast<int>(i) + 1;
    const size_t indent = content.find_first_not_of(' ');
    if (indent == 0) {
      const bool camera = IsKalibrCamera(trimmed);
      if (camera) cameras.emplace_back(std::string(trimmed.substr(0, trimmed.size() - 1)), line);
      in_first_camera = camera && cameras.size() == 1;
      continue;
    }
    if (!in_first_camera || trimmed.front() == '-') continue;  // '-': rows of T_cam_imu etc.
    if (key_indent == 0) key_indent = indent;
    if (indent != key_indent) continue;  // Deeper: inside a nested value.
    const auto key_value = SplitKey(trimmed);
    if (!key_value) throw Error(path, line, "expected 'key: value' in " + cameras[0].first);
    KalibrField field{key_value->second, line};
    while (!field.value.empty() && field.value.front() == '[' &&
           field.value.find(']') == std::string::npos && i + 1 < lines.size()) {
      field.value += " " + std::string(Trim(WithoutComment(lines[++i])));
    }
    fields[key_value->first] = field;
  }
  if (cameras.size() > 1) {
    throw Error(path, cameras[1].second,
                "a second camera '" + cameras[1].first +
                    "': expected a camchain with one camera (keep the one to calibrate)");
  }
  const auto field = [&](const std::string& key) -> const KalibrField& {
    const auto found = fields.find(key);
    if (found == fields.end()) {
      throw Error(path, cameras[0].second,
                  "'" + cameras[0].first + "' has no '" + key +
                      "' (expected camera_model, intrinsics, distortion_model, "
                      "distortion_coeffs, resolution)");
    }
    return found->second;
  };

  const KalibrField& model = field("camera_model");
  if (Unquoted(model.value) != "pinhole") {
    throw Error(path, model.line, "expected camera_model pinhole, found '" + model.value + "'");
  }
  const std::vector<double> intrinsics = KalibrList(path, "intrinsics", field("intrinsics"), 4);
  const KalibrField& distortion = field("distortion_model");
  const std::string distortion_name = Unquoted(distortion.value);
  if (distortion_name != "radtan" && distortion_name != "none") {
    throw Error(path, distortion.line,
                "expected distortion_model radtan or none, found '" + distortion.value + "'");
  }
  const std::vector<double> coeffs =
      distortion_name == "none" && !fields.count("distortion_coeffs")
          ? std::vector<double>{}
          : KalibrList(path, "distortion_coeffs", field("distortion_coeffs"),
                       distortion_name == "radtan" ? 4 : 0);
  const KalibrField& resolution = field("resolution");
  const std::vector<double> size = KalibrList(path, "resolution", resolution, 2);
  const auto is_size = [](double v) { return v >= 0 && v <= 1e9 && v == std::floor(v); };
  if (!is_size(size[0]) || !is_size(size[1])) {
    throw Error(path, resolution.line, "expected 'resolution' as two integers [width, height]");
  }

  CameraIntrinsics camera;
  camera.width = static_cast<int>(size[0]);
  camera.height = static_cast<int>(size[1]);
  camera.fx = intrinsics[0];
  camera.fy = intrinsics[1];
  camera.cx = intrinsics[2];
  camera.cy = intrinsics[3];
  if (!coeffs.empty()) {
    camera.k1 = coeffs[0];
    camera.k2 = coeffs[1];
    camera.p1 = coeffs[2];
    camera.p2 = coeffs[3];
  }
  return camera;
}

// ---- COLMAP ------------------------------------------------------------------------------

// The models of COLMAP that the pinhole + Brown-Conrady model holds, with their parameters
// in COLMAP's order. "f" sets fx and fy, "k" sets k1; k4-k6 must be zero.
struct ColmapModel {
  const char* name;
  std::vector<std::string> params;
};
const std::vector<ColmapModel>& ColmapModels() {
  static const std::vector<ColmapModel> models = {
      {"SIMPLE_PINHOLE", {"f", "cx", "cy"}},
      {"PINHOLE", {"fx", "fy", "cx", "cy"}},
      {"SIMPLE_RADIAL", {"f", "cx", "cy", "k"}},
      {"RADIAL", {"f", "cx", "cy", "k1", "k2"}},
      {"OPENCV", {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"}},
      {"FULL_OPENCV", {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"}},
  };
  return models;
}

// The fields a COLMAP parameter sets; none for k4-k6.
std::vector<double*> ColmapTargets(CameraIntrinsics* c, const std::string& name) {
  if (name == "f") return {&c->fx, &c->fy};
  if (name == "k") return {&c->k1};
  const char* names[] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"};
  double* fields[] = {&c->fx, &c->fy, &c->cx, &c->cy, &c->k1, &c->k2, &c->p1, &c->p2, &c->k3};
  for (int i = 0; i < kNumIntrinsics; ++i) {
    if (name == names[i]) return {fields[i]};
  }
  return {};
}

CameraIntrinsics ReadColmap(const std::string& path, const std::string& text) {
  const std::vector<std::string_view> lines = SplitLines(text);
  const size_t first = FirstContentLine(lines);
  const int line = static_cast<int>(first) + 1;
  for (size_t i = first + 1; i < lines.size(); ++i) {
    const std::string_view s = Trim(lines[i]);
    if (!s.empty() && s.front() != '#') {
      throw Error(path, static_cast<int>(i) + 1,
                  "a second camera: expected cameras.txt with one camera (keep the one to "
                  "calibrate)");
    }
  }
  std::vector<std::string> tokens;
  std::istringstream words{std::string(lines[first])};
  for (std::string word; words >> word;) tokens.push_back(word);
  if (tokens.size() < 4) {
    throw Error(path, line, "expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]");
  }
  const auto model = std::find_if(ColmapModels().begin(), ColmapModels().end(),
                                  [&](const ColmapModel& m) { return tokens[1] == m.name; });
  if (model == ColmapModels().end()) {
    std::vector<std::string> names;
    for (const ColmapModel& m : ColmapModels()) names.push_back(m.name);
    throw Error(
        path, line,
        "camera model '" + tokens[1] + "' cannot be expressed; expected " + Joined(names, ", "));
  }
  const size_t found = tokens.size() - 4;
  if (found != model->params.size()) {
    throw Error(path, line,
                "camera model " + tokens[1] + " takes " + std::to_string(model->params.size()) +
                    " parameters (" + Joined(model->params, ", ") + "), found " +
                    std::to_string(found));
  }
  CameraIntrinsics camera;
  const std::optional<int> width = ParseNumber<int>(tokens[2]);
  const std::optional<int> height = ParseNumber<int>(tokens[3]);
  if (!width || !height) throw Error(path, line, "expected WIDTH and HEIGHT as integers");
  camera.width = *width;
  camera.height = *height;
  for (size_t i = 0; i < found; ++i) {
    const std::string& name = model->params[i];
    const std::string& token = tokens[4 + i];
    const bool centre = name == "cx" || name == "cy";
    // COLMAP's top-left pixel centre is (0.5, 0.5), OpenCV's (0, 0).
    const std::optional<std::string> shifted = centre ? ShiftedByHalf(token, false) : token;
    const std::optional<double> value = shifted ? ParseNumber<double>(*shifted) : std::nullopt;
    if (!value)
      throw Error(path, line, "parameter " + name + ": expected a number, found '" + token + "'");
    const std::vector<double*> targets = ColmapTargets(&camera, name);
    for (double* field : targets) *field = *value;
    if (targets.empty() && *value != 0) {
      throw Error(
          path, line,
          name + " = " + token + ": the model stops at k3 (k4, k5, k6 cannot be expressed)");
    }
  }
  return camera;
}

// ---- Writers -----------------------------------------------------------------------------

void WriteWithFileStorage(const std::string& path, const CameraIntrinsics& camera,
                          CalibrationFormat format) {
  const int mode =
      cv::FileStorage::WRITE | (format == CalibrationFormat::kJson ? cv::FileStorage::FORMAT_JSON
                                                                   : cv::FileStorage::FORMAT_YAML);
  cv::FileStorage file;
  try {
    file.open(path, mode);
  } catch (const cv::Exception& e) {
    throw Error(path, 0, "cannot write: " + e.msg);
  }
  if (!file.isOpened()) throw Error(path, 0, "cannot write");
  file << "image_width" << camera.width << "image_height" << camera.height;
  if (format == CalibrationFormat::kOpenCv) {
    const cv::Mat k =
        (cv::Mat_<double>(3, 3) << camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
    const cv::Mat d =
        (cv::Mat_<double>(1, 5) << camera.k1, camera.k2, camera.p1, camera.p2, camera.k3);
    file << "camera_matrix" << k << "distortion_coefficients" << d;
  } else {
    file << "fx" << camera.fx << "fy" << camera.fy << "cx" << camera.cx << "cy" << camera.cy << "k1"
         << camera.k1 << "k2" << camera.k2 << "p1" << camera.p1 << "p2" << camera.p2 << "k3"
         << camera.k3;
  }
  file.release();
}

std::string YamlList(std::initializer_list<double> values) {
  std::string list;
  for (double v : values) list += (list.empty() ? "" : ", ") + YamlNumber(v);
  return "[" + list + "]";
}

std::string YamlMatrix(const char* name, int rows, int cols, std::initializer_list<double> data) {
  return std::string(name) + ":\n  rows: " + std::to_string(rows) +
         "\n  cols: " + std::to_string(cols) + "\n  data: " + YamlList(data) + "\n";
}

// ROS names a camera after its calibration file (camera_info_manager's
// ${ROS_HOME}/camera_info/NAME.yaml) and allows letters, digits and '_'.
std::string RosCameraName(const std::string& path) {
  std::string name = std::filesystem::path(path).stem().string();
  for (char& c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  }
  return name.empty() ? "camera" : name;
}

std::string RosText(const CameraIntrinsics& c, const std::string& name) {
  return "image_width: " + std::to_string(c.width) + "\nimage_height: " + std::to_string(c.height) +
         "\ncamera_name: " + name + "\n" +
         YamlMatrix("camera_matrix", 3, 3, {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1}) +
         "distortion_model: plumb_bob\n" +
         YamlMatrix("distortion_coefficients", 1, 5, {c.k1, c.k2, c.p1, c.p2, c.k3}) +
         YamlMatrix("rectification_matrix", 3, 3, {1, 0, 0, 0, 1, 0, 0, 0, 1}) +
         YamlMatrix("projection_matrix", 3, 4, {c.fx, 0, c.cx, 0, 0, c.fy, c.cy, 0, 0, 0, 1, 0});
}

std::string KalibrText(const std::string& path, const CameraIntrinsics& c) {
  if (c.k3 != 0) {
    throw Error(path, 0,
                "k3 = " + ShortestDecimal(c.k3) +
                    " cannot be expressed: Kalibr's radtan model has 4 coefficients "
                    "(k1, k2, r1, r2); write another format or estimate without k3");
  }
  return "cam0:\n  camera_model: pinhole\n  intrinsics: " + YamlList({c.fx, c.fy, c.cx, c.cy}) +
         "\n  distortion_model: radtan\n  distortion_coeffs: " +
         YamlList({c.k1, c.k2, c.p1, c.p2}) + "\n  resolution: [" + std::to_string(c.width) + ", " +
         std::to_string(c.height) + "]\n";
}

std::string ColmapText(const CameraIntrinsics& c) {
  const bool full = c.k3 != 0;
  std::string line =
      std::string("1 ") + (full ? "FULL_OPENCV " : "OPENCV ") + std::to_string(c.width) + " " +
      std::to_string(c.height) + " " + ShortestDecimal(c.fx) + " " + ShortestDecimal(c.fy) + " " +
      *ShiftedByHalf(ShortestDecimal(c.cx), true) + " " + *ShiftedByHalf(ShortestDecimal(c.cy), true);
  for (double d : {c.k1, c.k2, c.p1, c.p2}) line += " " + ShortestDecimal(d);
  if (full) line += " " + ShortestDecimal(c.k3) + " 0 0 0";
  return "# Camera list with one line of data per camera:\n"
         "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
         "# Number of cameras: 1\n" +
         line + "\n";
}

}  // namespace

CalibrationFormat CalibrationFormatFromName(const std::string& name) {
  for (const NamedFormat& f : kFormats) {
    if (name == f.name) return f.format;
  }
  throw Error("unknown calibration format '" + name +
              "'; known: " + Joined(CalibrationFormatNames(), ", "));
}

std::vector<std::string> CalibrationFormatNames() {
  std::vector<std::string> names;
  for (const NamedFormat& f : kFormats) names.push_back(f.name);
  return names;
}

CameraIntrinsics ReadCalibration(const std::string& path, CalibrationFormat* format) {
  const std::string text = ReadText(path);
  const std::vector<std::string_view> lines = SplitLines(text);
  const size_t first = FirstContentLine(lines);
  if (first == lines.size()) throw Error(path, 0, "empty: expected a calibration");
  const std::string_view start = Trim(WithoutComment(lines[first]));
  CalibrationFormat found = CalibrationFormat::kColmap;
  CameraIntrinsics camera;
  if (IsDigit(start.front())) {
    camera = ReadColmap(path, text);
  } else if (IsKalibrCamera(start)) {
    found = CalibrationFormat::kKalibr;
    camera = ReadKalibr(path, text);
  } else {
    camera = ReadWithFileStorage(path, text, &found);
  }
  std::string why;
  if (!camera.Check(&why)) throw Error(path, 0, why);
  if (format) *format = found;
  return camera;
}

void WriteCalibration(const std::string& path, const CameraIntrinsics& camera,
                      CalibrationFormat format) {
  std::string why;
  if (!camera.Check(&why)) throw Error(path, 0, "cannot write an invalid calibration: " + why);
  switch (format) {
    case CalibrationFormat::kOpenCv:
    case CalibrationFormat::kJson:
      WriteWithFileStorage(path, camera, format);
      break;
    case CalibrationFormat::kRos:
      WriteText(path, RosText(camera, RosCameraName(path)));
      break;
    case CalibrationFormat::kKalibr:
      WriteText(path, KalibrText(path, camera));
      break;
    case CalibrationFormat::kColmap:
      WriteText(path, ColmapText(camera));
      break;
  }
}

}  // namespace autocal
