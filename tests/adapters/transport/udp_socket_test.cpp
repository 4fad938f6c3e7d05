// UdpSocket and Endpoint tests on real loopback sockets (port 0, so runs never collide).
#include "adapters/transport/udp_socket.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <future>
#include <thread>
#include <unordered_set>
#include <vector>

#include "absl/container/flat_hash_set.h"
#include "adapters/transport/endpoint.h"

namespace drivegw::transport {
namespace {

using ::testing::HasSubstr;
using namespace std::chrono_literals;
using Bytes = std::vector<uint8_t>;

UdpSocket BindLoopback() {
  auto s = UdpSocket::Bind(Endpoint{Endpoint::kLoopback, 0});
  EXPECT_TRUE(s.ok()) << s.status();
  return std::move(s).value();
}

// Receives with a generous deadline: datagrams on loopback arrive at once, the bound only
// keeps a broken test from hanging.
std::optional<Datagram> ReceiveOne(UdpSocket& s) {
  auto d = s.Receive(5s);
  EXPECT_TRUE(d.ok()) << d.status();
  return d.ok() ? *d : std::nullopt;
}

// ---- Endpoint ------------------------------------------------------------------------------

TEST(EndpointParse, NumericIpv4_HostOrder) {
  auto e = Endpoint::Parse("192.168.1.17", 49360);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_EQ(e->ipv4, 0xC0A80111u);
  EXPECT_EQ(e->port, 49360);
  EXPECT_EQ(e->ToString(), "192.168.1.17:49360");
}

TEST(EndpointParse, LocalhostAndAny_Accepted) {
  EXPECT_EQ(*Endpoint::Parse("localhost", 1), (Endpoint{Endpoint::kLoopback, 1}));
  EXPECT_EQ(*Endpoint::Parse("127.0.0.1", 2), (Endpoint{0x7F000001, 2}));
  EXPECT_EQ(*Endpoint::Parse("0.0.0.0", 0), (Endpoint{Endpoint::kAny, 0}));
  EXPECT_EQ(Endpoint::Parse("255.255.255.255", 65535)->ToString(), "255.255.255.255:65535");
}

TEST(EndpointParse, NotNumericIpv4_InvalidArgumentNamesHost) {
  for (const char* host : {"", "example.com", "256.1.1.1", "1.2.3", "1.2.3.4.5", " 127.0.0.1",
                           "127.0.0.1 ", "::1", "127.0.0.1:80", "LOCALHOST"}) {
    auto e = Endpoint::Parse(host, 49360);
    ASSERT_FALSE(e.ok()) << host;
    EXPECT_EQ(e.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(e.status().message(), HasSubstr(std::string("'") + host + "'"));
  }
}

TEST(EndpointResolve, NumericAndLocalhost_AsParse) {
  EXPECT_EQ(*Endpoint::Resolve("192.168.1.17", 7), *Endpoint::Parse("192.168.1.17", 7));
  EXPECT_EQ(*Endpoint::Resolve("localhost", 8), (Endpoint{Endpoint::kLoopback, 8}));
}

TEST(EndpointResolve, HostNameFromTheResolver_FirstIpv4) {
  // The machine's own name is in /etc/hosts on Debian (and in every Docker container): it goes
  // through getaddrinfo like a compose service name goes through Docker's DNS.
  char name[256] = {};
  ASSERT_EQ(gethostname(name, sizeof(name) - 1), 0);
  auto e = Endpoint::Resolve(name, 49360);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_NE(e->ipv4, Endpoint::kAny) << e->ToString();
  EXPECT_EQ(e->port, 49360);
}

TEST(EndpointResolve, UnknownName_UnavailableNamingHost) {
  // RFC 6761: .invalid never resolves.
  auto e = Endpoint::Resolve("no-such-drive.invalid", 49360);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(e.status().message(), HasSubstr("'no-such-drive.invalid'"));
  EXPECT_EQ(Endpoint::Resolve("", 1).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(Endpoint, EqualityAndHash_UseAddressAndPort) {
  const Endpoint a{0x7F000002, 49360};
  const Endpoint b{0x7F000002, 49360};
  const Endpoint c{0x7F000002, 41136};
  const Endpoint d{0x7F000003, 49360};
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  EXPECT_NE(a, d);
  std::unordered_set<Endpoint> std_set = {a, b, c, d};
  EXPECT_EQ(std_set.size(), 3u);
  absl::flat_hash_set<Endpoint> absl_set = {a, b, c, d};
  EXPECT_EQ(absl_set.size(), 3u);
}

// ---- Bind ----------------------------------------------------------------------------------

TEST(UdpSocketBind, PortZero_GetsEphemeralPort) {
  UdpSocket s = BindLoopback();
  EXPECT_NE(s.local_port(), 0);
  EXPECT_EQ(s.local_endpoint().ipv4, Endpoint::kLoopback);
}

TEST(UdpSocketBind, AddressNotLocal_ErrorNamesAddressAndErrno) {
  // 192.0.2.1 is TEST-NET-1: never assigned to this host.
  auto s = UdpSocket::Bind(Endpoint{0xC0000201, 41136});
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(s.status().message(), HasSubstr("192.0.2.1:41136"));
  EXPECT_THAT(s.status().message(), HasSubstr("Cannot assign requested address"));
}

TEST(UdpSocketBind, PortInUseWithoutReuse_Unavailable) {
  UdpSocket first = BindLoopback();
  auto second = UdpSocket::Bind(first.local_endpoint(), {.reuse_address = false});
  ASSERT_FALSE(second.ok());
  EXPECT_EQ(second.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(second.status().message(), HasSubstr(first.local_endpoint().ToString()));
  EXPECT_THAT(second.status().message(), HasSubstr("Address already in use"));
}

TEST(UdpSocketBind, PortInUseWithReuse_SecondBindSucceeds) {
  // Linux semantics of SO_REUSEADDR for UDP (docs/decisions/202-udp-reuseaddr.md): only when
  // both sockets opt in.
  auto first = UdpSocket::Bind(Endpoint{Endpoint::kLoopback, 0}, {.reuse_address = true});
  ASSERT_TRUE(first.ok()) << first.status();
  auto second = UdpSocket::Bind(first->local_endpoint(), {.reuse_address = true});
  EXPECT_TRUE(second.ok()) << second.status();
}

// ---- send / receive ------------------------------------------------------------------------

TEST(UdpSocket, SendTo_Loopback_ReceivedWithSourceAndBytes) {
  UdpSocket a = BindLoopback();
  UdpSocket b = BindLoopback();
  const Bytes payload = {0x00, 0x00, 0x00, 0x00, 0x7F, 0x00, 0x00, 0x00};
  ASSERT_TRUE(a.SendTo(b.local_endpoint(), payload).ok());
  auto d = ReceiveOne(b);
  ASSERT_TRUE(d.has_value());
  EXPECT_EQ(d->bytes, payload);
  EXPECT_EQ(d->from, a.local_endpoint());
  EXPECT_EQ(a.counters().sent, 1u);
  EXPECT_EQ(b.counters().received, 1u);
}

TEST(UdpSocket, SeveralDatagrams_ArriveWholeAndInOrder) {
  UdpSocket a = BindLoopback();
  UdpSocket b = BindLoopback();
  for (uint8_t i = 0; i < 20; ++i) {
    ASSERT_TRUE(a.SendTo(b.local_endpoint(), Bytes(size_t{i} + 1, i)).ok());
  }
  for (uint8_t i = 0; i < 20; ++i) {
    auto d = ReceiveOne(b);
    ASSERT_TRUE(d.has_value());
    EXPECT_EQ(d->bytes, Bytes(size_t{i} + 1, i));
  }
}

TEST(UdpSocket, EmptyAndLargeDatagrams_Delivered) {
  UdpSocket a = BindLoopback();
  UdpSocket b = BindLoopback();
  ASSERT_TRUE(a.SendTo(b.local_endpoint(), Bytes{}).ok());
  Bytes big(9000);
  for (size_t i = 0; i < big.size(); ++i) big[i] = static_cast<uint8_t>(i * 7);
  ASSERT_TRUE(a.SendTo(b.local_endpoint(), big).ok());
  auto empty = ReceiveOne(b);
  ASSERT_TRUE(empty.has_value());
  EXPECT_TRUE(empty->bytes.empty());
  auto large = ReceiveOne(b);
  ASSERT_TRUE(large.has_value());
  EXPECT_EQ(large->bytes, big);
}

TEST(UdpSocket, OversizedSend_UnavailableAndCounted) {
  UdpSocket a = BindLoopback();
  UdpSocket b = BindLoopback();
  const Bytes too_big(UdpSocket::kMaxDatagramSize + 1);
  auto status = a.SendTo(b.local_endpoint(), too_big);
  EXPECT_EQ(status.code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(status.message(), HasSubstr(b.local_endpoint().ToString()));
  EXPECT_EQ(a.counters().send_errors, 1u);
  EXPECT_EQ(a.counters().sent, 0u);
}

TEST(UdpSocket, Receive_Timeout_NulloptWithinBounds) {
  UdpSocket s = BindLoopback();
  const auto start = std::chrono::steady_clock::now();
  auto d = s.Receive(50ms);
  const auto elapsed = std::chrono::steady_clock::now() - start;
  ASSERT_TRUE(d.ok()) << d.status();
  EXPECT_FALSE(d->has_value());
  EXPECT_GE(elapsed, 50ms);
  EXPECT_LT(elapsed, 1s);  // loose upper bound: a loaded 2-core CI machine
}

TEST(UdpSocket, Receive_SubMillisecondTimeout_StillWaitsAtLeastThatLong) {
  UdpSocket s = BindLoopback();
  const auto start = std::chrono::steady_clock::now();
  auto d = s.Receive(300us);
  ASSERT_TRUE(d.ok()) << d.status();
  EXPECT_FALSE(d->has_value());
  EXPECT_GE(std::chrono::steady_clock::now() - start, 300us);
}

TEST(UdpSocket, Receive_ZeroOrNegativeTimeout_ReturnsAtOnce) {
  UdpSocket s = BindLoopback();
  const auto start = std::chrono::steady_clock::now();
  auto zero = s.Receive(0ns);
  auto negative = s.Receive(-5s);
  ASSERT_TRUE(zero.ok());
  ASSERT_TRUE(negative.ok());
  EXPECT_FALSE(zero->has_value());
  EXPECT_FALSE(negative->has_value());
  EXPECT_LT(std::chrono::steady_clock::now() - start, 1s);
}

TEST(UdpSocket, Receive_ZeroTimeoutWithPendingDatagram_ReturnsIt) {
  UdpSocket a = BindLoopback();
  UdpSocket b = BindLoopback();
  ASSERT_TRUE(a.SendTo(b.local_endpoint(), Bytes{1, 2, 3}).ok());
  // Loopback delivery is synchronous in sendto, so the datagram is queued already.
  auto d = b.Receive(0ns);
  ASSERT_TRUE(d.ok());
  ASSERT_TRUE(d->has_value());
  EXPECT_EQ((*d)->bytes, (Bytes{1, 2, 3}));
}

// ---- Wake / Shutdown -----------------------------------------------------------------------

TEST(UdpSocket, Wake_ReleasesBlockedReceive) {
  UdpSocket s = BindLoopback();
  const auto start = std::chrono::steady_clock::now();
  auto receiver = std::async(std::launch::async, [&s] { return s.Receive(30s); });
  s.Wake();  // before or during the wait: either way the receiver returns at once
  ASSERT_EQ(receiver.wait_for(5s), std::future_status::ready);
  auto d = receiver.get();
  ASSERT_TRUE(d.ok()) << d.status();
  EXPECT_FALSE(d->has_value());
  EXPECT_LT(std::chrono::steady_clock::now() - start, 5s);
  // The wake-up was consumed: the socket works normally afterwards.
  auto again = s.Receive(10ms);
  ASSERT_TRUE(again.ok());
  EXPECT_FALSE(again->has_value());
}

TEST(UdpSocket, Wake_ReleasesReceiveWithMaximalTimeout) {
  UdpSocket s = BindLoopback();
  auto receiver =
      std::async(std::launch::async, [&s] { return s.Receive(std::chrono::nanoseconds::max()); });
  s.Wake();
  ASSERT_EQ(receiver.wait_for(5s), std::future_status::ready);
  auto d = receiver.get();
  ASSERT_TRUE(d.ok()) << d.status();
  EXPECT_FALSE(d->has_value());
}

TEST(UdpSocket, Wake_BeforeReceive_NextReceiveReturnsAtOnceOnlyOnce) {
  UdpSocket a = BindLoopback();
  UdpSocket s = BindLoopback();
  s.Wake();
  auto woken = s.Receive(30s);
  ASSERT_TRUE(woken.ok());
  EXPECT_FALSE(woken->has_value());
  ASSERT_TRUE(a.SendTo(s.local_endpoint(), Bytes{9}).ok());
  auto d = ReceiveOne(s);
  ASSERT_TRUE(d.has_value());
  EXPECT_EQ(d->bytes, Bytes{9});
}

TEST(UdpSocket, Shutdown_ReleasesEveryBlockedReceiveWithCancelled) {
  UdpSocket s = BindLoopback();
  std::vector<std::future<absl::StatusOr<std::optional<Datagram>>>> receivers;
  for (int i = 0; i < 3; ++i) {
    receivers.push_back(std::async(std::launch::async, [&s] { return s.Receive(30s); }));
  }
  s.Shutdown();
  for (auto& r : receivers) {
    ASSERT_EQ(r.wait_for(5s), std::future_status::ready);
    auto d = r.get();
    ASSERT_FALSE(d.ok());
    EXPECT_EQ(d.status().code(), absl::StatusCode::kCancelled);
  }
  EXPECT_TRUE(s.is_shut_down());
  EXPECT_EQ(s.Receive(0ns).status().code(), absl::StatusCode::kCancelled);
  EXPECT_EQ(s.SendTo(Endpoint{Endpoint::kLoopback, 9}, Bytes{1}).code(),
            absl::StatusCode::kFailedPrecondition);
  s.Shutdown();  // idempotent
}

TEST(UdpSocket, ConcurrentSendAndReceive_AllDatagramsCounted) {
  UdpSocket a = BindLoopback();
  UdpSocket b = BindLoopback();
  constexpr int kCount = 200;
  auto receiver = std::async(std::launch::async, [&b] {
    int got = 0;
    const auto deadline = std::chrono::steady_clock::now() + 10s;
    while (got < kCount && std::chrono::steady_clock::now() < deadline) {
      auto d = b.Receive(100ms);
      if (d.ok() && d->has_value()) ++got;
    }
    return got;
  });
  for (int i = 0; i < kCount; ++i) {
    ASSERT_TRUE(a.SendTo(b.local_endpoint(), Bytes{static_cast<uint8_t>(i)}).ok());
  }
  EXPECT_EQ(receiver.get(), kCount);
  EXPECT_EQ(a.counters().sent, static_cast<uint64_t>(kCount));
  EXPECT_EQ(b.counters().received, static_cast<uint64_t>(kCount));
}

// ---- move ----------------------------------------------------------------------------------

TEST(UdpSocket, Move_TransfersSocketAndCounters) {
  UdpSocket a = BindLoopback();
  UdpSocket b = BindLoopback();
  ASSERT_TRUE(a.SendTo(b.local_endpoint(), Bytes{1}).ok());
  const Endpoint b_addr = b.local_endpoint();
  UdpSocket moved(std::move(b));
  EXPECT_EQ(moved.local_endpoint(), b_addr);
  auto d = ReceiveOne(moved);
  ASSERT_TRUE(d.has_value());
  UdpSocket assigned = BindLoopback();
  assigned = std::move(moved);
  EXPECT_EQ(assigned.counters().received, 1u);
  ASSERT_TRUE(a.SendTo(b_addr, Bytes{2}).ok());
  auto d2 = ReceiveOne(assigned);
  ASSERT_TRUE(d2.has_value());
  EXPECT_EQ(d2->bytes, Bytes{2});
}

TEST(UdpSocket, Destructor_ClosesPortForExclusiveRebind) {
  Endpoint addr;
  {
    UdpSocket s = BindLoopback();
    addr = s.local_endpoint();
  }
  auto again = UdpSocket::Bind(addr, {.reuse_address = false});
  EXPECT_TRUE(again.ok()) << again.status();
}

// Issue 10 (P2): one recvmmsg takes every queued datagram into the caller's buffers, with the
// source of each; longer datagrams are cut and flagged.
TEST(UdpSocket, ReceiveBatch_TakesQueuedDatagramsIntoCallerBuffers) {
  UdpSocket a = BindLoopback();
  UdpSocket b = BindLoopback();
  UdpSocket rx = BindLoopback();
  ASSERT_TRUE(a.SendTo(rx.local_endpoint(), Bytes{1, 2, 3}).ok());
  ASSERT_TRUE(b.SendTo(rx.local_endpoint(), Bytes{4}).ok());
  ASSERT_TRUE(a.SendTo(rx.local_endpoint(), Bytes(10, 7)).ok());
  std::array<std::array<uint8_t, 4>, 8> buffers{};
  std::array<DatagramSlot, 8> slots{};
  for (size_t i = 0; i < slots.size(); ++i) slots[i].buffer = buffers[i];
  size_t total = 0;
  std::vector<std::pair<Endpoint, Bytes>> got;
  while (total < 3) {
    auto n = rx.ReceiveBatch(slots, 2s);
    ASSERT_TRUE(n.ok()) << n.status();
    ASSERT_GT(*n, 0u) << "time-out with " << total << " of 3 datagrams";
    for (size_t i = 0; i < *n; ++i) {
      got.emplace_back(slots[i].from,
                       Bytes(slots[i].buffer.begin(), slots[i].buffer.begin() + slots[i].size));
      EXPECT_EQ(slots[i].truncated, slots[i].size == 4 && got.back().second == Bytes(4, 7));
    }
    total += *n;
  }
  ASSERT_EQ(got.size(), 3u);
  EXPECT_EQ(got[0], (std::pair{a.local_endpoint(), Bytes{1, 2, 3}}));
  EXPECT_EQ(got[1], (std::pair{b.local_endpoint(), Bytes{4}}));
  EXPECT_EQ(got[2], (std::pair{a.local_endpoint(), Bytes(4, 7)}));  // cut to the buffer
  EXPECT_EQ(rx.counters().received, 3u);
  EXPECT_EQ(rx.counters().truncated, 1u);
  // Nothing queued: TryReceiveBatch does not wait.
  auto none = rx.TryReceiveBatch(slots);
  ASSERT_TRUE(none.ok());
  EXPECT_EQ(*none, 0u);
}

TEST(UdpSocket, ReceiveBatch_WakeEndsTheWaitAndShutdownCancels) {
  UdpSocket rx = BindLoopback();
  std::array<uint8_t, 16> buffer{};
  std::array<DatagramSlot, 1> slots{};
  slots[0].buffer = buffer;
  rx.Wake();
  auto woken = rx.ReceiveBatch(slots, 24h);  // returns at once: a wake-up is pending
  ASSERT_TRUE(woken.ok());
  EXPECT_EQ(*woken, 0u);
  rx.Shutdown();
  EXPECT_TRUE(absl::IsCancelled(rx.ReceiveBatch(slots, 24h).status()));
  EXPECT_TRUE(absl::IsCancelled(rx.TryReceiveBatch(slots).status()));
}

TEST(UdpSocket, SendBatch_EveryDatagramToItsDestination) {
  UdpSocket tx = BindLoopback();
  UdpSocket r1 = BindLoopback();
  UdpSocket r2 = BindLoopback();
  const Bytes one{1}, two{2, 2};
  // More than one sendmmsg call's worth, alternating destinations.
  std::vector<OutgoingDatagram> out;
  for (size_t i = 0; i < UdpSocket::kMaxBatch + 6; ++i) {
    out.push_back(i % 2 == 0 ? OutgoingDatagram{r1.local_endpoint(), one}
                             : OutgoingDatagram{r2.local_endpoint(), two});
  }
  std::vector<size_t> failed;
  auto sent = tx.SendBatch(out, &failed);
  ASSERT_TRUE(sent.ok()) << sent.status();
  EXPECT_EQ(*sent, out.size());
  EXPECT_TRUE(failed.empty());
  EXPECT_EQ(tx.counters().sent, out.size());
  for (size_t i = 0; i < out.size() / 2; ++i) {
    auto d1 = ReceiveOne(r1);
    auto d2 = ReceiveOne(r2);
    ASSERT_TRUE(d1.has_value() && d2.has_value()) << "datagram pair " << i;
    EXPECT_EQ(d1->bytes, one);
    EXPECT_EQ(d2->bytes, two);
    EXPECT_EQ(d1->from, tx.local_endpoint());
  }
  tx.Shutdown();
  EXPECT_EQ(tx.SendBatch(out).status().code(), absl::StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace drivegw::transport
