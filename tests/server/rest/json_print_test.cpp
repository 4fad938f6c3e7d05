// PrintJson against protobuf's MessageToJsonString (the printer it stands in for, decision
// 1332): every message type of every drivegw.v1 proto file, filled at random many times with a
// fixed seed — special doubles and floats (NaN, infinities, -0, subnormals, random bit
// patterns), 64-bit extremes, unknown enum numbers, strings with and without characters that
// need escaping, empty and filled lists, set and unset sub-messages, timestamps across and
// beyond their range — must print byte for byte the same, and the direct walk must have
// answered most of them itself (else the test proves nothing about it).
#include "server/rest/json_print.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "drivegw/v1/audit.pb.h"
#include "drivegw/v1/auth.pb.h"
#include "drivegw/v1/curve_sets.pb.h"
#include "drivegw/v1/drive.pb.h"
#include "drivegw/v1/leases.pb.h"
#include "drivegw/v1/ops.pb.h"
#include "drivegw/v1/parameter_sets.pb.h"
#include "google/protobuf/descriptor.h"
#include "google/protobuf/message.h"
#include "google/protobuf/util/json_util.h"

namespace drivegw::rest {
namespace {

namespace pb = google::protobuf;
using Cpp = pb::FieldDescriptor::CppType;

std::string Reference(const pb::Message& m) {
  pb::util::JsonPrintOptions o;
  o.always_print_primitive_fields = true;
  o.preserve_proto_field_names = true;
  std::string json;
  const auto s = pb::util::MessageToJsonString(m, &json, o);
  return s.ok() ? json : "error: " + std::string(s.message());
}

class Filler {
 public:
  explicit Filler(uint32_t seed) : rng_(seed) {}

  void Fill(pb::Message* m, int depth) {
    const pb::Descriptor* d = m->GetDescriptor();
    const pb::Reflection* r = m->GetReflection();
    if (d->well_known_type() == pb::Descriptor::WELLKNOWNTYPE_TIMESTAMP) {
      r->SetInt64(m, d->FindFieldByNumber(1), Seconds());
      r->SetInt32(m, d->FindFieldByNumber(2), Nanos());
      return;
    }
    for (int i = 0; i < d->field_count(); ++i) {
      const pb::FieldDescriptor* f = d->field(i);
      if (Chance(25)) continue;  // left at its default
      if (f->is_map()) {
        if (Chance(30)) AddMapEntry(m, f, depth);
        continue;
      }
      if (f->is_repeated()) {
        const int n = Pick(0, 3);
        for (int k = 0; k < n; ++k) Add(m, f, depth);
        continue;
      }
      Set(m, f, depth);
    }
  }

 private:
  bool Chance(int percent) { return Pick(0, 99) < percent; }
  int Pick(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }

  int64_t Seconds() {
    switch (Pick(0, 5)) {
      case 0:
        return 0;
      case 1:
        return -62135596800 - Pick(0, 1);  // year 1, and one second before it
      case 2:
        return 253402300799 + Pick(0, 1);  // year 9999, and one second after it
      case 3:
        return -static_cast<int64_t>(rng_() % 62135596800ull);
      default:
        return static_cast<int64_t>(rng_() % 4102444800ull);  // up to 2100
    }
  }
  int32_t Nanos() {
    switch (Pick(0, 5)) {
      case 0:
        return 0;
      case 1:
        return Pick(0, 999) * 1000000;
      case 2:
        return Pick(0, 999999) * 1000;
      case 3:
        return Pick(0, 1) == 0 ? -1 : 1000000000;  // out of range
      default:
        return static_cast<int32_t>(rng_() % 1000000000u);
    }
  }
  double Double() {
    switch (Pick(0, 11)) {
      case 0:
        return std::numeric_limits<double>::quiet_NaN();
      case 1:
        return Pick(0, 1) ? std::numeric_limits<double>::infinity()
                          : -std::numeric_limits<double>::infinity();
      case 2:
        return -0.0;
      case 3:
        return std::numeric_limits<double>::denorm_min() * Pick(1, 1000);
      case 4:
        return Pick(0, 1) ? std::numeric_limits<double>::max() : std::numeric_limits<double>::min();
      case 5: {
        uint64_t bits = (static_cast<uint64_t>(rng_()) << 32) | rng_();
        double v;
        std::memcpy(&v, &bits, sizeof v);
        return v;
      }
      case 6:
        return Pick(-100000, 100000) / 1000.0;  // positions in mm
      case 7:
        return 0.1 * Pick(-30, 30);
      case 8:
        return std::ldexp(static_cast<double>(rng_()), Pick(-80, 80));
      default:
        return std::uniform_real_distribution<double>(-1e6, 1e6)(rng_);
    }
  }
  float Float() {
    if (Chance(30)) {
      uint32_t bits = rng_();
      float v;
      std::memcpy(&v, &bits, sizeof v);
      return v;
    }
    return static_cast<float>(Double());
  }
  std::string String() {
    static const char* kPlain[] = {"",
                                   "x1",
                                   "drives/x1",
                                   "udp://127.0.0.1:49360",
                                   "drives/x1/commands/17",
                                   "Limit switch (negative) active",
                                   "a-b_c.d~e!$&'()*+,;=:@%"};
    static const char* kEscaped[] = {"say \"hi\"",  "back\\slash",  "<b>",
                                     "tab\there",   "line\nfeed",   "\x01\x1f\x7f",
                                     "caf\xc3\xa9", "\xe2\x80\xa8", "\xe6\x97\xa5"};
    if (Chance(80)) return kPlain[Pick(0, std::size(kPlain) - 1)];
    return kEscaped[Pick(0, std::size(kEscaped) - 1)];
  }
  int Enum(const pb::FieldDescriptor* f) {
    const pb::EnumDescriptor* e = f->enum_type();
    if (Chance(10)) return 1000 + Pick(0, 5);  // not a known value
    return e->value(Pick(0, e->value_count() - 1))->number();
  }

  void Set(pb::Message* m, const pb::FieldDescriptor* f, int depth) {
    const pb::Reflection* r = m->GetReflection();
    switch (f->cpp_type()) {
      case Cpp::CPPTYPE_INT32:
        r->SetInt32(m, f, Chance(20) ? std::numeric_limits<int32_t>::min() : Pick(-5000, 5000));
        break;
      case Cpp::CPPTYPE_UINT32:
        r->SetUInt32(m, f, Chance(20) ? std::numeric_limits<uint32_t>::max() : rng_());
        break;
      case Cpp::CPPTYPE_INT64:
        r->SetInt64(m, f,
                    Chance(20) ? std::numeric_limits<int64_t>::min()
                               : static_cast<int64_t>(rng_()) * Pick(-3, 3));
        break;
      case Cpp::CPPTYPE_UINT64:
        r->SetUInt64(m, f,
                     Chance(20) ? std::numeric_limits<uint64_t>::max()
                                : (static_cast<uint64_t>(rng_()) << 20));
        break;
      case Cpp::CPPTYPE_DOUBLE:
        r->SetDouble(m, f, Double());
        break;
      case Cpp::CPPTYPE_FLOAT:
        r->SetFloat(m, f, Float());
        break;
      case Cpp::CPPTYPE_BOOL:
        r->SetBool(m, f, Chance(50));
        break;
      case Cpp::CPPTYPE_ENUM:
        r->SetEnumValue(m, f, Enum(f));
        break;
      case Cpp::CPPTYPE_STRING:
        r->SetString(m, f, f->type() == pb::FieldDescriptor::TYPE_BYTES ? "\x01\x02" : String());
        break;
      case Cpp::CPPTYPE_MESSAGE:
        if (depth < 4 && Chance(70)) Fill(r->MutableMessage(m, f), depth + 1);
        break;
    }
  }
  void Add(pb::Message* m, const pb::FieldDescriptor* f, int depth) {
    const pb::Reflection* r = m->GetReflection();
    switch (f->cpp_type()) {
      case Cpp::CPPTYPE_INT32:
        r->AddInt32(m, f, Pick(-5000, 5000));
        break;
      case Cpp::CPPTYPE_UINT32:
        r->AddUInt32(m, f, rng_());
        break;
      case Cpp::CPPTYPE_INT64:
        r->AddInt64(m, f, static_cast<int64_t>(rng_()) * Pick(-3, 3));
        break;
      case Cpp::CPPTYPE_UINT64:
        r->AddUInt64(m, f, static_cast<uint64_t>(rng_()) << 20);
        break;
      case Cpp::CPPTYPE_DOUBLE:
        r->AddDouble(m, f, Double());
        break;
      case Cpp::CPPTYPE_FLOAT:
        r->AddFloat(m, f, Float());
        break;
      case Cpp::CPPTYPE_BOOL:
        r->AddBool(m, f, Chance(50));
        break;
      case Cpp::CPPTYPE_ENUM:
        r->AddEnumValue(m, f, Enum(f));
        break;
      case Cpp::CPPTYPE_STRING:
        r->AddString(m, f, f->type() == pb::FieldDescriptor::TYPE_BYTES ? "\x03" : String());
        break;
      case Cpp::CPPTYPE_MESSAGE:
        if (depth < 4) Fill(r->AddMessage(m, f), depth + 1);
        break;
    }
  }
  void AddMapEntry(pb::Message* m, const pb::FieldDescriptor* f, int depth) {
    pb::Message* entry = m->GetReflection()->AddMessage(m, f);
    Fill(entry, depth + 1);
  }

  std::mt19937 rng_;
};

// Every message type (nested ones too) of the API's proto files.
std::vector<const pb::Descriptor*> ApiMessages() {
  const pb::FileDescriptor* files[] = {
      v1::Drive::descriptor()->file(),    v1::ParameterSet::descriptor()->file(),
      v1::CurveSet::descriptor()->file(), v1::AuditEvent::descriptor()->file(),
      v1::Token::descriptor()->file(),    v1::Lease::descriptor()->file(),
      v1::Readiness::descriptor()->file()};
  std::vector<const pb::Descriptor*> out;
  std::vector<const pb::Descriptor*> todo;
  for (const auto* file : files) {
    for (int i = 0; i < file->message_type_count(); ++i) todo.push_back(file->message_type(i));
  }
  while (!todo.empty()) {
    const pb::Descriptor* d = todo.back();
    todo.pop_back();
    if (d->options().map_entry()) continue;
    out.push_back(d);
    for (int i = 0; i < d->nested_type_count(); ++i) todo.push_back(d->nested_type(i));
  }
  return out;
}

TEST(PrintJson, EveryApiMessageFilledAtRandom_SameBytesAsMessageToJsonString) {
  const auto types = ApiMessages();
  ASSERT_GT(types.size(), 50u);
  Filler filler(20261207);
  int direct = 0, total = 0;
  for (const pb::Descriptor* type : types) {
    const pb::Message* prototype = pb::MessageFactory::generated_factory()->GetPrototype(type);
    for (int round = 0; round < 200; ++round) {
      std::unique_ptr<pb::Message> m(prototype->New());
      if (round > 0) filler.Fill(m.get(), 0);  // round 0: the empty message
      const std::string expected = Reference(*m);
      if (expected.rfind("error: ", 0) == 0) {  // protobuf refuses (a timestamp out of range)
        EXPECT_FALSE(PrintJson(*m).ok()) << type->full_name();
        continue;
      }
      auto got = PrintJson(*m);
      ASSERT_TRUE(got.ok()) << type->full_name() << ": " << got.status();
      ASSERT_EQ(*got, expected) << type->full_name() << " round " << round;
      std::string walked;
      if (AppendJsonDirect(*m, &walked)) {
        ++direct;
        EXPECT_EQ(walked, expected);
      }
      ++total;
    }
  }
  // The direct walk answered a real share (fallbacks are strings that need escaping, bytes,
  // maps, oneofs, out-of-range timestamps).
  EXPECT_GT(direct, total / 4) << direct << " of " << total;
  std::printf("direct walk: %d of %d messages\n", direct, total);
}

// What GET /v1/drives/x1 prints: a whole Drive with its status, link health and last command.
TEST(PrintJson, TypicalDrive_DirectWalkAndSameBytes) {
  v1::Drive d;
  d.set_name("drives/x1");
  d.set_family("linmot");
  d.set_endpoint("udp://127.0.0.1:49360");
  auto* s = d.mutable_status();
  s->set_name("drives/x1");
  s->set_position_mm(12.345);
  s->set_velocity_mm_s(-0.0);
  s->set_demand_position_mm(1e-7);
  s->set_homed(true);
  s->set_sequence(18446744073709551615ull);
  s->mutable_time()->set_seconds(1796601600);
  s->mutable_time()->set_nanos(123456000);
  s->mutable_link()->mutable_last_round_trip_ms()->set_value(0.25);
  std::string walked;
  ASSERT_TRUE(AppendJsonDirect(d, &walked));
  EXPECT_EQ(walked, Reference(d));
  EXPECT_EQ(*PrintJson(d), Reference(d));
}

}  // namespace
}  // namespace drivegw::rest
