// Minimal MessagePack writer and pull reader: just the value kinds python-can's udp_multicast
// frames use (msgpack spec.md); the reader is total on any input (docs/decisions/802).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace drivegw::transport::msgpack {

// Always the shortest encoding, as msgpack-python's packb does (so our bytes equal its bytes).
class Writer {
 public:
  void Nil();
  void Bool(bool value);
  void Uint(uint64_t value);
  void Int(int64_t value);
  void Float64(double value);
  void Str(std::string_view value);          // str8/16/32 or fixstr (UTF-8 not checked)
  void Bin(std::span<const uint8_t> value);  // bin8/16/32 (use_bin_type=True)
  void MapHeader(uint32_t entries);
  void ArrayHeader(uint32_t entries);

  const std::vector<uint8_t>& bytes() const { return out_; }
  std::vector<uint8_t> Take() { return std::move(out_); }

 private:
  void Byte(uint8_t b) { out_.push_back(b); }
  void BigEndian(uint64_t value, int bytes);
  std::vector<uint8_t> out_;
};

enum class Type { kNil, kBool, kInt, kFloat, kStr, kBin, kArray, kMap, kExt };

// Reads values one at a time from a byte span it does not own. Every call either consumes one
// complete item or fails with InvalidArgument "msgpack offset N: ..." and leaves the position
// unchanged; nothing reads past the span.
class Reader {
 public:
  // Nesting bound for Skip (unknown values); deeper input is refused, not recursed into.
  static constexpr int kMaxDepth = 16;

  explicit Reader(std::span<const uint8_t> bytes) : bytes_(bytes) {}

  absl::StatusOr<Type> PeekType() const;
  absl::Status ReadNil();
  absl::StatusOr<bool> ReadBool();
  // Any int encoding; uint64 values above INT64_MAX are OutOfRange.
  absl::StatusOr<int64_t> ReadInt();
  // float32, float64 or any int (as msgpack-python users may write 0 for 0.0).
  absl::StatusOr<double> ReadFloat();
  absl::StatusOr<std::string_view> ReadStr();
  absl::StatusOr<std::span<const uint8_t>> ReadBin();
  // Entry counts; the caller then reads 2*n (map) or n (array) values.
  absl::StatusOr<uint32_t> ReadMapHeader();
  absl::StatusOr<uint32_t> ReadArrayHeader();
  // Skips one complete value of any type, nested containers included.
  absl::Status Skip();

  size_t position() const { return pos_; }
  bool at_end() const { return pos_ >= bytes_.size(); }

 private:
  absl::Status Error(std::string_view what) const;
  absl::StatusOr<uint64_t> Peek(size_t offset, int bytes) const;  // big-endian at pos_+offset
  absl::StatusOr<std::span<const uint8_t>> ReadBlob(bool bin);
  absl::Status SkipDepth(int depth);

  std::span<const uint8_t> bytes_;
  size_t pos_ = 0;
};

}  // namespace drivegw::transport::msgpack
