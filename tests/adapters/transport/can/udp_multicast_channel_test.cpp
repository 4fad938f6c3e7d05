// UDP multicast CAN bus on this host: channels in one process and across processes, own
// frames, filters, counters, malformed datagrams, Wake, tracing, and the no-route error.
#include "adapters/transport/udp_multicast_channel.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sched.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "adapters/transport/candump_trace.h"
#include "adapters/transport/msgpack_lite.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace drivegw::transport {
namespace {

using std::chrono::milliseconds;
using std::chrono::seconds;
using ::testing::HasSubstr;

constexpr char kTestGroup[] = "239.74.163.77";  // not python-can's default: no stray traffic

// A port no other test (here or in a concurrent ctest process) uses at the same time.
uint16_t UniquePort() {
  static std::atomic<int> next{0};
  return static_cast<uint16_t>(20000 + (::getpid() * 16 + next++) % 40000);
}

UdpMulticastChannel::Options Bus(uint16_t port, std::string group = kTestGroup) {
  UdpMulticastChannel::Options o;
  o.group = std::move(group);
  o.port = port;
  return o;
}

std::unique_ptr<UdpMulticastChannel> OpenOrDie(const UdpMulticastChannel::Options& o) {
  auto ch = UdpMulticastChannel::Open(o);
  EXPECT_TRUE(ch.ok()) << ch.status();
  return ch.ok() ? *std::move(ch) : nullptr;
}

// Raw datagram to the group, as any other program on the bus could send it.
void SendRaw(const std::string& group, uint16_t port, const std::vector<uint8_t>& bytes) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(port);
  ::inet_pton(AF_INET, group.c_str(), &to.sin_addr);
  ASSERT_EQ(
      ::sendto(fd, bytes.data(), bytes.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof(to)),
      static_cast<ssize_t>(bytes.size()));
  ::close(fd);
}

CanFrame Data(uint32_t id, std::initializer_list<uint8_t> bytes, bool extended = false) {
  const std::vector<uint8_t> v(bytes);
  return MakeCanFrame(id, v, extended);
}

TEST(UdpMulticastChannel, TwoChannels_ExchangeBothWays) {
  const uint16_t port = UniquePort();
  auto a = OpenOrDie(Bus(port));
  auto b = OpenOrDie(Bus(port));
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->name(), absl::StrCat("udp:", kTestGroup, ":", port));
  const CanFrame ab = Data(0x42E, {0x00, 0x4B, 0x03, 0x01, 0x03});
  ASSERT_TRUE(a->Send(ab).ok());
  auto got = b->Receive(seconds(5));
  ASSERT_TRUE(got.ok()) << got.status();
  ASSERT_TRUE(got->has_value());
  EXPECT_EQ(**got, ab);

  const CanFrame ba_ext = Data(0x1ABCDEF0, {1, 2, 3, 4, 5, 6, 7, 8}, true);
  const CanFrame ba_rtr = MakeCanRtrFrame(0x7FF, 6);
  ASSERT_TRUE(b->Send(ba_ext).ok());
  ASSERT_TRUE(b->Send(ba_rtr).ok());
  auto g1 = a->Receive(seconds(5));
  auto g2 = a->Receive(seconds(5));
  ASSERT_TRUE(g1.ok() && g1->has_value() && g2.ok() && g2->has_value());
  EXPECT_EQ(**g1, ba_ext);
  EXPECT_EQ(**g2, ba_rtr);
  EXPECT_EQ(a->state(), CanBusState::kActive);
}

TEST(UdpMulticastChannel, OwnFrames_NotReturned) {
  const uint16_t port = UniquePort();
  auto a = OpenOrDie(Bus(port));
  auto b = OpenOrDie(Bus(port));
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(a->Send(Data(0x100, {1})).ok());
  ASSERT_TRUE(b->Receive(seconds(5))->has_value());  // it was on the bus
  auto own = a->Receive(milliseconds(200));
  ASSERT_TRUE(own.ok());
  EXPECT_FALSE(own->has_value());
  EXPECT_EQ(a->counters().rx, 0u);
  EXPECT_EQ(a->counters().dropped_malformed, 0u);
}

TEST(UdpMulticastChannel, Burst_AllInOrder) {
  const uint16_t port = UniquePort();
  auto a = OpenOrDie(Bus(port));
  auto b = OpenOrDie(Bus(port));
  ASSERT_TRUE(a && b);
  constexpr int kFrames = 2000;  // more than one socket send buffer holds
  // The receiver drains concurrently, as a session's I/O thread does.
  std::vector<CanFrame> got;
  std::thread receiver([&] {
    const auto deadline = std::chrono::steady_clock::now() + seconds(20);
    while (got.size() < kFrames && std::chrono::steady_clock::now() < deadline) {
      auto f = b->Receive(milliseconds(100));
      if (f.ok() && f->has_value()) got.push_back(**f);
    }
  });
  for (int i = 0; i < kFrames; ++i) {
    const absl::Status sent = a->Send(Data(
        static_cast<uint32_t>(i % 0x800), {static_cast<uint8_t>(i), static_cast<uint8_t>(i >> 8)}));
    if (!sent.ok()) {
      ADD_FAILURE() << i << ": " << sent;  // no ASSERT: the receiver thread must be joined
      break;
    }
  }
  receiver.join();
  ASSERT_EQ(got.size(), static_cast<size_t>(kFrames));
  for (int i = 0; i < kFrames; ++i) {
    ASSERT_EQ(got[i].id, static_cast<uint32_t>(i % 0x800));
    ASSERT_EQ(got[i].data[0] | (got[i].data[1] << 8), i);
  }
  EXPECT_EQ(a->counters().tx, static_cast<uint64_t>(kFrames));
  EXPECT_EQ(b->counters().rx, static_cast<uint64_t>(kFrames));
}

TEST(UdpMulticastChannel, Filters_IdMaskFormat) {
  const uint16_t port = UniquePort();
  auto a = OpenOrDie(Bus(port));
  auto b = OpenOrDie(Bus(port));
  ASSERT_TRUE(a && b);
  const std::vector<CanFilter> filters{{0x400, 0x700, false}, {0x18FF0000, 0x1FFF0000, true}};
  ASSERT_TRUE(b->SetFilters(filters).ok());
  for (const CanFrame& f : {Data(0x300, {}), Data(0x4FF, {1}), Data(0x400, {}, true),
                            Data(0x18FF1234, {2}, true), Data(0x18FE0000, {}, true)}) {
    ASSERT_TRUE(a->Send(f).ok());
  }
  auto f1 = b->Receive(seconds(5));
  auto f2 = b->Receive(seconds(5));
  ASSERT_TRUE(f1.ok() && f1->has_value() && f2.ok() && f2->has_value());
  EXPECT_EQ(FormatCanFrame(**f1), "4FF#01");
  EXPECT_EQ(FormatCanFrame(**f2), "18FF1234#02");
  EXPECT_FALSE(b->Receive(milliseconds(100))->has_value());
  // Cleared: everything again.
  ASSERT_TRUE(b->SetFilters({}).ok());
  ASSERT_TRUE(a->Send(Data(0x300, {})).ok());
  EXPECT_TRUE(b->Receive(seconds(5))->has_value());
  const std::vector<CanFilter> bad{{0x800, 0, false}};
  EXPECT_EQ(b->SetFilters(bad).code(), absl::StatusCode::kInvalidArgument);
}

TEST(UdpMulticastChannel, MalformedDatagrams_CountedDroppedBusSurvives) {
  const uint16_t port = UniquePort();
  auto a = OpenOrDie(Bus(port));
  ASSERT_TRUE(a);
  SendRaw(kTestGroup, port, {0xc1});                             // never-used byte
  SendRaw(kTestGroup, port, {0x81, 0xa3, 'd', 'l', 'c', 0x09});  // dlc 9, no data
  SendRaw(kTestGroup, port, std::vector<uint8_t>(5000, 0x90));   // oversize
  SendRaw(kTestGroup, port, {});                                 // empty
  SendRaw(kTestGroup, port, EncodePythonCanMessage(Data(0x55, {5}), 1.0));
  auto f = a->Receive(seconds(5));
  ASSERT_TRUE(f.ok() && f->has_value());
  EXPECT_EQ(FormatCanFrame(**f), "055#05");
  EXPECT_EQ(a->counters().dropped_malformed, 4u);
  EXPECT_EQ(a->counters().rx, 1u);
}

TEST(UdpMulticastChannel, ErrorFrameFromPeer_CountedNotReturned) {
  const uint16_t port = UniquePort();
  auto a = OpenOrDie(Bus(port));
  ASSERT_TRUE(a);
  CanFrame err;
  err.error = true;
  err.extended = true;
  err.id = 0x40;
  err.dlc = 8;
  SendRaw(kTestGroup, port, EncodePythonCanMessage(err, 1.0));
  EXPECT_FALSE(a->Receive(milliseconds(300))->has_value());
  EXPECT_EQ(a->counters().error_frames, 1u);
  EXPECT_EQ(a->counters().rx, 0u);
}

TEST(UdpMulticastChannel, OtherGroupSamePort_NotMixedIn) {
  const uint16_t port = UniquePort();
  auto a = OpenOrDie(Bus(port, "239.74.163.78"));
  auto other = OpenOrDie(Bus(port, "239.74.163.79"));
  ASSERT_TRUE(a && other);
  ASSERT_TRUE(other->Send(Data(0x1, {})).ok());
  EXPECT_FALSE(a->Receive(milliseconds(200))->has_value());
  EXPECT_EQ(a->counters().dropped_malformed, 0u);
}

TEST(UdpMulticastChannel, Wake_ReleasesBlockedReceive) {
  auto a = OpenOrDie(Bus(UniquePort()));
  ASSERT_TRUE(a);
  const auto start = std::chrono::steady_clock::now();
  std::thread waker([&] {
    std::this_thread::sleep_for(milliseconds(50));  // let Receive block first; not a sync point
    a->Wake();
  });
  auto r = a->Receive(seconds(30));
  waker.join();
  ASSERT_TRUE(r.ok());
  EXPECT_FALSE(r->has_value());
  EXPECT_LT(std::chrono::steady_clock::now() - start, seconds(10));
  // A wake-up before Receive is kept for the next call.
  a->Wake();
  EXPECT_FALSE(a->Receive(seconds(30))->has_value());
}

TEST(UdpMulticastChannel, Receive_TimesOut) {
  auto a = OpenOrDie(Bus(UniquePort()));
  ASSERT_TRUE(a);
  const auto start = std::chrono::steady_clock::now();
  auto r = a->Receive(milliseconds(30));
  ASSERT_TRUE(r.ok());
  EXPECT_FALSE(r->has_value());
  EXPECT_GE(std::chrono::steady_clock::now() - start, milliseconds(30));
  EXPECT_FALSE(a->Receive(std::chrono::nanoseconds(-5))->has_value());
}

TEST(UdpMulticastChannel, Send_InvalidFrame_RefusedNotCounted) {
  auto a = OpenOrDie(Bus(UniquePort()));
  ASSERT_TRUE(a);
  EXPECT_EQ(a->Send(Data(0x800, {})).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(a->counters().tx, 0u);
  EXPECT_EQ(a->counters().tx_errors, 0u);
}

TEST(UdpMulticastChannel, Open_Errors) {
  auto unicast = UdpMulticastChannel::Open(Bus(5000, "10.0.0.1"));
  EXPECT_EQ(unicast.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(unicast.status().message(),
            "udp:10.0.0.1:5000: group '10.0.0.1' is not an IPv4 multicast address (224.0.0.0/4)");
  auto garbage = UdpMulticastChannel::Open(Bus(5000, "bus"));
  EXPECT_EQ(garbage.status().message(), "udp:bus:5000: group 'bus' is not an IPv4 address");
  auto port0 = UdpMulticastChannel::Open(Bus(0));
  EXPECT_THAT(std::string(port0.status().message()), HasSubstr("port 0 is not a bus port"));
}

TEST(UdpMulticastChannel, AcrossProcesses_ExchangeBothWays) {
  const uint16_t port = UniquePort();
  auto parent = OpenOrDie(Bus(port));
  ASSERT_TRUE(parent);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // Child: no gtest assertions; the exit code says what went wrong.
    auto ch = UdpMulticastChannel::Open(Bus(port));
    if (!ch.ok()) ::_exit(10);
    if (!(*ch)->Send(Data(0x123, {0xC0, 0xDE})).ok()) ::_exit(11);
    for (int i = 0; i < 50; ++i) {
      auto f = (*ch)->Receive(milliseconds(100));
      if (!f.ok()) ::_exit(12);
      if (f->has_value()) ::_exit(FormatCanFrame(**f) == "00000321#ACED" ? 0 : 13);
      // The parent answers only after hearing us; resend in case it missed the first one.
      if (!(*ch)->Send(Data(0x123, {0xC0, 0xDE})).ok()) ::_exit(11);
    }
    ::_exit(14);
  }
  auto hello = parent->Receive(seconds(10));
  ASSERT_TRUE(hello.ok() && hello->has_value());
  EXPECT_EQ(FormatCanFrame(**hello), "123#C0DE");
  ASSERT_TRUE(parent->Send(Data(0x321, {0xAC, 0xED}, true)).ok());
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
}

TEST(UdpMulticastChannel, OpenCanChannel_TracesBothDirections) {
  const std::string path = absl::StrCat(std::getenv("TMPDIR") ? std::getenv("TMPDIR") : "/tmp",
                                        "/dgw_udp_trace.", ::getpid(), ".log");
  ::unlink(path.c_str());
  const uint16_t port = UniquePort();
  CanBusConfig config;
  config.kind = CanBusConfig::Kind::kUdpMulticast;
  config.group = kTestGroup;
  config.port = port;
  config.trace_file = path;
  auto traced = OpenCanChannel(config);
  ASSERT_TRUE(traced.ok()) << traced.status();
  auto peer = OpenOrDie(Bus(port));
  ASSERT_TRUE(peer);
  ASSERT_TRUE((*traced)->Send(Data(0x42E, {0x00, 0x4B, 0x03, 0x01, 0x03})).ok());
  ASSERT_TRUE(peer->Receive(seconds(5))->has_value());
  ASSERT_TRUE(peer->Send(MakeCanRtrFrame(0x1F, 2)).ok());
  ASSERT_TRUE((*traced)->Receive(seconds(5))->has_value());
  std::ifstream in(path);
  std::vector<CandumpRecord> records;
  for (std::string line; std::getline(in, line);) {
    auto r = ParseCandumpLine(line);
    ASSERT_TRUE(r.ok()) << line;
    records.push_back(*r);
  }
  ASSERT_EQ(records.size(), 2u);
  EXPECT_EQ(records[0].interface, (*traced)->name());
  EXPECT_EQ(FormatCanFrame(records[0].frame), "42E#004B030103");
  EXPECT_EQ(records[0].direction, CanDirection::kTx);
  EXPECT_EQ(FormatCanFrame(records[1].frame), "01F#R2");
  EXPECT_EQ(records[1].direction, CanDirection::kRx);
  ::unlink(path.c_str());
}

// In a fresh network namespace (only lo, no routes) the bus cannot work; the error must say
// what to do. Needs CAP_SYS_ADMIN for unshare(CLONE_NEWNET): skipped without it.
TEST(UdpMulticastChannel, NoMulticastRoute_ErrorSaysWhatToDo) {
  int pipe_fds[2];
  ASSERT_EQ(::pipe(pipe_fds), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::close(pipe_fds[0]);
    std::string out;
    if (::unshare(CLONE_NEWNET) != 0) {
      out = "SKIP";
    } else {
      auto ch = UdpMulticastChannel::Open(Bus(43113, "239.74.163.2"));
      out = ch.ok() ? "OPENED" : std::string(ch.status().ToString());
    }
    [[maybe_unused]] ssize_t n = ::write(pipe_fds[1], out.data(), out.size());
    ::_exit(0);
  }
  ::close(pipe_fds[1]);
  std::string text;
  char buf[512];
  for (ssize_t n; (n = ::read(pipe_fds[0], buf, sizeof(buf))) > 0;)
    text.append(buf, static_cast<size_t>(n));
  ::close(pipe_fds[0]);
  ::waitpid(child, nullptr, 0);
  if (text == "SKIP") GTEST_SKIP() << "unshare(CLONE_NEWNET) not permitted here";
  EXPECT_THAT(text, HasSubstr("UNAVAILABLE: udp:239.74.163.2:43113:"));
  EXPECT_THAT(text, HasSubstr("ip route add 224.0.0.0/4 dev lo"));
}

}  // namespace
}  // namespace drivegw::transport
