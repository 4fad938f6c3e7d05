// msgpack subset round trips and refusals, and the python-can udp_multicast message codec.
#include "adapters/transport/msgpack_lite.h"

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "adapters/transport/udp_multicast_channel.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace drivegw::transport {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

std::vector<uint8_t> Bytes(std::initializer_list<int> v) {
  std::vector<uint8_t> out;
  for (int b : v) out.push_back(static_cast<uint8_t>(b));
  return out;
}

TEST(MsgpackWriter, ShortestIntEncodings) {
  msgpack::Writer w;
  w.Uint(0x7f);
  w.Uint(0x80);
  w.Uint(0x100);
  w.Uint(0x10000);
  w.Uint(0x100000000ull);
  w.Int(-1);
  w.Int(-33);
  w.Int(-200);
  EXPECT_EQ(w.bytes(),
            Bytes({0x7f, 0xcc, 0x80, 0xcd, 0x01, 0x00, 0xce, 0x00, 0x01, 0x00, 0x00, 0xcf, 0,
                   0,    0,    1,    0,    0,    0,    0,    0xff, 0xd0, 0xdf, 0xd1, 0xff, 0x38}));
}

TEST(MsgpackWriter, StrBinMapNilBoolFloat) {
  msgpack::Writer w;
  w.MapHeader(2);
  w.Str("dlc");
  w.Nil();
  w.Bool(true);
  w.Bin(Bytes({1, 2}));
  w.Float64(1.5);
  EXPECT_EQ(w.bytes(), Bytes({0x82, 0xa3, 'd',  'l',  'c', 0xc0, 0xc3, 0xc4, 0x02, 1,
                              2,    0xcb, 0x3f, 0xf8, 0,   0,    0,    0,    0,    0}));
}

TEST(MsgpackReader, RoundTripEveryKind) {
  msgpack::Writer w;
  w.ArrayHeader(20);
  w.MapHeader(16);
  w.Str(std::string(40, 'x'));
  w.Str(std::string(300, 'y'));
  w.Bin(std::vector<uint8_t>(70000, 7));
  for (int64_t v : {int64_t{0}, int64_t{-32}, int64_t{-129}, int64_t{-40000}, int64_t{-3000000000},
                    std::numeric_limits<int64_t>::min(), int64_t{65535}, int64_t{1} << 40}) {
    w.Int(v);
  }
  w.Float64(-2.25);
  msgpack::Reader r(w.bytes());
  EXPECT_EQ(*r.ReadArrayHeader(), 20u);
  EXPECT_EQ(*r.ReadMapHeader(), 16u);
  EXPECT_EQ(std::string(*r.ReadStr()), std::string(40, 'x'));
  EXPECT_EQ(r.ReadStr()->size(), 300u);
  EXPECT_EQ(r.ReadBin()->size(), 70000u);
  for (int64_t v : {int64_t{0}, int64_t{-32}, int64_t{-129}, int64_t{-40000}, int64_t{-3000000000},
                    std::numeric_limits<int64_t>::min(), int64_t{65535}, int64_t{1} << 40}) {
    EXPECT_EQ(*r.ReadInt(), v);
  }
  EXPECT_EQ(*r.ReadFloat(), -2.25);
  EXPECT_TRUE(r.at_end());
}

TEST(MsgpackReader, Float32AndIntAsFloat) {
  const auto f32 = Bytes({0xca, 0x3f, 0xc0, 0x00, 0x00, 0x05});  // 1.5f, then fixint 5
  msgpack::Reader r(f32);
  EXPECT_EQ(*r.ReadFloat(), 1.5);
  EXPECT_EQ(*r.ReadFloat(), 5.0);
}

TEST(MsgpackReader, Uint64AboveInt64_OutOfRangeButSkippable) {
  const auto big = Bytes({0xcf, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff});
  msgpack::Reader r(big);
  EXPECT_EQ(r.ReadInt().status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(r.position(), 0u);
  EXPECT_TRUE(r.Skip().ok());
  EXPECT_TRUE(r.at_end());
}

TEST(MsgpackReader, Truncated_FailsWithoutMoving) {
  for (const auto& bytes : {Bytes({0xcd, 0x01}), Bytes({0xa5, 'a', 'b'}), Bytes({0xc4, 0x05, 1}),
                            Bytes({0xdb, 0, 0}), Bytes({0xde, 0}), Bytes({0xcb, 0, 0, 0})}) {
    msgpack::Reader r(bytes);
    EXPECT_FALSE(r.Skip().ok());
    EXPECT_EQ(r.position(), 0u);
  }
  msgpack::Reader empty(std::span<const uint8_t>{});
  EXPECT_THAT(std::string(empty.ReadInt().status().message()), HasSubstr("msgpack offset 0"));
}

TEST(MsgpackReader, HugeLengthPrefix_RefusedNotAllocated) {
  const auto bytes = Bytes({0xc6, 0xff, 0xff, 0xff, 0xff, 1, 2});
  msgpack::Reader r(bytes);
  EXPECT_THAT(std::string(r.ReadBin().status().message()), HasSubstr("truncated"));
}

TEST(MsgpackReader, NeverUsedByte_Refused) {
  const auto bytes = Bytes({0xc1});
  msgpack::Reader r(bytes);
  EXPECT_THAT(std::string(r.PeekType().status().message()), HasSubstr("0xc1 is never used"));
}

TEST(MsgpackReader, DeepNesting_RefusedByDepthBound) {
  std::vector<uint8_t> deep(100, 0x91);  // [[[[...]]]]
  deep.push_back(0xc0);
  msgpack::Reader r(deep);
  EXPECT_THAT(std::string(r.Skip().message()), HasSubstr("nested deeper than"));
  std::vector<uint8_t> ok(10, 0x91);
  ok.push_back(0xc0);
  msgpack::Reader r2(ok);
  EXPECT_TRUE(r2.Skip().ok());
}

TEST(MsgpackReader, SkipExt) {
  const auto bytes = Bytes({0xd6, 0xff, 1, 2, 3, 4, 0xc7, 0x02, 0x01, 9, 9, 0xc0});
  msgpack::Reader r(bytes);
  EXPECT_TRUE(r.Skip().ok());
  EXPECT_TRUE(r.Skip().ok());
  EXPECT_TRUE(r.ReadNil().ok());
  EXPECT_TRUE(r.at_end());
}

TEST(MsgpackReader, RandomBytes_NeverCrash) {
  std::mt19937 rng(7);
  for (int i = 0; i < 20000; ++i) {
    std::vector<uint8_t> bytes(rng() % 40);
    for (auto& b : bytes) b = static_cast<uint8_t>(rng());
    msgpack::Reader r(bytes);
    while (!r.at_end() && r.Skip().ok()) {
    }
  }
}

// python-can 4.1: pack_message(Message(timestamp=1700000000.5, arbitration_id=0x42E,
// is_extended_id=False, data=[0, 0x4B, 3, 1, 3])) — bytes written out by msgpack-python 1.0.3
// (Debian 12), checked against the live library by python_can_interop_test too.
const char kPythonPacked42E[] =
    "8ba974696d657374616d70cb41d954fc40200000ae6172626974726174696f6e5f6964cd042eae69735f657874"
    "656e6465645f6964c2af69735f72656d6f74655f6672616d65c2ae69735f6572726f725f6672616d65c2a76368"
    "616e6e656cc0a3646c6305a464617461c405004b030103a569735f6664c2ae626974726174655f737769746368"
    "c2b56572726f725f73746174655f696e64696361746f72c2";

std::vector<uint8_t> FromHex(std::string_view hex) {
  std::vector<uint8_t> out;
  for (size_t i = 0; i + 1 < hex.size(); i += 2) {
    out.push_back(static_cast<uint8_t>(std::stoi(std::string(hex.substr(i, 2)), nullptr, 16)));
  }
  return out;
}

TEST(PythonCanMessage, Encode_EqualsMsgpackPythonBytes) {
  const std::array<uint8_t, 5> data{0, 0x4B, 3, 1, 3};
  EXPECT_EQ(EncodePythonCanMessage(MakeCanFrame(0x42E, data), 1700000000.5),
            FromHex(kPythonPacked42E));
}

TEST(PythonCanMessage, RoundTrip_StandardExtendedRtrEmpty) {
  const std::array<uint8_t, 8> eight{1, 2, 3, 4, 5, 6, 7, 8};
  for (const CanFrame& f :
       {MakeCanFrame(0x000, {}), MakeCanFrame(0x7FF, eight), MakeCanFrame(0x1FFFFFFF, eight, true),
        MakeCanRtrFrame(0x123, 8), MakeCanRtrFrame(0x1234567, 0, true)}) {
    auto back = DecodePythonCanMessage(EncodePythonCanMessage(f, 12.25));
    ASSERT_TRUE(back.ok()) << back.status();
    EXPECT_EQ(*back, f) << FormatCanFrame(f);
  }
}

std::vector<uint8_t> Dict(const std::function<void(msgpack::Writer&)>& fill, uint32_t entries) {
  msgpack::Writer w;
  w.MapHeader(entries);
  fill(w);
  return w.Take();
}

TEST(PythonCanMessage, MissingKeys_TakeMessageDefaults) {
  // can.Message() defaults: is_extended_id=True, dlc=len(data).
  const auto bytes = Dict(
      [](msgpack::Writer& w) {
        w.Str("arbitration_id");
        w.Uint(0x123456);
        w.Str("data");
        w.Bin(Bytes({9, 8}));
      },
      2);
  auto f = DecodePythonCanMessage(bytes);
  ASSERT_TRUE(f.ok()) << f.status();
  EXPECT_TRUE(f->extended);
  EXPECT_EQ(f->id, 0x123456u);
  EXPECT_EQ(f->dlc, 2);
}

TEST(PythonCanMessage, DataAsArrayAndChannelString_Accepted) {
  const auto bytes = Dict(
      [](msgpack::Writer& w) {
        w.Str("is_extended_id");
        w.Bool(false);
        w.Str("channel");
        w.Str("vcan0");
        w.Str("data");
        w.ArrayHeader(2);
        w.Uint(255);
        w.Uint(1);
        w.Str("is_rx");
        w.Bool(true);
      },
      4);
  auto f = DecodePythonCanMessage(bytes);
  ASSERT_TRUE(f.ok()) << f.status();
  EXPECT_EQ(FormatCanFrame(*f), "000#FF01");
}

struct BadCase {
  const char* name;
  std::function<void(msgpack::Writer&)> fill;
  uint32_t entries;
  const char* message;
};

TEST(PythonCanMessage, Refusals_NameTheKey) {
  const std::vector<BadCase> cases = {
      {"unknown key",
       [](msgpack::Writer& w) {
         w.Str("colour");
         w.Nil();
       },
       1, "python-can message.colour: is not a can.Message field"},
      {"dlc mismatch",
       [](msgpack::Writer& w) {
         w.Str("dlc");
         w.Uint(3);
         w.Str("data");
         w.Bin(Bytes({1}));
       },
       2, "python-can message.dlc: 3 differs from the 1 data bytes"},
      {"dlc 9",
       [](msgpack::Writer& w) {
         w.Str("dlc");
         w.Uint(9);
         w.Str("is_remote_frame");
         w.Bool(true);
       },
       2, "python-can message.dlc: 9 exceeds 8"},
      {"base id",
       [](msgpack::Writer& w) {
         w.Str("is_extended_id");
         w.Bool(false);
         w.Str("arbitration_id");
         w.Uint(0x800);
       },
       2, "python-can message.arbitration_id: 2048 exceeds 0x7FF (11-bit)"},
      {"ext id",
       [](msgpack::Writer& w) {
         w.Str("arbitration_id");
         w.Uint(0x20000000);
       },
       1, "python-can message.arbitration_id: 536870912 exceeds 0x1FFFFFFF (29-bit)"},
      {"remote with data",
       [](msgpack::Writer& w) {
         w.Str("is_remote_frame");
         w.Bool(true);
         w.Str("data");
         w.Bin(Bytes({1}));
       },
       2, "python-can message.data: remote frames carry no data"},
      {"remote error",
       [](msgpack::Writer& w) {
         w.Str("is_remote_frame");
         w.Bool(true);
         w.Str("is_error_frame");
         w.Bool(true);
       },
       2, "python-can message.is_remote_frame: a frame cannot be remote and error"},
      {"negative timestamp",
       [](msgpack::Writer& w) {
         w.Str("timestamp");
         w.Float64(-1);
       },
       1, "python-can message.timestamp: negative, infinite or NaN"},
      {"nan timestamp",
       [](msgpack::Writer& w) {
         w.Str("timestamp");
         w.Float64(std::nan(""));
       },
       1, "python-can message.timestamp: negative, infinite or NaN"},
      {"flag not bool",
       [](msgpack::Writer& w) {
         w.Str("is_extended_id");
         w.Str("yes");
       },
       1, "python-can message.is_extended_id: msgpack offset 16: expected bool"},
      {"brs without fd",
       [](msgpack::Writer& w) {
         w.Str("bitrate_switch");
         w.Bool(true);
       },
       1, "python-can message.bitrate_switch: only allowed for CAN FD frames"},
      {"data not bytes",
       [](msgpack::Writer& w) {
         w.Str("data");
         w.Str("abc");
       },
       1, "python-can message.data: is neither bin nor an array of bytes"},
  };
  for (const BadCase& c : cases) {
    auto f = DecodePythonCanMessage(Dict(c.fill, c.entries));
    EXPECT_EQ(f.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_EQ(f.status().message(), c.message) << c.name;
  }
}

TEST(PythonCanMessage, CanFd_Unimplemented) {
  const auto bytes = Dict(
      [](msgpack::Writer& w) {
        w.Str("is_fd");
        w.Bool(true);
      },
      1);
  EXPECT_EQ(DecodePythonCanMessage(bytes).status().code(), absl::StatusCode::kUnimplemented);
}

TEST(PythonCanMessage, NotAMapOrTrailingBytes_Refused) {
  EXPECT_FALSE(DecodePythonCanMessage(Bytes({0x91, 0xc0})).ok());
  EXPECT_FALSE(DecodePythonCanMessage(Bytes({})).ok());
  auto good = EncodePythonCanMessage(MakeCanFrame(1, {}), 0);
  good.push_back(0xc0);
  EXPECT_THAT(std::string(DecodePythonCanMessage(good).status().message()),
              HasSubstr("1 trailing bytes"));
}

TEST(PythonCanMessage, BitFlips_NeverCrash) {
  const std::array<uint8_t, 8> eight{1, 2, 3, 4, 5, 6, 7, 8};
  const auto good = EncodePythonCanMessage(MakeCanFrame(0x1ABCDE, eight, true), 3.5);
  std::mt19937 rng(11);
  int decoded = 0;
  for (int i = 0; i < 50000; ++i) {
    auto bytes = good;
    const int flips = 1 + static_cast<int>(rng() % 4);
    for (int k = 0; k < flips; ++k)
      bytes[rng() % bytes.size()] ^= static_cast<uint8_t>(1u << (rng() % 8));
    if (rng() % 4 == 0) bytes.resize(rng() % bytes.size());
    auto f = DecodePythonCanMessage(bytes);
    if (f.ok()) {
      ++decoded;
      EXPECT_LE(f->dlc, 8);
    }
  }
  EXPECT_GT(decoded, 0);  // some flips (timestamp bits) keep the frame valid
}

}  // namespace
}  // namespace drivegw::transport
