// The ADAPTER-target contract cases of trinamic-sixpack.md §8: the real TrinamicDrive (factory)
// against the simulated SIXpack over a real pty or the UDP multicast CAN bus, the wire checked
// byte-exactly through the simulator's trace (`words()`, `wire()`) or a CAN sniffer. Some cases
// are also covered under other names in tests/adapters/trinamic; each case is stated here once.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <thread>

#include "adapters/trinamic/parameters.h"
#include "tests/contract/trinamic/adapter_line.h"

namespace drivegw::trinamic::adapter_contract {
namespace {

using sim::trinamic::Controller;
using sim::trinamic::ServerOptions;
using ::testing::HasSubstr;

ParameterRef Param(const char* name) {
  auto def = FindParameter(name);
  EXPECT_TRUE(def.ok()) << def.status();
  ParameterRef ref;
  ref.id = def.ok() ? (*def)->id : 0;
  return ref;
}

const Bytes kQuery43 = {0x01, 0x43, 0xF0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};

// CT-01 "Request is exactly 9 bytes, zero padded" — L275-277, L375, L398-411: "move motor 0 to
// 10000" writes exactly `01 23 00 10 27 00 00 00 00`, and nothing else.
TEST(TrinamicAdapter, CT01_RequestIsExactlyNineBytesZeroPadded) {
  PtyPack pack;
  ASSERT_TRUE(pack.ok());
  Drive* d = pack.Enabled(pack.Config("m0", 0));
  ASSERT_NE(d, nullptr);
  pack.ClearWords();
  const auto before = pack.server->counters();
  auto r = d->Move(MoveAbsolute{10000, kV511, kA128, 0});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(WaitFinal(d, r->id).state, CommandState::kDone);
  const auto after = pack.server->counters();
  const std::vector<Bytes> words = Commands(pack.server->words());
  ASSERT_EQ(words.size(), 1u) << ::testing::PrintToString(words);
  EXPECT_EQ(words[0], (Bytes{0x01, 0x23, 0x00, 0x10, 0x27, 0x00, 0x00, 0x00, 0x00}));
  // Every byte the gateway wrote belonged to a complete 9-byte word (its polls included).
  EXPECT_EQ(after.bytes_in - before.bytes_in, 9 * (after.words - before.words));
  EXPECT_EQ(after.partial_timeouts, before.partial_timeouts);
}

// CT-02 "Little-endian, signed parameters" (ADAPTER half) — L475, L503, L701: "move motor 5 to
// −6400" → `01 23 05 00 E7 FF FF 00 00`; the `$20` poll `01 20 05 F0 00 …` decodes −6400.
TEST(TrinamicAdapter, CT02_LittleEndianSignedParameters) {
  PtyPack pack;
  ASSERT_TRUE(pack.ok());
  Drive* d = pack.Enabled(pack.Config("m5", 5));
  ASSERT_NE(d, nullptr);
  pack.ClearWords();
  auto r = d->Move(MoveAbsolute{-6400, kV511, kA128, 0});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(WaitFinal(d, r->id).state, CommandState::kDone);
  const std::vector<Bytes> all = pack.server->words();
  const std::vector<Bytes> words = Commands(all);
  ASSERT_EQ(words.size(), 1u) << ::testing::PrintToString(words);
  EXPECT_EQ(words[0], (Bytes{0x01, 0x23, 0x05, 0x00, 0xE7, 0xFF, 0xFF, 0x00, 0x00}));
  const auto move = IndexOf(all, words[0]);
  ASSERT_TRUE(move.has_value());
  EXPECT_TRUE(IndexOf(all, Bytes{0x01, 0x20, 0x05, 0xF0, 0x00, 0x00, 0x00, 0x00, 0x00}, *move))
      << "no $20 poll of motor 5 after the move";
  const DriveStatus s = d->GetStatus();
  EXPECT_DOUBLE_EQ(s.position_mm, -6400);
  EXPECT_EQ(pack.Sim<int32_t>([](Controller& c) { return c.state(5).position; }), -6400);
}

// CT-08 "Baud-rate change" (ADAPTER half) — L273, L832, G-40: the gateway requests 9600 baud:
// `01 40 82 00 03 00 00 00 00` at 19200, its own port at 9600 before the next word, the next
// `$43` answered (the simulator ignores words at the wrong speed). Only standard rates; after a
// controller reset the gateway returns to 19200 before re-applying (and then to 9600 again).
TEST(TrinamicAdapter, CT08_BaudChange_SwitchVerifyAndBackAfterReset) {
  ServerOptions o;
  o.check_peer_baud = true;
  PtyPack pack(o);
  ASSERT_TRUE(pack.ok());
  Drive* d = pack.Enabled(pack.Config("m0", 0));
  ASSERT_NE(d, nullptr);

  pack.ClearWords();
  const absl::Status bad = d->WriteParameter(Param("$40.divisor"), 100);
  EXPECT_EQ(bad.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad.message(), HasSubstr("$40.divisor: 100"));
  EXPECT_THAT(bad.message(), HasSubstr("130 (9600)"));
  EXPECT_TRUE(Commands(pack.server->words()).empty());

  ASSERT_TRUE(d->WriteParameter(Param("$40.divisor"), 130).ok());
  std::vector<Bytes> words = pack.server->words();
  const auto set = IndexOf(words, Bytes{0x01, 0x40, 0x82, 0x00, 0x03, 0x00, 0x00, 0x00, 0x00});
  ASSERT_TRUE(set.has_value()) << ::testing::PrintToString(words);
  // The very next word the PACK understood is the verifying `$43`, at the new rate.
  ASSERT_LT(*set + 1, words.size());
  EXPECT_EQ(words[*set + 1], kQuery43);
  EXPECT_EQ(pack.Sim<int>([](Controller& c) { return c.globals().baud_divisor; }), 130);
  EXPECT_EQ(*d->ReadParameter(Param("$40.divisor")), 130);
  const uint64_t noise = pack.server->counters().noise_bytes;
  auto r = d->Move(MoveAbsolute{300, kV511, kA128, 0});  // works at 9600
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(WaitFinal(d, r->id).state, CommandState::kDone);
  EXPECT_EQ(pack.server->counters().noise_bytes, noise) << "a word at the wrong speed";

  // Power cycle: the PACK talks 19200 again (L273, L899); the gateway at 9600 is noise to it.
  // Reset first: until the gateway is back at 19200 its words are noise and stay out of the trace.
  pack.server->WithController([](Controller& c) { c.Reset(); });
  pack.server->ClearWords();
  const DriveStatus s = WaitStatus(
      d,
      [](const DriveStatus& s) {
        return s.state == DriveState::kDisabled && !s.warnings.empty() &&
               s.warnings[0].find("controller reset") != std::string::npos;
      },
      8000ms);
  ASSERT_EQ(s.state, DriveState::kDisabled) << ::testing::PrintToString(s.warnings);
  EXPECT_GT(pack.server->counters().noise_bytes, noise);
  words = pack.server->words();
  ASSERT_FALSE(words.empty());
  // The first word the reset PACK understood: the gateway's `$43` at 19200, before any re-apply.
  EXPECT_EQ(words[0], kQuery43);
  const auto again = IndexOf(words, Bytes{0x01, 0x40, 0x82, 0x00, 0x03, 0x00, 0x00, 0x00, 0x00});
  ASSERT_TRUE(again.has_value()) << ::testing::PrintToString(words);
  EXPECT_TRUE(IndexOf(words, Bytes{0x01, 0x14, 0x00, 0x80, 0x00, 0xFF, 0x01, 0x00, 0x00})
                  .value_or(words.size()) < *again)
      << "the axis words are re-applied at 19200 before `$40`";
  EXPECT_TRUE(Eventually([&] {
    return pack.Sim<int>([](Controller& c) { return c.globals().baud_divisor; }) == 130;
  }));
}

// CT-10 "No interlacing" — L357: with every reply delayed by 50 ms (switchover 25 × 2 ms, L833)
// and three concurrent native position queries for motors 0, 1, 2 from three threads (plus the
// poll thread), the wire shows every query's complete reply before the next word.
TEST(TrinamicAdapter, CT10_NoInterlacing_ConcurrentQueriesStrictlyAlternate) {
  ServerOptions o;
  o.turnaround = true;  // replies after the `$40` switchover time (decision 1040)
  PtyPack pack(o);
  ASSERT_TRUE(pack.ok());
  std::vector<Drive*> drives;
  for (uint8_t m = 0; m < 3; ++m) {
    DriveConfig c = pack.Config("m" + std::to_string(m), m);
    c.trinamic->reply_timeout = 1000ms;
    c.trinamic->poll_period = 20ms;
    drives.push_back(pack.drives.Activate(c));
    ASSERT_NE(drives.back(), nullptr);
  }
  ASSERT_TRUE(drives[0]->WriteParameter(Param("$40.switchover"), 25).ok());
  ASSERT_TRUE(Eventually(
      [&] { return pack.Sim<int>([](Controller& c) { return c.globals().switchover; }) == 25; }));
  pack.ClearWords();
  std::vector<absl::StatusOr<NativeReply>> replies(3, absl::UnknownError("not run"));
  std::vector<std::thread> threads;
  for (uint8_t m = 0; m < 3; ++m) {
    threads.emplace_back([&, m] {
      replies[m] = drives[m]->SendNative(TrinamicRequest{0x20, {m, 0, 0, 0, 0, 0, 0}});
    });
  }
  for (auto& t : threads) t.join();
  for (uint8_t m = 0; m < 3; ++m) {
    ASSERT_TRUE(replies[m].ok()) << replies[m].status();
    EXPECT_EQ(replies[m]->data, (Bytes{0x20, m, 0, 0, 0, 0, 0, 0}));
  }
  pack.drives.Clear();  // the last poll completed: every reply is on the wire
  const auto wire = pack.server->wire();
  size_t queries = 0;
  for (size_t i = 0; i < wire.size(); ++i) {
    if (!wire[i].from_host) continue;
    const uint8_t op = wire[i].bytes.at(1);
    if (!SpecOf(static_cast<Opcode>(op)).has_reply) continue;
    ++queries;
    ASSERT_LT(i + 1, wire.size()) << "query " << i << " without a reply";
    EXPECT_FALSE(wire[i + 1].from_host) << "word " << i + 1 << " sent before the reply to " << i;
    EXPECT_EQ(wire[i + 1].bytes.at(0), op) << "reply " << i + 1 << " (R8 starts with the opcode)";
  }
  EXPECT_GE(queries, 3u);
}

// CT-11 "Stray zero byte after reset is ignored" — L228, L902: after `$CC` the simulator emits
// one `00`; the gateway's next `$43` is decoded (reset flag 1) and the reset is reported.
TEST(TrinamicAdapter, CT11_StrayZeroAfterReset_NextUnitInformationDecoded) {
  PtyPack pack;
  ASSERT_TRUE(pack.ok());
  Drive* d = pack.Enabled(pack.Config("m0", 0));
  ASSERT_NE(d, nullptr);
  auto* t = Drives::Trinamic(d);
  const uint64_t zeros = t->session_counters()->stray_zeros;
  pack.ClearWords();
  ASSERT_TRUE(d->SendNative(TrinamicRequest{0xCC, {}}).ok());
  const DriveStatus s = WaitStatus(
      d,
      [](const DriveStatus& s) {
        return s.state == DriveState::kDisabled && !s.warnings.empty() &&
               s.warnings[0].find("controller reset") != std::string::npos;
      },
      8000ms);
  ASSERT_EQ(s.state, DriveState::kDisabled);
  EXPECT_GE(t->session_counters()->stray_zeros, zeros + 1);
  EXPECT_GE(t->pack_counters()->resets, 1u);
  const auto wire = pack.server->wire();
  size_t i = 0;
  while (i < wire.size() && !(wire[i].from_host && wire[i].bytes.at(1) == 0xCC)) ++i;
  ASSERT_LT(i + 1, wire.size());
  EXPECT_EQ(wire[i + 1].bytes, Bytes{0x00});
  // The first reply after the boot answers the gateway's `$43`, reset flag 1 (L853); words sent
  // while the unit was still busy (L900) went unanswered.
  i += 2;
  while (i < wire.size() && wire[i].from_host) ++i;
  ASSERT_LT(i, wire.size());
  EXPECT_EQ(wire[i].bytes, (Bytes{0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00}));
  EXPECT_EQ(wire[i - 1].bytes, kQuery43);
}

// CT-17 "Delayed reply demultiplexed on RS-232" — L357, L740, G-41: the adapter never has a
// delayed `$28` outstanding (decision 1099): a native `$28` with a delay mask is refused without
// wire traffic; mask 0 answers at once, also while a motor moves.
TEST(TrinamicAdapter, CT17_DelayedActivityQuery_RefusedMaskZeroAnswered) {
  PtyPack pack;
  ASSERT_TRUE(pack.ok());
  Drive* d = pack.Enabled(pack.Config("m0", 0));
  ASSERT_NE(d, nullptr);
  pack.ClearWords();
  auto refused = d->SendNative(TrinamicRequest{0x28, {0, 0x01, 0, 0, 0, 0, 0}});
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(refused.status().message(), HasSubstr("G-41"));
  EXPECT_THAT(refused.status().message(), HasSubstr("mask 0"));
  for (const Bytes& w : pack.server->words()) EXPECT_NE(w.at(1), 0x28);

  auto r = d->Move(MoveAbsolute{15000, 2000, kA128, 0});
  ASSERT_TRUE(r.ok()) << r.status();
  pack.ClearWords();
  auto now = d->SendNative(TrinamicRequest{0x28, {0, 0, 0, 0, 0, 0, 0}});
  ASSERT_TRUE(now.ok()) << now.status();
  ASSERT_EQ(now->data.size(), 8u);
  EXPECT_EQ(now->data[0], 0x28);
  EXPECT_EQ(now->data[1], 5) << "motor 0 in its ramp";
  EXPECT_TRUE(
      IndexOf(pack.server->words(), Bytes{0x01, 0x28, 0xF0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}));
  ASSERT_TRUE(d->Move(StopMotion{0}).ok());
}

// CT-20 "Jumper bits" (ADAPTER half) — L293-305, L790, G-19: with JP1 and JP2 set the adapter
// reports 1 Mbit/s from `$30` P4 bits 6/7 (1 = set); JP1 alone is 125 kbit/s (§3.2 table).
TEST(TrinamicAdapter, CT20_JumperBits_CanBitRateReported) {
  struct Case {
    bool jp1, jp2;
    int rate;
  };
  for (const Case& c :
       {Case{true, true, 1'000'000}, Case{true, false, 125'000}, Case{false, false, 250'000}}) {
    const CanBusConfig bus = UdpBus(RandomPort());
    CanSniffer sniffer(bus);
    auto sim = StartCanPack(bus, [&](sim::trinamic::CanServerOptions& o) {
      o.controller.jumper1 = c.jp1;
      o.controller.jumper2 = c.jp2;
    });
    ASSERT_NE(sim, nullptr);
    Drives drives;
    DriveConfig cfg = AxisConfig("can0", 0);
    cfg.trinamic->can = bus;
    Drive* d = drives.Activate(cfg);
    ASSERT_NE(d, nullptr);
    auto* t = Drives::Trinamic(d);
    ASSERT_TRUE(Eventually([&] { return t->can_bit_rate().has_value(); }));
    EXPECT_EQ(*t->can_bit_rate(), c.rate) << "JP1 " << c.jp1 << " JP2 " << c.jp2;
    EXPECT_TRUE(IndexOf(sniffer.DataOn(0x008), Bytes{0x30, 0x00, 0xF0, 0, 0, 0, 0, 0}));
    const auto replies = sniffer.DataOn(0x780);
    const auto reply = std::find_if(replies.begin(), replies.end(),
                                    [](const Bytes& b) { return b.at(0) == 0x30; });
    ASSERT_NE(reply, replies.end());
    EXPECT_EQ((*reply)[5] & 0xC0, (c.jp1 ? 0x40 : 0) | (c.jp2 ? 0x80 : 0));
    drives.Clear();
    sim->Stop();
  }
}

// CT-50 "CAN identifiers follow the address" — L289: PACK addresses 0x10 and 0xFF → command IDs
// 0x080 and 0x7F8; address 0 and an RA equal to a configured PACK address are rejected.
TEST(TrinamicAdapter, CT50_CanIdentifiersFollowTheAddress) {
  const CanBusConfig bus = UdpBus(RandomPort());
  CanSniffer sniffer(bus);
  auto a =
      StartCanPack(bus, [](sim::trinamic::CanServerOptions& o) { o.controller.address = 0x10; });
  auto b =
      StartCanPack(bus, [](sim::trinamic::CanServerOptions& o) { o.controller.address = 0xFF; });
  ASSERT_NE(a, nullptr);
  ASSERT_NE(b, nullptr);
  Drives drives;
  DriveConfig ca = AxisConfig("a", 0);
  ca.trinamic->can = bus;
  ca.trinamic->address = 0x10;
  DriveConfig cb = AxisConfig("b", 0);
  cb.trinamic->can = bus;
  cb.trinamic->address = 0xFF;
  cb.trinamic->response_address = 0xE0;  // each controller its own RA on a shared bus (1053)
  Drive* da = drives.Activate(ca);
  Drive* db = drives.Activate(cb);
  ASSERT_NE(da, nullptr);
  ASSERT_NE(db, nullptr);
  EXPECT_EQ(da->GetStatus().state, DriveState::kDisabled);
  EXPECT_EQ(db->GetStatus().state, DriveState::kDisabled);
  EXPECT_TRUE(IndexOf(sniffer.DataOn(0x080), Bytes{0x43, 0xF0, 0, 0, 0, 0, 0, 0}));
  EXPECT_TRUE(IndexOf(sniffer.DataOn(0x7F8), Bytes{0x43, 0xE0, 0, 0, 0, 0, 0, 0}));
  EXPECT_FALSE(sniffer.DataOn(0x780).empty());  // replies to RA F0 and E0
  EXPECT_FALSE(sniffer.DataOn(0x700).empty());
  for (const auto& f : sniffer.frames()) {
    EXPECT_TRUE(f.id == 0x080 || f.id == 0x7F8 || f.id == 0x780 || f.id == 0x700)
        << "frame on ID " << f.id;
    EXPECT_EQ(f.dlc, 8);
  }

  DriveConfig zero = AxisConfig("zero", 1);
  zero.trinamic->can = bus;
  zero.trinamic->address = 0;
  auto z = CreateTrinamicDrive(zero, SteadyClock::Instance());
  EXPECT_EQ(z.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(z.status().message(), HasSubstr("trinamic.address: 0"));

  DriveConfig own = AxisConfig("own", 1);
  own.trinamic->can = bus;
  own.trinamic->address = 0x20;
  own.trinamic->response_address = 0x20;
  EXPECT_THAT(CreateTrinamicDrive(own, SteadyClock::Instance()).status().message(),
              HasSubstr("trinamic.response_address"));

  DriveConfig clash = AxisConfig("clash", 1);
  clash.trinamic->can = bus;
  clash.trinamic->address = 0x20;
  clash.trinamic->response_address = 0x10;  // = the address of PACK a
  auto c = CreateTrinamicDrive(clash, SteadyClock::Instance());
  ASSERT_TRUE(c.ok()) << c.status();
  const absl::Status s = (*c)->Activate();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("trinamic.response_address: 16 is the address"));
  drives.Clear();
  a->Stop();
  b->Stop();
}

// CT-55 "Out-of-range values are refused before transmission" — L493-497, L543, L556-561,
// L613-614, L832-838: each request fails InvalidArgument and produces no wire traffic; the
// controller-wide clkdiv is checked against every axis of the PACK (decision 1098).
TEST(TrinamicAdapter, CT55_OutOfRangeRefusedBeforeTransmission) {
  PtyPack pack;
  ASSERT_TRUE(pack.ok());
  Drive* x = pack.drives.Activate(pack.Config("x", 0));
  Drive* y = pack.drives.Activate(pack.Config("y", 1));
  ASSERT_NE(x, nullptr);
  ASSERT_NE(y, nullptr);
  // Motor 0 at div 0 and vmax 300: 61 kHz at clkdiv 5, 366 kHz at clkdiv 0 (L497).
  ASSERT_TRUE(x->WriteParameter(Param("$14.vmax"), 300).ok());
  ASSERT_TRUE(x->WriteParameter(Param("$13.div"), 0).ok());
  pack.ClearWords();
  struct Case {
    const char* name;
    int64_t value;
    const char* why;
  };
  for (const Case& c : {
           Case{"$12.clkdiv", 32, "$12.clkdiv: 32 exceeds"},
           Case{"$13.div", 4, "$13.div: 4 exceeds"},
           Case{"$14.vmax", 512, "$14.vmax: 512 exceeds"},
           Case{"$14.amax", 0, "$14.amax: 0 below"},
           Case{"$14.amax", 321, "exceeds vstart x 64 = 320 (L556)"},
           Case{"$13.vmin", 6, "$13.vmin: 6 exceeds vstart 5 (L544)"},
           Case{"$16.vrefmax", 301, "$16.vrefmax: 301 exceeds vmax 300 (L613)"},
           Case{"$12.clkdiv", 0, "above 200000 Hz (L497)"},
           Case{"$40.switchover", 0, "$40.switchover: 0 below 1"},
           Case{"$40.switchover", 1001, "$40.switchover: 1001 exceeds 1000"},
           Case{"$41.timeout", 1, "$41.timeout: 1 below 2"},
           Case{"$41.timeout", 2, "shorter than one 9-byte word at 19200 baud"},
       }) {
    const absl::Status s = x->WriteParameter(Param(c.name), c.value);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << c.name << " " << c.value;
    EXPECT_THAT(s.message(), HasSubstr(c.why)) << c.name << " " << c.value;
  }
  // Motor 1 (div 2, vmax 511) would accept clkdiv 0 (156 kHz); motor 0 would not.
  const absl::Status shared = y->WriteParameter(Param("$12.clkdiv"), 0);
  EXPECT_EQ(shared.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(shared.message(), HasSubstr("drive 'x' (motor 0) would break"));
  EXPECT_THAT(shared.message(), HasSubstr("366211 Hz"));
  EXPECT_TRUE(Commands(pack.server->words()).empty())
      << ::testing::PrintToString(Commands(pack.server->words()));
  EXPECT_EQ(*y->ReadParameter(Param("$12.clkdiv")), 5);
  EXPECT_EQ(pack.Sim<int>([](Controller& c) { return c.globals().clkdiv; }), 5);
}

// CT-56 "Stopped-only parameters" — L532, L539, L609: with motor 3 active the adapter refuses
// clkdiv, vstart/div and vrefmax of motor 3 and never sends `$12`/`$13`/`$16` meanwhile.
TEST(TrinamicAdapter, CT56_StoppedOnlyParametersRefusedWhileActive) {
  PtyPack pack;
  ASSERT_TRUE(pack.ok());
  Drive* d = pack.Enabled(pack.Config("m3", 3));
  ASSERT_NE(d, nullptr);
  auto r = d->Move(MoveVelocity{3000, kA128, 0});
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(
      WaitStatus(d, [](const DriveStatus& s) { return s.state == DriveState::kMoving; }).state,
      DriveState::kMoving);
  pack.ClearWords();
  for (const auto& [name, value] : std::vector<std::pair<const char*, int64_t>>{
           {"$12.clkdiv", 4}, {"$13.vstart", 6}, {"$13.div", 1}, {"$16.vrefmax", 50}}) {
    const absl::Status s = d->WriteParameter(Param(name), value);
    EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition) << name;
    EXPECT_THAT(s.message(), HasSubstr(name));
  }
  for (const Bytes& w : pack.server->words()) {
    EXPECT_TRUE(w.at(1) != 0x12 && w.at(1) != 0x13 && w.at(1) != 0x16)
        << ::testing::PrintToString(w);
  }
  auto stop = d->Move(StopMotion{0});
  ASSERT_TRUE(stop.ok()) << stop.status();
  EXPECT_EQ(WaitFinal(d, stop->id).state, CommandState::kDone);
  EXPECT_TRUE(d->WriteParameter(Param("$13.vstart"), 6).ok());  // standing: accepted
}

// CT-57 "Parameters re-applied after reset" — L853, L899, G-24: a stored vmax 300 for motor 0 is
// re-sent (`01 14 00 80 00 2C 01 00 00`) after the reset flag, before any motion word.
TEST(TrinamicAdapter, CT57_ParametersReappliedBeforeAnyMotionWord) {
  PtyPack pack;
  ASSERT_TRUE(pack.ok());
  DriveConfig c = pack.Config("m0", 0);
  c.trinamic->parameters = {{"$14.vmax", 300}};
  Drive* d = pack.Enabled(c);
  ASSERT_NE(d, nullptr);
  pack.ClearWords();
  pack.server->WithController([](Controller& c) { c.Reset(); });
  ASSERT_EQ(WaitStatus(d,
                       [](const DriveStatus& s) {
                         return !s.warnings.empty() &&
                                s.warnings[0].find("controller reset") != std::string::npos;
                       })
                .state,
            DriveState::kDisabled);
  auto e = d->Enable();
  ASSERT_TRUE(e.ok()) << e.status();
  auto r = d->Move(MoveAbsolute{500, 5000, kA128, 0});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(WaitFinal(d, r->id).state, CommandState::kDone);
  const std::vector<Bytes> words = pack.server->words();
  const auto apply = IndexOf(words, Bytes{0x01, 0x14, 0x00, 0x80, 0x00, 0x2C, 0x01, 0x00, 0x00});
  ASSERT_TRUE(apply.has_value()) << ::testing::PrintToString(words);
  for (size_t i = 0; i < *apply; ++i) {
    const uint8_t op = words[i].at(1);
    EXPECT_FALSE((op >= 0x22 && op <= 0x26) || op == 0x29 || op == 0x50)
        << "motion word before the re-apply: " << ::testing::PrintToString(words[i]);
  }
  const auto reset_probe = IndexOf(words, kQuery43);
  ASSERT_TRUE(reset_probe.has_value());
  EXPECT_LT(*reset_probe, *apply) << "the reset flag is read before the re-apply";
  EXPECT_TRUE(IndexOf(words, Bytes{0x01, 0x23, 0x00, 0xF4, 0x01, 0x00, 0x00, 0x00, 0x00}, *apply));
}

}  // namespace
}  // namespace drivegw::trinamic::adapter_contract
