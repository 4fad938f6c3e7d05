// MessagePack subset: encodings from msgpack spec.md ("Formats"), shortest form on write.
#include "adapters/transport/msgpack_lite.h"

#include <algorithm>
#include <bit>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>

#include "absl/strings/str_cat.h"

namespace drivegw::transport::msgpack {

void Writer::BigEndian(uint64_t value, int bytes) {
  for (int i = bytes - 1; i >= 0; --i) Byte(static_cast<uint8_t>(value >> (8 * i)));
}

void Writer::Nil() { Byte(0xc0); }
void Writer::Bool(bool value) { Byte(value ? 0xc3 : 0xc2); }

void Writer::Uint(uint64_t value) {
  if (value <= 0x7f) {
    Byte(static_cast<uint8_t>(value));  // positive fixint
  } else if (value <= 0xff) {
    Byte(0xcc);
    BigEndian(value, 1);
  } else if (value <= 0xffff) {
    Byte(0xcd);
    BigEndian(value, 2);
  } else if (value <= 0xffffffff) {
    Byte(0xce);
    BigEndian(value, 4);
  } else {
    Byte(0xcf);
    BigEndian(value, 8);
  }
}

void Writer::Int(int64_t value) {
  if (value >= 0) return Uint(static_cast<uint64_t>(value));
  const auto bits = static_cast<uint64_t>(value);
  if (value >= -32) {
    Byte(static_cast<uint8_t>(bits));  // negative fixint 0xe0..0xff
  } else if (value >= std::numeric_limits<int8_t>::min()) {
    Byte(0xd0);
    BigEndian(bits, 1);
  } else if (value >= std::numeric_limits<int16_t>::min()) {
    Byte(0xd1);
    BigEndian(bits, 2);
  } else if (value >= std::numeric_limits<int32_t>::min()) {
    Byte(0xd2);
    BigEndian(bits, 4);
  } else {
    Byte(0xd3);
    BigEndian(bits, 8);
  }
}

void Writer::Float64(double value) {
  Byte(0xcb);
  BigEndian(std::bit_cast<uint64_t>(value), 8);
}

void Writer::Str(std::string_view value) {
  const size_t n = value.size();
  if (n <= 31) {
    Byte(static_cast<uint8_t>(0xa0 | n));
  } else if (n <= 0xff) {
    Byte(0xd9);
    BigEndian(n, 1);
  } else if (n <= 0xffff) {
    Byte(0xda);
    BigEndian(n, 2);
  } else {
    Byte(0xdb);
    BigEndian(n, 4);
  }
  out_.insert(out_.end(), value.begin(), value.end());
}

void Writer::Bin(std::span<const uint8_t> value) {
  const size_t n = value.size();
  if (n <= 0xff) {
    Byte(0xc4);
    BigEndian(n, 1);
  } else if (n <= 0xffff) {
    Byte(0xc5);
    BigEndian(n, 2);
  } else {
    Byte(0xc6);
    BigEndian(n, 4);
  }
  out_.insert(out_.end(), value.begin(), value.end());
}

void Writer::MapHeader(uint32_t entries) {
  if (entries <= 15) {
    Byte(static_cast<uint8_t>(0x80 | entries));
  } else if (entries <= 0xffff) {
    Byte(0xde);
    BigEndian(entries, 2);
  } else {
    Byte(0xdf);
    BigEndian(entries, 4);
  }
}

void Writer::ArrayHeader(uint32_t entries) {
  if (entries <= 15) {
    Byte(static_cast<uint8_t>(0x90 | entries));
  } else if (entries <= 0xffff) {
    Byte(0xdc);
    BigEndian(entries, 2);
  } else {
    Byte(0xdd);
    BigEndian(entries, 4);
  }
}

absl::Status Reader::Error(std::string_view what) const {
  return absl::InvalidArgumentError(absl::StrCat("msgpack offset ", pos_, ": ", std::string(what)));
}

absl::StatusOr<uint64_t> Reader::Peek(size_t offset, int bytes) const {
  if (pos_ + offset > bytes_.size() || bytes_.size() - pos_ - offset < static_cast<size_t>(bytes)) {
    return Error(
        absl::StrCat("truncated (", bytes, "-byte field past the end at ", bytes_.size(), ")"));
  }
  uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | bytes_[pos_ + offset + i];
  return v;
}

absl::StatusOr<Type> Reader::PeekType() const {
  if (at_end()) return Error("truncated (no value)");
  const uint8_t b = bytes_[pos_];
  if (b <= 0x7f || b >= 0xe0) return Type::kInt;
  if (b <= 0x8f) return Type::kMap;
  if (b <= 0x9f) return Type::kArray;
  if (b <= 0xbf) return Type::kStr;
  switch (b) {
    case 0xc0:
      return Type::kNil;
    case 0xc2:
    case 0xc3:
      return Type::kBool;
    case 0xc4:
    case 0xc5:
    case 0xc6:
      return Type::kBin;
    case 0xc7:
    case 0xc8:
    case 0xc9:
    case 0xd4:
    case 0xd5:
    case 0xd6:
    case 0xd7:
    case 0xd8:
      return Type::kExt;
    case 0xca:
    case 0xcb:
      return Type::kFloat;
    case 0xcc:
    case 0xcd:
    case 0xce:
    case 0xcf:
    case 0xd0:
    case 0xd1:
    case 0xd2:
    case 0xd3:
      return Type::kInt;
    case 0xd9:
    case 0xda:
    case 0xdb:
      return Type::kStr;
    case 0xdc:
    case 0xdd:
      return Type::kArray;
    case 0xde:
    case 0xdf:
      return Type::kMap;
    default:
      break;
  }
  char hex[8];
  std::snprintf(hex, sizeof(hex), "0x%02x", b);
  return Error(absl::StrCat("byte ", hex, " is never used"));  // 0xc1
}

absl::Status Reader::ReadNil() {
  if (at_end() || bytes_[pos_] != 0xc0) return Error("expected nil");
  ++pos_;
  return absl::OkStatus();
}

absl::StatusOr<bool> Reader::ReadBool() {
  if (!at_end() && (bytes_[pos_] == 0xc2 || bytes_[pos_] == 0xc3)) return bytes_[pos_++] == 0xc3;
  return Error("expected bool");
}

absl::StatusOr<int64_t> Reader::ReadInt() {
  if (at_end()) return Error("expected int, found the end");
  const uint8_t b = bytes_[pos_];
  if (b <= 0x7f) {
    ++pos_;
    return b;
  }
  if (b >= 0xe0) {
    ++pos_;
    return static_cast<int8_t>(b);
  }
  int width = 0;
  bool is_signed = false;
  switch (b) {
    case 0xcc:
      width = 1;
      break;
    case 0xcd:
      width = 2;
      break;
    case 0xce:
      width = 4;
      break;
    case 0xcf:
      width = 8;
      break;
    case 0xd0:
      width = 1;
      is_signed = true;
      break;
    case 0xd1:
      width = 2;
      is_signed = true;
      break;
    case 0xd2:
      width = 4;
      is_signed = true;
      break;
    case 0xd3:
      width = 8;
      is_signed = true;
      break;
    default:
      return Error("expected int");
  }
  auto raw = Peek(1, width);
  if (!raw.ok()) return raw.status();
  int64_t value = 0;
  if (is_signed) {
    // Sign-extend the big-endian two's complement field.
    const int shift = 64 - 8 * width;
    value = static_cast<int64_t>(*raw << shift) >> shift;
  } else {
    if (*raw > static_cast<uint64_t>(std::numeric_limits<int64_t>::max())) {
      return absl::OutOfRangeError(
          absl::StrCat("msgpack offset ", pos_, ": uint64 ", *raw, " exceeds int64"));
    }
    value = static_cast<int64_t>(*raw);
  }
  pos_ += 1 + static_cast<size_t>(width);
  return value;
}

absl::StatusOr<double> Reader::ReadFloat() {
  if (at_end()) return Error("expected float, found the end");
  const uint8_t b = bytes_[pos_];
  if (b == 0xca) {
    auto raw = Peek(1, 4);
    if (!raw.ok()) return raw.status();
    pos_ += 5;
    return static_cast<double>(std::bit_cast<float>(static_cast<uint32_t>(*raw)));
  }
  if (b == 0xcb) {
    auto raw = Peek(1, 8);
    if (!raw.ok()) return raw.status();
    pos_ += 9;
    return std::bit_cast<double>(*raw);
  }
  auto i = ReadInt();
  if (!i.ok()) return Error("expected float");
  return static_cast<double>(*i);
}

absl::StatusOr<std::span<const uint8_t>> Reader::ReadBlob(bool bin) {
  if (at_end()) return Error(bin ? "expected bin, found the end" : "expected str, found the end");
  const uint8_t b = bytes_[pos_];
  size_t header = 1;
  uint64_t length = 0;
  if (!bin && b >= 0xa0 && b <= 0xbf) {
    length = b & 0x1f;
  } else {
    int width = 0;
    switch (b) {
      case 0xc4:
        width = bin ? 1 : 0;
        break;
      case 0xc5:
        width = bin ? 2 : 0;
        break;
      case 0xc6:
        width = bin ? 4 : 0;
        break;
      case 0xd9:
        width = bin ? 0 : 1;
        break;
      case 0xda:
        width = bin ? 0 : 2;
        break;
      case 0xdb:
        width = bin ? 0 : 4;
        break;
      default:
        break;
    }
    if (width == 0) return Error(bin ? "expected bin" : "expected str");
    auto raw = Peek(1, width);
    if (!raw.ok()) return raw.status();
    length = *raw;
    header += static_cast<size_t>(width);
  }
  const size_t left = bytes_.size() - pos_;
  if (header > left || length > left - header) {
    return Error(absl::StrCat("truncated (", length, "-byte ", bin ? "bin" : "str", ", ",
                              left - std::min(header, left), " left)"));
  }
  const auto blob = bytes_.subspan(pos_ + header, static_cast<size_t>(length));
  pos_ += header + static_cast<size_t>(length);
  return blob;
}

absl::StatusOr<std::string_view> Reader::ReadStr() {
  auto blob = ReadBlob(false);
  if (!blob.ok()) return blob.status();
  return std::string_view(reinterpret_cast<const char*>(blob->data()), blob->size());
}

absl::StatusOr<std::span<const uint8_t>> Reader::ReadBin() { return ReadBlob(true); }

absl::StatusOr<uint32_t> Reader::ReadMapHeader() {
  if (at_end()) return Error("expected map, found the end");
  const uint8_t b = bytes_[pos_];
  if (b >= 0x80 && b <= 0x8f) {
    ++pos_;
    return b & 0x0fu;
  }
  const int width = b == 0xde ? 2 : b == 0xdf ? 4 : 0;
  if (width == 0) return Error("expected map");
  auto raw = Peek(1, width);
  if (!raw.ok()) return raw.status();
  pos_ += 1 + static_cast<size_t>(width);
  return static_cast<uint32_t>(*raw);
}

absl::StatusOr<uint32_t> Reader::ReadArrayHeader() {
  if (at_end()) return Error("expected array, found the end");
  const uint8_t b = bytes_[pos_];
  if (b >= 0x90 && b <= 0x9f) {
    ++pos_;
    return b & 0x0fu;
  }
  const int width = b == 0xdc ? 2 : b == 0xdd ? 4 : 0;
  if (width == 0) return Error("expected array");
  auto raw = Peek(1, width);
  if (!raw.ok()) return raw.status();
  pos_ += 1 + static_cast<size_t>(width);
  return static_cast<uint32_t>(*raw);
}

absl::Status Reader::Skip() {
  const size_t start = pos_;
  absl::Status s = SkipDepth(0);
  if (!s.ok()) pos_ = start;  // all or nothing, as documented
  return s;
}

absl::Status Reader::SkipDepth(int depth) {
  if (depth > kMaxDepth) return Error(absl::StrCat("nested deeper than ", kMaxDepth));
  auto type = PeekType();
  if (!type.ok()) return type.status();
  switch (*type) {
    case Type::kNil:
      return ReadNil();
    case Type::kBool:
      return ReadBool().status();
    case Type::kInt: {
      auto v = ReadInt();
      if (v.ok() || !absl::IsOutOfRange(v.status())) return v.status();
      pos_ += 9;  // a uint64 above INT64_MAX is still a complete, valid value
      return absl::OkStatus();
    }
    case Type::kFloat:
      return ReadFloat().status();
    case Type::kStr:
      return ReadStr().status();
    case Type::kBin:
      return ReadBin().status();
    case Type::kArray: {
      auto n = ReadArrayHeader();
      if (!n.ok()) return n.status();
      for (uint32_t i = 0; i < *n; ++i) {
        absl::Status s = SkipDepth(depth + 1);
        if (!s.ok()) return s;
      }
      return absl::OkStatus();
    }
    case Type::kMap: {
      auto n = ReadMapHeader();
      if (!n.ok()) return n.status();
      for (uint64_t i = 0; i < 2ull * *n; ++i) {
        absl::Status s = SkipDepth(depth + 1);
        if (!s.ok()) return s;
      }
      return absl::OkStatus();
    }
    case Type::kExt: {
      const uint8_t b = bytes_[pos_];
      size_t header = 2;  // marker + type byte (fixext)
      uint64_t length = 0;
      switch (b) {
        case 0xd4:
          length = 1;
          break;
        case 0xd5:
          length = 2;
          break;
        case 0xd6:
          length = 4;
          break;
        case 0xd7:
          length = 8;
          break;
        case 0xd8:
          length = 16;
          break;
        default: {
          const int width = b == 0xc7 ? 1 : b == 0xc8 ? 2 : 4;
          auto raw = Peek(1, width);
          if (!raw.ok()) return raw.status();
          length = *raw;
          header = 2 + static_cast<size_t>(width);
        }
      }
      const size_t left = bytes_.size() - pos_;
      if (header > left || length > left - header) return Error("truncated ext");
      pos_ += header + static_cast<size_t>(length);
      return absl::OkStatus();
    }
  }
  return Error("unknown type");
}

}  // namespace drivegw::transport::msgpack
