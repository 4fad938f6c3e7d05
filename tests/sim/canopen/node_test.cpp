// Tests for sim/canopen/node: the slave driven directly with explicit time points and the
// protocol library's SdoClientTransfer as the master: boot-up, NMT, SDO (expedited, segmented,
// every abort path, timeout), PDO mapping rules, synchronous/event TPDOs, RPDOs at SYNC,
// heartbeat producer/consumer with 1029h, EMCY with 1003h, and the faults.
#include "sim/canopen/node.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

#include "adapters/canopen/emcy.h"
#include "adapters/canopen/nmt.h"
#include "adapters/canopen/sync.h"
#include "tests/sim/canopen/test_model.h"

namespace drivegw::sim::canopen {
namespace {

namespace co = drivegw::canopen;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using transport::CanFrame;
using Bytes = std::vector<uint8_t>;
using namespace std::chrono_literals;
using testing::TestModel;

constexpr uint8_t kNode = 5;

Bytes Data(const CanFrame& f) { return Bytes(f.payload().begin(), f.payload().end()); }

Bytes Le(uint64_t v, size_t n) {
  Bytes b(n);
  for (size_t i = 0; i < n; ++i) b[i] = static_cast<uint8_t>(v >> (8 * i));
  return b;
}

class NodeTest : public ::testing::Test {
 protected:
  void SetUp() override { Make({}); }

  void Make(SlaveNodeOptions options) {
    options.node_id = kNode;
    options.identity.device_name = "canopen test slave";
    options.identity.device_type = 0x00020192;
    options.identity.vendor_id = 0x1234;
    model = TestModel();
    auto n = SlaveNode::Create(options, &model);
    ASSERT_TRUE(n.ok()) << n.status();
    node = *std::move(n);
    node->Boot(now);
  }

  void At(Duration d) {
    now += d;
    node->Advance(now);
  }
  std::vector<CanFrame> Frames() { return node->TakeFrames(); }
  void Feed(const CanFrame& f) { node->OnFrame(f, now); }
  void Nmt(co::NmtCommand c, uint8_t target = kNode) { Feed(*co::EncodeNmt({c, target})); }
  void Sync() { Feed(*co::EncodeSync({})); }

  // One SDO transfer against the node; frames other than the SDO responses are kept in `other`.
  co::SdoStep Run(co::SdoClientTransfer client) {
    CanFrame request = client.Start();
    for (int guard = 0; guard < 1000; ++guard) {
      Feed(request);
      std::optional<CanFrame> response;
      for (const CanFrame& f : Frames()) {
        if (f.id == 0x580u + kNode && !response) {
          response = f;
        } else {
          other.push_back(f);
        }
      }
      if (!response) return {};  // no answer
      co::SdoStep step = client.OnFrame(*response);
      if (step.kind != co::SdoStep::Kind::kSend) return step;
      request = *step.frame;
    }
    ADD_FAILURE() << "transfer does not end";
    return {};
  }
  absl::StatusOr<Bytes> Upload(uint16_t index, uint8_t sub) {
    co::SdoStep step = Run(co::SdoClientTransfer::Upload(channel, index, sub));
    if (step.kind == co::SdoStep::Kind::kDone) return step.data;
    if (step.kind == co::SdoStep::Kind::kFailed) return step.status;
    return absl::DeadlineExceededError("no SDO answer");
  }
  absl::Status Download(uint16_t index, uint8_t sub, Bytes data) {
    co::SdoStep step = Run(co::SdoClientTransfer::Download(channel, index, sub, std::move(data)));
    if (step.kind == co::SdoStep::Kind::kDone) return absl::OkStatus();
    if (step.kind == co::SdoStep::Kind::kFailed) return step.status;
    return absl::DeadlineExceededError("no SDO answer");
  }
  absl::StatusOr<int64_t> UploadU(uint16_t index, uint8_t sub) {
    auto b = Upload(index, sub);
    if (!b.ok()) return b.status();
    uint64_t v = 0;
    for (size_t i = 0; i < b->size(); ++i) v |= static_cast<uint64_t>((*b)[i]) << (8 * i);
    return static_cast<int64_t>(v);
  }
  std::optional<co::SdoAbortCode> AbortOf(const absl::Status& s) { return co::AbortCodeOf(s); }

  // Configures a PDO the way the gateway will: the library's MappingWrites as SDO downloads.
  void ConfigurePdo(co::PdoKind kind, uint16_t number, co::PdoCommParams comm,
                    std::vector<co::PdoMappingEntry> mapping) {
    auto writes = co::MappingWrites(kind, number, kNode, comm, mapping);
    ASSERT_TRUE(writes.ok()) << writes.status();
    for (const co::SdoWrite& w : *writes) {
      ASSERT_TRUE(Download(w.index, w.sub, w.data).ok())
          << std::hex << w.index << ":" << int{w.sub} << " " << Download(w.index, w.sub, w.data);
    }
  }

  TimePoint now{std::chrono::seconds(1000)};
  TestModel model;
  std::unique_ptr<SlaveNode> node;
  co::SdoChannel channel = co::DefaultSdoChannel(kNode).value();
  std::vector<CanFrame> other;
};

// ---- boot-up and NMT ----

TEST_F(NodeTest, Boot_BootUpMessageThenPreOperational) {
  auto frames = Frames();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].id, 0x705u);
  EXPECT_THAT(Data(frames[0]), ElementsAre(0x00));
  EXPECT_EQ(node->state(), NmtState::kPreOperational);
  EXPECT_THAT(model.nmt, ElementsAre(std::pair(NmtState::kBootUp, NmtState::kPreOperational)));
}

TEST_F(NodeTest, Nmt_StartStopPreOperational_OwnIdAndBroadcastOnly) {
  Frames();
  Nmt(co::NmtCommand::kStart);
  EXPECT_EQ(node->state(), NmtState::kOperational);
  Nmt(co::NmtCommand::kStop, 6);  // another node
  EXPECT_EQ(node->state(), NmtState::kOperational);
  Nmt(co::NmtCommand::kStop, 0);  // all nodes
  EXPECT_EQ(node->state(), NmtState::kStopped);
  // STOPPED: no SDO.
  EXPECT_FALSE(Upload(0x1000, 0).ok());
  Nmt(co::NmtCommand::kEnterPreOperational);
  EXPECT_EQ(node->state(), NmtState::kPreOperational);
  EXPECT_EQ(*UploadU(0x1000, 0), 0x00020192);
  Nmt(co::NmtCommand::kStart);
  EXPECT_EQ(node->state(), NmtState::kOperational);
  EXPECT_TRUE(Frames().empty());                 // transitions themselves send nothing
  EXPECT_EQ(node->counters().nmt_commands, 4u);  // not the one for node 6
}

TEST_F(NodeTest, Nmt_ResetCommunicationKeepsApplicationValues_ResetNodeRestoresThem) {
  ASSERT_TRUE(Download(0x2000, 0, Le(500, 2)).ok());
  ASSERT_TRUE(Download(0x1017, 0, Le(250, 2)).ok());
  Nmt(co::NmtCommand::kStart);
  Frames();
  Nmt(co::NmtCommand::kResetCommunication);
  auto frames = Frames();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].id, 0x705u);
  EXPECT_THAT(Data(frames[0]), ElementsAre(0x00));
  EXPECT_EQ(node->state(), NmtState::kPreOperational);
  EXPECT_EQ(*UploadU(0x1017, 0), 0);    // communication area: default
  EXPECT_EQ(*UploadU(0x2000, 0), 500);  // application area: kept
  EXPECT_EQ(model.resets, 0);
  Nmt(co::NmtCommand::kResetNode);
  EXPECT_EQ(*UploadU(0x2000, 0), 100);
  EXPECT_EQ(model.resets, 1);
  EXPECT_EQ(node->counters().boot_ups, 3u);
}

// ---- heartbeat producer ----

TEST_F(NodeTest, Heartbeat_PeriodFrom1017h_StateByte) {
  ASSERT_TRUE(Download(0x1017, 0, Le(100, 2)).ok());
  Frames();
  At(99ms);
  EXPECT_TRUE(Frames().empty());
  At(1ms);
  auto f = Frames();
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].id, 0x705u);
  EXPECT_THAT(Data(f[0]), ElementsAre(0x7F));
  Nmt(co::NmtCommand::kStart);
  At(100ms);
  f = Frames();
  ASSERT_EQ(f.size(), 1u);
  EXPECT_THAT(Data(f[0]), ElementsAre(0x05));
  Nmt(co::NmtCommand::kStop);
  At(100ms);
  f = Frames();
  ASSERT_EQ(f.size(), 1u);
  EXPECT_THAT(Data(f[0]), ElementsAre(0x04));
  // A late advance sends once, not a burst.
  At(350ms);
  EXPECT_EQ(Frames().size(), 1u);
  Nmt(co::NmtCommand::kEnterPreOperational);
  ASSERT_TRUE(Download(0x1017, 0, Le(0, 2)).ok());
  At(1s);
  EXPECT_TRUE(Frames().empty());
}

TEST_F(NodeTest, Heartbeat_OptionStartsAfterBootUp) {
  SlaveNodeOptions o;
  o.heartbeat_ms = 50;
  Make(o);
  EXPECT_EQ(Frames().size(), 1u);  // boot-up
  At(50ms);
  auto f = Frames();
  ASSERT_EQ(f.size(), 1u);
  EXPECT_THAT(Data(f[0]), ElementsAre(0x7F));
}

// ---- SDO ----

TEST_F(NodeTest, Sdo_ExpeditedAndSegmented) {
  EXPECT_EQ(*UploadU(0x1000, 0), 0x00020192);
  EXPECT_EQ(*UploadU(0x1018, 1), 0x1234);
  EXPECT_EQ(*UploadU(0x1018, 0), 4);
  EXPECT_EQ(*UploadU(0x1200, 1), 0x605);
  ASSERT_TRUE(Download(0x2000, 0, Le(777, 2)).ok());
  EXPECT_EQ(*UploadU(0x2000, 0), 777);
  ASSERT_TRUE(Download(0x2001, 0, Le(static_cast<uint32_t>(-5), 4)).ok());
  EXPECT_EQ(*node->dictionary().GetInt(0x2001, 0), -5);
  // Segmented: the device name (18 bytes) and a string written and read back.
  auto name = Upload(0x1008, 0);
  ASSERT_TRUE(name.ok()) << name.status();
  EXPECT_EQ(std::string(name->begin(), name->end()), "canopen test slave");
  const std::string label = "a label of twenty-nine bytes.";
  ASSERT_TRUE(Download(0x2003, 0, Bytes(label.begin(), label.end())).ok());
  auto back = Upload(0x2003, 0);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(std::string(back->begin(), back->end()), label);
  // Read hook: the model's value at the instant of the read.
  model.position = -1234;
  EXPECT_EQ(*UploadU(0x6064, 0), static_cast<uint32_t>(-1234));
}

TEST_F(NodeTest, Sdo_ExpeditedWithoutSizeTakesTheObjectsSize) {
  Frames();
  // ccs 1, e = 1, s = 0: four data bytes, size unspecified (CiA 301 §7.2.4.3.3).
  Feed(transport::MakeCanFrame(0x605, Bytes{0x22, 0x00, 0x20, 0x00, 0x2C, 0x01, 0xAA, 0xBB}));
  auto f = Frames();
  ASSERT_EQ(f.size(), 1u);
  EXPECT_THAT(Data(f[0]), ElementsAre(0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0));
  EXPECT_EQ(*node->dictionary().GetInt(0x2000, 0), 300);
}

struct AbortCase {
  const char* name;
  bool write;
  uint16_t index;
  uint8_t sub;
  Bytes data;
  co::SdoAbortCode code;
};

TEST_F(NodeTest, Sdo_EveryAbortCodePath) {
  ASSERT_TRUE(Download(0x1016, 1, Le(0x00640064, 4)).ok());  // node 100, 100 ms
  const std::vector<AbortCase> cases = {
      {"no object", false, 0x5000, 0, {}, co::SdoAbortCode::kNoObject},
      {"no object (write)", true, 0x5000, 0, {1}, co::SdoAbortCode::kNoObject},
      {"no sub-index", false, 0x1018, 9, {}, co::SdoAbortCode::kNoSubIndex},
      {"write-only", false, 0x2004, 0, {}, co::SdoAbortCode::kWriteOnly},
      {"read-only", true, 0x6041, 0, {1, 0}, co::SdoAbortCode::kReadOnly},
      {"const", true, 0x1000, 0, {1, 0, 0, 0}, co::SdoAbortCode::kReadOnly},
      {"length too high", true, 0x2000, 0, {1, 0, 0}, co::SdoAbortCode::kLengthTooHigh},
      {"length too low", true, 0x2001, 0, {1, 0}, co::SdoAbortCode::kLengthTooLow},
      {"string too long", true, 0x2003, 0, Bytes(33, 'x'), co::SdoAbortCode::kLengthTooHigh},
      {"value too high", true, 0x2000, 0, Le(1001, 2), co::SdoAbortCode::kValueTooHigh},
      {"value too low", true, 0x2000, 0, Le(9, 2), co::SdoAbortCode::kValueTooLow},
      {"1029h above 2", true, 0x1029, 1, {3}, co::SdoAbortCode::kValueTooHigh},
      {"reserved transmission type", true, 0x1800, 2, {245}, co::SdoAbortCode::kValueRange},
      {"RTR type on an RPDO", true, 0x1400, 2, {253}, co::SdoAbortCode::kValueRange},
      {"1003h:00 not 0", true, 0x1003, 0, {1}, co::SdoAbortCode::kValueRange},
      {"1003h entry beyond the count", false, 0x1003, 1, {}, co::SdoAbortCode::kNoData},
      {"hook refuses in this device state",
       true,
       0x6040,
       0,
       {0xFF, 0xFF},
       co::SdoAbortCode::kDeviceState},
      {"1005h generate bit", true, 0x1005, 0, Le(0x40000080, 4), co::SdoAbortCode::kValueRange},
      {"1014h 29-bit bits", true, 0x1014, 0, Le(0x00000885, 4), co::SdoAbortCode::kValueRange},
      {"1016h same node twice", true, 0x1016, 2, Le(0x006400C8, 4),
       co::SdoAbortCode::kParameterIncompatible},
      {"1016h reserved bits", true, 0x1016, 3, Le(0x01010064, 4), co::SdoAbortCode::kValueRange},
  };
  for (const AbortCase& c : cases) {
    absl::Status s = c.write ? Download(c.index, c.sub, c.data) : Upload(c.index, c.sub).status();
    ASSERT_FALSE(s.ok()) << c.name;
    EXPECT_EQ(AbortOf(s), c.code) << c.name << ": " << s;
  }
  // Refused writes change nothing.
  EXPECT_EQ(*node->dictionary().GetInt(0x2000, 0), 100);
  EXPECT_EQ(*node->dictionary().GetInt(0x1029, 1), 0);
  EXPECT_EQ(node->counters().sdo_aborts, cases.size());
}

TEST_F(NodeTest, Sdo_ProtocolAbortsFromTheLibraryServer) {
  Frames();
  auto abort_code = [&](Bytes request) -> std::optional<uint32_t> {
    Feed(transport::MakeCanFrame(0x605, request));
    auto f = Frames();
    if (f.size() != 1) return std::nullopt;
    auto d = co::DecodeSdo(f[0].payload(), co::SdoDirection::kResponse);
    if (!d.ok() || d->command != co::SdoCommand::kAbort) return 0;
    return d->abort_code;
  };
  // A download segment without a transfer, a block upload request: 0504 0001h.
  EXPECT_EQ(abort_code({0x00, 1, 2, 3, 4, 5, 6, 7}), 0x05040001u);
  EXPECT_EQ(abort_code({0xA0, 0x00, 0x10, 0x00, 0x7F, 0, 0, 0}), 0x05040001u);
  // Segmented download of 10 bytes to 2003h, first segment with toggle 1: 0503 0000h.
  EXPECT_EQ(abort_code({0x21, 0x03, 0x20, 0x00, 10, 0, 0, 0}), 0u);  // accepted, no abort
  EXPECT_EQ(abort_code({0x10, 1, 2, 3, 4, 5, 6, 7}), 0x05030000u);
  // A download announcing more than the server takes: 0504 0005h.
  EXPECT_EQ(abort_code({0x21, 0x03, 0x20, 0x00, 0x00, 0x00, 0x02, 0x00}), 0x05040005u);
  EXPECT_EQ(node->dictionary().GetString(0x2003, 0).value(), "abc");
}

TEST_F(NodeTest, Sdo_MessagesNameObjectAndLimit) {
  auto s = Download(0x2000, 0, Le(1001, 2));
  // The client's status carries the abort; the node's own message names field and limit.
  EXPECT_EQ(AbortOf(s), co::SdoAbortCode::kValueTooHigh);
  auto direct = node->dictionary().Write(0x2000, 0, Le(1001, 2));
  EXPECT_THAT(std::string(direct.message()),
              HasSubstr("2000h:00 setpoint: value 1001 above max 1000"));
}

TEST_F(NodeTest, Sdo_InjectedAbortForOneObject) {
  node->InjectSdoAbort(0x2000, 0, co::SdoAbortCode::kHardwareError);
  EXPECT_EQ(AbortOf(Upload(0x2000, 0).status()), co::SdoAbortCode::kHardwareError);
  EXPECT_EQ(AbortOf(Download(0x2000, 0, Le(200, 2))), co::SdoAbortCode::kHardwareError);
  EXPECT_TRUE(Upload(0x2001, 0).ok());
  node->ClearSdoAborts();
  EXPECT_EQ(*UploadU(0x2000, 0), 100);
}

TEST_F(NodeTest, Sdo_SegmentTimeoutAbortsAfterOptionTime) {
  Frames();
  // Segmented download initiate of 10 bytes to 2003h, then silence.
  auto init = co::ToCanFrame(co::InitiateDownloadSegmented(0x2003, 0, 10),
                             co::SdoDirection::kRequest, channel);
  ASSERT_TRUE(init.ok());
  Feed(*init);
  ASSERT_EQ(Frames().size(), 1u);
  At(999ms);
  EXPECT_TRUE(Frames().empty());
  At(1ms);
  auto f = Frames();
  ASSERT_EQ(f.size(), 1u);
  auto decoded = co::DecodeSdo(f[0].payload(), co::SdoDirection::kResponse);
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(decoded->command, co::SdoCommand::kAbort);
  EXPECT_EQ(decoded->abort_code, static_cast<uint32_t>(co::SdoAbortCode::kTimeout));
  EXPECT_EQ(decoded->index, 0x2003);
}

// ---- PDO mapping configuration ----

TEST_F(NodeTest, PdoMapping_LibrarySequenceAccepted_RulesRefusedWithTheirCodes) {
  const co::PdoCommParams comm{0, true, 1, 0, 0};
  ConfigurePdo(co::PdoKind::kTpdo, 1, comm, {{0x6041, 0, 16}, {0x6064, 0, 32}});
  EXPECT_EQ(*node->dictionary().GetInt(0x1800, 1), 0x40000185);
  EXPECT_EQ(*node->dictionary().GetInt(0x1A00, 0), 2);
  EXPECT_EQ(*node->dictionary().GetInt(0x1A00, 2), 0x60640020);
  auto code = [&](uint16_t i, uint8_t s, Bytes d) { return AbortOf(Download(i, s, d)); };
  // Valid PDO: mapping and inhibit time are frozen, the identifier too.
  EXPECT_EQ(code(0x1A00, 0, {0}), co::SdoAbortCode::kUnsupportedAccess);
  EXPECT_EQ(code(0x1A00, 1, Le(0x60400010, 4)), co::SdoAbortCode::kUnsupportedAccess);
  EXPECT_EQ(code(0x1800, 3, Le(10, 2)), co::SdoAbortCode::kValueRange);
  EXPECT_EQ(code(0x1800, 1, Le(0x40000190, 4)), co::SdoAbortCode::kValueRange);
  EXPECT_TRUE(Download(0x1800, 2, {5}).ok());  // the transmission type may change
  // Invalidate: sub 0 still 2, so entries stay frozen.
  ASSERT_TRUE(Download(0x1800, 1, Le(0xC0000185, 4)).ok());
  EXPECT_EQ(code(0x1A00, 1, Le(0x60400010, 4)), co::SdoAbortCode::kUnsupportedAccess);
  ASSERT_TRUE(Download(0x1A00, 0, {0}).ok());
  EXPECT_EQ(code(0x1A00, 1, Le(0x50000010, 4)), co::SdoAbortCode::kNoObject);
  EXPECT_EQ(code(0x1A00, 1, Le(0x20000110, 4)), co::SdoAbortCode::kNoObject);  // no sub 1
  EXPECT_EQ(code(0x1A00, 1, Le(0x20050010, 4)), co::SdoAbortCode::kNotMappable);
  EXPECT_EQ(code(0x1A00, 1, Le(0x20000020, 4)), co::SdoAbortCode::kNotMappable);  // 32 != 16
  EXPECT_EQ(code(0x1A00, 1, Le(0x20040020, 4)), co::SdoAbortCode::kNotMappable);  // wo in TPDO
  EXPECT_EQ(code(0x1A00, 1, Le(0x00070020, 4)), co::SdoAbortCode::kNoObject);  // dummy: RPDO only
  EXPECT_EQ(code(0x1600, 1, Le(0x60410010, 4)), co::SdoAbortCode::kNotMappable);  // ro in RPDO
  EXPECT_TRUE(Download(0x1600, 1, Le(0x00070020, 4)).ok());                       // RPDO dummy
  // 64 + 32 bits: sub 0 = 2 refused with the PDO length code.
  ASSERT_TRUE(Download(0x1A00, 1, Le(0x20060040, 4)).ok());
  ASSERT_TRUE(Download(0x1A00, 2, Le(0x20010020, 4)).ok());
  EXPECT_EQ(code(0x1A00, 0, {2}), co::SdoAbortCode::kPdoLength);
  EXPECT_EQ(code(0x1A00, 0, {9}), co::SdoAbortCode::kValueTooHigh);
  ASSERT_TRUE(Download(0x1A00, 0, {1}).ok());
  // Validating: restricted identifiers and empty mappings are refused.
  EXPECT_EQ(code(0x1800, 1, Le(0x40000705, 4)), co::SdoAbortCode::kValueRange);
  EXPECT_EQ(code(0x1800, 1, Le(0x20000185, 4)), co::SdoAbortCode::kValueRange);
  EXPECT_EQ(code(0x1801, 1, Le(0x40000285, 4)), co::SdoAbortCode::kValueRange);  // no mapping
  EXPECT_TRUE(Download(0x1800, 1, Le(0x40000185, 4)).ok());
}

// ---- PDO transmission ----

TEST_F(NodeTest, SyncTpdo_EveryThirdSyncWithValuesSampledAtTheSync) {
  ConfigurePdo(co::PdoKind::kTpdo, 1, {0, true, 3, 0, 0}, {{0x6064, 0, 32}});
  // PDOs only in OPERATIONAL.
  Sync();
  Sync();
  Sync();
  EXPECT_TRUE(Frames().empty());
  Nmt(co::NmtCommand::kStart);
  std::vector<int32_t> seen;
  for (int i = 1; i <= 9; ++i) {
    model.position = i * 10;
    Sync();
    for (const CanFrame& f : Frames()) {
      ASSERT_EQ(f.id, 0x185u);
      ASSERT_EQ(f.dlc, 4);
      seen.push_back(
          static_cast<int32_t>(f.data[0] | f.data[1] << 8 | f.data[2] << 16 | f.data[3] << 24));
    }
  }
  EXPECT_THAT(seen, ElementsAre(30, 60, 90));
  EXPECT_EQ(node->counters().syncs, 9u);
}

TEST_F(NodeTest, SyncTpdo_AcyclicType0OnlyAfterAChange) {
  ConfigurePdo(co::PdoKind::kTpdo, 2, {0, true, 0, 0, 0}, {{0x2000, 0, 16}});
  Nmt(co::NmtCommand::kStart);
  Sync();
  EXPECT_EQ(Frames().size(), 1u);  // first SYNC in OPERATIONAL
  Sync();
  EXPECT_TRUE(Frames().empty());
  ASSERT_TRUE(node->dictionary().SetInt(0x2000, 0, 200).ok());
  EXPECT_TRUE(Frames().empty());  // waits for the SYNC
  Sync();
  auto f = Frames();
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].id, 0x285u);
  EXPECT_THAT(Data(f[0]), ElementsAre(200, 0));
  node->RequestTpdo(2);
  Sync();
  EXPECT_EQ(Frames().size(), 1u);
}

TEST_F(NodeTest, EventTpdo_InhibitTimeDelaysChanges_EventTimerRepeats) {
  // Inhibit 100 x 100 us = 10 ms, event timer 50 ms.
  ConfigurePdo(co::PdoKind::kTpdo, 2, {0, true, 255, 100, 50}, {{0x2000, 0, 16}});
  Frames();
  Nmt(co::NmtCommand::kStart);
  auto f = Frames();  // sent once on entering OPERATIONAL
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].id, 0x285u);
  EXPECT_THAT(Data(f[0]), ElementsAre(100, 0));
  At(1ms);
  ASSERT_TRUE(node->dictionary().SetInt(0x2000, 0, 101).ok());
  At(1ms);
  ASSERT_TRUE(node->dictionary().SetInt(0x2000, 0, 102).ok());
  At(7ms);  // 9 ms after the first transmission
  EXPECT_TRUE(Frames().empty());
  At(1ms);  // inhibit time over: the latest value
  f = Frames();
  ASSERT_EQ(f.size(), 1u);
  EXPECT_THAT(Data(f[0]), ElementsAre(102, 0));
  At(49ms);
  EXPECT_TRUE(Frames().empty());
  At(1ms);  // event timer: unchanged data again
  f = Frames();
  ASSERT_EQ(f.size(), 1u);
  EXPECT_THAT(Data(f[0]), ElementsAre(102, 0));
  // An application request without a change.
  At(20ms);
  node->RequestTpdo(2);
  EXPECT_EQ(Frames().size(), 1u);
  // Leaving OPERATIONAL stops it.
  Nmt(co::NmtCommand::kEnterPreOperational);
  At(200ms);
  EXPECT_TRUE(Frames().empty());
}

TEST_F(NodeTest, Rpdo_SynchronousAppliedAtNextSync_EventDrivenAtOnce) {
  ConfigurePdo(co::PdoKind::kRpdo, 1, {0, true, 1, 0, 0}, {{0x6040, 0, 16}, {0x2001, 0, 32}});
  ConfigurePdo(co::PdoKind::kRpdo, 2, {0, true, 255, 0, 0},
               {{0x0006, 0, 16}, {0x2000, 0, 16}});  // a dummy entry first
  Nmt(co::NmtCommand::kStart);
  Frames();
  Feed(transport::MakeCanFrame(0x205, Bytes{0x0F, 0x00, 0x07, 0, 0, 0}));
  EXPECT_EQ(*node->dictionary().GetInt(0x6040, 0), 0);  // not before the SYNC
  EXPECT_TRUE(model.rpdos.empty());
  Sync();
  EXPECT_EQ(*node->dictionary().GetInt(0x6040, 0), 0x0F);
  EXPECT_EQ(*node->dictionary().GetInt(0x2001, 0), 7);
  EXPECT_THAT(model.controlwords, ElementsAre(0x0F));  // the write hook ran
  EXPECT_THAT(model.rpdos, ElementsAre(1));
  Feed(transport::MakeCanFrame(0x305, Bytes{0xFF, 0xFF, 0x2C, 0x01}));
  EXPECT_EQ(*node->dictionary().GetInt(0x2000, 0), 300);
  EXPECT_THAT(model.rpdos, ElementsAre(1, 2));
  // Out of range for 2000h: the object keeps its value, counted.
  Feed(transport::MakeCanFrame(0x305, Bytes{0, 0, 0xFF, 0xFF}));
  EXPECT_EQ(*node->dictionary().GetInt(0x2000, 0), 300);
  EXPECT_EQ(node->counters().rpdo_write_errors, 1u);
  EXPECT_TRUE(Frames().empty());
  // Too short: not processed, EMCY 8210h.
  Feed(transport::MakeCanFrame(0x305, Bytes{1, 2, 3}));
  auto f = Frames();
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].id, 0x85u);
  EXPECT_THAT(Data(f[0]), ElementsAre(0x10, 0x82, 0x11, 0, 0, 0, 0, 0));
  // Not in PRE-OPERATIONAL.
  Nmt(co::NmtCommand::kEnterPreOperational);
  Feed(transport::MakeCanFrame(0x305, Bytes{0, 0, 0x90, 0x01}));
  EXPECT_EQ(*node->dictionary().GetInt(0x2000, 0), 300);
}

TEST_F(NodeTest, Rpdo_DeadlineMonitoringRaisesEmcy8250h) {
  ConfigurePdo(co::PdoKind::kRpdo, 1, {0, true, 255, 0, 20}, {{0x6040, 0, 16}});
  Nmt(co::NmtCommand::kStart);
  At(100ms);
  Frames();  // no monitoring before the first RPDO
  Feed(transport::MakeCanFrame(0x205, Bytes{6, 0}));
  At(20ms);
  EXPECT_TRUE(Frames().empty());
  At(1ms);
  auto f = Frames();
  ASSERT_EQ(f.size(), 1u);
  EXPECT_THAT(Data(f[0]), ElementsAre(0x50, 0x82, 0x11, 0, 0, 0, 0, 0));
}

TEST_F(NodeTest, Model_TickedToEveryInstant) {
  model.velocity = 1000;  // counts per second
  At(250ms);
  EXPECT_EQ(model.ticked, 250ms);
  EXPECT_EQ(model.position, 250);
  EXPECT_EQ(*UploadU(0x6064, 0), 250);
}

// ---- EMCY ----

TEST_F(NodeTest, Emcy_FrameErrorRegisterAndHistory) {
  Frames();
  node->RaiseEmcy(0x2310, co::error_register::kCurrent, {1, 2, 3, 4, 5});
  auto f = Frames();
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].id, 0x85u);
  EXPECT_THAT(Data(f[0]), ElementsAre(0x10, 0x23, 0x03, 1, 2, 3, 4, 5));
  EXPECT_EQ(*UploadU(0x1001, 0), 0x03);
  node->RaiseEmcy(0x4210, co::error_register::kTemperature);
  Frames();
  EXPECT_EQ(*UploadU(0x1001, 0), 0x0B);
  EXPECT_EQ(*UploadU(0x1003, 0), 2);
  EXPECT_EQ(*UploadU(0x1003, 1), 0x4210);  // newest first
  EXPECT_EQ(*UploadU(0x1003, 2), 0x2310);
  for (int i = 0; i < 10; ++i) node->RaiseEmcy(static_cast<uint16_t>(0x5000 + i), 0);
  EXPECT_EQ(*UploadU(0x1003, 0), kErrorHistoryDepth);
  EXPECT_EQ(*UploadU(0x1003, 1), 0x5009);
  EXPECT_EQ(*UploadU(0x1003, 8), 0x5002);
  ASSERT_TRUE(Download(0x1003, 0, {0}).ok());
  EXPECT_EQ(*UploadU(0x1003, 0), 0);
  EXPECT_EQ(AbortOf(Upload(0x1003, 1).status()), co::SdoAbortCode::kNoData);
  Frames();
  node->ClearErrors();
  f = Frames();
  ASSERT_EQ(f.size(), 1u);
  EXPECT_THAT(Data(f[0]), ElementsAre(0, 0, 0, 0, 0, 0, 0, 0));
  EXPECT_EQ(*UploadU(0x1001, 0), 0);
  // STOPPED: recorded, not sent; 1014h invalid: not sent either.
  Nmt(co::NmtCommand::kStop);
  node->RaiseEmcy(0x1000, 0);
  EXPECT_TRUE(Frames().empty());
  Nmt(co::NmtCommand::kEnterPreOperational);
  ASSERT_TRUE(Download(0x1014, 0, Le(0x80000085, 4)).ok());
  node->RaiseEmcy(0x1000, 0);
  EXPECT_TRUE(Frames().empty() || Frames().front().id != 0x85u);
  EXPECT_EQ(*UploadU(0x1003, 0), 2);
}

// ---- heartbeat consumer and 1029h ----

TEST_F(NodeTest, HeartbeatConsumer_TimeoutAppliesErrorBehaviour) {
  SlaveNodeOptions o;
  o.master_node = 100;
  o.master_heartbeat_ms = 200;
  Make(o);
  const CanFrame master_hb = *co::EncodeErrorControl({100, NmtState::kOperational, false});
  Nmt(co::NmtCommand::kStart);
  Frames();
  At(1s);
  EXPECT_TRUE(Frames().empty());  // monitoring starts with the first heartbeat
  Feed(master_hb);
  At(200ms);
  Feed(master_hb);
  At(200ms);
  EXPECT_TRUE(Frames().empty());
  EXPECT_EQ(node->state(), NmtState::kOperational);
  At(1ms);
  auto f = Frames();
  ASSERT_EQ(f.size(), 1u);
  EXPECT_THAT(Data(f[0]), ElementsAre(0x30, 0x81, 0x11, 0, 0, 0, 0, 0));
  EXPECT_EQ(node->state(), NmtState::kPreOperational);  // 1029h:01 = 0
  // 1029h:01 = 2: STOPPED.
  ASSERT_TRUE(Download(0x1029, 1, {2}).ok());
  Nmt(co::NmtCommand::kStart);
  Feed(master_hb);
  At(201ms);
  EXPECT_EQ(node->state(), NmtState::kStopped);
  // 1029h:01 = 1: no change.
  Nmt(co::NmtCommand::kEnterPreOperational);
  ASSERT_TRUE(Download(0x1029, 1, {1}).ok());
  Nmt(co::NmtCommand::kStart);
  Feed(master_hb);
  At(201ms);
  EXPECT_EQ(node->state(), NmtState::kOperational);
  EXPECT_EQ(*UploadU(0x1003, 0), 3);
}

// ---- faults ----

TEST_F(NodeTest, Fault_RebootMidOperation) {
  ASSERT_TRUE(Download(0x2000, 0, Le(900, 2)).ok());
  ASSERT_TRUE(Download(0x1017, 0, Le(100, 2)).ok());
  ConfigurePdo(co::PdoKind::kTpdo, 1, {0, true, 1, 0, 0}, {{0x6064, 0, 32}});
  Nmt(co::NmtCommand::kStart);
  model.position = 55;
  Frames();
  At(10ms);
  node->Reboot(now);
  auto f = Frames();
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].id, 0x705u);
  EXPECT_THAT(Data(f[0]), ElementsAre(0x00));
  EXPECT_EQ(node->state(), NmtState::kPreOperational);
  EXPECT_EQ(model.resets, 1);
  EXPECT_EQ(model.position, 0);
  EXPECT_EQ(*UploadU(0x2000, 0), 100);
  EXPECT_EQ(*UploadU(0x1800, 1), 0xC0000185);  // the PDO configuration is gone too
  EXPECT_EQ(*UploadU(0x1017, 0), 0);
}

TEST_F(NodeTest, Fault_SilentAndHeartbeatLoss) {
  ASSERT_TRUE(Download(0x1017, 0, Le(100, 2)).ok());
  Frames();
  node->SetSilent(true);
  EXPECT_FALSE(Upload(0x1000, 0).ok());  // no answer
  Nmt(co::NmtCommand::kStart);           // not received either
  EXPECT_EQ(node->state(), NmtState::kPreOperational);
  At(300ms);
  EXPECT_TRUE(Frames().empty());
  node->SetSilent(false);
  EXPECT_TRUE(Upload(0x1000, 0).ok());
  node->SetHeartbeatLoss(true);
  At(300ms);
  EXPECT_TRUE(Frames().empty());
  EXPECT_TRUE(Upload(0x1000, 0).ok());  // SDO still works
  node->SetHeartbeatLoss(false);
  At(100ms);
  EXPECT_EQ(Frames().size(), 1u);
}

TEST_F(NodeTest, Create_RefusesBadOptions) {
  SlaveNodeOptions o;
  o.node_id = 0;
  EXPECT_THAT(std::string(SlaveNode::Create(o).status().message()), HasSubstr("options.node_id"));
  o.node_id = 3;
  o.master_node = 3;
  EXPECT_THAT(std::string(SlaveNode::Create(o).status().message()),
              HasSubstr("options.master_node"));
  o.master_node = 0;
  o.sdo_timeout = Duration::zero();
  EXPECT_FALSE(SlaveNode::Create(o).ok());
}

}  // namespace
}  // namespace drivegw::sim::canopen
