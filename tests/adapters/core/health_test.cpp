// The shared device health model (decision 1431): state changes, counting, back-off, errors.
#include "adapters/core/health.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace drivegw {
namespace {
using std::chrono::milliseconds;
using ::testing::HasSubstr;

HealthConfig Config(int n, int min_ms, int max_ms) {
  HealthConfig c;
  c.down_after_failures = n;
  c.backoff_min = milliseconds(min_ms);
  c.backoff_max = milliseconds(max_ms);
  return c;
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

TEST(HealthModel, RecoversFromDownThroughDemoted) {
  ManualClock clock;
  HealthModel m(Config(1, 100, 5000), clock);
  m.RecordSuccess();
  m.RecordFailure("misses");
  ASSERT_EQ(m.state(), HealthState::kDown);
  EXPECT_TRUE(m.RecordSuccess());
  EXPECT_EQ(m.state(), HealthState::kDemoted);
  EXPECT_EQ(m.info().reason, "recovering");
  EXPECT_TRUE(m.RecordSuccess());
  EXPECT_EQ(m.state(), HealthState::kUp);
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
