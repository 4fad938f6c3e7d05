// MC command codec: raw wire values <-> the 32-byte interface block, driven by the §5 table
// (linmot-mc.md §4.1, §4.2; byte order D-01, block size D-02, signed positions D-13).
#include "adapters/linmot/mc/motion_command.h"

#include <cctype>
#include <cstdio>

#include "absl/strings/cord.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace drivegw::linmot::mc {
namespace {

std::string IdText(uint8_t master_id, uint8_t sub_id) {
  return absl::StrFormat("0x%02X%X", master_id, sub_id);
}

// D-01: little-endian, byte by byte (parameters sit at unaligned offsets, §4.1).
void PutLe(uint8_t* out, uint64_t bits, size_t size) {
  for (size_t i = 0; i < size; ++i) out[i] = static_cast<uint8_t>(bits >> (8 * i));
}
int64_t GetLe(const uint8_t* in, ParamType type) {
  switch (type) {
    case ParamType::kSInt16:
      return static_cast<int16_t>(static_cast<uint16_t>(in[0] | (in[1] << 8)));
    case ParamType::kUInt16:
      return static_cast<uint16_t>(in[0] | (in[1] << 8));
    case ParamType::kSInt32:
    case ParamType::kUInt32: {
      const uint32_t u = static_cast<uint32_t>(in[0]) | (static_cast<uint32_t>(in[1]) << 8) |
                         (static_cast<uint32_t>(in[2]) << 16) |
                         (static_cast<uint32_t>(in[3]) << 24);
      if (type == ParamType::kSInt32) return static_cast<int32_t>(u);
      return u;
    }
  }
  return 0;
}

absl::Status CheckParams(const CommandSpec& spec, const McCommand& cmd) {
  if (cmd.values.size() != spec.params.size()) {
    return absl::InvalidArgumentError(absl::StrCat(
        spec.key(), ": ", cmd.values.size(), " values given, ", IdText(spec.master_id, spec.sub_id),
        " '", spec.name, "' takes ", spec.params.size()));
  }
  for (size_t i = 0; i < spec.params.size(); ++i) {
    const ParamType t = spec.params[i].type;
    const int64_t v = cmd.values[i];
    if (v > ParamTypeMax(t)) {
      return absl::OutOfRangeError(absl::StrCat(FieldName(spec, i), ": ", v, " exceeds ",
                                                ParamTypeName(t), " max ", ParamTypeMax(t)));
    }
    if (v < ParamTypeMin(t)) {
      return absl::OutOfRangeError(absl::StrCat(FieldName(spec, i), ": ", v, " is below ",
                                                ParamTypeName(t), " min ", ParamTypeMin(t)));
    }
  }
  return absl::OkStatus();
}

McCommand Make(CommandId id, std::vector<int64_t> values = {}) {
  return McCommand{id.master, id.sub, std::move(values)};
}

}  // namespace

const char* ParamTypeName(ParamType t) {
  switch (t) {
    case ParamType::kSInt16:
      return "SInt16";
    case ParamType::kUInt16:
      return "UInt16";
    case ParamType::kSInt32:
      return "SInt32";
    case ParamType::kUInt32:
      return "UInt32";
  }
  return "?";
}

const char* ProductName(Product p) {
  switch (p) {
    case Product::kC1100:
      return "C1100";
    case Product::kC1250:
      return "C1250";
    case Product::kE1200:
      return "E1200";
    case Product::kE1400:
      return "E1400";
  }
  return "?";
}

size_t CommandSpec::size() const {
  if (params.empty()) return 2;
  const ParamSpec& last = params.back();
  return last.offset + ParamTypeSize(last.type);
}

std::string CommandSpec::key() const {
  std::string out;
  bool pending_sep = false;
  for (const char* p = name; *p != '\0'; ++p) {
    const unsigned char c = static_cast<unsigned char>(*p);
    if (std::isalnum(c)) {
      if (pending_sep && !out.empty()) out.push_back('_');
      pending_sep = false;
      out.push_back(static_cast<char>(std::tolower(c)));
    } else {
      pending_sep = true;
    }
  }
  return out;
}

bool CommandSpec::AvailableOn(Product p, bool force_control_key) const {
  switch (availability[static_cast<size_t>(p)]) {
    case Availability::kYes:
      return true;
    case Availability::kForceControlKey:
      return force_control_key;
    case Availability::kNo:
      return false;
  }
  return false;
}

std::optional<size_t> CommandSpec::ParamIndex(std::string_view param_name) const {
  for (size_t i = 0; i < params.size(); ++i) {
    if (param_name == params[i].name) return i;
  }
  return std::nullopt;
}

std::string FieldName(const CommandSpec& spec, size_t param_index) {
  if (param_index >= spec.params.size()) return spec.key();
  return absl::StrCat(spec.key(), ".", spec.params[param_index].name);
}

absl::StatusOr<McBlock> EncodeMotionCommand(const McCommand& cmd, uint8_t count) {
  if (count > 15) {
    return absl::InvalidArgumentError(
        absl::StrCat("motion_command.count: ", count, " exceeds the 4-bit maximum 15"));
  }
  if (cmd.sub_id > 15) {
    return absl::InvalidArgumentError(
        absl::StrCat("motion_command.sub_id: ", cmd.sub_id, " exceeds the 4-bit maximum 15"));
  }
  const CommandSpec* spec = FindCommand(cmd.master_id, cmd.sub_id);
  if (spec == nullptr) {
    return absl::NotFoundError(absl::StrCat("motion_command: ID ",
                                            IdText(cmd.master_id, cmd.sub_id),
                                            " is not a LinMot MC command (linmot-mc.md §5)"));
  }
  if (absl::Status s = CheckParams(*spec, cmd); !s.ok()) return s;

  McBlock block{};  // unused bytes 0 (D-02)
  PutLe(block.data(), Header{cmd.master_id, cmd.sub_id, count}.raw(), 2);
  for (size_t i = 0; i < spec->params.size(); ++i) {
    const ParamSpec& p = spec->params[i];
    // Two's complement of the (range-checked) value, truncated to the field width.
    PutLe(block.data() + p.offset, static_cast<uint64_t>(cmd.values[i]), ParamTypeSize(p.type));
  }
  return block;
}

absl::StatusOr<Header> DecodeHeader(std::span<const uint8_t> block) {
  if (block.size() < 2) {
    return absl::InvalidArgumentError(absl::StrCat("motion_command.header: block of ", block.size(),
                                                   " bytes, the header needs 2"));
  }
  return Header::FromRaw(static_cast<uint16_t>(block[0] | (block[1] << 8)));
}

absl::StatusOr<DecodedMotionCommand> DecodeMotionCommand(std::span<const uint8_t> block) {
  absl::StatusOr<Header> header = DecodeHeader(block);
  if (!header.ok()) return header.status();
  const CommandSpec* spec = FindCommand(header->master_id, header->sub_id);
  if (spec == nullptr) {
    absl::Status s = absl::NotFoundError(
        absl::StrFormat("motion_command: unknown ID %s (header 0x%04X)",
                        IdText(header->master_id, header->sub_id), header->raw()));
    s.SetPayload(kHeaderPayloadUrl, absl::Cord(absl::StrFormat("%04X", header->raw())));
    return s;
  }
  if (block.size() < spec->size()) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: block of %d bytes, the command needs %d (bytes %d..%d missing)",
                        spec->key(), block.size(), spec->size(), block.size(), spec->size() - 1));
  }
  DecodedMotionCommand out;
  out.header = *header;
  out.spec = spec;
  out.command.master_id = header->master_id;
  out.command.sub_id = header->sub_id;
  out.command.values.reserve(spec->params.size());
  for (const ParamSpec& p : spec->params) {
    out.command.values.push_back(GetLe(block.data() + p.offset, p.type));
  }
  return out;
}

std::optional<Header> UnknownCommandHeader(const absl::Status& status) {
  if (status.code() != absl::StatusCode::kNotFound) return std::nullopt;
  auto payload = status.GetPayload(kHeaderPayloadUrl);
  if (!payload.has_value()) return std::nullopt;
  uint32_t raw = 0;
  if (!absl::SimpleHexAtoi(std::string(*payload), &raw) || raw > 0xFFFF) return std::nullopt;
  return Header::FromRaw(static_cast<uint16_t>(raw));
}

absl::StatusOr<std::vector<uint8_t>> ParameterBytes(const McCommand& cmd) {
  absl::StatusOr<McBlock> block = EncodeMotionCommand(cmd, 0);
  if (!block.ok()) return block.status();
  const size_t size = FindCommand(cmd.master_id, cmd.sub_id)->size();
  return std::vector<uint8_t>(block->begin() + 2, block->begin() + size);
}

McCommand NoOperation() { return Make(kNoOperation); }
McCommand Reset() { return Make(kReset); }
McCommand ClearEventEvaluation() { return Make(kClearEventEvaluation); }
McCommand WriteInterfaceControlWord(uint16_t control_word) {
  return Make(kWriteInterfaceControlWord, {control_word});
}
McCommand WriteLiveParameter(uint16_t upid, int32_t value) {
  return Make(kWriteLiveParameter, {upid, value});
}
McCommand MasterHoming(int32_t home_position) { return Make(kMasterHoming, {home_position}); }
McCommand VaiGoToPos(int32_t target_position, uint32_t maximal_velocity, uint32_t acceleration,
                     uint32_t deceleration) {
  return Make(kVaiGoToPos, {target_position, maximal_velocity, acceleration, deceleration});
}
McCommand VaiIncrementDemPos(int32_t position_increment, uint32_t maximal_velocity,
                             uint32_t acceleration, uint32_t deceleration) {
  return Make(kVaiIncrementDemPos,
              {position_increment, maximal_velocity, acceleration, deceleration});
}
McCommand VaiIncrementTargetPos(int32_t position_increment, uint32_t maximal_velocity,
                                uint32_t acceleration, uint32_t deceleration) {
  return Make(kVaiIncrementTargetPos,
              {position_increment, maximal_velocity, acceleration, deceleration});
}
McCommand VaiIncrementActPos(int32_t position_increment, uint32_t maximal_velocity,
                             uint32_t acceleration, uint32_t deceleration) {
  return Make(kVaiIncrementActPos,
              {position_increment, maximal_velocity, acceleration, deceleration});
}
McCommand VaiGoToPosAfterActualCommand(int32_t target_position, uint32_t maximal_velocity,
                                       uint32_t acceleration, uint32_t deceleration) {
  return Make(kVaiGoToPosAfterActualCommand,
              {target_position, maximal_velocity, acceleration, deceleration});
}
McCommand VaiStop(uint32_t deceleration) { return Make(kVaiStop, {deceleration}); }
McCommand PredefVaiGoToPos(int32_t target_position) {
  return Make(kPredefVaiGoToPos, {target_position});
}
McCommand PredefVaiIncrementDemPos(int32_t position_increment) {
  return Make(kPredefVaiIncrementDemPos, {position_increment});
}
McCommand PredefVaiStop() { return Make(kPredefVaiStop); }
McCommand PredefVaiInfinitePositive() { return Make(kPredefVaiInfinitePositive); }
McCommand PredefVaiInfiniteNegative() { return Make(kPredefVaiInfiniteNegative); }
McCommand VaiDecAccInfinitePositive(uint32_t maximal_velocity, uint32_t acceleration) {
  return Make(kVaiDecAccInfinitePositive, {maximal_velocity, acceleration});
}
McCommand VaiDecAccInfiniteNegative(uint32_t maximal_velocity, uint32_t acceleration) {
  return Make(kVaiDecAccInfiniteNegative, {maximal_velocity, acceleration});
}
McCommand TimeCurveWithDefaultParameters(uint16_t curve_id) {
  return Make(kTimeCurveWithDefaultParameters, {curve_id});
}
McCommand TimeCurveWithAdjustableOffsetTimeScaleAmplitudeScale(uint16_t curve_id,
                                                               int32_t curve_offset,
                                                               uint16_t time_scale,
                                                               int16_t amplitude_scale) {
  return Make(kTimeCurveWithAdjustableOffsetTimeScaleAmplitudeScale,
              {curve_id, curve_offset, time_scale, amplitude_scale});
}

absl::StatusOr<VaParams> AsVa(const McCommand& cmd) {
  const CommandSpec* spec = FindCommand(cmd.master_id, cmd.sub_id);
  if (spec == nullptr) {
    return absl::NotFoundError(absl::StrCat(
        "motion_command: ID ", IdText(cmd.master_id, cmd.sub_id), " is not a LinMot MC command"));
  }
  const auto& p = spec->params;
  const bool va = p.size() == 4 && p[0].type == ParamType::kSInt32 && p[0].offset == 2 &&
                  p[1].type == ParamType::kUInt32 && p[2].type == ParamType::kUInt32 &&
                  p[3].type == ParamType::kUInt32 &&
                  std::string_view(p[1].name) == "maximal_velocity" &&
                  std::string_view(p[2].name) == "acceleration" &&
                  std::string_view(p[3].name) == "deceleration";
  if (!va) {
    return absl::InvalidArgumentError(absl::StrCat(
        spec->key(), ": ", IdText(spec->master_id, spec->sub_id), " does not have the VA layout"));
  }
  if (absl::Status s = CheckParams(*spec, cmd); !s.ok()) return s;
  return VaParams{static_cast<int32_t>(cmd.values[0]), static_cast<uint32_t>(cmd.values[1]),
                  static_cast<uint32_t>(cmd.values[2]), static_cast<uint32_t>(cmd.values[3])};
}

}  // namespace drivegw::linmot::mc
