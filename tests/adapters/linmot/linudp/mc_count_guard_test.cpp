// McCountGuard (decision 1461): when the MC block may be omitted, and which echo shows that a
// stale telegram was executed.
#include "adapters/linmot/linudp/mc_count_guard.h"

#include <gtest/gtest.h>

#include <initializer_list>

namespace drivegw::linmot::linudp {
namespace {

using V = McCountGuard::Verdict;

// A guard through which `counts` were sent and echoed in order, from a drive showing 0.
McCountGuard Accepted(std::initializer_list<uint8_t> counts) {
  McCountGuard g;
  uint8_t echo = 0;
  for (const uint8_t c : counts) {
    g.Arm(c, echo);
    EXPECT_EQ(g.OnEcho(c), V::kEcho);
    echo = c;
  }
  return g;
}

TEST(McCountGuard, NothingArmed_NoVerdict) {
  McCountGuard g;
  EXPECT_EQ(g.OnEcho(3), V::kNone);
}

TEST(McCountGuard, PreviousCountUntilEchoed_NotStale_ThenEcho) {
  McCountGuard g;
  g.Arm(1, 0);
  EXPECT_EQ(g.OnEcho(0), V::kNone);
  EXPECT_EQ(g.OnEcho(1), V::kEcho);
  g.Arm(2, 1);
  EXPECT_EQ(g.OnEcho(1), V::kNone);  // not interpreted yet: the drive still shows 1
  EXPECT_EQ(g.OnEcho(2), V::kEcho);
  EXPECT_TRUE(g.echoed());
}

TEST(McCountGuard, EchoBackToSupersededCount_Stale_ThenAdopted) {
  McCountGuard g = Accepted({1, 2});
  EXPECT_EQ(g.OnEcho(1), V::kStale);
  EXPECT_EQ(g.current(), 1);
  EXPECT_EQ(g.OnEcho(1), V::kEcho);   // the same state again: not reported twice
  EXPECT_EQ(g.OnEcho(2), V::kStale);  // a stale telegram of command 2 after that
}

TEST(McCountGuard, OlderCountWhilePending_Stale) {
  McCountGuard g = Accepted({1, 2});
  g.Arm(3, 2);
  EXPECT_EQ(g.OnEcho(1), V::kStale);  // neither what the drive showed (2) nor the new count (3)
}

TEST(McCountGuard, UnknownBaseWhilePending_NotJudged) {
  McCountGuard g;
  g.Arm(1, std::nullopt);
  g.Arm(2, std::nullopt);
  EXPECT_EQ(g.OnEcho(1), V::kNone);
}

TEST(McCountGuard, EchoZeroAfterReboot_NeverStale) {
  McCountGuard g = Accepted({1});
  EXPECT_EQ(g.OnEcho(0), V::kNone);
}

TEST(McCountGuard, CountNeverOurs_NotStale) {
  McCountGuard g;
  g.Arm(5, 4);  // 4: the drive's count from before this activation
  EXPECT_EQ(g.OnEcho(5), V::kEcho);
  EXPECT_EQ(g.OnEcho(4), V::kNone);  // another master or an earlier session: not ours to judge
  EXPECT_EQ(g.OnEcho(9), V::kNone);
}

TEST(McCountGuard, ReusedCountAfterWrap_LiveAgain) {
  McCountGuard g = Accepted({1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15});  // the ring
  g.Arm(1, 15);  // count 1 again: live, not superseded
  EXPECT_EQ(g.OnEcho(1), V::kEcho);
  EXPECT_EQ(g.OnEcho(15), V::kStale);
}

TEST(McCountGuard, Reset_ForgetsEverything) {
  McCountGuard g = Accepted({1, 2});
  g.Reset();
  EXPECT_FALSE(g.current().has_value());
  EXPECT_EQ(g.OnEcho(1), V::kNone);
}

}  // namespace
}  // namespace drivegw::linmot::linudp
