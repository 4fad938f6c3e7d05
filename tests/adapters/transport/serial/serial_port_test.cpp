// SerialPort and PseudoTerminal on real ptys (a pty ignores baud and timing: trinamic-sixpack.md
// §2.7).
#include "adapters/transport/serial_port.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <string>
#include <thread>
#include <vector>

#include "adapters/transport/pty.h"

namespace drivegw::transport {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using namespace std::chrono_literals;
using Bytes = std::vector<uint8_t>;
using Clock = std::chrono::steady_clock;

// trinamic-sixpack.md §8 example: 9600 baud, 6 ms switchover ($40), a 9-byte request word.
const Bytes kRequest = {0x01, 0x40, 0x82, 0x00, 0x03, 0x00, 0x00, 0x00, 0x00};
// $43 reply body (R8, 8 bytes) and the same with the F0 response-address prefix (R9), §2.4.
const Bytes kReplyR8 = {0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00};
const Bytes kReplyR9 = {0xF0, 0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00};

PseudoTerminal OpenPty(const std::string& link = "") {
  auto p = PseudoTerminal::Open(link);
  EXPECT_TRUE(p.ok()) << p.status();
  return std::move(p).value();
}

SerialPort OpenPort(const std::string& device, int baud = 9600,
                    SerialConfig::Duplex duplex = SerialConfig::Duplex::kFull,
                    std::chrono::microseconds turnaround = 0us) {
  SerialConfig c;
  c.device = device;
  c.baud = baud;
  c.duplex = duplex;
  c.turnaround = turnaround;
  auto s = SerialPort::Open(c);
  EXPECT_TRUE(s.ok()) << s.status();
  return std::move(s).value();
}

std::string TempPath(const std::string& name) {
  const char* dir = std::getenv("TMPDIR");
  return std::string(dir ? dir : "/tmp") + "/dgw-serial-" + std::to_string(::getpid()) + "-" + name;
}

class SerialPortBaud : public ::testing::TestWithParam<int> {};

TEST_P(SerialPortBaud, Open_AnyBaudOnPty_SpeedReadsBack) {
  PseudoTerminal pty = OpenPty();
  SerialPort port = OpenPort(pty.slave_path(), GetParam());
  auto baud = port.ReadBackBaud();
  ASSERT_TRUE(baud.ok()) << baud.status();
  EXPECT_EQ(*baud, GetParam());
  // One termios for both ends: the simulator sees the adapter's speed (§2.7).
  auto peer = pty.PeerBaud();
  ASSERT_TRUE(peer.ok()) << peer.status();
  EXPECT_EQ(*peer, GetParam());
}

TEST_P(SerialPortBaud, Exchange_NineByteRequest_EightAndNineByteReplies) {
  PseudoTerminal pty = OpenPty();
  SerialPort port = OpenPort(pty.slave_path(), GetParam());
  ASSERT_TRUE(port.Write(kRequest).ok());
  auto got = pty.ReadExactly(9, 5s);
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(*got, kRequest);

  ASSERT_TRUE(pty.Write(kReplyR8).ok());
  auto r8 = port.ReadExactly(8, 5s);
  ASSERT_TRUE(r8.ok()) << r8.status();
  EXPECT_EQ(*r8, kReplyR8);

  ASSERT_TRUE(pty.Write(kReplyR9).ok());
  auto r9 = port.ReadExactly(9, 5s);
  ASSERT_TRUE(r9.ok()) << r9.status();
  EXPECT_EQ(*r9, kReplyR9);

  EXPECT_EQ(port.counters().bytes_out, 9u);
  EXPECT_EQ(port.counters().bytes_in, 17u);
  EXPECT_EQ(port.counters().timeouts, 0u);
}

INSTANTIATE_TEST_SUITE_P(Pty, SerialPortBaud, ::testing::Values(9600, 115200));

TEST(SerialPort, SetBaud_ChangesSpeedOfOpenPort_PeerSeesIt_BadRateKeepsSpeed) {
  PseudoTerminal pty = OpenPty();
  SerialPort port = OpenPort(pty.slave_path(), 19200);
  ASSERT_TRUE(port.Write(kRequest).ok());  // queued at 19200, then the switch (G-40)
  ASSERT_TRUE(port.SetBaud(9600).ok());
  EXPECT_EQ(port.config().baud, 9600);
  EXPECT_EQ(*port.ReadBackBaud(), 9600);
  EXPECT_EQ(*pty.PeerBaud(), 9600);  // one termios for both pty ends (§2.7)
  auto got = pty.ReadExactly(9, 5s);
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(*got, kRequest);
  // The port still works at the new speed.
  ASSERT_TRUE(pty.Write(kReplyR8).ok());
  auto r8 = port.ReadExactly(8, 5s);
  ASSERT_TRUE(r8.ok()) << r8.status();
  EXPECT_EQ(*r8, kReplyR8);

  const absl::Status bad = port.SetBaud(12345);
  EXPECT_EQ(bad.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad.message(), HasSubstr("serial.baud: 12345"));
  EXPECT_EQ(port.config().baud, 9600);
  EXPECT_EQ(*port.ReadBackBaud(), 9600);

  SerialPort moved = std::move(port);
  EXPECT_EQ(port.SetBaud(19200).code(), absl::StatusCode::kFailedPrecondition);  // NOLINT
  EXPECT_TRUE(moved.SetBaud(19200).ok());
  EXPECT_EQ(*pty.PeerBaud(), 19200);
}

TEST(SerialPort, ReadExactly_ReplyArrivesInPieces_Assembled) {
  PseudoTerminal pty = OpenPty();
  SerialPort port = OpenPort(pty.slave_path());
  auto writer = std::async(std::launch::async, [&] {
    EXPECT_TRUE(pty.Write(std::span(kReplyR9).first(4)).ok());
    std::this_thread::sleep_for(20ms);  // only to split the reply; nothing asserts on it
    EXPECT_TRUE(pty.Write(std::span(kReplyR9).subspan(4)).ok());
  });
  auto got = port.ReadExactly(9, 5s);
  writer.get();
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(*got, kReplyR9);
}

TEST(SerialPort, ReadExactly_ShortReply_DeadlineExceededWithPartialCount) {
  PseudoTerminal pty = OpenPty();
  SerialPort port = OpenPort(pty.slave_path());
  ASSERT_TRUE(pty.Write(std::span(kReplyR8).first(4)).ok());
  const auto start = Clock::now();
  auto got = port.ReadExactly(9, 50ms);
  const auto took = Clock::now() - start;
  ASSERT_FALSE(got.ok());
  EXPECT_EQ(got.status().code(), absl::StatusCode::kDeadlineExceeded);
  EXPECT_THAT(got.status().message(), HasSubstr("4 of 9 bytes"));
  EXPECT_THAT(got.status().message(), HasSubstr(pty.slave_path()));
  EXPECT_THAT(PartialReadBytes(got.status()), ElementsAre(0x43, 0x94, 0x01, 0x1F));
  EXPECT_GE(took, 50ms);  // lower bound only
  EXPECT_EQ(port.counters().timeouts, 1u);
  EXPECT_EQ(port.counters().bytes_in, 4u);
}

TEST(SerialPort, ReadAvailable_NothingThere_EmptyAfterTimeout) {
  PseudoTerminal pty = OpenPty();
  SerialPort port = OpenPort(pty.slave_path());
  auto got = port.ReadAvailable(10ms);
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_TRUE(got->empty());
  ASSERT_TRUE(pty.Write(kReplyR8).ok());
  auto more = port.ReadAvailable(5s);
  ASSERT_TRUE(more.ok()) << more.status();
  // A pty may hand the bytes over in pieces: collect until all 8 came.
  while (more->size() < kReplyR8.size()) {
    auto rest = port.ReadAvailable(5s);
    ASSERT_TRUE(rest.ok()) << rest.status();
    ASSERT_FALSE(rest->empty());
    more->insert(more->end(), rest->begin(), rest->end());
  }
  EXPECT_EQ(*more, kReplyR8);
}

TEST(SerialPort, Flush_GarbageQueued_DiscardedThenCleanReply) {
  PseudoTerminal pty = OpenPty();
  SerialPort port = OpenPort(pty.slave_path());
  ASSERT_TRUE(pty.Write(Bytes{0xDE, 0xAD, 0xBE, 0xEF, 0x00}).ok());
  // Wait until the garbage is really queued on the slave before flushing it.
  auto first = port.ReadExactly(1, 5s);
  ASSERT_TRUE(first.ok()) << first.status();
  ASSERT_TRUE(port.Flush().ok());
  EXPECT_EQ(port.counters().flushes, 1u);
  auto nothing = port.ReadAvailable(10ms);
  ASSERT_TRUE(nothing.ok());
  EXPECT_TRUE(nothing->empty());
  ASSERT_TRUE(pty.Write(kReplyR8).ok());
  auto got = port.ReadExactly(8, 5s);
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(*got, kReplyR8);
}

TEST(SerialPort, Wake_BlockedRead_ReleasedPromptly) {
  PseudoTerminal pty = OpenPty();
  SerialPort port = OpenPort(pty.slave_path());
  auto reader = std::async(std::launch::async, [&] { return port.ReadExactly(9, 60s); });
  std::this_thread::sleep_for(20ms);  // let the reader block; the result holds either way
  port.Wake();
  ASSERT_EQ(reader.wait_for(10s), std::future_status::ready) << "Wake did not release the read";
  auto got = reader.get();
  ASSERT_FALSE(got.ok());
  EXPECT_EQ(got.status().code(), absl::StatusCode::kCancelled);
  EXPECT_EQ(port.counters().wakeups, 1u);
}

TEST(SerialPort, SendBreak_OnPty_SucceedsAndIsCounted) {
  PseudoTerminal pty = OpenPty();
  SerialPort port = OpenPort(pty.slave_path());
  // §2.7 / G-39: on a pty the break is accepted and delivers nothing to the master.
  EXPECT_TRUE(port.SendBreak(5ms).ok());
  EXPECT_EQ(port.counters().breaks, 1u);
  auto seen = pty.ReadAvailable(10ms);
  ASSERT_TRUE(seen.ok());
  EXPECT_TRUE(seen->empty());
}

TEST(SerialPort, Open_MissingDevice_NamesDeviceAndErrno) {
  SerialConfig c;
  c.device = "/dev/drivegw-no-such-tty";
  auto s = SerialPort::Open(c);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(s.status().message(), HasSubstr("/dev/drivegw-no-such-tty"));
  EXPECT_THAT(s.status().message(), HasSubstr("No such file or directory"));
}

TEST(SerialPort, Open_NotATerminal_InvalidArgument) {
  SerialConfig c;
  c.device = "/dev/null";
  auto s = SerialPort::Open(c);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.status().message(), HasSubstr("/dev/null"));
}

TEST(SerialPort, Open_BadBaud_NamesFieldAndAllowedList) {
  PseudoTerminal pty = OpenPty();
  SerialConfig c;
  c.device = pty.slave_path();
  c.baud = 12345;
  auto s = SerialPort::Open(c);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.status().message(), HasSubstr("serial.baud: 12345"));
  EXPECT_THAT(s.status().message(), HasSubstr("1200, 1800, 2400"));
  EXPECT_THAT(s.status().message(), HasSubstr("921600"));
}

TEST(SerialPort, Open_EmptyDeviceOrNegativeTurnaround_NamesField) {
  SerialConfig c;
  auto empty = SerialPort::Open(c);
  ASSERT_FALSE(empty.ok());
  EXPECT_THAT(empty.status().message(), HasSubstr("serial.device"));
  c.device = "/dev/null";
  c.turnaround = -1us;
  auto negative = SerialPort::Open(c);
  ASSERT_FALSE(negative.ok());
  EXPECT_THAT(negative.status().message(), HasSubstr("serial.turnaround"));
}

TEST(SerialPort, Move_ConstructAndAssign_NewOwnerWorksOldIsClosed) {
  PseudoTerminal pty = OpenPty();
  SerialPort a = OpenPort(pty.slave_path());
  SerialPort b(std::move(a));
  EXPECT_FALSE(a.is_open());  // NOLINT(bugprone-use-after-move): moved-from state is defined
  EXPECT_EQ(a.Write(kRequest).code(), absl::StatusCode::kFailedPrecondition);
  ASSERT_TRUE(b.Write(kRequest).ok());
  PseudoTerminal other = OpenPty();
  SerialPort c = OpenPort(other.slave_path());
  c = std::move(b);
  EXPECT_TRUE(c.is_open());
  EXPECT_EQ(c.config().device, pty.slave_path());
  EXPECT_EQ(c.counters().bytes_out, 9u);
  ASSERT_TRUE(c.Write(kRequest).ok());
  auto got = pty.ReadExactly(18, 5s);
  ASSERT_TRUE(got.ok()) << got.status();
}

TEST(SerialPort, Write_HalfDuplex_ReturnsNoEarlierThanTurnaround) {
  PseudoTerminal pty = OpenPty();
  constexpr auto kTurnaround = 30ms;
  SerialPort port = OpenPort(pty.slave_path(), 19200, SerialConfig::Duplex::kHalfRs485,
                             std::chrono::duration_cast<std::chrono::microseconds>(kTurnaround));
  const auto start = Clock::now();
  ASSERT_TRUE(port.Write(kRequest).ok());
  // The last byte left after `start`, so Write must not return before start + turnaround.
  EXPECT_GE(Clock::now() - start, kTurnaround);
  auto got = pty.ReadExactly(9, 5s);
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(*got, kRequest);

  // The PACK's line-release guard: after a received byte, Write waits the turnaround again.
  ASSERT_TRUE(pty.Write(kReplyR8).ok());
  auto reply = port.ReadExactly(8, 5s);
  ASSERT_TRUE(reply.ok()) << reply.status();
  const auto after_reply = Clock::now();
  ASSERT_TRUE(port.Write(kRequest).ok());
  EXPECT_GE(Clock::now() - after_reply, 2 * kTurnaround);
}

TEST(PseudoTerminal, Symlink_CreatedAndRemovedOnDestruction) {
  const std::string link = TempPath("link");
  ::unlink(link.c_str());
  std::string slave;
  {
    PseudoTerminal pty = OpenPty(link);
    slave = pty.slave_path();
    EXPECT_EQ(pty.symlink_path(), link);
    struct stat st {};
    ASSERT_EQ(::lstat(link.c_str(), &st), 0);
    EXPECT_TRUE(S_ISLNK(st.st_mode));
    // The simulator's clients open the link, not the /dev/pts name.
    SerialPort port = OpenPort(link);
    ASSERT_TRUE(port.Write(kRequest).ok());
    auto got = pty.ReadExactly(9, 5s);
    ASSERT_TRUE(got.ok()) << got.status();
  }
  struct stat st {};
  EXPECT_NE(::lstat(link.c_str(), &st), 0) << "symlink left behind";
}

TEST(PseudoTerminal, Symlink_StaleLinkReplacedRegularFileRefused) {
  const std::string link = TempPath("stale");
  ::unlink(link.c_str());
  ASSERT_EQ(::symlink("/dev/drivegw-gone", link.c_str()), 0);
  {
    PseudoTerminal pty = OpenPty(link);
    EXPECT_EQ(pty.symlink_path(), link);
  }
  const std::string file = TempPath("file");
  {
    FILE* f = std::fopen(file.c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fclose(f);
  }
  auto refused = PseudoTerminal::Open(file);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kAlreadyExists);
  EXPECT_THAT(refused.status().message(), HasSubstr(file));
  ::unlink(file.c_str());
}

TEST(PseudoTerminal, Move_SymlinkOwnershipFollows) {
  const std::string link = TempPath("move");
  ::unlink(link.c_str());
  {
    PseudoTerminal a = OpenPty(link);
    PseudoTerminal b(std::move(a));
    EXPECT_EQ(a.master_fd(), -1);  // NOLINT(bugprone-use-after-move)
    EXPECT_GE(b.master_fd(), 0);
    { PseudoTerminal gone = std::move(a); }  // destroying the moved-from one keeps the link
    struct stat st {};
    EXPECT_EQ(::lstat(link.c_str(), &st), 0);
  }
  struct stat st {};
  EXPECT_NE(::lstat(link.c_str(), &st), 0);
}

TEST(PseudoTerminal, ReadExactly_Timeout_PartialPayload) {
  PseudoTerminal pty = OpenPty();
  SerialPort port = OpenPort(pty.slave_path());
  ASSERT_TRUE(port.Write(std::span(kRequest).first(3)).ok());
  auto got = pty.ReadExactly(9, 30ms);
  ASSERT_FALSE(got.ok());
  EXPECT_EQ(got.status().code(), absl::StatusCode::kDeadlineExceeded);
  EXPECT_THAT(PartialReadBytes(got.status()), ElementsAre(0x01, 0x40, 0x82));
}

}  // namespace
}  // namespace drivegw::transport
