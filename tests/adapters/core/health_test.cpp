// The shared device health model (decision 1431): state changes, counting, back-off, errors.
#include "adapters/core/health.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <iostream>
#include <random>
#include <vector>

namespace drivegw {
namespace {
using std::chrono::milliseconds;
using ::testing::HasSubstr;

// up_after 0 by default: the tests of decision 1431's transitions; the hold (decision 1432) has
// its own tests below.
HealthConfig Config(int n, int min_ms, int max_ms, int up_after_ms = 0) {
  HealthConfig c;
  c.down_after_failures = n;
  c.backoff_min = milliseconds(min_ms);
  c.backoff_max = milliseconds(max_ms);
  c.up_after = milliseconds(up_after_ms);
  return c;
}

// The hold's edge, `left` before its end: 1 ms before, a success leaves the drive DEMOTED and
// publishes nothing; at the end, a success makes it UP.
void ExpectUpWhenTheHoldEnds(HealthModel& m, ManualClock& clock, milliseconds left) {
  clock.Advance(left - milliseconds(1));
  EXPECT_FALSE(m.RecordSuccess());
  EXPECT_EQ(m.state(), HealthState::kDemoted);
  clock.Advance(milliseconds(1));
  EXPECT_TRUE(m.RecordSuccess());
  EXPECT_EQ(m.state(), HealthState::kUp);
}

TEST(HealthConfig, DefaultHoldIsTheDocumentedOne) {
  EXPECT_EQ(HealthConfig{}.up_after, milliseconds(3000));  // docs/config.md, decision 1432
}

TEST(HealthModel, StartsDemotedUntilTheFirstReply) {
  ManualClock clock;
  HealthModel m(Config(3, 100, 5000), clock);
  EXPECT_EQ(m.state(), HealthState::kDemoted);
  EXPECT_EQ(m.info().reason, "no reply yet");
  EXPECT_TRUE(m.ProbeDue());  // the first probe is not delayed
  EXPECT_TRUE(m.RecordSuccess());
  EXPECT_EQ(m.state(), HealthState::kUp);
  EXPECT_FALSE(m.RecordSuccess());
}

TEST(HealthModel, ANeverAnsweringDriveGoesDownAtTheCount) {
  ManualClock clock;
  HealthModel m(Config(2, 100, 5000), clock);
  EXPECT_TRUE(m.RecordFailure("time-outs"));
  EXPECT_EQ(m.state(), HealthState::kDemoted);
  EXPECT_TRUE(m.RecordFailure("time-outs"));
  EXPECT_EQ(m.state(), HealthState::kDown);
}

// Without a hold (decision 1431) the next success is UP; with one (decision 1432) the hold counts
// from the success that made it DEMOTED.
TEST(HealthModel, RecoversFromDownThroughDemoted) {
  for (const int hold_ms : {0, 1000}) {
    SCOPED_TRACE(hold_ms);
    ManualClock clock;
    HealthModel m(Config(1, 100, 5000, hold_ms), clock);
    m.RecordSuccess();
    m.RecordFailure("misses");
    ASSERT_EQ(m.state(), HealthState::kDown);
    EXPECT_TRUE(m.RecordSuccess());
    EXPECT_EQ(m.state(), HealthState::kDemoted);
    EXPECT_EQ(m.info().reason, "recovering");
    if (hold_ms == 0) {
      EXPECT_TRUE(m.RecordSuccess());
      EXPECT_EQ(m.state(), HealthState::kUp);
    } else {
      ExpectUpWhenTheHoldEnds(m, clock, milliseconds(hold_ms));
    }
  }
}

TEST(HealthModel, ProbeNotBeforeDelaysOnlyADownLink) {
  ManualClock clock;
  HealthModel m(Config(1, 100, 5000), clock);
  m.RecordSuccess();
  m.ProbeNotBefore(clock.Now() + std::chrono::seconds(1));
  EXPECT_TRUE(m.ProbeDue());
  m.ForceDown("hardware reset");
  m.ProbeNotBefore(clock.Now() + std::chrono::seconds(1));
  clock.Advance(milliseconds(999));
  EXPECT_FALSE(m.ProbeDue());
  clock.Advance(milliseconds(1));
  EXPECT_TRUE(m.ProbeDue());
}

TEST(HealthModel, FailuresDemoteThenDownAtTheConfiguredCount) {
  ManualClock clock;
  HealthModel m(Config(3, 100, 5000), clock);
  m.RecordSuccess();
  m.RecordSuccess();
  EXPECT_TRUE(m.RecordFailure("time-outs"));
  EXPECT_EQ(m.state(), HealthState::kDemoted);
  EXPECT_EQ(m.info().consecutive_failures, 1u);
  EXPECT_TRUE(m.RecordFailure("time-outs"));  // the count is part of the published info
  EXPECT_EQ(m.state(), HealthState::kDemoted);
  EXPECT_TRUE(m.RecordFailure("time-outs"));
  EXPECT_EQ(m.state(), HealthState::kDown);
  EXPECT_EQ(m.info().reason, "3 consecutive time-outs");
  EXPECT_EQ(m.info().consecutive_failures, 3u);
}

TEST(HealthModel, ASuccessBelowTheCountResetsIt) {
  ManualClock clock;
  HealthModel m(Config(2, 100, 5000), clock);
  m.RecordSuccess();
  m.RecordSuccess();
  m.RecordFailure("misses");
  EXPECT_TRUE(m.RecordSuccess());
  EXPECT_EQ(m.state(), HealthState::kUp);
  EXPECT_EQ(m.info().consecutive_failures, 0u);
  m.RecordFailure("misses");
  EXPECT_EQ(m.state(), HealthState::kDemoted);  // counting restarted at 1, below 2
}

TEST(HealthModel, DownAfterOneFailureGoesStraightFromUp) {
  ManualClock clock;
  HealthModel m(Config(1, 100, 5000), clock);
  m.RecordSuccess();
  m.RecordSuccess();
  EXPECT_TRUE(m.RecordFailure("misses"));
  EXPECT_EQ(m.state(), HealthState::kDown);
}

TEST(HealthModel, ProbesOfADownLinkBackOffDoublingToTheCeiling) {
  ManualClock clock;
  HealthModel m(Config(1, 100, 500), clock);
  m.RecordSuccess();
  m.RecordSuccess();
  m.RecordFailure("misses");
  EXPECT_FALSE(m.ProbeDue());
  EXPECT_EQ(m.backoff(), milliseconds(100));
  clock.Advance(milliseconds(99));
  EXPECT_FALSE(m.ProbeDue());
  clock.Advance(milliseconds(1));
  EXPECT_TRUE(m.ProbeDue());
  std::vector<int64_t> seen;
  for (int i = 0; i < 5; ++i) {
    EXPECT_FALSE(m.RecordFailure("misses"));  // a failed probe changes no state
    seen.push_back(m.backoff().count());
    EXPECT_FALSE(m.ProbeDue());
    clock.Advance(m.backoff());
    EXPECT_TRUE(m.ProbeDue());
  }
  EXPECT_EQ(seen, (std::vector<int64_t>{200, 400, 500, 500, 500}));
  EXPECT_EQ(m.failed_probes(), 5u);
  EXPECT_EQ(m.info().consecutive_failures, 1u);  // frozen while DOWN
  // Recovery resets the back-off for the next loss.
  m.RecordSuccess();
  m.RecordSuccess();
  m.RecordFailure("misses");
  EXPECT_EQ(m.backoff(), milliseconds(100));
}

TEST(HealthModel, AFailedFirstProbeWaitsTheMinimum) {
  ManualClock clock;
  HealthModel m(Config(3, 100, 5000), clock);
  m.ForceDown("probe failed");
  EXPECT_EQ(m.backoff(), milliseconds(100));
  clock.Advance(milliseconds(100));
  m.RecordFailure("probe failed");
  EXPECT_EQ(m.backoff(), milliseconds(200));
}

TEST(HealthModel, ZeroBackoffProbesEveryTime) {
  ManualClock clock;
  HealthModel m(Config(1, 0, 0), clock);
  m.RecordSuccess();
  m.RecordFailure("time-outs");
  EXPECT_EQ(m.state(), HealthState::kDown);
  EXPECT_TRUE(m.ProbeDue());
  m.RecordFailure("time-outs");
  EXPECT_TRUE(m.ProbeDue());
}

TEST(HealthModel, ForceDownIgnoresTheCount) {
  ManualClock clock;
  HealthModel m(Config(5, 100, 5000), clock);
  m.RecordSuccess();
  m.RecordSuccess();
  EXPECT_TRUE(m.ForceDown("heartbeat lost"));
  EXPECT_EQ(m.state(), HealthState::kDown);
  EXPECT_EQ(m.info().reason, "heartbeat lost");
  EXPECT_TRUE(m.ForceDown("bus off"));  // the reason is published
  EXPECT_EQ(m.info().reason, "bus off");
  EXPECT_FALSE(m.ForceDown("bus off"));
}

TEST(HealthModel, SinceMovesOnlyOnAStateChange) {
  ManualClock clock;
  HealthModel m(Config(3, 100, 5000), clock);
  m.RecordSuccess();
  m.RecordSuccess();
  m.RecordFailure("x");
  const auto since = m.info().since;
  m.RecordFailure("x");
  EXPECT_EQ(m.info().since, since);
}

// ---- Decision 1432: the hold before a DEMOTED link is UP again.

TEST(HealthModelHold, OneFailureThenSuccesses_DemotedUntilTheHoldPassed) {
  ManualClock clock;
  HealthModel m(Config(3, 100, 5000, 1000), clock);
  ASSERT_TRUE(m.RecordSuccess());
  EXPECT_TRUE(m.RecordFailure("time-outs"));
  EXPECT_EQ(m.state(), HealthState::kDemoted);
  EXPECT_FALSE(m.RecordSuccess());  // starts the hold, publishes nothing
  for (int i = 0; i < 99; ++i) {
    clock.Advance(milliseconds(10));  // up to 990 ms after the first success
    EXPECT_FALSE(m.RecordSuccess()) << i;
  }
  EXPECT_EQ(m.info().consecutive_failures, 1u);
  ExpectUpWhenTheHoldEnds(m, clock, milliseconds(10));  // 1000 ms clean
  EXPECT_EQ(m.info().consecutive_failures, 0u);
  EXPECT_EQ(m.info().reason, "");
}

TEST(HealthModelHold, AFailureInsideTheHoldRestartsIt) {
  ManualClock clock;
  HealthModel m(Config(3, 100, 5000, 1000), clock);
  m.RecordSuccess();
  m.RecordFailure("time-outs");
  m.RecordSuccess();  // hold from t = 0
  clock.Advance(milliseconds(900));
  EXPECT_FALSE(m.RecordFailure("time-outs"));  // a run of 1 again: nothing new to publish
  clock.Advance(milliseconds(200));            // 1100 ms after the first hold started
  EXPECT_FALSE(m.RecordSuccess());             // the hold restarts here
  EXPECT_EQ(m.state(), HealthState::kDemoted);
  ExpectUpWhenTheHoldEnds(m, clock, milliseconds(1000));
}

// Connecting is not flapping: the first reply is UP at once, also after failures below the
// count; a drive that went DOWN before its first reply is recovering and waits the hold.
TEST(HealthModelHold, TheFirstReplyIsUpAtOnceUnlessTheDriveWentDownFirst) {
  ManualClock clock;
  HealthModel connecting(Config(3, 100, 5000, 1000), clock);
  HealthModel down_first(Config(2, 100, 5000, 1000), clock);
  for (HealthModel* m : {&connecting, &down_first}) {
    EXPECT_TRUE(m->RecordFailure("time-outs"));  // the count is published
    EXPECT_TRUE(m->RecordFailure("time-outs"));
    EXPECT_EQ(m->info().consecutive_failures, 2u);
    EXPECT_TRUE(m->RecordSuccess());
  }
  EXPECT_EQ(connecting.state(), HealthState::kUp);
  EXPECT_EQ(down_first.state(), HealthState::kDemoted);
  EXPECT_EQ(down_first.info().reason, "recovering");
  EXPECT_FALSE(down_first.RecordSuccess());
  ExpectUpWhenTheHoldEnds(down_first, clock, milliseconds(1000));
}

TEST(HealthModelHold, InsideDemotedOnlyALongerRunIsPublished) {
  ManualClock clock;
  HealthModel m(Config(4, 100, 5000, 1000), clock);
  m.RecordSuccess();
  EXPECT_TRUE(m.RecordFailure("time-outs"));  // UP -> DEMOTED, 1
  EXPECT_FALSE(m.RecordSuccess());
  EXPECT_FALSE(m.RecordFailure("time-outs"));  // a run of 1: nothing new
  EXPECT_FALSE(m.RecordSuccess());
  EXPECT_FALSE(m.RecordFailure("time-outs"));
  EXPECT_TRUE(m.RecordFailure("time-outs"));  // a run of 2: closer to DOWN, published
  EXPECT_EQ(m.info().consecutive_failures, 2u);
  EXPECT_EQ(m.info().reason, "2 consecutive time-outs");
  EXPECT_FALSE(m.RecordSuccess());
  EXPECT_FALSE(m.RecordFailure("time-outs"));
  EXPECT_FALSE(m.RecordFailure("time-outs"));  // 2 again
  EXPECT_TRUE(m.RecordFailure("time-outs"));   // 3
  EXPECT_TRUE(m.RecordFailure("time-outs"));   // 4: DOWN, counted from the current run
  EXPECT_EQ(m.state(), HealthState::kDown);
  EXPECT_EQ(m.info().reason, "4 consecutive time-outs");
  EXPECT_EQ(m.info().consecutive_failures, 4u);
}

TEST(HealthModelHold, ZeroHoldIsTheBehaviourOfDecision1431) {
  ManualClock clock;
  HealthModel m(Config(3, 100, 5000, 0), clock);
  m.RecordSuccess();
  EXPECT_TRUE(m.RecordFailure("time-outs"));
  EXPECT_TRUE(m.RecordSuccess());
  EXPECT_EQ(m.state(), HealthState::kUp);
}

// Published changes of a model fed `exchanges` outcomes, one per 10 ms of the manual clock.
struct Outcomes {
  int changes = 0;
  int state_changes = 0;
  HealthState last = HealthState::kDemoted;
};
template <typename Fails>
Outcomes Feed(HealthModel& m, ManualClock& clock, int exchanges, Fails fails) {
  Outcomes r;
  for (int i = 0; i < exchanges; ++i) {
    const HealthState before = m.state();
    const bool changed = fails(i) ? m.RecordFailure("time-outs") : m.RecordSuccess();
    r.changes += changed ? 1 : 0;
    r.state_changes += m.state() != before ? 1 : 0;
    clock.Advance(milliseconds(10));
  }
  r.last = m.state();
  return r;
}

// The pattern of issue 11: every 10th exchange of a 10 ms poll lost, for 60 simulated seconds.
TEST(HealthModelHold, TenPercentLossFor60s_DemotedSteadilyWithTwoChanges) {
  auto every_tenth = [](int i) { return i % 10 == 9; };
  ManualClock c0;
  HealthModel without(Config(3, 0, 0, 0), c0);
  const Outcomes flapping = Feed(without, c0, 6000, every_tenth);
  ManualClock c1;
  HealthConfig config = Config(3, 0, 0);
  config.up_after = HealthConfig{}.up_after;
  HealthModel with(config, c1);
  const Outcomes held = Feed(with, c1, 6000, every_tenth);
  std::cout << "[ measured ] every 10th of 6000 exchanges (10 ms, 60 s) lost: " << flapping.changes
            << " published changes without the hold, " << held.changes << " with up_after "
            << HealthConfig{}.up_after.count() << " ms\n";
  // First reply UP, then UP <-> DEMOTED per lost exchange: 1 + 600 + 599.
  EXPECT_EQ(flapping.changes, 1200);
  // First reply UP, the first loss DEMOTED; the later runs of 1 publish nothing.
  EXPECT_EQ(held.changes, 2);
  EXPECT_EQ(held.last, HealthState::kDemoted);
  // The loss stops: UP once the hold passed, one more change.
  const Outcomes clean = Feed(with, c1, 400, [](int) { return false; });
  EXPECT_EQ(clean.changes, 1);
  EXPECT_EQ(clean.last, HealthState::kUp);
}

// Random loss over a simulated hour (seeded): whatever the rate, UP needs a clean hold, so the
// published changes are bounded per hold window: (UP spells + 1) x (down_after_failures + 1).
TEST(HealthModelHold, RandomLossForAnHour_ChangesBoundedPerHoldWindow) {
  constexpr int kExchanges = 360000;  // 1 h at 10 ms
  constexpr int kN = 5;               // the LinUDP default (linudp.lost_after_timeouts)
  const milliseconds hold = HealthConfig{}.up_after;
  const int64_t windows = 3600000 / hold.count();
  for (const double p : {0.001, 0.0033, 0.01, 0.1}) {
    std::mt19937_64 rng(1432);
    std::bernoulli_distribution lost(p);
    std::vector<bool> pattern(kExchanges);
    for (int i = 0; i < kExchanges; ++i) pattern[i] = lost(rng);
    auto fails = [&](int i) { return pattern[static_cast<size_t>(i)]; };
    ManualClock c0;
    HealthModel without(Config(kN, 0, 0, 0), c0);
    const Outcomes before = Feed(without, c0, kExchanges, fails);
    ManualClock c1;
    HealthConfig config = Config(kN, 0, 0);
    config.up_after = hold;
    HealthModel with(config, c1);
    const Outcomes after = Feed(with, c1, kExchanges, fails);
    std::cout << "[ measured ] loss " << p * 100 << " % for 1 h at 10 ms: " << before.changes
              << " changes (" << before.state_changes << " of state) without the hold, "
              << after.changes << " (" << after.state_changes << ") with " << hold.count()
              << " ms\n";
    EXPECT_LE(after.changes, (windows + 2) * (kN + 1)) << p;
    EXPECT_LT(after.changes, before.changes) << p;
  }
}

TEST(HealthConfigValidation, NamesTheKeyAndTheLimit) {
  EXPECT_TRUE(ValidateHealthConfig(Config(3, 100, 5000), "drives[0].health.").ok());
  absl::Status s = ValidateHealthConfig(Config(0, 100, 5000), "drives[0].health.");
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("drives[0].health.down_after_failures: 0 is outside 1..1000"));
  s = ValidateHealthConfig(Config(3, 600, 500), "h.");
  EXPECT_THAT(s.message(), HasSubstr("h.backoff_min_ms: 600 is outside 0..500 (h.backoff_max_ms)"));
  s = ValidateHealthConfig(Config(3, 0, 600001), "h.");
  EXPECT_THAT(s.message(), HasSubstr("h.backoff_max_ms: 600001 is outside 0..600000"));
  s = ValidateHealthConfig(Config(3, -1, 5), "h.");
  EXPECT_THAT(s.message(), HasSubstr("h.backoff_min_ms: -1"));
  EXPECT_TRUE(ValidateHealthConfig(Config(3, 0, 0, 600000), "h.").ok());
  s = ValidateHealthConfig(Config(3, 0, 0, 600001), "h.");
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("h.up_after_ms: 600001 is outside 0..600000"));
  s = ValidateHealthConfig(Config(3, 0, 0, -1), "h.");
  EXPECT_THAT(s.message(), HasSubstr("h.up_after_ms: -1 is outside 0..600000"));
}

TEST(HealthConfigResolve, UpAfterOverridesTheFamilyDefault) {
  HealthOverrides given;
  EXPECT_EQ(ResolveHealthConfig(given, Config(3, 0, 0, 1234)).up_after, milliseconds(1234));
  given.up_after = milliseconds(0);
  EXPECT_EQ(ResolveHealthConfig(given, Config(3, 0, 0, 1234)).up_after, milliseconds(0));
}

TEST(DownError, NamesTheDriveSinceWhenInUtcAndTheCause) {
  HealthInfo h;
  h.state = HealthState::kDown;
  h.since = std::chrono::sys_days{std::chrono::year{2026} / 12 / 7} + std::chrono::hours(5) +
            std::chrono::minutes(12) + std::chrono::seconds(3) + milliseconds(700);
  h.reason = "3 consecutive time-outs";
  absl::Status s = DownError("x1", h, "move_absolute");
  EXPECT_EQ(s.code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(s.message(),
            "drive 'x1' is DOWN since 2026-12-07T05:12:03Z (3 consecutive time-outs): "
            "move_absolute refused");
}

}  // namespace
}  // namespace drivegw
