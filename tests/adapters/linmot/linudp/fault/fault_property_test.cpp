// Fault-injection properties for LinMot LinUDP (issue 11, decision 1421): a scripted sequence of
// enable and moves through the Drive interface against the real simulator while the simulator
// drops/duplicates/reorders 10 % of the datagrams in both directions. Judged from the
// SIMULATOR's own motion log (LinMotDevice::started_targets) and position, not from the adapter:
// (a) no motion started that the client did not request (a retried or duplicated telegram must
// not start a second move, e.g. a relative move executed twice), (b) every command reported DONE
// really finished in the simulator at its target, (c) after the loss stops the link is online
// and a new move completes. A corrupt-mode run checks truncated replies are rejected and counted.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include "adapters/core/clock.h"
#include "adapters/linmot/linudp/drive.h"
#include "adapters/linmot/linudp/factory.h"
#include "adapters/transport/impaired_link.h"
#include "sim/linmot/device.h"
#include "sim/linmot/server.h"
#include "tests/support/linudp_bench.h"
#include "tests/support/lossy_link.h"
#include "tests/support/wait_status.h"

namespace drivegw::linmot::linudp {
namespace {

using namespace std::chrono_literals;
using sim::linmot::LinMotServer;
using sim::linmot::SimOptions;

constexpr auto kWait = 15s;          // generous: the host runs at load 6-10
constexpr double kIncPerMm = 10000;  // 0.1 um

class LinUdpFaultTest : public ::testing::Test {
 protected:
  void SetUp() override {
    SimOptions o = test_support::LinUdpSimOptions();
    auto server = LinMotServer::Start(o, SteadyClock::Instance());
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);

    DriveConfig c = test_support::LinUdpDriveConfig(server_->port());
    // 10 % loss each way loses ~19 % of the exchanges; 3 consecutive misses (the default test
    // value) would then take the link down every few hundred cycles. A test bench for lossy
    // links raises the count; 10 in a row happens with p = 0.19^10 ~ 6e-8 per cycle.
    c.linudp->lost_after_timeouts = 10;
    // Acceptance (the count echo, D-11): each lost exchange costs a 30 ms reply time-out, so the
    // default 100 ms fails a move after three in a row (seen under load: "not accepted within
    // 100 ms (count 1, echo 0)"); a lossy bench raises it (decision 1422).
    c.timeouts.accept = 500ms;
    auto drive = CreateLinMotUdpDrive(c, SteadyClock::Instance());
    ASSERT_TRUE(drive.ok()) << drive.status();
    drive_ = std::move(*drive);
    ASSERT_TRUE(drive_->Activate().ok());
  }
  void TearDown() override {
    if (drive_) drive_->Deactivate();
  }

  std::vector<int64_t> StartedTargets() {
    std::vector<int64_t> out;
    server_->WithDevice([&](sim::linmot::LinMotDevice& d) { out = d.started_targets(); });
    return out;
  }
  const LinMotUdpDrive& Udp() const { return dynamic_cast<const LinMotUdpDrive&>(*drive_); }

  // Enables; under loss a call may time out, so it is repeated like a client would (Enable is
  // idempotent: it moves no axis).
  void EnableUnderLoss() { ASSERT_TRUE(test_support::EnableUnderLoss(*drive_, kWait)); }

  // One move; returns the absolute target the simulator must have started exactly once when the
  // move was accepted, nullopt when the drive refused it (then it must not have started).
  struct Outcome {
    bool accepted = false;
    CommandState final_state = CommandState::kBusy;
  };
  Outcome RunMove(const MotionCommand& cmd, double target_mm) {
    Outcome out;
    auto r = drive_->Move(cmd);
    if (!r.ok()) {
      std::printf("move to %.3f refused: %s\n", target_mm,
                  std::string(r.status().message()).c_str());
      return out;
    }
    out.accepted = true;
    const CommandInfo final = test_support::WaitCommandFinal(*drive_, r->id, kWait);
    out.final_state = final.state;
    if (final.state == CommandState::kDone) {
      // (b) DONE means finished in the simulator, at the target.
      const auto sim = server_->Snapshot().device;
      EXPECT_FALSE(sim.motion_active) << "DONE while the simulator still moves to " << target_mm;
      EXPECT_NEAR(sim.demand_position_mm, target_mm, 1e-3) << "DONE for the wrong target";
      EXPECT_NEAR(sim.actual_position_mm, target_mm, 0.05) << "DONE before arriving";
    } else {
      std::printf("move to %.3f ended %d: %s\n", target_mm, static_cast<int>(final.state),
                  final.message.c_str());
    }
    return out;
  }

  // The property run: `loss` on the replies, `request_loss` on the requests, the scripted
  // moves (each from where the previous run left the axis), then checks (a) to (c).
  void RunLossyScript(const transport::Impairment& loss, const transport::Impairment& request_loss);

  std::unique_ptr<LinMotServer> server_;
  std::unique_ptr<Drive> drive_;
};

MotionCommand Abs(double mm) { return MoveAbsolute{mm, 400, 10000, 10000}; }
MotionCommand Rel(double mm) { return MoveRelative{mm, 400, 10000, 10000}; }

void LinUdpFaultTest::RunLossyScript(const transport::Impairment& loss,
                                     const transport::Impairment& request_loss) {
  std::printf("replies: %s; requests: %s\n", transport::ImpairmentString(loss).c_str(),
              transport::ImpairmentString(request_loss).c_str());
  ASSERT_TRUE(server_->SetImpairment(loss).ok());
  ASSERT_TRUE(server_->SetRequestImpairment(request_loss).ok());

  EnableUnderLoss();
  // Moves started by an earlier run of this test are not this run's business.
  const size_t earlier = StartedTargets().size();
  auto started = [&] {
    const std::vector<int64_t> all = StartedTargets();
    return std::vector<int64_t>(all.begin() + static_cast<std::ptrdiff_t>(earlier), all.end());
  };
  // Absolute and relative moves; relative ones are the dangerous kind (executed twice = a motion
  // nobody asked for). Each waits for its end before the next, so the expected target of a
  // relative move is the previous target plus the distance.
  struct Step {
    MotionCommand cmd;
    double target_mm;
  };
  const std::vector<Step> script = {
      {Abs(20), 20},  {Rel(5), 25},     {Rel(5), 30},  {Abs(50), 50},
      {Rel(-10), 40}, {Rel(2.5), 42.5}, {Abs(15), 15}, {Rel(7), 22},
  };
  std::vector<int64_t> expected;
  for (const Step& s : script) {
    const Outcome o = RunMove(s.cmd, s.target_mm);
    ASSERT_TRUE(o.accepted) << "the sequence below assumes every move ran";
    ASSERT_EQ(o.final_state, CommandState::kDone) << "target " << s.target_mm;
    expected.push_back(std::llround(s.target_mm * kIncPerMm));
  }
  // (a) the simulator started exactly the requested moves, once each, in order.
  EXPECT_EQ(started(), expected);

  const auto sc = server_->counters();
  const auto ec = Udp().exchange_counters();
  ASSERT_TRUE(ec.has_value());
  std::printf(
      "requests dropped %llu duplicated %llu reordered %llu; replies dropped %llu duplicated %llu "
      "reordered %llu; gateway telegrams %llu replies %llu timeouts %llu late %llu\n",
      (unsigned long long)sc.requests_dropped, (unsigned long long)sc.requests_duplicated,
      (unsigned long long)sc.requests_reordered, (unsigned long long)sc.replies_dropped,
      (unsigned long long)sc.replies_duplicated, (unsigned long long)sc.replies_reordered,
      (unsigned long long)ec->telegrams_sent, (unsigned long long)ec->replies,
      (unsigned long long)ec->timeouts, (unsigned long long)ec->late);
  // The faults really happened.
  if (request_loss.drop_probability > 0) {
    EXPECT_GT(sc.requests_dropped, 0u);
  }
  if (loss.drop_probability > 0) {
    EXPECT_GT(sc.replies_dropped, 0u);
  }
  if (request_loss.duplicate_probability > 0) {
    EXPECT_GT(sc.requests_duplicated, 0u);
  }
  if (request_loss.reorder_probability > 0) {
    EXPECT_GT(sc.requests_reordered, 0u);
  }
  EXPECT_GT(ec->timeouts, 0u);
  // No stale command ran, so the guard never had to halt the axis (decision 1461).
  EXPECT_EQ(Udp().stale_motion_commands(), 0u);

  // (c) the loss stops: online again and a new move completes.
  ASSERT_TRUE(server_->SetImpairment(transport::Impairment{}).ok());
  ASSERT_TRUE(server_->SetRequestImpairment(transport::Impairment{}).ok());
  test_support::WaitStatus(
      *drive_, [](const DriveStatus& s) { return s.state != DriveState::kOffline; }, kWait);
  const Outcome last = RunMove(Abs(60), 60);
  ASSERT_TRUE(last.accepted);
  EXPECT_EQ(last.final_state, CommandState::kDone);
  expected.push_back(std::llround(60 * kIncPerMm));
  EXPECT_EQ(started(), expected);
}

TEST_F(LinUdpFaultTest, TenPercentLossBothWays_NoUnrequestedMotion_NoFalseDone_Recovers) {
  const transport::Impairment loss{.drop_probability = 0.1,
                                   .duplicate_probability = 0.05,
                                   .reorder_probability = 0.05,
                                   .seed = 7};
  // Requests are reordered too: a stale telegram delivered after a newer one used to carry the
  // older command count, and the drive executes every count change (linmot-mc.md §4.3), so it
  // ran the old command and then the current one again (targets 30, 30, 30.045 mm for one
  // requested 30 mm move, decision 1424). Since decision 1461 a block travels only until its
  // count is echoed, so a telegram the simulator holds back (it delivers it right after the
  // next one) can no longer carry a superseded command; seed 8 is the run of finding 1424.
  const transport::Impairment request_loss{.drop_probability = 0.1,
                                           .duplicate_probability = 0.05,
                                           .reorder_probability = 0.05,
                                           .seed = 8};
  RunLossyScript(loss, request_loss);
}

// Decision 1461: heavy reordering of the requests alone (30 % held back and delivered after the
// next one) with replies that take 1.5 ms of the 2 ms cycle, so that a move usually finds a
// telegram in flight and leaves right behind it: when that one is held back it arrives after
// the move's first telegram. With the block repeated every cycle it carried the previous
// command, which then ran again (and the current one after it); seeds 3 and 21.
TEST_F(LinUdpFaultTest, HeavyRequestReordering_NoUnrequestedMotion_NoFalseDone_Recovers) {
  server_->SetReplyDelay(1500us);
  for (const uint64_t seed : {3u, 21u}) {
    SCOPED_TRACE(seed);
    const transport::Impairment request_reorder{
        .drop_probability = 0.05, .reorder_probability = 0.3, .seed = seed};
    RunLossyScript(transport::Impairment{.seed = seed}, request_reorder);
    if (HasFatalFailure()) return;
  }
}

TEST_F(LinUdpFaultTest, CorruptReplies_RejectedAndCounted_NeverTakenAsState) {
  // 20 % of the replies arrive truncated (decision 1421: UDP's checksum turns bit flips into
  // losses, so a short datagram is the corruption the gateway can see). seed 11.
  const transport::Impairment corrupt{.corrupt_probability = 0.2, .seed = 11};
  std::printf("replies: %s\n", transport::ImpairmentString(corrupt).c_str());
  ASSERT_TRUE(server_->SetImpairment(corrupt).ok());
  EnableUnderLoss();
  const Outcome o = RunMove(Abs(33), 33);
  ASSERT_TRUE(o.accepted);
  EXPECT_EQ(o.final_state, CommandState::kDone);
  EXPECT_EQ(StartedTargets(), std::vector<int64_t>{std::llround(33 * kIncPerMm)});
  const auto sc = server_->counters();
  const auto ec = Udp().exchange_counters();
  ASSERT_TRUE(ec.has_value());
  std::printf("replies corrupted %llu; gateway malformed %llu timeouts %llu replies %llu\n",
              (unsigned long long)sc.replies_corrupted, (unsigned long long)ec->malformed,
              (unsigned long long)ec->timeouts, (unsigned long long)ec->replies);
  EXPECT_GT(sc.replies_corrupted, 0u);
  // Every truncated reply the gateway received was refused as malformed; none counted as a
  // valid reply. (Some truncated replies arrive after the request timed out: counted late.)
  EXPECT_GT(ec->malformed, 0u);
  EXPECT_LE(ec->malformed, sc.replies_corrupted);
  // The reported state stayed consistent with the simulator: enabled and at the target.
  const DriveStatus s = drive_->GetStatus();
  EXPECT_NEAR(s.position_mm, 33, 0.05);
  EXPECT_EQ(s.state, DriveState::kEnabled);
}

}  // namespace
}  // namespace drivegw::linmot::linudp
