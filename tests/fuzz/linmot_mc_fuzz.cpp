// Fuzz target of the LinMot MC command codec: any block that decodes must re-encode to the same
// bytes over the command's extent, with zeros after it (linmot-mc.md §4.1, D-01, D-02).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "adapters/linmot/mc/motion_command.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace drivegw::linmot::mc;
  const std::span<const uint8_t> block(data, size);
  auto decoded = DecodeMotionCommand(block);
  if (!decoded.ok()) {
    // Unknown IDs must carry their header; everything else is a short block.
    if (decoded.status().code() == absl::StatusCode::kNotFound) {
      auto header = UnknownCommandHeader(decoded.status());
      if (!header.has_value() || size < 2 || header->raw() != (data[0] | (data[1] << 8))) abort();
      if (FindCommand(header->master_id, header->sub_id) != nullptr) abort();
    } else if (decoded.status().code() != absl::StatusCode::kInvalidArgument) {
      abort();
    }
    return 0;
  }
  if (decoded->spec == nullptr) abort();
  auto encoded = EncodeMotionCommand(decoded->command, decoded->header.count);
  if (!encoded.ok()) abort();
  const size_t used = decoded->spec->size();
  if (used > size) abort();
  for (size_t i = 0; i < used; ++i) {
    if ((*encoded)[i] != data[i]) abort();
  }
  for (size_t i = used; i < kMcBlockSize; ++i) {
    if ((*encoded)[i] != 0) abort();
  }
  auto again = DecodeMotionCommand(*encoded);
  if (!again.ok() || !(again->command == decoded->command) || !(again->header == decoded->header)) {
    abort();
  }
  return 0;
}
