#include "devices/usb/accel_mapping.h"

#include <algorithm>
#include <array>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <opencv2/core.hpp>

#include "pipeline/error.h"

namespace autocal {
namespace {

class MappingReader {
 public:
  MappingReader(const cv::FileNode& root, std::string name) : root_(root), name_(std::move(name)) {}

  [[noreturn]] void Fail(const std::string& key, const std::string& what) const {
    throw Error(name_, 0, key + ": " + what);
  }

  // A 16-bit id written as a number or as hex text ("046d", "0x046d").
  uint16_t UsbId(const std::string& key) const {
    const cv::FileNode node = root_[key];
    long value = -1;
    if (node.isInt()) {
      value = static_cast<int>(node);
    } else if (node.isString()) {
      const std::string text = static_cast<std::string>(node);
      char* end = nullptr;
      value = std::strtol(text.c_str(), &end, 16);
      if (text.empty() || *end != '\0') value = -1;
    } else if (node.empty()) {
      Fail(key, "missing (the USB id, e.g. \"046d\")");
    }
    if (value < 0 || value > 0xffff) Fail(key, "expected a 16-bit USB id, e.g. \"046d\"");
    return static_cast<uint16_t>(value);
  }

  int Int(const cv::FileNode& node, const std::string& key, int fallback, int min, int max) const {
    if (node.empty()) return fallback;
    if (!node.isInt()) Fail(key, "expected an integer");
    const int value = static_cast<int>(node);
    if (value < min || value > max) {
      Fail(key, std::to_string(value) + " out of range " + std::to_string(min) + " to " +
                    std::to_string(max));
    }
    return value;
  }

  bool Bool(const cv::FileNode& node, const std::string& key, bool fallback) const {
    if (node.empty()) return fallback;
    if (node.isInt()) return static_cast<int>(node) != 0;
    const std::string text = node.isString() ? static_cast<std::string>(node) : "";
    if (text == "true" || text == "yes") return true;
    if (text == "false" || text == "no") return false;
    Fail(key, "expected true/false or 1/0");
  }

  std::array<int, 3> Triple(const std::string& key, std::array<int, 3> fallback) const {
    const cv::FileNode node = root_[key];
    if (node.empty()) return fallback;
    if (!node.isSeq() || node.size() != 3) Fail(key, "expected a list of 3 integers");
    std::array<int, 3> values;
    for (int i = 0; i < 3; ++i) {
      if (!node[i].isInt()) Fail(key, "expected a list of 3 integers");
      values[i] = static_cast<int>(node[i]);
    }
    return values;
  }

  const cv::FileNode& root() const { return root_; }

 private:
  cv::FileNode root_;
  std::string name_;
};

ReportField ReadField(const MappingReader& reader, const cv::FileNode& node, int index,
                      bool big_endian) {
  const std::string key = "fields[" + std::to_string(index) + "]";
  if (!node.isMap()) reader.Fail(key, "expected a map with byte, bits, signed, scale");
  ReportField field;
  const int byte = reader.Int(node["byte"], key + ".byte", -1, 0, 65535);
  if (byte < 0) reader.Fail(key + ".byte", "missing (offset of the field's first byte)");
  const int bit = reader.Int(node["bit"], key + ".bit", 0, 0, 7);
  field.bit_offset = 8 * byte + bit;
  field.bit_size = reader.Int(node["bits"], key + ".bits", 16, 1, 32);
  field.is_signed = reader.Bool(node["signed"], key + ".signed", true);
  field.big_endian = big_endian;
  if (big_endian && (bit != 0 || field.bit_size % 8 != 0)) {
    reader.Fail(key, "big-endian fields must start on a byte and span whole bytes");
  }
  const cv::FileNode scale = node["scale"];
  if (!scale.isReal() && !scale.isInt()) {
    reader.Fail(key + ".scale", "missing (m/s^2 per count, e.g. 0.0011978 for 1/8192 g)");
  }
  field.scale = static_cast<double>(scale);
  if (!(field.scale > 0.0))
    reader.Fail(key + ".scale", "must be positive (signs go in axis_signs)");
  return field;
}

}  // namespace

AccelMapping ParseAccelMapping(const std::string& text, const std::string& name) {
  const size_t start = text.find_first_not_of(" \t\r\n");
  const bool json = start != std::string::npos && text[start] == '{';
  // cv::FileStorage wants the %YAML header, which hand-written files often lack.
  const std::string contents = json || text.starts_with("%YAML") ? text : "%YAML:1.0\n" + text;
  cv::FileStorage storage;
  try {
    storage.open(contents,
                 cv::FileStorage::READ | cv::FileStorage::MEMORY |
                     (json ? cv::FileStorage::FORMAT_JSON : cv::FileStorage::FORMAT_YAML));
  } catch (const cv::Exception& e) {
    throw Error(name, 0,
                std::string("is not valid ") + (json ? "JSON" : "YAML") + " (" + e.err + ")");
  }
  if (!storage.isOpened() || !storage.root().isMap()) {
    throw Error(name, 0, "expected a map with vendor_id, product_id and fields");
  }
  const MappingReader reader(storage.root(), name);
  AccelMapping mapping;
  mapping.vendor_id = reader.UsbId("vendor_id");
  mapping.product_id = reader.UsbId("product_id");
  mapping.interface_number = reader.Int(reader.root()["interface"], "interface", -1, 0, 255);
  mapping.layout.report_id =
      static_cast<uint8_t>(reader.Int(reader.root()["report_id"], "report_id", 0, 0, 255));

  const cv::FileNode order_node = reader.root()["byte_order"];
  const std::string order = order_node.isString() ? static_cast<std::string>(order_node) : "";
  if (!order_node.empty() && order != "little" && order != "big") {
    reader.Fail("byte_order", "expected little or big");
  }
  const cv::FileNode fields_node = reader.root()["fields"];
  if (!fields_node.isSeq() || fields_node.size() != 3) {
    reader.Fail("fields", "expected a list of the 3 axis fields as the device sends them");
  }
  std::array<ReportField, 3> fields;
  for (int i = 0; i < 3; ++i) {
    fields[i] = ReadField(reader, fields_node[i], i, order == "big");
    if (mapping.layout.report_id != 0 && fields[i].bit_offset < 8) {
      reader.Fail("fields[" + std::to_string(i) + "].byte",
                  "byte 0 holds the report id; data starts at byte 1");
    }
  }

  const std::array<int, 3> axis_order = reader.Triple("axis_order", {0, 1, 2});
  std::array<int, 3> sorted = axis_order;
  std::sort(sorted.begin(), sorted.end());
  if (sorted != std::array<int, 3>{0, 1, 2}) {
    reader.Fail("axis_order", "expected a permutation of 0, 1, 2 (the field feeding x, y, z)");
  }
  const std::array<int, 3> axis_signs = reader.Triple("axis_signs", {1, 1, 1});
  for (int i = 0; i < 3; ++i) {
    if (axis_signs[i] != 1 && axis_signs[i] != -1) reader.Fail("axis_signs", "expected 1 or -1");
    mapping.layout.axes[i] = fields[axis_order[i]];
    mapping.layout.axes[i].scale *= axis_signs[i];
  }
  return mapping;
}

AccelMapping LoadAccelMapping(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, 0, "cannot be opened for reading");
  std::ostringstream text;
  text << in.rdbuf();
  return ParseAccelMapping(text.str(), path);
}

}  // namespace autocal
