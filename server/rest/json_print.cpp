// The direct proto -> JSON walk (json_print.h). What it prints follows protobuf 3.21's
// MessageToJsonString (util/internal/json_objectwriter.cc, protostream_objectsource.cc) as
// observed and proven by tests/server/rest/json_print_test.cpp over randomly filled messages of
// every drivegw.v1 type: fields in declaration order except set Timestamps and wrappers, which
// come last (see AppendMessage), unset singular messages left out, unset
// primitives and empty lists printed, doubles as "%.15g" (or "%.17g" when that does not read
// back) with NaN/Infinity quoted, 64-bit integers quoted, enums by name (unknown numbers bare),
// Timestamps as RFC 3339 UTC with 0, 3, 6 or 9 fractional digits.
#include "server/rest/json_print.h"

#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <type_traits>
#include <utility>

#include "google/protobuf/descriptor.h"
#include "google/protobuf/message.h"
#include "google/protobuf/util/json_util.h"

namespace drivegw::rest {
namespace {

namespace pb = google::protobuf;
using Cpp = pb::FieldDescriptor::CppType;

// Strings the walk prints itself: printable ASCII that JSON and protobuf's escaper leave as
// is. Anything else (quotes, backslash, '<' and '>' which protobuf writes as \u003c/\u003e,
// control characters, UTF-8) goes to protobuf.
bool AppendString(const std::string& s, std::string* out) {
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u > 0x7e || c == '"' || c == '\\' || c == '<' || c == '>') return false;
  }
  out->push_back('"');
  out->append(s);
  out->push_back('"');
  return true;
}

// protobuf SimpleDtoa: "%.15g", or "%.17g" when that does not read back; non-finite quoted.
// std::to_chars with a precision is specified as printf's %.*g (C++20 [charconv.to.chars]),
// and from_chars as strtod in the C locale: protobuf's steps without printf's cost.
template <typename T>
bool AppendFloating(T v, int digits, std::string* out) {
  if (std::isnan(v)) {
    out->append("\"NaN\"");
    return true;
  }
  if (std::isinf(v)) {
    out->append(v > 0 ? "\"Infinity\"" : "\"-Infinity\"");
    return true;
  }
  char buf[64];
  std::to_chars_result r =
      std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, digits);
  if (r.ec != std::errc()) return false;
  T back{};
  if (auto p = std::from_chars(buf, r.ptr, back); p.ec != std::errc() || back != v) {
    r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general,
                      digits + (std::is_same_v<T, float> ? 3 : 2));
    if (r.ec != std::errc()) return false;
  }
  char* const end = r.ptr;
  out->append(buf, end);
  return true;
}

bool AppendDouble(double v, std::string* out) { return AppendFloating(v, DBL_DIG, out); }

// protobuf SimpleFtoa: "%.6g", or "%.9g" when that does not read back as the same float.
bool AppendFloat(float v, std::string* out) { return AppendFloating(v, FLT_DIG, out); }

template <typename T>
void AppendInteger(T v, bool quoted, std::string* out) {
  if (quoted) out->push_back('"');
  out->append(std::to_string(v));
  if (quoted) out->push_back('"');
}

// Days since 1970-01-01 -> civil date (proleptic Gregorian; H. Hinnant, "chrono-compatible
// low-level date algorithms", days_from_civil inverse).
void CivilFromDays(int64_t z, int64_t* y, unsigned* m, unsigned* d) {
  z += 719468;
  const int64_t era = (z >= 0 ? z : z - 146096) / 146097;
  const auto doe = static_cast<unsigned>(z - era * 146097);
  const unsigned yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
  const unsigned doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
  const unsigned mp = (5 * doy + 2) / 153;
  *d = doy - (153 * mp + 2) / 5 + 1;
  *m = mp < 10 ? mp + 3 : mp - 9;
  *y = static_cast<int64_t>(yoe) + era * 400 + (*m <= 2 ? 1 : 0);
}

// `v` in decimal, zero-padded to `width` digits.
void AppendDigits(uint64_t v, int width, std::string* out) {
  char buf[20];
  int n = 0;
  do {
    buf[n++] = static_cast<char>('0' + v % 10);
    v /= 10;
  } while (v != 0 && n < 20);
  for (int i = n; i < width; ++i) out->push_back('0');
  while (n > 0) out->push_back(buf[--n]);
}

// google.protobuf.Timestamp as protobuf prints it; out-of-range values go to protobuf (which
// refuses them).
bool AppendTimestamp(const pb::Message& m, std::string* out) {
  const pb::Descriptor* d = m.GetDescriptor();
  const pb::Reflection* r = m.GetReflection();
  const int64_t seconds = r->GetInt64(m, d->FindFieldByNumber(1));
  const int32_t nanos = r->GetInt32(m, d->FindFieldByNumber(2));
  constexpr int64_t kMin = -62135596800;  // 0001-01-01T00:00:00Z
  constexpr int64_t kMax = 253402300799;  // 9999-12-31T23:59:59Z
  if (seconds < kMin || seconds > kMax || nanos < 0 || nanos > 999999999) return false;
  int64_t days = seconds / 86400;
  int64_t rem = seconds % 86400;
  if (rem < 0) {
    rem += 86400;
    --days;
  }
  int64_t year;
  unsigned month, day;
  CivilFromDays(days, &year, &month, &day);
  // "\"YYYY-MM-DDThh:mm:ss[.fff|.ffffff|.fffffffff]Z\"" (years 1..9999: four digits).
  out->push_back('"');
  AppendDigits(static_cast<uint64_t>(year), 4, out);
  out->push_back('-');
  AppendDigits(month, 2, out);
  out->push_back('-');
  AppendDigits(day, 2, out);
  out->push_back('T');
  AppendDigits(static_cast<uint64_t>(rem / 3600), 2, out);
  out->push_back(':');
  AppendDigits(static_cast<uint64_t>(rem / 60 % 60), 2, out);
  out->push_back(':');
  AppendDigits(static_cast<uint64_t>(rem % 60), 2, out);
  if (nanos != 0) {
    out->push_back('.');
    if (nanos % 1000000 == 0) {
      AppendDigits(static_cast<uint64_t>(nanos / 1000000), 3, out);
    } else if (nanos % 1000 == 0) {
      AppendDigits(static_cast<uint64_t>(nanos / 1000), 6, out);
    } else {
      AppendDigits(static_cast<uint64_t>(nanos), 9, out);
    }
  }
  out->append("Z\"");
  return true;
}

bool AppendMessage(const pb::Message& m, std::string* out);

// One value of field f (element `index` when repeated).
bool AppendValue(const pb::Message& m, const pb::FieldDescriptor* f, int index, std::string* out) {
  const pb::Reflection* r = m.GetReflection();
  const bool rep = f->is_repeated();
  switch (f->cpp_type()) {
    case Cpp::CPPTYPE_INT32:
      AppendInteger(rep ? r->GetRepeatedInt32(m, f, index) : r->GetInt32(m, f), false, out);
      return true;
    case Cpp::CPPTYPE_UINT32:
      AppendInteger(rep ? r->GetRepeatedUInt32(m, f, index) : r->GetUInt32(m, f), false, out);
      return true;
    case Cpp::CPPTYPE_INT64:
      AppendInteger(rep ? r->GetRepeatedInt64(m, f, index) : r->GetInt64(m, f), true, out);
      return true;
    case Cpp::CPPTYPE_UINT64:
      AppendInteger(rep ? r->GetRepeatedUInt64(m, f, index) : r->GetUInt64(m, f), true, out);
      return true;
    case Cpp::CPPTYPE_DOUBLE:
      return AppendDouble(rep ? r->GetRepeatedDouble(m, f, index) : r->GetDouble(m, f), out);
    case Cpp::CPPTYPE_FLOAT:
      return AppendFloat(rep ? r->GetRepeatedFloat(m, f, index) : r->GetFloat(m, f), out);
    case Cpp::CPPTYPE_BOOL:
      out->append((rep ? r->GetRepeatedBool(m, f, index) : r->GetBool(m, f)) ? "true" : "false");
      return true;
    case Cpp::CPPTYPE_ENUM: {
      const int number = rep ? r->GetRepeatedEnumValue(m, f, index) : r->GetEnumValue(m, f);
      if (const auto* v = f->enum_type()->FindValueByNumber(number)) {
        return AppendString(v->name(), out);
      }
      AppendInteger(number, false, out);
      return true;
    }
    case Cpp::CPPTYPE_STRING: {
      if (f->type() == pb::FieldDescriptor::TYPE_BYTES) return false;  // base64: protobuf's
      std::string scratch;
      const std::string& s = rep ? r->GetRepeatedStringReference(m, f, index, &scratch)
                                 : r->GetStringReference(m, f, &scratch);
      return AppendString(s, out);
    }
    case Cpp::CPPTYPE_MESSAGE:
      return AppendMessage(rep ? r->GetRepeatedMessage(m, f, index) : r->GetMessage(m, f), out);
  }
  return false;
}

bool AppendMessage(const pb::Message& m, std::string* out) {
  const pb::Descriptor* d = m.GetDescriptor();
  switch (d->well_known_type()) {
    case pb::Descriptor::WELLKNOWNTYPE_UNSPECIFIED:
      break;
    case pb::Descriptor::WELLKNOWNTYPE_TIMESTAMP:
      return AppendTimestamp(m, out);
    case pb::Descriptor::WELLKNOWNTYPE_DOUBLEVALUE:
    case pb::Descriptor::WELLKNOWNTYPE_FLOATVALUE:
    case pb::Descriptor::WELLKNOWNTYPE_INT64VALUE:
    case pb::Descriptor::WELLKNOWNTYPE_UINT64VALUE:
    case pb::Descriptor::WELLKNOWNTYPE_INT32VALUE:
    case pb::Descriptor::WELLKNOWNTYPE_UINT32VALUE:
    case pb::Descriptor::WELLKNOWNTYPE_BOOLVALUE:
    case pb::Descriptor::WELLKNOWNTYPE_STRINGVALUE:
      return AppendValue(m, d->FindFieldByNumber(1), 0, out);  // the wrapped value, bare
    default:
      return false;  // Any, Struct, Duration, FieldMask, BytesValue, ...
  }
  if (d->file()->syntax() != pb::FileDescriptor::SYNTAX_PROTO3) return false;
  const pb::Reflection* r = m.GetReflection();
  out->push_back('{');
  bool first = true;
  auto key = [&](const pb::FieldDescriptor* f) {
    if (!first) out->push_back(',');
    first = false;
    out->push_back('"');
    out->append(f->name());
    out->append("\":");
  };
  // Set singular Timestamp and wrapper fields come last, by field number: protobuf 3.21's
  // DefaultValueObjectWriter lays out one node per field in declaration order, but these
  // arrive as primitives where it holds an object node, so it appends new nodes at the end
  // (util/internal/default_value_objectwriter.cc, RenderDataPiece).
  const pb::FieldDescriptor* late[8];
  size_t late_count = 0;
  for (int i = 0; i < d->field_count(); ++i) {
    const pb::FieldDescriptor* f = d->field(i);
    if (f->is_map() || f->containing_oneof() != nullptr) return false;
    if (!f->is_repeated()) {
      if (f->cpp_type() == Cpp::CPPTYPE_MESSAGE) {
        if (!r->HasField(m, f)) continue;  // unset sub-messages are left out
        if (f->message_type()->well_known_type() != pb::Descriptor::WELLKNOWNTYPE_UNSPECIFIED) {
          if (late_count == std::size(late)) return false;
          late[late_count++] = f;
          continue;
        }
      } else if (f->has_presence()) {
        return false;  // proto3 `optional`
      }
      key(f);
      if (!AppendValue(m, f, 0, out)) return false;
      continue;
    }
    key(f);
    out->push_back('[');
    const int n = r->FieldSize(m, f);
    for (int k = 0; k < n; ++k) {
      if (k > 0) out->push_back(',');
      if (!AppendValue(m, f, k, out)) return false;
    }
    out->push_back(']');
  }
  for (size_t i = 1; i < late_count; ++i) {  // insertion sort by number: a handful at most
    for (size_t k = i; k > 0 && late[k - 1]->number() > late[k]->number(); --k) {
      std::swap(late[k - 1], late[k]);
    }
  }
  for (size_t i = 0; i < late_count; ++i) {
    key(late[i]);
    if (!AppendValue(m, late[i], 0, out)) return false;
  }
  out->push_back('}');
  return true;
}

}  // namespace

bool AppendJsonDirect(const pb::Message& msg, std::string* out) { return AppendMessage(msg, out); }

absl::StatusOr<std::string> PrintJson(const pb::Message& msg) {
  std::string json;
  json.reserve(1024);
  if (AppendMessage(msg, &json)) return json;
  json.clear();
  pb::util::JsonPrintOptions options;
  options.always_print_primitive_fields = true;
  options.preserve_proto_field_names = true;
  if (auto s = pb::util::MessageToJsonString(msg, &json, options); !s.ok()) {
    return absl::InternalError(std::string(s.message()));
  }
  return json;
}

}  // namespace drivegw::rest
