// ImpairedCanChannel over the real user-space CAN bus (UDP multicast): drop, duplicate,
// reorder, delay and corrupt applied per frame from the seed, in the send and the receive
// direction; validation naming the field; Wake; stopping the loss.
#include "adapters/transport/impaired_can_channel.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <map>
#include <thread>
#include <vector>

#include "adapters/transport/udp_multicast_channel.h"

namespace drivegw::transport {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;

constexpr char kGroup[] = "239.74.163.78";  // a group of its own: no stray traffic

uint16_t UniquePort() {
  static std::atomic<int> next{0};
  return static_cast<uint16_t>(60000 + (::getpid() * 8 + next++) % 5000);
}

std::unique_ptr<CanChannel> Open(uint16_t port) {
  UdpMulticastChannel::Options o;
  o.group = kGroup;
  o.port = port;
  auto ch = UdpMulticastChannel::Open(o);
  EXPECT_TRUE(ch.ok()) << ch.status();
  return ch.ok() ? std::unique_ptr<CanChannel>(*std::move(ch)) : nullptr;
}

CanFrame Numbered(uint16_t n) {
  const std::vector<uint8_t> bytes = {
      static_cast<uint8_t>(n), static_cast<uint8_t>(n >> 8), 0xA5, 0xA5, 0xA5, 0xA5, 0xA5, 0xA5};
  return MakeCanFrame(0x181, bytes);
}

// Everything `rx` receives until the bus has been quiet for `quiet`.
std::vector<CanFrame> Drain(CanChannel& rx, std::chrono::milliseconds quiet = 300ms) {
  std::vector<CanFrame> out;
  for (;;) {
    auto f = rx.Receive(quiet);
    EXPECT_TRUE(f.ok()) << f.status();
    if (!f.ok() || !f->has_value()) return out;
    out.push_back(**f);
  }
}

TEST(ImpairedCanChannel, SendSide_DropDuplicateReorder_AsDecided) {
  const uint16_t port = UniquePort();
  auto rx = Open(port);
  const Impairment imp{.drop_probability = 0.2,
                       .duplicate_probability = 0.1,
                       .reorder_probability = 0.1,
                       .seed = 21};
  auto tx = ImpairedCanChannel::Wrap(Open(port), imp, Impairment{});
  ASSERT_TRUE(tx.ok()) << tx.status();
  constexpr int kN = 200;
  for (uint16_t i = 0; i < kN; ++i) {
    ASSERT_TRUE((*tx)->Send(Numbered(i)).ok());
    if (i % 20 == 19) std::this_thread::sleep_for(2ms);  // pacing, not timing: no socket overrun
  }
  const std::vector<CanFrame> got = Drain(*rx);
  const ImpairedLinkCounters c = (*tx)->impaired_counters().send;
  EXPECT_EQ(c.decided, static_cast<uint64_t>(kN));
  EXPECT_GT(c.dropped, 0u);
  EXPECT_GT(c.duplicated, 0u);
  EXPECT_GT(c.reordered, 0u);
  std::map<int, int> copies;
  int out_of_order = 0, last = -1;
  for (const CanFrame& f : got) {
    const int n = f.data[0] | (f.data[1] << 8);
    ++copies[n];
    if (n < last) ++out_of_order;
    last = std::max(last, n);
  }
  // A frame held for reordering at the very end is still held: at most one missing for that.
  const uint64_t expected = kN - c.dropped + c.duplicated;
  EXPECT_GE(got.size() + 1, expected);
  EXPECT_LE(got.size(), expected);
  EXPECT_GE(copies.size() + 1, kN - c.dropped);
  for (const auto& [n, k] : copies) EXPECT_LE(k, 2) << n;
  EXPECT_GT(out_of_order, 0);

  // Same seed, same fate: a second run drops the same sequence numbers.
  const uint16_t port2 = UniquePort();
  auto rx2 = Open(port2);
  auto tx2 = ImpairedCanChannel::Wrap(Open(port2), imp, Impairment{});
  ASSERT_TRUE(tx2.ok());
  for (uint16_t i = 0; i < kN; ++i) {
    ASSERT_TRUE((*tx2)->Send(Numbered(i)).ok());
    if (i % 20 == 19) std::this_thread::sleep_for(2ms);
  }
  std::map<int, int> copies2;
  for (const CanFrame& f : Drain(*rx2)) ++copies2[f.data[0] | (f.data[1] << 8)];
  EXPECT_EQ(copies, copies2);
}

TEST(ImpairedCanChannel, ReceiveSide_DropAllThenStopTheLoss) {
  const uint16_t port = UniquePort();
  auto tx = Open(port);
  auto rx = ImpairedCanChannel::Wrap(Open(port), Impairment{}, Impairment{.drop_probability = 1});
  ASSERT_TRUE(rx.ok());
  for (uint16_t i = 0; i < 10; ++i) ASSERT_TRUE(tx->Send(Numbered(i)).ok());
  EXPECT_TRUE(Drain(**rx, 200ms).empty());
  EXPECT_EQ((*rx)->impaired_counters().receive.dropped, 10u);
  ASSERT_TRUE((*rx)->SetImpairment(Impairment{}, Impairment{}).ok());
  for (uint16_t i = 10; i < 15; ++i) ASSERT_TRUE(tx->Send(Numbered(i)).ok());
  const auto got = Drain(**rx);
  ASSERT_EQ(got.size(), 5u);
  EXPECT_EQ(got[0].data[0], 10);
  EXPECT_EQ(got[4].data[0], 14);
}

TEST(ImpairedCanChannel, Corrupt_CutsTheDlcOnACopy) {
  const uint16_t port = UniquePort();
  auto tx = Open(port);
  auto rx =
      ImpairedCanChannel::Wrap(Open(port), Impairment{}, Impairment{.corrupt_probability = 1});
  ASSERT_TRUE(rx.ok());
  const CanFrame original = Numbered(7);
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(tx->Send(original).ok());
  const auto got = Drain(**rx);
  ASSERT_EQ(got.size(), 20u);
  for (const CanFrame& f : got) {
    EXPECT_LT(f.dlc, original.dlc);
    EXPECT_EQ(f.id, original.id);
    for (size_t b = 0; b < f.dlc; ++b) EXPECT_EQ(f.data[b], original.data[b]);
  }
  EXPECT_EQ((*rx)->impaired_counters().receive.corrupted, 20u);
}

TEST(ImpairedCanChannel, Delay_EveryFrameArrivesInOrder) {
  const uint16_t port = UniquePort();
  auto rx = Open(port);
  auto tx = ImpairedCanChannel::Wrap(
      Open(port), Impairment{.delay_min = 5ms, .delay_max = 5ms, .seed = 3}, Impairment{});
  ASSERT_TRUE(tx.ok());
  for (uint16_t i = 0; i < 10; ++i) ASSERT_TRUE((*tx)->Send(Numbered(i)).ok());
  const auto got = Drain(*rx);
  ASSERT_EQ(got.size(), 10u);
  for (uint16_t i = 0; i < 10; ++i) EXPECT_EQ(got[i].data[0], i);
  EXPECT_EQ((*tx)->impaired_counters().send.delayed, 10u);
}

TEST(ImpairedCanChannel, ReceiveDelay_BlockedReceiveGetsTheFrame) {
  const uint16_t port = UniquePort();
  auto tx = Open(port);
  auto rx = ImpairedCanChannel::Wrap(Open(port), Impairment{},
                                     Impairment{.delay_min = 5ms, .delay_max = 5ms});
  ASSERT_TRUE(rx.ok());
  ASSERT_TRUE(tx->Send(Numbered(1)).ok());
  auto f = (*rx)->Receive(10s);
  ASSERT_TRUE(f.ok());
  ASSERT_TRUE(f->has_value());
  EXPECT_EQ((**f).data[0], 1);
}

TEST(ImpairedCanChannel, Wake_ReturnsNulloptAtOnce) {
  auto rx = ImpairedCanChannel::Wrap(Open(UniquePort()), Impairment{}, Impairment{});
  ASSERT_TRUE(rx.ok());
  (*rx)->Wake();
  auto f = (*rx)->Receive(60s);  // would block a minute without the wake
  ASSERT_TRUE(f.ok());
  EXPECT_FALSE(f->has_value());
}

TEST(ImpairedCanChannel, BadImpairment_InvalidArgumentNamingDirectionAndField) {
  auto a =
      ImpairedCanChannel::Wrap(Open(UniquePort()), Impairment{.drop_probability = 2}, Impairment{});
  EXPECT_EQ(a.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(a.status().message(), HasSubstr("send impairment.drop_probability: 2"));
  auto b = ImpairedCanChannel::Wrap(Open(UniquePort()), Impairment{},
                                    Impairment{.corrupt_probability = -1});
  EXPECT_THAT(b.status().message(), HasSubstr("receive impairment.corrupt_probability"));
  auto c = ImpairedCanChannel::Wrap(nullptr, Impairment{}, Impairment{});
  EXPECT_EQ(c.status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace drivegw::transport
