#include "devices/csv.h"

#include <charconv>
#include <cmath>
#include <limits>
#include <utility>

#include "pipeline/error.h"

namespace autocal {
namespace {

std::string_view Trim(std::string_view text) {
  const auto first = text.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(" \t\r");
  return text.substr(first, last - first + 1);
}

std::string Join(const std::vector<std::string>& names) {
  std::string joined;
  for (const auto& name : names) {
    if (!joined.empty()) joined += ", ";
    joined += name;
  }
  return joined;
}

}  // namespace

CsvReader::CsvReader(const std::filesystem::path& path, Separator separator,
                     std::vector<std::string> columns)
    : path_(path.string()), separator_(separator), columns_(std::move(columns)), in_(path) {
  if (!in_) {
    throw Error(
        path_, 0,
        std::filesystem::exists(path) ? "cannot be opened for reading" : "file does not exist");
  }
}

bool CsvReader::Next() {
  while (std::getline(in_, line_)) {
    ++line_number_;
    const std::string_view text = Trim(line_);
    if (text.empty() || text.front() == '#') continue;

    fields_.clear();
    if (separator_ == Separator::kComma) {
      size_t start = 0;
      while (true) {
        const size_t comma = text.find(',', start);
        fields_.push_back(Trim(text.substr(start, comma - start)));
        if (comma == std::string_view::npos) break;
        start = comma + 1;
      }
    } else {
      size_t start = text.find_first_not_of(" \t");
      while (start != std::string_view::npos) {
        const size_t end = text.find_first_of(" \t", start);
        fields_.push_back(text.substr(start, end - start));
        start = text.find_first_not_of(" \t", end);
      }
    }

    if (fields_.size() != columns_.size()) {
      Fail("expected " + std::to_string(columns_.size()) +
           (separator_ == Separator::kComma ? " comma" : " space") +
           "-separated fields: " + Join(columns_) + "; got " + std::to_string(fields_.size()));
    }
    return true;
  }
  if (in_.bad()) throw Error(path_, line_number_, "read error");
  return false;
}

std::string_view CsvReader::Text(size_t index) const { return fields_.at(index); }

std::string CsvReader::FieldLabel(size_t index) const {
  return "field " + std::to_string(index + 1) + " (" + columns_.at(index) + ")";
}

int64_t CsvReader::Int64(size_t index) const {
  const std::string_view text = Text(index);
  int64_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error == std::errc::result_out_of_range) {
    Fail(FieldLabel(index) + " is out of range: \"" + std::string(text) + "\"");
  }
  if (error != std::errc() || end != text.data() + text.size()) {
    Fail(FieldLabel(index) + " is not an integer: \"" + std::string(text) + "\"");
  }
  return value;
}

double CsvReader::Double(size_t index) const {
  const std::string_view text = Text(index);
  double value = 0.0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error == std::errc::result_out_of_range) {
    Fail(FieldLabel(index) + " is out of range: \"" + std::string(text) + "\"");
  }
  if (error != std::errc() || end != text.data() + text.size()) {
    Fail(FieldLabel(index) + " is not a number: \"" + std::string(text) + "\"");
  }
  if (!std::isfinite(value)) {
    Fail(FieldLabel(index) + " is not finite: \"" + std::string(text) + "\"");
  }
  return value;
}

int64_t CsvReader::SecondsAsNs(size_t index) const {
  const std::string_view text = Text(index);
  const size_t dot = text.find('.');
  const std::string_view whole = text.substr(0, dot);
  const std::string_view fraction =
      dot == std::string_view::npos ? std::string_view() : text.substr(dot + 1);
  const auto all_digits = [](std::string_view digits) {
    return digits.find_first_not_of("0123456789") == std::string_view::npos;
  };
  if (whole.empty() || !all_digits(whole) || !all_digits(fraction)) {
    Fail(FieldLabel(index) + " is not a time in seconds (digits, optionally '.' and digits): \"" +
         std::string(text) + "\"");
  }
  if (fraction.size() > 9) {
    Fail(FieldLabel(index) + " has more than 9 decimal places (finer than 1 ns): \"" +
         std::string(text) + "\"");
  }
  int64_t seconds = 0;
  const auto [end, error] = std::from_chars(whole.data(), whole.data() + whole.size(), seconds);
  constexpr int64_t kNsPerSecond = 1'000'000'000;
  if (error != std::errc() || seconds > std::numeric_limits<int64_t>::max() / kNsPerSecond - 1) {
    Fail(FieldLabel(index) + " is out of range: \"" + std::string(text) + "\"");
  }
  int64_t nanoseconds = 0;
  for (size_t i = 0; i < 9; ++i) {
    nanoseconds = nanoseconds * 10 + (i < fraction.size() ? fraction[i] - '0' : 0);
  }
  return seconds * kNsPerSecond + nanoseconds;
}

void CsvReader::CheckIncreasing(int64_t t_ns) {
  if (previous_t_line_ > 0 && t_ns <= previous_t_ns_) {
    Fail("timestamp " + std::to_string(t_ns) + " is not after the previous one " +
         std::to_string(previous_t_ns_) + " on line " + std::to_string(previous_t_line_));
  }
  previous_t_ns_ = t_ns;
  previous_t_line_ = line_number_;
}

void CsvReader::Fail(const std::string& what) const {
  // getline sets eof only when the last line has no newline: a writer was cut off.
  const char* truncated =
      in_.eof() ? "last line is truncated (no newline at the end of the file): " : "";
  throw Error(path_, line_number_, truncated + what);
}

void ReadRows(CsvReader& reader, bool truncate_at_fault, std::vector<std::string>* warnings,
              const std::function<void(CsvReader&)>& read_row) {
  try {
    while (reader.Next()) read_row(reader);
  } catch (const Error& error) {
    if (!truncate_at_fault) throw;
    warnings->push_back(std::string(error.what()) + " (read up to the line before)");
  }
}

std::string FormatDouble(double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

}  // namespace autocal
