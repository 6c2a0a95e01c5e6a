// Line-oriented reading of the text tables in recordings and datasets: comma-separated
// (native, EuRoC, accelerometer CSVs) or whitespace-separated (TUM RGB-D). Every fault is
// an Error naming the file, the 1-based line and what was expected.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace autocal {

class CsvReader {
 public:
  enum class Separator { kComma, kWhitespace };

  // Opens `path`, whose rows must have exactly the named columns. Throws Error when the
  // file cannot be opened.
  CsvReader(const std::filesystem::path& path, Separator separator,
            std::vector<std::string> columns);

  // Moves to the next row, skipping blank lines and '#' comments. Returns false at the
  // end of the file. Throws Error for a row with the wrong number of fields.
  bool Next();

  // Field `index` of the current row, surrounding spaces removed.
  std::string_view Text(size_t index) const;
  // Field `index` as a whole number / a finite number; throws Error otherwise.
  int64_t Int64(size_t index) const;
  double Double(size_t index) const;
  // Field `index` as decimal seconds ("1305031102.175304"), converted to nanoseconds
  // digit by digit so that no precision is lost.
  int64_t SecondsAsNs(size_t index) const;
  // Checks that `t_ns`, read from the current row, is after the previous call's value.
  void CheckIncreasing(int64_t t_ns);

  // Throws Error(path, current line, what), saying when the row is an unterminated last
  // line (a file cut off while being written).
  [[noreturn]] void Fail(const std::string& what) const;

  const std::string& path() const { return path_; }
  int line() const { return line_number_; }

 private:
  std::string FieldLabel(size_t index) const;

  std::string path_;
  Separator separator_;
  std::vector<std::string> columns_;
  std::ifstream in_;
  std::string line_;
  std::vector<std::string_view> fields_;
  int line_number_ = 0;
  int64_t previous_t_ns_ = 0;
  int previous_t_line_ = 0;  // 0 until CheckIncreasing has seen a row.
};

// Calls `read_row` for every row of `reader`. A fault (from the reader or thrown as Error
// by `read_row`) is rethrown, or, with `truncate_at_fault`, its message is appended to
// `warnings` and reading stops there: the rows before it stay. `read_row` must therefore
// keep a row only once all of it has been checked.
void ReadRows(CsvReader& reader, bool truncate_at_fault, std::vector<std::string>* warnings,
              const std::function<void(CsvReader&)>& read_row);

// Shortest decimal text that reads back as exactly `value`.
std::string FormatDouble(double value);

}  // namespace autocal
