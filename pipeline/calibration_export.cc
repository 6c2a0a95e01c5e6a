#include "pipeline/calibration_export.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <sstream>
#include <string_view>

#include "pipeline/error.h"
#include "pipeline/text_format.h"

namespace autocal {
namespace {

// The numeric columns after the time, in order: CSV header, JSON key, field.
struct NumberColumn {
  const char* csv;
  const char* json;
  double HistoryEntry::*field;
};
constexpr NumberColumn kNumbers[] = {
    {"fx", "fx", &HistoryEntry::fx}, {"fy", "fy", &HistoryEntry::fy},
    {"cx", "cx", &HistoryEntry::cx}, {"cy", "cy", &HistoryEntry::cy},
    {"k1", "k1", &HistoryEntry::k1}, {"k2", "k2", &HistoryEntry::k2},
    {"p1", "p1", &HistoryEntry::p1}, {"p2", "p2", &HistoryEntry::p2},
    {"k3", "k3", &HistoryEntry::k3}, {"rms [px]", "rms_px", &HistoryEntry::rms_px}};

// "time [ns]", the numbers, "verdict", "reason".
std::vector<std::string> CsvColumns() {
  std::vector<std::string> columns = {"time [ns]"};
  for (const NumberColumn& column : kNumbers) columns.push_back(column.csv);
  columns.insert(columns.end(), {"verdict", "reason"});
  return columns;
}

std::string CsvHeader() {
  std::string header;
  for (const std::string& column : CsvColumns()) header += (header.empty() ? "" : ",") + column;
  return header;
}

template <typename T>
std::optional<T> Parse(std::string_view s) {
  T value{};
  const auto result = std::from_chars(s.data(), s.data() + s.size(), value);
  if (result.ec != std::errc() || result.ptr != s.data() + s.size()) return std::nullopt;
  return value;
}

// RFC 4180: a field with a comma, a quote or a line break is quoted, its quotes doubled.
std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? "\"\"" : std::string(1, c);
  return quoted + "\"";
}

std::string CsvText(const std::vector<HistoryEntry>& history) {
  std::string text = CsvHeader() + "\n";
  for (const HistoryEntry& entry : history) {
    text += std::to_string(entry.t_ns);
    for (const NumberColumn& column : kNumbers) text += "," + ShortestDecimal(entry.*column.field);
    text += "," + CsvField(entry.verdict) + "," + CsvField(entry.reason) + "\n";
  }
  return text;
}

std::string JsonText(const std::vector<HistoryEntry>& history) {
  std::string text = "{\n  \"history\": [";
  for (size_t i = 0; i < history.size(); ++i) {
    const HistoryEntry& entry = history[i];
    text += (i == 0 ? "\n    {" : ",\n    {");
    text += "\"t_ns\": " + std::to_string(entry.t_ns);
    for (const NumberColumn& column : kNumbers) {
      text += std::string(", \"") + column.json + "\": " + JsonNumber(entry.*column.field);
    }
    text += ", \"verdict\": " + JsonString(entry.verdict) +
            ", \"reason\": " + JsonString(entry.reason) + "}";
  }
  return text + (history.empty() ? "]\n}\n" : "\n  ]\n}\n");
}

struct CsvRecord {
  int line = 0;  // Where the record starts.
  std::vector<std::string> fields;
};

// RFC 4180 records; line ends may be CRLF, LF or CR, blank lines are skipped.
std::vector<CsvRecord> ParseCsv(const std::string& path, const std::string& text) {
  std::vector<CsvRecord> records;
  const auto line_end = [&](size_t i) { return text[i] == '\n' || text[i] == '\r'; };
  const auto skip_line_end = [&](size_t* i) {
    if (text[*i] == '\r' && *i + 1 < text.size() && text[*i + 1] == '\n') ++*i;
    ++*i;
  };
  int line = 1;
  size_t i = 0;
  while (i < text.size()) {
    if (line_end(i)) {
      skip_line_end(&i);
      ++line;
      continue;
    }
    CsvRecord record{line, {}};
    while (true) {
      std::string field;
      if (i < text.size() && text[i] == '"') {
        const int opened = line;
        for (++i;; ++i) {
          if (i == text.size()) {
            throw Error(path, opened,
                        "a quoted field is not closed: expected '\"' (quotes "
                        "inside a field are doubled)");
          }
          if (text[i] == '"' && (i + 1 == text.size() || text[i + 1] != '"')) break;
          if (text[i] == '"') ++i;  // A doubled quote stands for one.
          if (text[i] == '\n') ++line;
          field += text[i];
        }
        ++i;
        if (i < text.size() && text[i] != ',' && !line_end(i)) {
          throw Error(path, line, "expected ',' or the end of the line after a quoted field");
        }
      } else {
        for (; i < text.size() && text[i] != ',' && !line_end(i); ++i) {
          if (text[i] == '"') {
            throw Error(path, line,
                        "a '\"' in an unquoted field: expected the field quoted "
                        "and the quote doubled");
          }
          field += text[i];
        }
      }
      record.fields.push_back(std::move(field));
      if (i < text.size() && text[i] == ',') {
        ++i;
        continue;
      }
      if (i < text.size()) skip_line_end(&i);
      ++line;
      break;
    }
    records.push_back(std::move(record));
  }
  return records;
}

}  // namespace

HistoryFormat HistoryFormatFromName(const std::string& name) {
  if (name == "csv") return HistoryFormat::kCsv;
  if (name == "json") return HistoryFormat::kJson;
  throw Error("unknown history format '" + name + "'; known: csv, json");
}

std::vector<std::string> HistoryFormatNames() { return {"csv", "json"}; }

void WriteHistory(const std::string& path, const std::vector<HistoryEntry>& history,
                  HistoryFormat format) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << (format == HistoryFormat::kCsv ? CsvText(history) : JsonText(history));
  out.close();
  if (!out) throw Error(path, 0, "cannot write");
}

std::vector<HistoryEntry> ReadHistoryCsv(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw Error(path, 0, "no such history file");
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  if (!in.is_open() || in.bad()) throw Error(path, 0, "cannot read");
  const std::vector<CsvRecord> records = ParseCsv(path, text.str());
  const std::vector<std::string> columns = CsvColumns();
  const std::string header = CsvHeader();
  if (records.empty()) throw Error(path, 0, "empty: expected the header '" + header + "'");
  if (records[0].fields != columns) {
    throw Error(path, records[0].line, "expected the header '" + header + "'");
  }
  std::vector<HistoryEntry> history;
  for (size_t r = 1; r < records.size(); ++r) {
    const CsvRecord& record = records[r];
    const std::vector<std::string>& f = record.fields;
    if (f.size() != columns.size()) {
      throw Error(path, record.line,
                  "expected " + std::to_string(columns.size()) + " fields (" + header +
                      "), found " + std::to_string(f.size()));
    }
    HistoryEntry entry;
    const std::optional<int64_t> t = Parse<int64_t>(f[0]);
    if (!t) throw Error(path, record.line, "time [ns]: expected an integer, found '" + f[0] + "'");
    entry.t_ns = *t;
    for (size_t c = 0; c < std::size(kNumbers); ++c) {
      const std::optional<double> value = Parse<double>(f[1 + c]);
      if (!value) {
        throw Error(path, record.line,
                    std::string(kNumbers[c].csv) + ": expected a number, found '" + f[1 + c] + "'");
      }
      entry.*kNumbers[c].field = *value;
    }
    entry.verdict = f[columns.size() - 2];
    entry.reason = f[columns.size() - 1];
    history.push_back(std::move(entry));
  }
  return history;
}

}  // namespace autocal
