// candump log lines: format, parse, round trip, refusals; the trace file appender.
#include "adapters/transport/candump_trace.h"

#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace drivegw::transport {
namespace {

using ::testing::HasSubstr;

CandumpRecord Record(CanFrame frame, std::optional<CanDirection> dir = std::nullopt) {
  CandumpRecord r;
  r.seconds = 1700000000;
  r.microseconds = 123456;
  r.interface = "can0";
  r.frame = frame;
  r.direction = dir;
  return r;
}

TEST(CandumpLine, Format_IssueExample) {
  const std::array<uint8_t, 5> bytes{0x00, 0x4B, 0x03, 0x01, 0x03};
  EXPECT_EQ(FormatCandumpLine(Record(MakeCanFrame(0x42E, bytes))),
            "(1700000000.123456) can0 42E#004B030103");
  EXPECT_EQ(FormatCandumpLine(Record(MakeCanRtrFrame(0x1ABCDEF, 2, true), CanDirection::kTx)),
            "(1700000000.123456) can0 01ABCDEF#R2 T");
  CandumpRecord early = Record(MakeCanFrame(0x1, {}), CanDirection::kRx);
  early.seconds = 5;
  early.microseconds = 7;
  EXPECT_EQ(FormatCandumpLine(early), "(0000000005.000007) can0 001# R");
}

TEST(CandumpLine, RoundTrip) {
  const std::array<uint8_t, 8> eight{0xDE, 0xAD, 0xBE, 0xEF, 0, 1, 2, 3};
  CanFrame err;
  err.error = true;
  err.extended = true;
  err.id = 0x40;  // CAN_ERR_BUSOFF
  err.dlc = 8;
  for (const CandumpRecord& r :
       {Record(MakeCanFrame(0x7FF, eight)), Record(MakeCanFrame(0x0, {}), CanDirection::kRx),
        Record(MakeCanFrame(0x1FFFFFFF, eight, true), CanDirection::kTx),
        Record(MakeCanRtrFrame(0x100, 0)), Record(MakeCanRtrFrame(0x100, 8, true)), Record(err)}) {
    const std::string line = FormatCandumpLine(r);
    auto back = ParseCandumpLine(line);
    ASSERT_TRUE(back.ok()) << line << ": " << back.status();
    EXPECT_EQ(*back, r) << line;
  }
}

TEST(CandumpLine, Parse_CandumpVariants) {
  auto tabs = ParseCandumpLine("(1620742552.534499)\tvcan0\t4C5#B2.23.42.25\r\n");
  ASSERT_TRUE(tabs.ok()) << tabs.status();
  EXPECT_EQ(tabs->interface, "vcan0");
  EXPECT_EQ(FormatCanFrame(tabs->frame), "4C5#B2234225");
  EXPECT_FALSE(tabs->direction.has_value());
  auto lower = ParseCandumpLine("(1.5) can1 1abcdef0#aabb t");
  ASSERT_TRUE(lower.ok()) << lower.status();
  EXPECT_EQ(lower->microseconds, 500000u);
  EXPECT_EQ(lower->frame.id, 0x1ABCDEF0u);
  EXPECT_TRUE(lower->frame.extended);
  EXPECT_EQ(lower->direction, CanDirection::kTx);
  auto nanos = ParseCandumpLine("(2.123456789) can0 123#R");
  ASSERT_TRUE(nanos.ok());
  EXPECT_EQ(nanos->microseconds, 123456u);
}

TEST(CandumpLine, Refusals_SayWhat) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "candump line: empty"},
      {"1700000000.1 can0 123#", "timestamp '1700000000.1' is not (SECONDS.MICROS)"},
      {"(17x.1) can0 123#", "is not decimal"},
      {"(1.1)", "interface missing"},
      {"(1.1) can0", "frame missing"},
      {"(1.1) can0 123", "has no '#'"},
      {"(1.1) can0 1234#", "must have 3 (11-bit) or 8 (29-bit) hex digits"},
      {"(1.1) can0 800#", "exceeds 7FF (11-bit)"},
      {"(1.1) can0 E0000040#", "has flag bits beyond CAN_ERR_FLAG"},
      {"(1.1) can0 12G#", "is not hex"},
      {"(1.1) can0 123#123", "odd number of digits"},
      {"(1.1) can0 123#001122334455667788", "exceeds 8 bytes"},
      {"(1.1) can0 123#R9", "is not R or R0..R8"},
      {"(1.1) can0 123##1AA", "CAN FD frames ('##') are not supported"},
      {"(1.1) can0 123#11 X", "direction 'X' is not T or R"},
      {"(1.1) can0 123#11 T extra", "extra text after the direction"},
  };
  for (const auto& [line, what] : cases) {
    auto r = ParseCandumpLine(line);
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << line;
    EXPECT_THAT(std::string(r.status().message()), HasSubstr(what)) << line;
  }
}

TEST(CandumpLine, RandomText_NeverCrash) {
  std::mt19937 rng(3);
  const std::string alphabet = "()0123456789.#RTabcdefABCDEF xyz\t\n";
  for (int i = 0; i < 50000; ++i) {
    std::string line(rng() % 48, ' ');
    for (char& c : line) c = alphabet[rng() % alphabet.size()];
    auto r = ParseCandumpLine(line);
    if (r.ok()) {
      EXPECT_LE(r->frame.dlc, 8);
      // What parses prints back to something that parses to the same record.
      auto again = ParseCandumpLine(FormatCandumpLine(*r));
      ASSERT_TRUE(again.ok()) << line;
      EXPECT_EQ(*again, *r) << line;
    }
  }
}

std::string TempPath(const std::string& stem) {
  const char* dir = std::getenv("TMPDIR");
  return std::string(dir ? dir : "/tmp") + "/" + stem + "." + std::to_string(::getpid()) + ".log";
}

std::vector<std::string> ReadLines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  return lines;
}

TEST(CandumpTrace, RecordsLinesWithInjectedClock) {
  const std::string path = TempPath("dgw_trace_test");
  ::unlink(path.c_str());
  auto trace = CandumpTrace::Open(path, [] {
    return std::chrono::system_clock::time_point(std::chrono::microseconds(1700000000123456));
  });
  ASSERT_TRUE(trace.ok()) << trace.status();
  const std::array<uint8_t, 2> bytes{0xAB, 0xCD};
  (*trace)->Record("can0", MakeCanFrame(0x42E, bytes), CanDirection::kTx);
  (*trace)->Record("udp:239.74.163.2:43113", MakeCanRtrFrame(0x5, 1), CanDirection::kRx);
  EXPECT_EQ((*trace)->lines(), 2u);
  EXPECT_THAT(ReadLines(path),
              ::testing::ElementsAre("(1700000000.123456) can0 42E#ABCD T",
                                     "(1700000000.123456) udp:239.74.163.2:43113 005#R1 R"));
  ::unlink(path.c_str());
}

TEST(CandumpTrace, ConcurrentWriters_WholeLines) {
  const std::string path = TempPath("dgw_trace_concurrent");
  ::unlink(path.c_str());
  auto trace = CandumpTrace::Open(path);
  ASSERT_TRUE(trace.ok());
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      const std::array<uint8_t, 8> eight{};
      for (int i = 0; i < 500; ++i) {
        (*trace)->Record("can0", MakeCanFrame(static_cast<uint32_t>(t), eight), CanDirection::kTx);
      }
    });
  }
  for (auto& th : threads) th.join();
  const auto lines = ReadLines(path);
  ASSERT_EQ(lines.size(), 2000u);
  for (const auto& l : lines) ASSERT_TRUE(ParseCandumpLine(l).ok()) << l;
  ::unlink(path.c_str());
}

TEST(CandumpTrace, Open_BadPath_NamesIt) {
  auto trace = CandumpTrace::Open("/nonexistent-dir/x.log");
  EXPECT_EQ(trace.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(trace.status().message(),
            "can trace '/nonexistent-dir/x.log': No such file or directory");
}

}  // namespace
}  // namespace drivegw::transport
