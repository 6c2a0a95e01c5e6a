#include "pipeline/calibration_export.h"

#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "pipeline/error.h"
#include "tests/test_util.h"

namespace autocal {
namespace {

const char kHeader[] = "time [ns],fx,fy,cx,cy,k1,k2,p1,p2,k3,rms [px],verdict,reason";

HistoryEntry Entry(int64_t t_ns, const std::string& verdict, const std::string& reason) {
  HistoryEntry e;
  e.t_ns = t_ns;
  e.fx = 427.123456789012;
  e.fy = 428.5;
  e.cx = 322.25;
  e.cy = 237.0625;
  e.k1 = -0.301234567890123;
  e.k2 = 0.1;
  e.p1 = 1e-4;
  e.p2 = -2e-4;
  e.k3 = -0.01;
  e.rms_px = 0.21;
  e.verdict = verdict;
  e.reason = reason;
  return e;
}

std::vector<HistoryEntry> History() {
  return {Entry(1700000000123456789, "accepted", "fits the trend (1.2 sigma)"),
          Entry(1700000002000000001, "rejected", "rejected: \"fx\" 9.1 sigma off, rms 0.8 px"),
          Entry(1700000004000000000, "no update", "no update: insufficient rotation, 2 deg")};
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

Error ReadError(const std::string& path) {
  try {
    ReadHistoryCsv(path);
  } catch (const Error& e) {
    return e;
  }
  ADD_FAILURE() << "no error reading " << path << ":\n" << test::ReadTextFile(path);
  return Error("none");
}

bool Contains(const Error& e, const std::string& part) {
  return std::string(e.what()).find(part) != std::string::npos;
}

TEST(CalibrationExport, NamesItsFormats) {
  EXPECT_EQ(HistoryFormatNames(), (std::vector<std::string>{"csv", "json"}));
  EXPECT_EQ(HistoryFormatFromName("csv"), HistoryFormat::kCsv);
  EXPECT_EQ(HistoryFormatFromName("json"), HistoryFormat::kJson);
  EXPECT_THROW(HistoryFormatFromName("sqlite"), Error);
}

TEST(CalibrationExport, CsvHasTheHeaderAndOneRowPerEntry) {
  test::TempDir dir;
  const std::string path = dir / "history.csv";
  WriteHistory(path, History(), HistoryFormat::kCsv);
  const std::vector<std::string> lines = Lines(test::ReadTextFile(path));
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0], kHeader);
  EXPECT_EQ(lines[1],
            "1700000000123456789,427.123456789012,428.5,322.25,237.0625,-0.301234567890123,0.1,"
            "1e-04,-2e-04,-0.01,0.21,accepted,fits the trend (1.2 sigma)");
  // RFC 4180: fields with a comma or a quote are quoted, their quotes doubled.
  EXPECT_EQ(lines[2].substr(lines[2].find(",rejected,")),
            ",rejected,\"rejected: \"\"fx\"\" 9.1 sigma off, rms 0.8 px\"");
  EXPECT_EQ(lines[3].substr(lines[3].find(",no update,")),
            ",no update,\"no update: insufficient rotation, 2 deg\"");
  EXPECT_EQ(ReadHistoryCsv(path), History());
}

TEST(CalibrationExport, CsvRoundTripsEveryBitAndEveryCharacter) {
  std::mt19937_64 random(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<HistoryEntry> history;
  const std::string reasons[] = {"",
                                 " leading and trailing spaces ",
                                 "a,b",
                                 "\"",
                                 "\"\"",
                                 "two\nlines",
                                 "crlf\r\nend",
                                 "tab\there",
                                 "caf\xc3\xa9, \xce\xbc"};
  for (const std::string& reason : reasons) {
    HistoryEntry e = Entry(static_cast<int64_t>(random()) - (int64_t{1} << 62), "rejected", reason);
    for (double* v : {&e.fx, &e.fy, &e.cx, &e.cy, &e.k1, &e.k2, &e.p1, &e.p2, &e.k3, &e.rms_px}) {
      *v = std::ldexp(unit(random), static_cast<int>(40 * unit(random)));
    }
    history.push_back(e);
  }
  history.back().rms_px = std::numeric_limits<double>::infinity();
  test::TempDir dir;
  const std::string path = dir / "history.csv";
  WriteHistory(path, history, HistoryFormat::kCsv);
  EXPECT_EQ(ReadHistoryCsv(path), history) << test::ReadTextFile(path);

  // A spreadsheet's CRLF line ends read the same; NaN reads back as NaN.
  std::vector<HistoryEntry> simple = History();
  simple[0].rms_px = std::nan("");
  WriteHistory(path, simple, HistoryFormat::kCsv);
  std::string crlf;
  for (const std::string& line : Lines(test::ReadTextFile(path))) crlf += line + "\r\n";
  test::WriteTextFile(path, crlf);
  std::vector<HistoryEntry> read = ReadHistoryCsv(path);
  ASSERT_EQ(read.size(), simple.size());
  EXPECT_TRUE(std::isnan(read[0].rms_px));
  read[0].rms_px = simple[0].rms_px = 0.0;
  EXPECT_EQ(read, simple);
}

TEST(CalibrationExport, EmptyHistoryIsJustTheHeader) {
  test::TempDir dir;
  const std::string csv = dir / "history.csv";
  WriteHistory(csv, {}, HistoryFormat::kCsv);
  EXPECT_EQ(test::ReadTextFile(csv), std::string(kHeader) + "\n");
  EXPECT_TRUE(ReadHistoryCsv(csv).empty());
  const std::string json = dir / "history.json";
  WriteHistory(json, {}, HistoryFormat::kJson);
  cv::FileStorage file(json, cv::FileStorage::READ);
  ASSERT_TRUE(file.isOpened());
  EXPECT_TRUE(file["history"].isSeq());
  EXPECT_EQ(file["history"].size(), 0u);
}

TEST(CalibrationExport, JsonIsValidAndReadsBackWithOpenCv) {
  std::vector<HistoryEntry> history = History();
  history[0].reason = "back\\slash, \"quoted\"\nand a second line\ttab";
  test::TempDir dir;
  const std::string path = dir / "history.json";
  WriteHistory(path, history, HistoryFormat::kJson);
  const std::string text = test::ReadTextFile(path);
  cv::FileStorage file;
  ASSERT_NO_THROW(file.open(path, cv::FileStorage::READ)) << text;
  ASSERT_TRUE(file.isOpened());
  const cv::FileNode entries = file["history"];
  ASSERT_TRUE(entries.isSeq());
  ASSERT_EQ(entries.size(), history.size());
  for (size_t i = 0; i < history.size(); ++i) {
    const cv::FileNode e = entries[static_cast<int>(i)];
    EXPECT_EQ(static_cast<double>(e["fx"]), history[i].fx);
    EXPECT_EQ(static_cast<double>(e["cy"]), history[i].cy);
    EXPECT_EQ(static_cast<double>(e["k1"]), history[i].k1);
    EXPECT_EQ(static_cast<double>(e["p2"]), history[i].p2);
    EXPECT_EQ(static_cast<double>(e["k3"]), history[i].k3);
    EXPECT_EQ(static_cast<double>(e["rms_px"]), history[i].rms_px);
    EXPECT_EQ(static_cast<std::string>(e["verdict"]), history[i].verdict);
    EXPECT_EQ(static_cast<std::string>(e["reason"]), history[i].reason);
    // OpenCV reads integers into 32 bits: the 64-bit time is checked in the text.
    EXPECT_NE(text.find("\"t_ns\": " + std::to_string(history[i].t_ns) + ","), std::string::npos);
  }
}

TEST(CalibrationExport, JsonWritesNullWhereThereIsNoNumber) {
  std::vector<HistoryEntry> history = History();
  history[1].rms_px = std::nan("");
  test::TempDir dir;
  const std::string path = dir / "history.json";
  WriteHistory(path, history, HistoryFormat::kJson);
  EXPECT_NE(test::ReadTextFile(path).find("\"rms_px\": null"), std::string::npos);
}

TEST(CalibrationExport, BadCsvIsReportedWithLineAndExpectation) {
  test::TempDir dir;
  const std::string good = [&] {
    WriteHistory(dir / "good.csv", History(), HistoryFormat::kCsv);
    return test::ReadTextFile(dir / "good.csv");
  }();
  const auto write = [&](const std::string& name, const std::string& text) {
    test::WriteTextFile(dir / name, text);
    return dir / name;
  };

  Error e = ReadError(write("header.csv", "t,fx\n"));
  EXPECT_EQ(e.file(), dir / "header.csv");
  EXPECT_EQ(e.line(), 1);
  EXPECT_TRUE(Contains(e, std::string("expected the header '") + kHeader + "'")) << e.what();

  // The second entry's reason spans two lines, so the third entry starts on line 5.
  std::string text = good;
  text.replace(text.find("9.1 sigma"), 9, "9.1\nsigma");
  text.replace(text.find(",0.21,no update,"), 16, ",0.21;no update,");
  e = ReadError(write("fields.csv", text));
  EXPECT_EQ(e.line(), 5) << e.what();
  EXPECT_TRUE(Contains(e, "expected 13 fields (time [ns],fx,")) << e.what();
  EXPECT_TRUE(Contains(e, "found 12")) << e.what();

  text = good;
  text.replace(text.find(",428.5,", text.find("1700000002")), 7, ",4x8.5,");
  e = ReadError(write("number.csv", text));
  EXPECT_EQ(e.line(), 3);
  EXPECT_TRUE(Contains(e, "fy: expected a number, found '4x8.5'")) << e.what();

  const std::string row = Lines(good)[1];
  e = ReadError(
      write("time.csv", std::string(kHeader) + "\n1.5e9" + row.substr(row.find(',')) + "\n"));
  EXPECT_TRUE(Contains(e, "time [ns]: expected an integer, found '1.5e9'")) << e.what();

  e = ReadError(write("open.csv", good + "1,2,3,4,5,6,7,8,9,10,11,x,\"never closed\n"));
  EXPECT_EQ(e.line(), 5);
  EXPECT_TRUE(Contains(e, "a quoted field is not closed")) << e.what();

  e = ReadError(
      write("stray.csv", std::string(kHeader) + "\n1,2,3,4,5,6,7,8,9,10,11,x,say \"hi\"\n"));
  EXPECT_EQ(e.line(), 2);
  EXPECT_TRUE(Contains(e, "expected the field quoted")) << e.what();

  EXPECT_TRUE(Contains(ReadError(write("empty.csv", "")), "empty"));
  EXPECT_TRUE(Contains(ReadError(dir / "missing.csv"), "missing.csv"));
}

}  // namespace
}  // namespace autocal
