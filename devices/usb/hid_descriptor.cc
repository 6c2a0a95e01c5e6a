#include "devices/usb/hid_descriptor.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "pipeline/error.h"

namespace autocal {
namespace {

// Item types and tags (HID 1.11, 6.2.2.4-6.2.2.8).
enum ItemType { kMain = 0, kGlobal = 1, kLocal = 2 };
enum MainTag { kInput = 8, kOutput = 9, kCollection = 10, kFeature = 11, kEndCollection = 12 };
enum GlobalTag {
  kUsagePage = 0,
  kLogicalMinimum = 1,
  kLogicalMaximum = 2,
  kUnitExponent = 5,
  kUnit = 6,
  kReportSize = 7,
  kReportId = 8,
  kReportCount = 9,
  kPush = 10,
  kPop = 11,
};
enum LocalTag { kUsage = 0, kUsageMinimum = 1, kUsageMaximum = 2 };
constexpr uint8_t kLongItemPrefix = 0xfe;
constexpr int64_t kMaxReportBits = 8 * 65536;

std::string HexString(uint32_t value, int digits) {
  char text[16];
  std::snprintf(text, sizeof(text), "0x%0*x", digits, value);
  return text;
}

Error Malformed(size_t offset, const std::string& what) {
  return Error("HID report descriptor, byte " + std::to_string(offset) + ": " + what);
}

struct GlobalState {
  uint32_t usage_page = 0;
  int32_t logical_minimum = 0;
  int32_t logical_maximum = 0;
  uint32_t unit = 0;
  int unit_exponent = 0;
  uint32_t report_size = 0;
  uint8_t report_id = 0;
  uint32_t report_count = 0;
};

// A usage as written: 4-byte usages carry their page, shorter ones take the usage page
// in effect at the main item (HID 1.11, 6.2.2.8).
struct LocalUsage {
  uint32_t value = 0;
  bool has_page = false;
  uint32_t Resolve(uint32_t usage_page) const {
    return has_page ? value : (usage_page << 16) | value;
  }
};

struct LocalState {
  std::vector<LocalUsage> usages;
  std::optional<LocalUsage> minimum;
  std::optional<LocalUsage> maximum;

  // The usage of the index-th value of a main item: listed usages first, then the
  // usage range; the last one repeats for the remaining values.
  uint32_t UsageFor(uint32_t index, uint32_t usage_page) const {
    if (index < usages.size()) return usages[index].Resolve(usage_page);
    if (minimum && maximum) {
      const uint32_t first = minimum->Resolve(usage_page);
      const uint32_t last = maximum->Resolve(usage_page);
      const uint32_t in_range = index - static_cast<uint32_t>(usages.size());
      return last >= first && in_range <= last - first ? first + in_range : last;
    }
    return usages.empty() ? 0 : usages.back().Resolve(usage_page);
  }
};

struct OpenCollection {
  uint32_t usage = 0;
  size_t offset = 0;
};

// Power of ten of a Unit Exponent item: a 4-bit two's complement nibble in one byte
// (HID 1.11, 6.2.2.7), though some devices write a whole signed byte or more.
int DecodeUnitExponent(int size, uint32_t unsigned_value, int32_t signed_value) {
  if (size == 1 && unsigned_value <= 0x0f) {
    return unsigned_value >= 8 ? static_cast<int>(unsigned_value) - 16
                               : static_cast<int>(unsigned_value);
  }
  return signed_value;
}

uint64_t ExtractBits(std::span<const uint8_t> report, const ReportField& field) {
  uint64_t raw = 0;
  if (field.big_endian) {
    for (int i = 0; i < field.bit_size / 8; ++i)
      raw = (raw << 8) | report[field.bit_offset / 8 + i];
    return raw;
  }
  for (int i = 0; i < field.bit_size; ++i) {
    const int bit = field.bit_offset + i;
    if ((report[bit >> 3] >> (bit & 7)) & 1) raw |= uint64_t{1} << i;
  }
  return raw;
}

}  // namespace

HidReportDescriptor ParseHidReportDescriptor(std::span<const uint8_t> descriptor) {
  HidReportDescriptor result;
  GlobalState global;
  std::vector<GlobalState> global_stack;
  LocalState local;
  std::vector<OpenCollection> collections;
  std::map<uint8_t, int64_t> input_bits;

  size_t pos = 0;
  while (pos < descriptor.size()) {
    const size_t item_offset = pos;
    const uint8_t prefix = descriptor[pos];
    if (prefix == kLongItemPrefix) {
      // Long items are reserved for future use and carry nothing we need: skip them.
      if (pos + 3 > descriptor.size() || pos + 3 + descriptor[pos + 1] > descriptor.size()) {
        throw Malformed(item_offset, "long item truncated");
      }
      pos += 3 + descriptor[pos + 1];
      continue;
    }
    const int size = (prefix & 3) == 3 ? 4 : (prefix & 3);
    if (pos + 1 + size > descriptor.size()) {
      throw Malformed(item_offset, "item " + HexString(prefix, 2) + " needs " +
                                       std::to_string(size) + " data bytes, only " +
                                       std::to_string(descriptor.size() - pos - 1) +
                                       " left (truncated descriptor)");
    }
    uint32_t value = 0;
    for (int i = 0; i < size; ++i) value |= uint32_t{descriptor[pos + 1 + i]} << (8 * i);
    int32_t signed_value = static_cast<int32_t>(value);
    if (size > 0 && size < 4 && (value >> (8 * size - 1)) & 1) {
      signed_value = static_cast<int32_t>(value | (~uint32_t{0} << (8 * size)));
    }
    pos += 1 + size;
    const int type = (prefix >> 2) & 3;
    const int tag = prefix >> 4;

    if (type == kGlobal) {
      switch (tag) {
        case kUsagePage:
          global.usage_page = value & 0xffff;
          break;
        case kLogicalMinimum:
          global.logical_minimum = signed_value;
          break;
        case kLogicalMaximum:
          global.logical_maximum = signed_value;
          break;
        case kUnitExponent:
          global.unit_exponent = DecodeUnitExponent(size, value, signed_value);
          break;
        case kUnit:
          global.unit = value;
          break;
        case kReportSize:
          global.report_size = value;
          break;
        case kReportId:
          if (value == 0 || value > 255) {
            throw Malformed(item_offset,
                            "report id " + std::to_string(value) + " (must be 1 to 255)");
          }
          global.report_id = static_cast<uint8_t>(value);
          result.uses_report_ids = true;
          break;
        case kReportCount:
          global.report_count = value;
          break;
        case kPush:
          global_stack.push_back(global);
          break;
        case kPop:
          if (global_stack.empty()) throw Malformed(item_offset, "Pop without a Push");
          global = global_stack.back();
          global_stack.pop_back();
          break;
        default:
          break;  // Physical extent and reserved tags: not needed.
      }
      continue;
    }
    if (type == kLocal) {
      const LocalUsage usage{value, size == 4};
      switch (tag) {
        case kUsage:
          local.usages.push_back(usage);
          break;
        case kUsageMinimum:
          local.minimum = usage;
          break;
        case kUsageMaximum:
          local.maximum = usage;
          break;
        default:
          break;  // Designators, strings, delimiters.
      }
      continue;
    }
    if (type != kMain)
      throw Malformed(item_offset, "reserved item type in " + HexString(prefix, 2));

    switch (tag) {
      case kInput: {
        const int64_t bits = int64_t{global.report_size} * global.report_count;
        int64_t& offset = input_bits[global.report_id];
        if (offset + bits > kMaxReportBits) {
          throw Malformed(item_offset, "input report " + std::to_string(global.report_id) +
                                           " longer than 64 KiB");
        }
        const bool constant = value & 1;
        const bool variable = value & 2;
        if (!constant) {
          std::vector<uint32_t> enclosing;
          for (const OpenCollection& c : collections) enclosing.push_back(c.usage);
          for (uint32_t i = 0; i < global.report_count && global.report_size > 0; ++i) {
            HidInputField field;
            field.report_id = global.report_id;
            field.usage = variable ? local.UsageFor(i, global.usage_page) : 0;
            field.bit_offset = static_cast<int>(offset + int64_t{i} * global.report_size);
            field.bit_size = static_cast<int>(global.report_size);
            field.is_variable = variable;
            field.logical_minimum = global.logical_minimum;
            field.logical_maximum = global.logical_maximum;
            field.unit = global.unit;
            field.unit_exponent = global.unit_exponent;
            field.collections = enclosing;
            result.inputs.push_back(std::move(field));
          }
        }
        offset += bits;
        break;
      }
      case kCollection:
        collections.push_back({local.UsageFor(0, global.usage_page), item_offset});
        break;
      case kEndCollection:
        if (collections.empty()) {
          throw Malformed(item_offset, "End Collection without an open collection");
        }
        collections.pop_back();
        break;
      case kOutput:
      case kFeature:
        break;  // Their reports are separate from the input reports.
      default:
        throw Malformed(item_offset, "reserved main item " + HexString(prefix, 2));
    }
    local = LocalState();
  }
  if (!collections.empty()) {
    throw Malformed(collections.back().offset, "collection (usage " +
                                                   HexString(collections.back().usage, 8) +
                                                   ") is not closed by the end of the descriptor");
  }
  for (const auto& [id, bits] : input_bits) {
    result.input_report_bytes[id] =
        static_cast<int>((bits + 7) / 8) + (result.uses_report_ids ? 1 : 0);
  }
  return result;
}

int AccelReportLayout::min_report_bytes() const {
  int bytes = report_id != 0 ? 1 : 0;
  for (const ReportField& axis : axes)
    bytes = std::max(bytes, (axis.bit_offset + axis.bit_size + 7) / 8);
  return bytes;
}

std::string AccelReportLayout::Describe() const {
  std::ostringstream out;
  out << (report_id != 0 ? "report " + std::to_string(report_id) : std::string("no report id"));
  const char* names[] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    const ReportField& f = axes[i];
    out << ", " << names[i] << ": bits " << f.bit_offset << "+" << f.bit_size << " "
        << (f.is_signed ? "signed" : "unsigned") << (f.big_endian ? " big-endian" : "") << " * "
        << f.scale;
  }
  out << " m/s^2";
  return out.str();
}

double HidAccelerationScale(uint32_t unit, int unit_exponent) {
  double per_count = kStandardGravity;
  if (unit != 0) {
    // Nibbles: system, then exponents of length, mass, time, temperature, current, light.
    const uint32_t system = unit & 0xf;
    const bool length_over_time_squared = (unit & 0x0ffffff0) == 0x0000e010;
    if (length_over_time_squared && system == 1) {
      per_count = 0.01;  // SI linear: centimetres.
    } else if (length_over_time_squared && system == 3) {
      per_count = 0.0254;  // English linear: inches.
    } else {
      throw Error("unsupported unit " + HexString(unit, 8) +
                  " on an acceleration field (expected none for G, or length per second "
                  "squared: 0xe011 cm/s^2, 0xe013 in/s^2)");
    }
  }
  return per_count * std::pow(10.0, unit_exponent);
}

AccelReportLayout FindAccelerometerLayout(const HidReportDescriptor& descriptor) {
  const uint32_t axis_usages[3] = {kHidUsageAccelerationX, kHidUsageAccelerationY,
                                   kHidUsageAccelerationZ};
  const char* axis_names[3] = {"X", "Y", "Z"};
  auto in_accelerometer = [](const HidInputField& field) {
    return std::find(field.collections.begin(), field.collections.end(),
                     kHidUsageAccelerometer3D) != field.collections.end();
  };
  auto is_axis = [&](const HidInputField& field) {
    return field.is_variable && in_accelerometer(field) &&
           std::find(std::begin(axis_usages), std::end(axis_usages), field.usage) !=
               std::end(axis_usages);
  };
  const auto first = std::find_if(descriptor.inputs.begin(), descriptor.inputs.end(), is_axis);
  if (first == descriptor.inputs.end()) {
    const bool has_collection =
        std::any_of(descriptor.inputs.begin(), descriptor.inputs.end(), in_accelerometer);
    throw Error(has_collection
                    ? "HID report descriptor: the Accelerometer 3D collection has no "
                      "acceleration axis inputs (usages 0x200453-0x200455)"
                    : "HID report descriptor has no Accelerometer 3D input (HID Sensor usage "
                      "page 0x20, usage 0x73): not a HID sensor accelerometer");
  }
  AccelReportLayout layout;
  layout.report_id = first->report_id;
  const int id_bits = descriptor.uses_report_ids ? 8 : 0;
  for (int axis = 0; axis < 3; ++axis) {
    const auto field = std::find_if(
        descriptor.inputs.begin(), descriptor.inputs.end(), [&](const HidInputField& f) {
          return is_axis(f) && f.usage == axis_usages[axis] && f.report_id == layout.report_id;
        });
    if (field == descriptor.inputs.end()) {
      throw Error(std::string("HID report descriptor: the Accelerometer 3D input report ") +
                  std::to_string(layout.report_id) + " has no " + axis_names[axis] +
                  " acceleration (usage " + HexString(axis_usages[axis], 6) + ")");
    }
    if (field->bit_size < 1 || field->bit_size > 32) {
      throw Error(std::string("HID report descriptor: the ") + axis_names[axis] +
                  " acceleration is " + std::to_string(field->bit_size) +
                  " bits wide (1 to 32 supported)");
    }
    ReportField& out = layout.axes[axis];
    out.bit_offset = field->bit_offset + id_bits;
    out.bit_size = field->bit_size;
    out.is_signed = field->is_signed();
    out.scale = HidAccelerationScale(field->unit, field->unit_exponent);
  }
  return layout;
}

std::optional<Eigen::Vector3d> DecodeAccelReport(const AccelReportLayout& layout,
                                                 std::span<const uint8_t> report) {
  if (layout.report_id != 0 && (report.empty() || report[0] != layout.report_id)) {
    return std::nullopt;
  }
  if (static_cast<int>(report.size()) < layout.min_report_bytes()) return std::nullopt;
  Eigen::Vector3d value;
  for (int i = 0; i < 3; ++i) {
    const ReportField& field = layout.axes[i];
    const uint64_t raw = ExtractBits(report, field);
    int64_t count = static_cast<int64_t>(raw);
    if (field.is_signed && field.bit_size < 64 && ((raw >> (field.bit_size - 1)) & 1)) {
      count -= int64_t{1} << field.bit_size;
    }
    value[i] = static_cast<double>(count) * field.scale;
  }
  return value;
}

}  // namespace autocal
