// SocketCAN back end on a real kernel interface. Self-contained (links dgw_transport only) so
// tests/socketcan-vm can copy it into a VM: DGW_CAN_IFACE=vcan0 runs the bus tests; without
// it they skip, and only the open-error tests run (this host's kernel has no AF_CAN).
#include "adapters/transport/socketcan_channel.h"

#include <linux/can.h>
#include <linux/can/raw.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "adapters/transport/can_channel.h"
#include "adapters/transport/candump_trace.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace drivegw::transport {
namespace {

using std::chrono::milliseconds;
using std::chrono::seconds;
using ::testing::HasSubstr;
using ::testing::StartsWith;

// errno of socket(PF_CAN, SOCK_RAW, CAN_RAW) on this kernel; 0 when it works.
int CanSocketErrno() {
  const int fd = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
  if (fd < 0) return errno;
  ::close(fd);
  return 0;
}

const char* Iface() { return std::getenv("DGW_CAN_IFACE"); }

#define REQUIRE_CAN_IFACE()                                                               \
  do {                                                                                    \
    if (Iface() == nullptr || *Iface() == '\0') {                                         \
      GTEST_SKIP() << "DGW_CAN_IFACE is not set: these tests need a SocketCAN interface " \
                      "(tests/socketcan-vm runs them on vcan0 inside a VM)";              \
    }                                                                                     \
  } while (false)

std::unique_ptr<SocketCanChannel> OpenOrDie(const std::string& iface) {
  SocketCanChannel::Options o;
  o.interface = iface;
  o.min_backoff = milliseconds(20);
  o.max_backoff = milliseconds(200);
  auto ch = SocketCanChannel::Open(o);
  EXPECT_TRUE(ch.ok()) << ch.status();
  return ch.ok() ? *std::move(ch) : nullptr;
}

CanFrame Data(uint32_t id, std::initializer_list<uint8_t> bytes, bool extended = false) {
  const std::vector<uint8_t> v(bytes);
  return MakeCanFrame(id, v, extended);
}

// Frames a channel receives within `timeout`, until `n` arrived.
std::vector<std::string> ReceiveN(CanChannel& ch, size_t n,
                                  milliseconds timeout = milliseconds(2000)) {
  std::vector<std::string> out;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (out.size() < n && std::chrono::steady_clock::now() < deadline) {
    auto f = ch.Receive(milliseconds(100));
    if (!f.ok()) {
      out.push_back("ERROR " + std::string(f.status().message()));
      break;
    }
    if (f->has_value()) out.push_back(FormatCanFrame(**f));
  }
  return out;
}

TEST(SocketCanOpen, NoKernelCan_ErrorSaysSo) {
  const int err = CanSocketErrno();
  if (err == 0) GTEST_SKIP() << "this kernel has AF_CAN; the no-SocketCAN message cannot occur";
  auto ch = SocketCanChannel::Open({.interface = "can0"});
  ASSERT_FALSE(ch.ok());
  EXPECT_EQ(ch.status().code(), absl::StatusCode::kUnavailable);
  if (err == EAFNOSUPPORT) {
    EXPECT_THAT(std::string(ch.status().message()),
                StartsWith("can.socketcan.interface 'can0': this kernel has no SocketCAN "
                           "(EAFNOSUPPORT)"));
  } else {
    EXPECT_THAT(std::string(ch.status().message()), StartsWith("can.socketcan.interface 'can0': "));
  }
  // Through the factory too, as the gateway opens it from config.
  CanBusConfig config;
  config.kind = CanBusConfig::Kind::kSocketCan;
  config.interface = "can0";
  EXPECT_THAT(std::string(OpenCanChannel(config).status().message()),
              StartsWith("can.socketcan.interface 'can0': "));
}

TEST(SocketCanOpen, UnknownInterface_ErrorSaysEnodev) {
  if (CanSocketErrno() != 0) GTEST_SKIP() << "no AF_CAN in this kernel: ENODEV cannot be reached";
  auto ch = SocketCanChannel::Open({.interface = "dgwnosuch0"});
  ASSERT_FALSE(ch.ok());
  EXPECT_EQ(ch.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(ch.status().message(),
            "can.socketcan.interface 'dgwnosuch0': no such interface (ENODEV)");
}

TEST(SocketCanOpen, BadInterfaceName_InvalidArgument) {
  for (const char* name : {"", "sixteen-chars-xx"}) {
    auto ch = SocketCanChannel::Open({.interface = name});
    EXPECT_EQ(ch.status().code(), absl::StatusCode::kInvalidArgument) << name;
    EXPECT_THAT(std::string(ch.status().message()),
                HasSubstr("an interface name has 1..15 characters"));
  }
}

TEST(SocketCan, SendReceive_BothWays_AllFrameKinds) {
  REQUIRE_CAN_IFACE();
  auto a = OpenOrDie(Iface());
  auto b = OpenOrDie(Iface());
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->name(), Iface());
  EXPECT_EQ(a->state(), CanBusState::kActive);
  ASSERT_TRUE(a->Send(Data(0x42E, {0x00, 0x4B, 0x03, 0x01, 0x03})).ok());
  ASSERT_TRUE(a->Send(Data(0x000, {})).ok());
  ASSERT_TRUE(a->Send(Data(0x1ABCDEF0, {1, 2, 3, 4, 5, 6, 7, 8}, true)).ok());
  ASSERT_TRUE(a->Send(MakeCanRtrFrame(0x7FF, 3)).ok());
  ASSERT_TRUE(a->Send(MakeCanRtrFrame(0x1234567, 0, true)).ok());
  EXPECT_THAT(ReceiveN(*b, 5),
              ::testing::ElementsAre("42E#004B030103", "000#", "1ABCDEF0#0102030405060708",
                                     "7FF#R3", "01234567#R"));
  ASSERT_TRUE(b->Send(Data(0x123, {0xAA})).ok());
  EXPECT_THAT(ReceiveN(*a, 1), ::testing::ElementsAre("123#AA"));
  EXPECT_EQ(a->counters().tx, 5u);
  EXPECT_EQ(b->counters().rx, 5u);
  EXPECT_EQ(a->counters().rx, 1u);
}

TEST(SocketCan, OwnFrames_NotReturned) {
  REQUIRE_CAN_IFACE();
  auto a = OpenOrDie(Iface());
  auto b = OpenOrDie(Iface());
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(a->Send(Data(0x100, {1})).ok());
  EXPECT_THAT(ReceiveN(*b, 1), ::testing::ElementsAre("100#01"));
  auto own = a->Receive(milliseconds(200));
  ASSERT_TRUE(own.ok());
  EXPECT_FALSE(own->has_value());
}

TEST(SocketCan, KernelFilters_IdMaskFormat) {
  REQUIRE_CAN_IFACE();
  auto a = OpenOrDie(Iface());
  auto b = OpenOrDie(Iface());
  ASSERT_TRUE(a && b);
  const std::vector<CanFilter> filters{{0x400, 0x700, false}, {0x18FF0000, 0x1FFF0000, true}};
  ASSERT_TRUE(b->SetFilters(filters).ok());
  for (const CanFrame& f :
       {Data(0x300, {}), Data(0x4FF, {1}), Data(0x400, {}, true), Data(0x18FF1234, {2}, true),
        Data(0x18FE0000, {}, true), MakeCanRtrFrame(0x401, 1)}) {
    ASSERT_TRUE(a->Send(f).ok());
  }
  EXPECT_THAT(ReceiveN(*b, 4, milliseconds(500)),
              ::testing::ElementsAre("4FF#01", "18FF1234#02", "401#R1"));
  ASSERT_TRUE(b->SetFilters({}).ok());
  ASSERT_TRUE(a->Send(Data(0x300, {})).ok());
  EXPECT_THAT(ReceiveN(*b, 1), ::testing::ElementsAre("300#"));
}

TEST(SocketCan, Wake_ReleasesBlockedReceive) {
  REQUIRE_CAN_IFACE();
  auto a = OpenOrDie(Iface());
  ASSERT_TRUE(a);
  std::thread waker([&] {
    std::this_thread::sleep_for(milliseconds(50));  // not a sync point: an early Wake counts too
    a->Wake();
  });
  const auto start = std::chrono::steady_clock::now();
  auto r = a->Receive(seconds(30));
  waker.join();
  ASSERT_TRUE(r.ok());
  EXPECT_FALSE(r->has_value());
  EXPECT_LT(std::chrono::steady_clock::now() - start, seconds(10));
}

TEST(SocketCan, Burst_AllInOrder) {
  REQUIRE_CAN_IFACE();
  auto a = OpenOrDie(Iface());
  auto b = OpenOrDie(Iface());
  ASSERT_TRUE(a && b);
  constexpr int kFrames = 200;  // below vcan's default txqueuelen and the socket buffers
  for (int i = 0; i < kFrames; ++i) {
    ASSERT_TRUE(a->Send(Data(static_cast<uint32_t>(i), {static_cast<uint8_t>(i)})).ok()) << i;
  }
  const auto got = ReceiveN(*b, kFrames, milliseconds(5000));
  ASSERT_EQ(got.size(), static_cast<size_t>(kFrames));
  for (int i = 0; i < kFrames; ++i)
    EXPECT_EQ(got[i], FormatCanFrame(Data(static_cast<uint32_t>(i), {static_cast<uint8_t>(i)})));
}

TEST(SocketCan, OpenCanChannel_TraceFile) {
  REQUIRE_CAN_IFACE();
  const std::string path =
      std::string("/tmp/dgw_socketcan_trace.") + std::to_string(::getpid()) + ".log";
  ::unlink(path.c_str());
  CanBusConfig config;
  config.kind = CanBusConfig::Kind::kSocketCan;
  config.interface = Iface();
  config.trace_file = path;
  auto traced = OpenCanChannel(config);
  ASSERT_TRUE(traced.ok()) << traced.status();
  auto peer = OpenOrDie(Iface());
  ASSERT_TRUE(peer);
  ASSERT_TRUE((*traced)->Send(Data(0x42E, {0x00, 0x4B})).ok());
  EXPECT_THAT(ReceiveN(*peer, 1), ::testing::ElementsAre("42E#004B"));
  ASSERT_TRUE(peer->Send(Data(0x10, {7}, true)).ok());
  EXPECT_THAT(ReceiveN(**traced, 1), ::testing::ElementsAre("00000010#07"));
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) {
    auto r = ParseCandumpLine(l);
    ASSERT_TRUE(r.ok()) << l;
    lines.push_back(r->interface + " " + FormatCanFrame(r->frame) +
                    (r->direction == CanDirection::kTx ? " T" : " R"));
  }
  EXPECT_THAT(lines, ::testing::ElementsAre(std::string(Iface()) + " 42E#004B T",
                                            std::string(Iface()) + " 00000010#07 R"));
  ::unlink(path.c_str());
}

// Needs root and iproute2 (the VM test has both): takes the interface down and up again.
TEST(SocketCan, InterfaceDownThenUp_RecoversWithBackoff) {
  REQUIRE_CAN_IFACE();
  if (::geteuid() != 0 || std::system("command -v ip >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "needs root and the ip tool to take " << Iface() << " down";
  }
  auto a = OpenOrDie(Iface());
  auto b = OpenOrDie(Iface());
  ASSERT_TRUE(a && b);
  const std::string iface = Iface();
  ASSERT_EQ(std::system(("ip link set " + iface + " down").c_str()), 0);
  auto sent = a->Send(Data(0x1, {}));
  EXPECT_EQ(sent.code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(std::string(sent.message()), HasSubstr("ENETDOWN"));
  EXPECT_EQ(a->state(), CanBusState::kDown);
  // While down, Send fails at once and Receive keeps retrying on the back-off schedule.
  EXPECT_EQ(a->Send(Data(0x1, {})).code(), absl::StatusCode::kUnavailable);
  EXPECT_FALSE(a->Receive(milliseconds(100))->has_value());
  EXPECT_EQ(a->state(), CanBusState::kDown);
  ASSERT_EQ(std::system(("ip link set " + iface + " up").c_str()), 0);
  const auto deadline = std::chrono::steady_clock::now() + seconds(10);
  while (a->state() != CanBusState::kActive && std::chrono::steady_clock::now() < deadline) {
    ASSERT_TRUE(a->Receive(milliseconds(50)).ok());
  }
  EXPECT_EQ(a->state(), CanBusState::kActive);
  // b saw the down too (on receive) and recovers the same way.
  while (b->state() != CanBusState::kActive && std::chrono::steady_clock::now() < deadline) {
    ASSERT_TRUE(b->Receive(milliseconds(50)).ok());
  }
  ASSERT_TRUE(a->Send(Data(0x2, {2})).ok());
  EXPECT_THAT(ReceiveN(*b, 1), ::testing::ElementsAre("002#02"));
  EXPECT_GE(a->counters().tx_errors, 2u);
}

}  // namespace
}  // namespace drivegw::transport
